// EXR and PNG output: exact float round trips with layer names and metadata, the Rec.709
// chromaticities attribute, all-or-nothing writing, input errors on bad files, rejection of
// non-finite values, the PNG header and the documented display encoding, and auto-exposure.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <unistd.h>
#include <vector>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfMultiPartInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <png.h>

#include "flare/core/Error.h"
#include "flare/core/Spectrum.h"
#include "flare/film/ImageIO.h"

namespace flare {
namespace {

namespace fs = std::filesystem;
constexpr double kEpsilon = std::numeric_limits<double>::epsilon();

// A fresh directory per test, removed afterwards.
class ImageIOTest : public ::testing::Test {
protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = fs::temp_directory_path() /
               ("flare_image_io_" + std::to_string(::getpid()) + "_" + info->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }
    std::string path(const std::string& name) const { return (dir_ / name).string(); }

    fs::path dir_;
};

ImageLayer makeLayer(const std::string& name, int width, int height, float seed) {
    ImageLayer layer{name, width, height, {}};
    for (int i = 0; i < 3 * width * height; ++i)
        layer.rgb.push_back(seed * static_cast<float>(i % 17) - 0.37f * static_cast<float>(i) +
                            (i % 5 == 0 ? 1e30f : 0.0f) + (i % 7 == 0 ? 1e-40f : 0.0f));
    return layer;
}

std::vector<unsigned char> fileBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

bool leftovers(const fs::path& dir) { return !fs::is_empty(dir); }

TEST_F(ImageIOTest, ExrRoundTripsLayersExactlyWithNamesAndMetadata) {
    const std::vector<ImageLayer> layers = {makeLayer("", 7, 5, 0.25f),
                                            makeLayer("ghosts", 7, 5, -3.5f)};
    writeExr(path("out.exr"), layers,
             {{"colorSpace", "linear Rec.709 (sRGB primaries)"}, {"software", "flare test"}});
    EXPECT_FALSE(fs::exists(path("out.exr.partial")));

    const std::vector<ImageLayer> back = readExr(path("out.exr"));
    ASSERT_EQ(back.size(), 2u);
    for (size_t i = 0; i < 2; ++i) {
        EXPECT_EQ(back[i].name, layers[i].name);
        EXPECT_EQ(back[i].width, 7);
        EXPECT_EQ(back[i].height, 5);
        ASSERT_EQ(back[i].rgb.size(), layers[i].rgb.size());
        for (size_t k = 0; k < back[i].rgb.size(); ++k)  // 32-bit float and lossless ZIP: exact
            EXPECT_EQ(back[i].rgb[k], layers[i].rgb[k]) << layers[i].name << " value " << k;
    }
    Imf::InputFile file(path("out.exr").c_str());
    const auto* software = file.header().findTypedAttribute<Imf::StringAttribute>("software");
    ASSERT_NE(software, nullptr);
    EXPECT_EQ(software->value(), "flare test");
    EXPECT_EQ(file.header().compression(), Imf::ZIP_COMPRESSION);
    EXPECT_NE(file.header().channels().findChannel("ghosts.G"), nullptr);
    EXPECT_EQ(file.header().channels().findChannel("ghosts.G")->type, Imf::FLOAT);
}

// PIZ (what renders write) is lossless too, for float and half-precision layers alike.
TEST_F(ImageIOTest, PizAndUncompressedRoundTripExactly) {
    ImageLayer grain{"grain", 37, 21, std::vector<float>(37 * 21 * 3)};
    std::uint32_t state = 12345;
    for (float& v : grain.rgb) {
        state = state * 1664525u + 1013904223u;
        v = static_cast<float>(state >> 8) * 1e-9f;
    }
    const std::vector<ImageLayer> layers = {makeLayer("", 37, 21, 0.25f), grain};
    ExrWriteOptions options;
    options.compression = ExrCompression::Piz;
    options.storage["grain"] = ExrStorage::FloatHalfPrecision;
    writeExr(path("piz.exr"), layers, {}, options);
    options.compression = ExrCompression::Zip;
    writeExr(path("zip.exr"), layers, {}, options);
    const std::vector<ImageLayer> back = readExr(path("piz.exr")), zip = readExr(path("zip.exr"));
    ASSERT_EQ(back.size(), 2u);
    EXPECT_EQ(back[0].rgb, layers[0].rgb);
    EXPECT_EQ(back[1].rgb, zip[1].rgb);
    EXPECT_NE(back[1].rgb, grain.rgb) << "rounded to half's precision";
    EXPECT_EQ(Imf::InputFile(path("piz.exr").c_str()).header().compression(), Imf::PIZ_COMPRESSION);
    // Uncompressed (the preview's single image): the same pixels, stored as they are.
    options.compression = ExrCompression::None;
    options.storage.clear();
    writeExr(path("none.exr"), layers, {}, options);
    const std::vector<ImageLayer> none = readExr(path("none.exr"));
    ASSERT_EQ(none.size(), 2u);
    EXPECT_EQ(none[1].rgb, grain.rgb);
    EXPECT_EQ(Imf::InputFile(path("none.exr").c_str()).header().compression(), Imf::NO_COMPRESSION);
}

TEST_F(ImageIOTest, HalfAndHalfPrecisionLayersKeepElevenSignificantBits) {
    // A weak layer, 1e-12 to 1e-6 (below half's normal range), and one within half's range.
    ImageLayer wide{"wide", 8, 4, std::vector<float>(8 * 4 * 3)};
    ImageLayer fits{"fits", 8, 4, std::vector<float>(8 * 4 * 3)};
    for (size_t i = 0; i < wide.rgb.size(); ++i) {
        wide.rgb[i] = static_cast<float>(1e-12 * std::pow(10.0, 6.0 * i / (wide.rgb.size() - 1))) * (i % 2 ? -1.0f : 1.0f);
        fits.rgb[i] = static_cast<float>(1e-3 + 3.7 * i);
    }
    EXPECT_FALSE(fitsHalf(wide));
    EXPECT_TRUE(fitsHalf(fits));
    const ImageLayer exact = makeLayer("", 8, 4, 0.123456789f);
    ExrWriteOptions options;
    options.storage["fits"] = ExrStorage::Half;
    options.storage["wide"] = ExrStorage::FloatHalfPrecision;
    writeExr(path("half.exr"), {exact, wide, fits}, {}, options);

    const std::vector<ImageLayer> back = readExr(path("half.exr"));
    ASSERT_EQ(back.size(), 3u);  // "", fits, wide
    EXPECT_EQ(back[0].rgb, exact.rgb);  // not named: 32-bit float, exact
    // Rounded to nearest at 11 significant bits: relative error at most half a unit in the last
    // place, 2⁻¹¹.
    for (size_t i = 0; i < fits.rgb.size(); ++i) EXPECT_NEAR(back[1].rgb[i], fits.rgb[i], std::ldexp(std::abs(fits.rgb[i]), -11));
    for (size_t i = 0; i < wide.rgb.size(); ++i) EXPECT_NEAR(back[2].rgb[i], wide.rgb[i], std::ldexp(std::abs(wide.rgb[i]), -11));
    Imf::InputFile file(path("half.exr").c_str());
    EXPECT_EQ(file.header().channels().findChannel("fits.R")->type, Imf::HALF);
    EXPECT_EQ(file.header().channels().findChannel("wide.R")->type, Imf::FLOAT);
    EXPECT_EQ(file.header().channels().findChannel("G")->type, Imf::FLOAT);

    // Beyond half's range is a programming error, and so is storage for a layer that is not there.
    ImageLayer big = fits;
    big.rgb[5] = 70000.0f;
    EXPECT_THROW(writeExr(path("big.exr"), {big}, {}, options), std::logic_error);
    EXPECT_THROW(writeExr(path("none.exr"), {exact}, {}, options), std::invalid_argument);
    EXPECT_FALSE(fs::exists(path("big.exr")) || fs::exists(path("big.exr.partial")));
    EXPECT_FALSE(fs::exists(path("none.exr")) || fs::exists(path("none.exr.partial")));
}

TEST_F(ImageIOTest, ChromaticitiesAttributeIsRec709WithD65White) {
    writeExr(path("c.exr"), {makeLayer("", 2, 2, 1.0f)}, {});
    Imf::InputFile file(path("c.exr").c_str());
    ASSERT_TRUE(Imf::hasChromaticities(file.header()));
    const Imf::Chromaticities& c = Imf::chromaticities(file.header());
    // Stored as 32-bit floats: exactly the float nearest each published value.
    EXPECT_EQ(c.red, Imath::V2f(0.64f, 0.33f));
    EXPECT_EQ(c.green, Imath::V2f(0.30f, 0.60f));
    EXPECT_EQ(c.blue, Imath::V2f(0.15f, 0.06f));
    EXPECT_EQ(c.white, Imath::V2f(0.3127f, 0.3290f));
}

TEST_F(ImageIOTest, FailedWritesThrowNamingThePathAndLeaveNothing) {
    const std::string missingDir = path("no-such-dir/out.exr");
    try {
        writeExr(missingDir, {makeLayer("", 2, 2, 1.0f)}, {});
        FAIL() << "expected an error";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(missingDir), std::string::npos) << e.what();
    }
    EXPECT_THROW(writePng(path("no-such-dir/out.png"), makeLayer("", 2, 2, 1.0f), 1.0),
                 std::runtime_error);
    EXPECT_FALSE(leftovers(dir_));

    // The file is complete but cannot take its final name (a non-empty directory is there):
    // the partial file must not survive.
    fs::create_directories(path("taken.exr/inside"));
    EXPECT_THROW(writeExr(path("taken.exr"), {makeLayer("", 2, 2, 1.0f)}, {}), std::runtime_error);
    EXPECT_FALSE(fs::exists(path("taken.exr.partial")));
    fs::create_directories(path("taken.png/inside"));
    EXPECT_THROW(writePng(path("taken.png"), makeLayer("", 2, 2, 1.0f), 1.0), std::runtime_error);
    EXPECT_FALSE(fs::exists(path("taken.png.partial")));
}

TEST_F(ImageIOTest, BadFilesRaiseInputError) {
    EXPECT_THROW(readExr(path("missing.exr")), InputError);
    std::ofstream(path("garbage.exr")) << "this is not an OpenEXR file\n";
    try {
        readExr(path("garbage.exr"));
        FAIL() << "expected InputError";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), path("garbage.exr"));
        EXPECT_EQ(e.line(), 0);
    }
    // A valid file cut short.
    writeExr(path("whole.exr"), {makeLayer("", 64, 64, 1.0f)}, {});
    const std::vector<unsigned char> bytes = fileBytes(path("whole.exr"));
    std::ofstream(path("cut.exr"), std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size() / 2));
    EXPECT_THROW(readExr(path("cut.exr")), InputError);
}

// A data window that starts left of and above the origin (overscan) reads its pixels in place. The
// reader used to offset its buffer pointer by the window origin in unsigned arithmetic, which for a
// negative origin wrapped around the address space: undefined behaviour that UBSan reports
// (scripts/test-sanitize.sh; found by the exr fuzz target), not a wrong value in a plain build.
TEST_F(ImageIOTest, NegativeDataWindowOriginReadsPixelsInPlace) {
    const Imath::Box2i window(Imath::V2i(-5, -2), Imath::V2i(1, 0));
    const int width = 7, height = 3;
    std::vector<float> rgb(3 * width * height);
    for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = 0.25f * static_cast<float>(i) + 1.0f;
    {
        Imf::Header header(Imath::Box2i(Imath::V2i(0, 0), Imath::V2i(3, 3)), window);
        Imf::FrameBuffer buffer;
        for (int c = 0; c < 3; ++c) {
            const char* name = c == 0 ? "R" : c == 1 ? "G" : "B";
            header.channels().insert(name, Imf::Channel(Imf::FLOAT));
            buffer.insert(name, Imf::Slice::Make(Imf::FLOAT, rgb.data() + c, window, 3 * sizeof(float),
                                                 3 * sizeof(float) * width));
        }
        Imf::OutputFile file(path("overscan.exr").c_str(), header);
        file.setFrameBuffer(buffer);
        file.writePixels(height);
    }
    // As stored: the data window, placed relative to the display window's corner.
    const ExrImage stored = readExrImage(path("overscan.exr"));
    ASSERT_EQ(stored.layers.size(), 1u);
    EXPECT_EQ(stored.layers[0].x, -5);
    EXPECT_EQ(stored.layers[0].y, -2);
    EXPECT_EQ(stored.layers[0].width, width);
    EXPECT_EQ(stored.layers[0].height, height);
    EXPECT_EQ(stored.layers[0].rgb, rgb);
    // Over the frame (the display window, 4 × 4): the window's pixels at x, y ≥ 0 in place, zero elsewhere.
    const std::vector<ImageLayer> back = readExr(path("overscan.exr"));
    ASSERT_EQ(back.size(), 1u);
    ASSERT_EQ(back[0].width, 4);
    ASSERT_EQ(back[0].height, 4);
    std::vector<float> expected(3 * 4 * 4, 0.0f);
    for (int y = 0; y <= 0; ++y)
        for (int x = 0; x <= 1; ++x)
            for (int c = 0; c < 3; ++c)
                expected[(static_cast<size_t>(y) * 4 + x) * 3 + c] = rgb[(static_cast<size_t>(y + 2) * width + x + 5) * 3 + c];
    EXPECT_EQ(back[0].rgb, expected);
}

// A header may declare any window; readExr refuses a data window or a frame (display window) of
// more than kMaxExrFramePixels before it allocates their buffers (3 × 4 bytes a pixel, over 3 GB
// at the limit), naming the sizes. The files hold a header and no pixels: OpenEXR writes its
// offset table and stops, so they are a few hundred kilobytes.
TEST_F(ImageIOTest, WindowBeyondTheFrameLimitIsRefused) {
    // 32 768 × 8 193 = 2^28 + 32 768 pixels: just beyond the limit.
    const Imath::Box2i small(Imath::V2i(0, 0), Imath::V2i(3, 3));
    const Imath::Box2i huge(Imath::V2i(0, 0), Imath::V2i(32767, 8192));
    ASSERT_GT(32768LL * 8193LL, kMaxExrFramePixels);
    for (const auto& [name, display, data] : {std::tuple{"data.exr", small, huge}, std::tuple{"frame.exr", huge, small}}) {
        {
            Imf::Header header(display, data);
            for (const char* channel : {"R", "G", "B"}) header.channels().insert(channel, Imf::Channel(Imf::FLOAT));
            Imf::OutputFile file(path(name).c_str(), header);  // closed with no pixels written
        }
        try {
            readExr(path(name));
            ADD_FAILURE() << name << " was read";
        } catch (const InputError& e) {
            const std::string message = e.what();
            EXPECT_NE(message.find("32768 × 8193 pixels (at most " + std::to_string(kMaxExrFramePixels) + ")"),
                      std::string::npos)
                << message;
        }
    }
}

// An 87-byte file from the exr fuzz target: its channel list holds a channel with an x sampling of
// 1 and a y sampling of 0, and OpenEXR's C++ reader, reading the list past its declared size, took
// a later attribute's size from the wrong bytes and allocated 1.6 GB for it. The headers are now
// parsed by OpenEXR's C core first, which refuses the channel list, so the C++ reader never sees it.
// readExr's InputError message for one of the kept fuzz inputs ("" if it read the file).
std::string refusalOfKeptInput(const std::string& name) {
    try {
        readExr(std::string(FLARE_SOURCE_DIR) + "/tests/data/fuzz/exr/" + name);
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

TEST_F(ImageIOTest, HeaderTheCoreRefusesNeverReachesTheReader) {
    const std::string message = refusalOfKeptInput("channel-list-read-past-its-size.exr");
    EXPECT_NE(message.find("channel-list-read-past-its-size.exr"), std::string::npos) << message;
    EXPECT_NE(message.find("Invalid pixel sampling"), std::string::npos) << message;
}

// A 440-byte file from the exr fuzz target: an attribute of type box2i declared 0 bytes long. The
// C core skips it by its declared size and accepts the header; OpenEXR's C++ reader read 16 bytes
// for it (a box2i's size), took a later string attribute's size from the wrong bytes and allocated
// 1.9 GB. readExr now checks every attribute's declared size against what that reader reads.
TEST_F(ImageIOTest, AttributeTheReaderReadsByItsTypeMustDeclareThatSize) {
    const std::string message = refusalOfKeptInput("box2i-declared-empty.exr");
    EXPECT_NE(message.find("declares 0 bytes, but a box2i is 16"), std::string::npos) << message;
}

TEST_F(ImageIOTest, NonFiniteValuesAndMismatchedLayersAreRejected) {
    for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                      -std::numeric_limits<float>::infinity()}) {
        ImageLayer layer = makeLayer("", 3, 3, 1.0f);
        layer.rgb[13] = bad;
        EXPECT_THROW(writeExr(path("bad.exr"), {layer}, {}), std::logic_error);
        EXPECT_THROW(writePng(path("bad.png"), layer, 1.0), std::logic_error);
    }
    EXPECT_THROW(writeExr(path("bad.exr"), {makeLayer("", 3, 3, 1.0f), makeLayer("a", 3, 2, 1.0f)}, {}),
                 std::logic_error);
    ImageLayer shortLayer = makeLayer("", 3, 3, 1.0f);
    shortLayer.rgb.pop_back();
    EXPECT_THROW(writeExr(path("bad.exr"), {shortLayer}, {}), std::logic_error);
    EXPECT_THROW(writeExr(path("bad.exr"), {makeLayer("", 3, 3, 1.0f)}, {{"channels", "x"}}),
                 std::logic_error);
    EXPECT_FALSE(leftovers(dir_));
}

// Per-ghost layers over their footprints: a part of their own each, the data window where the
// layer lies in the frame, the display window the frame; the first part holds the main image and
// the other whole-frame layers, so a reader that knows no parts sees the image.
TEST_F(ImageIOTest, WindowedLayersAreOwnPartsWithTheirDataWindowsInPlace) {
    const ImageLayer main = makeLayer("", 40, 30, 0.5f), whole = makeLayer("ghost", 40, 30, 2.0f);
    ImageLayer small = makeLayer("ghost_03_01", 7, 5, -1.5f);
    small.x = 31, small.y = 2;  // touches no frame edge
    ImageLayer corner = makeLayer("ghost_09_04", 9, 4, 3.25f);
    corner.x = 31, corner.y = 26;  // the bottom-right corner: its last pixel is the frame's last
    ImageLayer everything = makeLayer("ghost_12_10", 40, 30, -0.75f);  // covers the frame, still a part
    ExrWriteOptions options;
    options.ownParts = {"ghost_03_01", "ghost_09_04", "ghost_12_10"};
    options.storage["ghost_09_04"] = ExrStorage::FloatHalfPrecision;
    writeExr(path("parts.exr"), {main, whole, small, corner, everything}, {{"software", "flare test"}}, options);

    Imf::MultiPartInputFile file(path("parts.exr").c_str());
    ASSERT_EQ(file.parts(), 4);
    EXPECT_EQ(file.header(0).name(), "rgba");
    EXPECT_NE(file.header(0).channels().findChannel("R"), nullptr);
    EXPECT_NE(file.header(0).channels().findChannel("ghost.R"), nullptr);
    EXPECT_NE(file.header(0).findTypedAttribute<Imf::StringAttribute>("software"), nullptr);
    const Imath::Box2i frame(Imath::V2i(0, 0), Imath::V2i(39, 29));
    const std::pair<const ImageLayer*, int> parts[] = {{&small, 1}, {&corner, 2}, {&everything, 3}};
    for (const auto& [layer, p] : parts) {
        const Imf::Header& header = file.header(p);
        EXPECT_EQ(header.name(), layer->name);
        EXPECT_EQ(header.displayWindow(), frame);
        EXPECT_EQ(header.dataWindow(), Imath::Box2i(Imath::V2i(layer->x, layer->y),
                                                    Imath::V2i(layer->x + layer->width - 1, layer->y + layer->height - 1)));
        EXPECT_NE(header.channels().findChannel(layer->name + ".G"), nullptr);
        EXPECT_TRUE(hasChromaticities(header));
    }
    // A single-part reader sees the first part: the main image and the whole-frame layers.
    EXPECT_EQ(Imf::InputFile(path("parts.exr").c_str()).header().channels().findChannel("ghost_03_01.R"), nullptr);

    // Read as stored: each over its window, exactly (the half-precision one rounded).
    const ExrImage image = readExrImage(path("parts.exr"));
    EXPECT_EQ(image.width, 40);
    EXPECT_EQ(image.height, 30);
    EXPECT_EQ(image.ownParts, options.ownParts);
    ASSERT_EQ(image.layers.size(), 5u);
    EXPECT_EQ(image.layers[0].name, "");
    for (const ImageLayer* written : std::vector<const ImageLayer*>{&main, &whole, &small, &everything}) {
        const auto it = std::find_if(image.layers.begin(), image.layers.end(),
                                     [&](const ImageLayer& l) { return l.name == written->name; });
        ASSERT_NE(it, image.layers.end()) << written->name;
        EXPECT_EQ(std::tie(it->x, it->y, it->width, it->height),
                  std::tie(written->x, written->y, written->width, written->height));
        EXPECT_EQ(it->rgb, written->rgb) << written->name;
    }
    // Over the whole frame: the window's pixels in place, zeros elsewhere.
    for (const ImageLayer* written : std::vector<const ImageLayer*>{&small, &corner}) {
        const ImageLayer back = readExrLayer(path("parts.exr"), written->name);
        ASSERT_EQ(back.width, 40);
        ASSERT_EQ(back.height, 30);
        EXPECT_EQ(back.x, 0);
        for (int y = 0; y < 30; ++y)
            for (int x = 0; x < 40; ++x)
                for (int c = 0; c < 3; ++c) {
                    const bool inside = x >= written->x && x < written->x + written->width && y >= written->y &&
                                        y < written->y + written->height;
                    const float value = back.rgb[(static_cast<size_t>(y) * 40 + x) * 3 + c];
                    if (!inside) {
                        ASSERT_EQ(value, 0.0f) << written->name << " at " << x << ", " << y;
                        continue;
                    }
                    const float stored =
                        written->rgb[(static_cast<size_t>(y - written->y) * written->width + (x - written->x)) * 3 + c];
                    if (written == &small) ASSERT_EQ(value, stored);
                    else ASSERT_NEAR(value, stored, std::ldexp(std::abs(stored), -11));
                }
    }
    const std::vector<ImageLayer> expanded = readExr(path("parts.exr"));
    ASSERT_EQ(expanded.size(), 5u);
    for (const ImageLayer& layer : expanded) EXPECT_EQ(std::tie(layer.width, layer.height), std::tie(whole.width, whole.height));
    EXPECT_EQ(expanded[0].rgb, main.rgb);
}

TEST_F(ImageIOTest, WindowsMustBeOwnPartsInsideTheFrame) {
    const ImageLayer main = makeLayer("", 10, 8, 1.0f);
    ImageLayer window = makeLayer("ghost_02_01", 4, 3, 1.0f);
    window.x = 2, window.y = 1;
    EXPECT_THROW(writeExr(path("bad.exr"), {main, window}, {}), std::logic_error);  // not a part of its own
    ExrWriteOptions options;
    options.ownParts = {"ghost_02_01"};
    window.x = 7;  // 7 + 4 > 10
    EXPECT_THROW(writeExr(path("bad.exr"), {main, window}, {}, options), std::logic_error);
    window.x = 2, window.y = -1;
    EXPECT_THROW(writeExr(path("bad.exr"), {main, window}, {}, options), std::logic_error);
    window.y = 1;
    options.ownParts.insert("no-such-layer");
    EXPECT_THROW(writeExr(path("bad.exr"), {main, window}, {}, options), std::logic_error);
    EXPECT_FALSE(leftovers(dir_));
    // Without parts the file is the single-part one it always was.
    writeExr(path("single.exr"), {main}, {});
    EXPECT_EQ(Imf::MultiPartInputFile(path("single.exr").c_str()).parts(), 1);
    EXPECT_FALSE(Imf::InputFile(path("single.exr").c_str()).header().hasName());
}

TEST_F(ImageIOTest, PngHasSignatureAndImageHeader) {
    writePng(path("quick.png"), makeLayer("", 13, 7, 0.01f), 1.0);
    const std::vector<unsigned char> b = fileBytes(path("quick.png"));
    ASSERT_GE(b.size(), 33u);
    const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    for (int i = 0; i < 8; ++i) EXPECT_EQ(b[i], signature[i]);
    EXPECT_EQ(std::string(b.begin() + 12, b.begin() + 16), "IHDR");
    auto be32 = [&](size_t at) { return (b[at] << 24) | (b[at + 1] << 16) | (b[at + 2] << 8) | b[at + 3]; };
    EXPECT_EQ(be32(16), 13);
    EXPECT_EQ(be32(20), 7);
    EXPECT_EQ(b[24], 8);  // bit depth
    EXPECT_EQ(b[25], 2);  // colour type: RGB
    EXPECT_FALSE(fs::exists(path("quick.png.partial")));
}

TEST_F(ImageIOTest, PngPixelsAreTheDisplayEncodingRounded) {
    ImageLayer image{"", 4, 1, {0.0f, 0.0f, 0.0f, 0.5f, 0.5f, 0.5f, 40.0f, 1.0f, 0.2f, -0.1f, 2.0f, 0.3f}};
    const double exposure = 1.7;
    writePng(path("px.png"), image, exposure);
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    ASSERT_TRUE(png_image_begin_read_from_file(&png, path("px.png").c_str()));
    png.format = PNG_FORMAT_RGB;
    std::vector<std::uint8_t> pixels(PNG_IMAGE_SIZE(png));
    ASSERT_TRUE(png_image_finish_read(&png, nullptr, pixels.data(), 0, nullptr));
    for (int p = 0; p < 4; ++p) {
        const glm::dvec3 v = displayEncode({image.rgb[3 * p], image.rgb[3 * p + 1], image.rgb[3 * p + 2]}, exposure);
        for (int c = 0; c < 3; ++c) EXPECT_EQ(pixels[3 * p + c], std::lround(255.0 * v[c])) << p << "," << c;
    }
}

double srgbDecode(double v) { return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4); }

TEST(DisplayEncode, GreyFollowsTheReinhardCurveThroughTheSrgbOetf) {
    for (double grey : {0.0, 0.001, 0.2, 1.0, 7.5, 1e6}) {
        const double x = 2.0 * grey;
        const double display = x / (1.0 + x);
        const double expected = display <= 0.0031308 ? 12.92 * display
                                                     : 1.055 * std::pow(display, 1.0 / 2.4) - 0.055;
        const glm::dvec3 v = displayEncode(glm::dvec3(grey), 2.0);
        // The grey's luminance is Σ of the matrix's Y row (1 to rounding): a few ulps.
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(v[c], expected, 16 * kEpsilon) << grey;
    }
}

TEST(DisplayEncode, OutOfGamutColoursKeepLuminanceAndHue) {
    // Bright and saturated (red channel far above 1) and spectral (a negative channel).
    for (const glm::dvec3 rgb : {glm::dvec3(40.0, 1.0, 0.2), glm::dvec3(-0.1, 2.0, 0.3),
                                 glm::dvec3(0.02, 0.01, 3.0)}) {
        const glm::dvec3 v = displayEncode(rgb, 1.0);
        const glm::dvec3 linear(srgbDecode(v.r), srgbDecode(v.g), srgbDecode(v.b));
        const double y = linearSrgbToXyz(rgb).y;
        // Decoding inverts the OETF to ~1e-15; the luminance is y/(1+y) to that precision.
        EXPECT_NEAR(linearSrgbToXyz(linear).y, y / (1.0 + y), 1e-12) << rgb.r;
        for (int c = 0; c < 3; ++c) {
            EXPECT_GE(v[c], 0.0);
            EXPECT_LE(v[c], 1.0);
        }
        // Same hue: the result lies on the segment from grey to the scaled input.
        const glm::dvec3 grey(y / (1.0 + y));
        const glm::dvec3 direction = glm::normalize(rgb / y * (y / (1.0 + y)) - grey);
        const glm::dvec3 moved = linear - grey;
        EXPECT_NEAR(glm::length(glm::cross(direction, moved)), 0.0, 1e-12) << rgb.r;
        EXPECT_GT(glm::dot(direction, moved), 0.0);
    }
}

TEST(AutoExposure, MapsThe99thPercentileOfLitPixelsToDisplayPointEight) {
    // 9000 empty pixels (black or below 1e-6 of the maximum) and 1000 lit greys 1..1000: the 99th
    // percentile of the lit ones is element 989 of 0..999, luminance 990.
    ImageLayer image{"", 100, 100, {}};
    for (int i = 0; i < 10000; ++i) {
        const float v = i < 1000 ? static_cast<float>(i + 1) : (i % 2 ? 0.0f : 1e-4f);
        image.rgb.insert(image.rgb.end(), {v, v, v});
    }
    const double exposure = autoExposure(image);
    EXPECT_NEAR(exposure * 990.0, 0.8 / (1.0 - 0.8), 1e-12);
    const glm::dvec3 shown = displayEncode(glm::dvec3(990.0), exposure);
    EXPECT_NEAR(srgbDecode(shown.g), 0.8, 1e-12);
    EXPECT_EQ(autoExposure(ImageLayer{"", 2, 1, std::vector<float>(6, 0.0f)}), 1.0);
}

}  // namespace
}  // namespace flare
