// `flare composite` run as a subprocess: a plate's bright pixels become lights at their field
// angles with their power, the layers add up, colour spaces round-trip, the lights it writes
// render its flare, and bad plates are refused with nothing written.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfMultiPartInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <gtest/gtest.h>
#include <png.h>
#include <glm/matrix.hpp>
#include <nlohmann/json.hpp>

#include "TestUtil.h"
#include "flare/core/Spectrum.h"
#include "flare/film/ImageIO.h"
#include "flare/scene/PlateColourSpace.h"

namespace flare {
namespace {

constexpr int kW = 240, kH = 160;  // 36 mm across: 0.15 mm pixels

std::filesystem::path dir() { return test::processTempDir("flare_composite_cli"); }
std::string path(const std::string& name) {
    std::filesystem::remove(dir() / name);
    return (dir() / name).string();
}

// An EXR of float channels written by OpenEXR itself (any values, NaN too; any channel names).
void writeRawExr(const std::string& file, int w, int h, const std::vector<float>& values,
                 const std::vector<std::string>& channels, const std::array<double, 8>* chromaticities = nullptr) {
    Imf::Header header(w, h);
    const size_t n = channels.size();
    for (const std::string& c : channels) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
    if (chromaticities) {
        const auto& c = *chromaticities;
        Imf::addChromaticities(header, Imf::Chromaticities(Imath::V2f(c[0], c[1]), Imath::V2f(c[2], c[3]),
                                                           Imath::V2f(c[4], c[5]), Imath::V2f(c[6], c[7])));
    }
    Imf::OutputFile out(file.c_str(), header);
    Imf::FrameBuffer fb;
    for (size_t k = 0; k < n; ++k)
        fb.insert(channels[k], Imf::Slice(Imf::FLOAT, (char*)(values.data() + k), sizeof(float) * n, sizeof(float) * n * w));
    out.setFrameBuffer(fb);
    out.writePixels(h);
}

struct Pixel {
    int x, y;
    glm::dvec3 rgb;
};
std::string writePlate(const std::string& name, const std::vector<Pixel>& pixels, const std::array<double, 8>* xy = nullptr,
                       glm::dvec3 background = glm::dvec3(0.0)) {
    std::vector<float> rgb(3 * kW * kH);
    for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<float>(background[i % 3]);
    for (const Pixel& p : pixels)
        for (int k = 0; k < 3; ++k) rgb[3 * (p.y * kW + p.x) + k] = static_cast<float>(p.rgb[k]);
    const std::string file = path(name);
    writeRawExr(file, kW, kH, rgb, {"R", "G", "B"}, xy);
    return file;
}

ImageLayer layer(const std::string& exr, const std::string& name) { return readExrLayer(exr, name); }

nlohmann::json readJson(const std::string& file) {
    std::ifstream in(file);
    return nlohmann::json::parse(in);
}

// Luminance-weighted centroid and total luminance of a Rec.709 layer.
struct Moments {
    glm::dvec2 centroid{0.0};
    double luminance = 0.0;
};
Moments moments(const ImageLayer& l) {
    const glm::dvec3 yRow(linearSrgbToXyz({1, 0, 0}).y, linearSrgbToXyz({0, 1, 0}).y, linearSrgbToXyz({0, 0, 1}).y);
    Moments m;
    for (int y = 0; y < l.height; ++y)
        for (int x = 0; x < l.width; ++x) {
            const size_t i = 3 * (static_cast<size_t>(y) * l.width + x);
            const double v = glm::dot(yRow, glm::dvec3(l.rgb[i], l.rgb[i + 1], l.rgb[i + 2]));
            m.luminance += v;
            m.centroid += v * glm::dvec2(x + 0.5, y + 0.5);
        }
    m.centroid /= m.luminance;
    return m;
}

const std::string kLens = "--lens double-gauss-50mm --f-number 8";

// One bright pixel: one directional light, whose direct image through the lens (rendered from
// the written scene by `flare preview`, the mesh preview: an estimator of its own) is centred on
// that pixel within a tenth of a pixel and holds the pixel's energy within 1 %.
TEST(CompositeCli, OneBrightPixelIsALightAtItsFieldWithItsPower) {
    const glm::dvec3 value(400.0, 300.0, 200.0);
    const std::string plate = writePlate("one.exr", {{170, 50, value}});
    const std::string out = path("one-out.exr"), lights = path("one.json");
    const test::CliRun r = test::runCli("composite " + plate + " " + kLens + " -o " + out + " --lights-json " + lights);
    ASSERT_EQ(r.exitCode, 0) << r.out;
    const nlohmann::json scene = readJson(lights);
    ASSERT_EQ(scene["lights"].size(), 1u);
    EXPECT_EQ(scene["lights"][0]["type"], "directional");
    EXPECT_FALSE(scene["lights"][0].contains("angular_diameter_deg"));  // one pixel: a point

    const std::string direct = path("one-direct.exr");
    const test::CliRun p = test::runCli("preview " + lights + " -o " + direct + " --layers --no-diffraction --quiet");
    ASSERT_EQ(p.exitCode, 0) << p.out;
    const Moments m = moments(layer(direct, "direct"));
    EXPECT_NEAR(m.centroid.x, 170.5, 0.1);
    EXPECT_NEAR(m.centroid.y, 50.5, 0.1);
    const double plateY = linearSrgbToXyz(value).y;
    EXPECT_NEAR(m.luminance, plateY, 0.01 * plateY);
}

// Composite − plate is the flare layer, the flare is ghost + starburst, the plate layer is the
// plate, and the scene written with --lights-json renders (flare preview, same seed and passes)
// the composite's ghost layer.
TEST(CompositeCli, LayersAddUpAndTheWrittenLightsRenderTheFlare) {
    std::vector<Pixel> pixels;
    for (int y = 30; y < 34; ++y)
        for (int x = 60; x < 66; ++x) pixels.push_back({x, y, glm::dvec3(900.0, 500.0, 120.0)});
    pixels.push_back({200, 120, glm::dvec3(50.0, 80.0, 400.0)});
    const std::string plate = writePlate("two.exr", pixels, nullptr, glm::dvec3(0.02, 0.03, 0.05));
    const std::string out = path("two-out.exr"), lights = path("two.json");
    const test::CliRun r = test::runCli("composite " + plate + " " + kLens + " -o " + out + " --lights-json " + lights +
                                        " --cell-px 2 --threshold 1");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    const nlohmann::json scene = readJson(lights);
    // Two groups: the 6 × 4 blob in 2 px cells (6 lights) and the single pixel.
    ASSERT_EQ(scene["lights"].size(), 7u);
    int firstGroup = 0;
    for (const auto& l : scene["lights"]) firstGroup += l["name"].get<std::string>().starts_with("source0-");
    EXPECT_EQ(firstGroup, 6);

    const ImageLayer composite = layer(out, ""), plateLayer = layer(out, "plate"), flare = layer(out, "flare"),
                     ghost = layer(out, "ghost"), starburst = layer(out, "starburst");
    const ImageLayer original = readExrLayer(plate, "");
    double largest = 0.0;
    for (float v : composite.rgb) largest = std::max(largest, std::abs(static_cast<double>(v)));
    for (size_t i = 0; i < composite.rgb.size(); ++i) {
        ASSERT_EQ(plateLayer.rgb[i], original.rgb[i]);
        ASSERT_NEAR(composite.rgb[i] - plateLayer.rgb[i], flare.rgb[i], 1e-6 * largest) << i;
        ASSERT_NEAR(flare.rgb[i], ghost.rgb[i] + starburst.rgb[i], 1e-6 * largest) << i;
    }

    const std::string rendered = path("two-preview.exr");
    const test::CliRun p = test::runCli("preview " + lights + " -o " + rendered + " --layers --quiet");
    ASSERT_EQ(p.exitCode, 0) << p.out;
    const ImageLayer again = layer(rendered, "ghost");
    double ghostLargest = 0.0;
    for (float v : ghost.rgb) ghostLargest = std::max(ghostLargest, std::abs(static_cast<double>(v)));
    ASSERT_GT(ghostLargest, 0.0);
    for (size_t i = 0; i < ghost.rgb.size(); ++i) ASSERT_NEAR(again.rgb[i], ghost.rgb[i], 1e-5 * ghostLargest) << i;
}

// --compression sets the file's compression and nothing else: the same pixels in every layer,
// none against the default PIZ (a preview written fast), and an unknown name is refused.
TEST(CompositeCli, CompressionChangesTheFileNotThePixels) {
    const std::string plate = writePlate("squeeze.exr", {{60, 40, glm::dvec3(900.0, 500.0, 120.0)}}, nullptr,
                                         glm::dvec3(0.02, 0.03, 0.05));
    const std::string piz = path("squeeze-piz.exr"), none = path("squeeze-none.exr");
    for (const auto& [out, extra] : {std::pair{piz, std::string()}, std::pair{none, std::string(" --compression none")}}) {
        const test::CliRun r = test::runCli("composite " + plate + " " + kLens + " -o " + out + " --quiet" + extra);
        ASSERT_EQ(r.exitCode, 0) << r.out;
    }
    EXPECT_EQ(Imf::MultiPartInputFile(piz.c_str()).header(0).compression(), Imf::PIZ_COMPRESSION);
    EXPECT_EQ(Imf::MultiPartInputFile(none.c_str()).header(0).compression(), Imf::NO_COMPRESSION);
    const std::vector<ImageLayer> a = readExr(piz), b = readExr(none);
    ASSERT_EQ(a.size(), b.size());
    for (size_t l = 0; l < a.size(); ++l) {
        EXPECT_EQ(a[l].name, b[l].name);
        EXPECT_TRUE(a[l].rgb == b[l].rgb) << a[l].name;
    }
    const std::string refused = path("squeeze-lzma.exr");
    const test::CliRun bad = test::runCli("composite " + plate + " " + kLens + " -o " + refused + " --compression lzma");
    EXPECT_EQ(bad.exitCode, 2) << bad.out;
    EXPECT_NE(bad.out.find("--compression"), std::string::npos) << bad.out;
    EXPECT_FALSE(std::filesystem::exists(refused));
}

// By default the source pixels become region lights: a two-coloured blob is one region light whose
// points are its pixels in its two colours, a lone pixel a directional light; the scene written
// with --lights-json reads back and renders (flare preview, the same seed and passes) the
// composite's ghost layer.
TEST(CompositeCli, RegionLightsAreWrittenAndRenderTheFlare) {
    std::vector<Pixel> pixels;
    for (int y = 30; y < 34; ++y)
        for (int x = 60; x < 72; ++x)
            pixels.push_back({x, y, x < 66 ? glm::dvec3(900.0, 500.0, 120.0) : glm::dvec3(150.0, 300.0, 800.0)});
    pixels.push_back({200, 120, glm::dvec3(50.0, 80.0, 400.0)});
    const std::string plate = writePlate("regions.exr", pixels, nullptr, glm::dvec3(0.02, 0.03, 0.05));
    const std::string out = path("regions-out.exr"), lights = path("regions.json");
    const test::CliRun r =
        test::runCli("composite " + plate + " " + kLens + " -o " + out + " --lights-json " + lights + " --threshold 1");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    EXPECT_NE(r.out.find("2 region lights of up to 2.5 deg"), std::string::npos) << r.out;
    const nlohmann::json scene = readJson(lights);
    ASSERT_EQ(scene["lights"].size(), 2u);
    const nlohmann::json& blob = scene["lights"][0];  // the strongest first
    EXPECT_EQ(blob["type"], "region");
    EXPECT_EQ(blob["points"].size(), 48u);
    EXPECT_EQ(blob["colours"].size(), 2u);
    EXPECT_EQ(scene["lights"][1]["type"], "directional");

    const ImageLayer composite = layer(out, ""), plateLayer = layer(out, "plate"), flare = layer(out, "flare"),
                     ghost = layer(out, "ghost"), starburst = layer(out, "starburst");
    double largest = 0.0;
    for (float v : composite.rgb) largest = std::max(largest, std::abs(static_cast<double>(v)));
    for (size_t i = 0; i < composite.rgb.size(); ++i) {
        ASSERT_NEAR(composite.rgb[i] - plateLayer.rgb[i], flare.rgb[i], 1e-6 * largest) << i;
        ASSERT_NEAR(flare.rgb[i], ghost.rgb[i] + starburst.rgb[i], 1e-6 * largest) << i;
    }
    const std::string rendered = path("regions-preview.exr");
    const test::CliRun p = test::runCli("preview " + lights + " -o " + rendered + " --layers --quiet");
    ASSERT_EQ(p.exitCode, 0) << p.out;
    const ImageLayer again = layer(rendered, "ghost");
    double ghostLargest = 0.0;
    for (float v : ghost.rgb) ghostLargest = std::max(ghostLargest, std::abs(static_cast<double>(v)));
    ASSERT_GT(ghostLargest, 0.0);
    for (size_t i = 0; i < ghost.rgb.size(); ++i) ASSERT_NEAR(again.rgb[i], ghost.rgb[i], 1e-5 * ghostLargest) << i;
}

// Moving a blob by one pixel moves its light by one pixel's field angle and its flare with it: the
// ghosts' centroid moves by more than four times what another seed alone moves it (the beams'
// noise, measured).
TEST(CompositeCli, AOnePixelShiftMovesTheFlare) {
    auto blob = [](int x0) {
        std::vector<Pixel> pixels;
        for (int y = 40; y < 43; ++y)
            for (int x = x0; x < x0 + 3; ++x) pixels.push_back({x, y, glm::dvec3(1000.0)});
        return pixels;
    };
    std::vector<nlohmann::json> light;
    std::vector<ImageLayer> ghosts;
    const int shifts[] = {0, 1, 0}, seeds[] = {1, 1, 2};
    for (int run = 0; run < 3; ++run) {
        const std::string tag = std::to_string(run);
        const std::string plate = writePlate("shift" + tag + ".exr", blob(150 + shifts[run]));
        const std::string out = path("shift-out" + tag + ".exr"), lights = path("shift" + tag + ".json");
        const test::CliRun r = test::runCli("composite " + plate + " " + kLens + " -o " + out + " --lights-json " + lights +
                                            " --cell-px 64 --passes 4 --seed " + std::to_string(seeds[run]) +
                                            " --quiet");  // one cell: the blob is one light
        ASSERT_EQ(r.exitCode, 0) << r.out;
        light.push_back(readJson(lights)["lights"]);
        ghosts.push_back(layer(out, "ghost"));
    }
    ASSERT_EQ(light[0].size(), 1u);
    ASSERT_EQ(light[1].size(), 1u);
    // One pixel (0.15 mm) at 50 mm is 0.17°; the field moves right by about that.
    const double dx = light[1][0]["field_deg"][0].get<double>() - light[0][0]["field_deg"][0].get<double>();
    const double pixelDeg = std::atan(0.15 / 50.0) * 180.0 / std::numbers::pi;
    EXPECT_NEAR(dx, pixelDeg, 0.02);
    // y changes only through the distortion's dependence on the radius: far under a pixel.
    EXPECT_LT(std::abs(light[1][0]["field_deg"][1].get<double>() - light[0][0]["field_deg"][1].get<double>()),
              0.01 * pixelDeg);
    const Moments a = moments(ghosts[0]), shifted = moments(ghosts[1]), reseeded = moments(ghosts[2]);
    const double moved = glm::length(shifted.centroid - a.centroid), noise = glm::length(reseeded.centroid - a.centroid);
    EXPECT_GT(moved, 4.0 * noise) << "moved " << moved << " px, noise " << noise << " px";
}

// An ACEScg plate: the output carries ACEScg's chromaticities, its plate layer is the input, and
// its flare is the Rec.709 plate's flare (the same light in the other space) converted to ACEScg.
TEST(CompositeCli, AnAcesCgPlateRoundTripsItsColourSpace) {
    const PlateColourSpace aces = resolveColourSpace("ACEScg");
    const glm::dvec3 rec709(800.0, 400.0, 100.0);
    const glm::dvec3 inAces = aces.fromXyz * linearSrgbToXyz(rec709);
    const std::string plateAces = writePlate("aces.exr", {{100, 80, inAces}}, &aces.chromaticities);
    const std::string plate709 = writePlate("rec709.exr", {{100, 80, rec709}});
    const std::string outAces = path("aces-out.exr"), out709 = path("rec709-out.exr");
    ASSERT_EQ(test::runCli("composite " + plateAces + " " + kLens + " -o " + outAces + " --quiet").exitCode, 0);
    ASSERT_EQ(test::runCli("composite " + plate709 + " " + kLens + " -o " + out709 + " --quiet").exitCode, 0);
    Imf::MultiPartInputFile file(outAces.c_str());
    ASSERT_TRUE(Imf::hasChromaticities(file.header(0)));
    const Imf::Chromaticities& c = Imf::chromaticities(file.header(0));
    EXPECT_FLOAT_EQ(c.red.x, 0.713f);
    EXPECT_FLOAT_EQ(c.green.y, 0.830f);
    EXPECT_FLOAT_EQ(c.white.x, 0.32168f);
    const ImageLayer plate = layer(outAces, "plate"), original = readExrLayer(plateAces, "");
    EXPECT_EQ(plate.rgb, original.rgb);
    const ImageLayer flareAces = layer(outAces, "flare"), flare709 = layer(out709, "flare");
    const glm::dmat3 toAces = aces.fromXyz * glm::inverse(glm::dmat3(xyzToLinearSrgbMatrix()));
    double largest = 0.0;
    for (float v : flare709.rgb) largest = std::max(largest, std::abs(static_cast<double>(v)));
    for (size_t i = 0; i < flare709.rgb.size(); i += 3) {
        const glm::dvec3 want = toAces * glm::dvec3(flare709.rgb[i], flare709.rgb[i + 1], flare709.rgb[i + 2]);
        for (int k = 0; k < 3; ++k) ASSERT_NEAR(flareAces.rgb[i + k], want[k], 1e-4 * largest) << i;
    }
}

// A 3 × 3 matrix as an OpenColorIO MatrixTransform's 16 values (row-major 4 × 4).
std::string ocioMatrix(const glm::dmat3& m) {
    std::string out;
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) out += std::to_string(m[c][r]) + ", ";
        out += "0, ";
    }
    return out + "0, 0, 0, 1";
}

// A colour space named in a user's OpenColorIO config ($OCIO): a matrix space is used (here
// ACEScg under another name: the same flare as the ACEScg plate), a non-linear one refused.
TEST(CompositeCli, ColourSpacesFromAnOcioConfig) {
    const PlateColourSpace aces = resolveColourSpace("ACEScg");
    const std::string matrix = ocioMatrix(aces.toXyz);
    const std::string config = path("config.ocio");
    std::ofstream(config) << "ocio_profile_version: 2\n"
                             "roles:\n  default: xyz\n  scene_linear: studio_cg\n  cie_xyz_d65_interchange: xyz\n"
                             "file_rules:\n  - !<Rule> {name: Default, colorspace: default}\n"
                             "colorspaces:\n"
                             "  - !<ColorSpace>\n    name: xyz\n"
                             "  - !<ColorSpace>\n    name: studio_cg\n    to_scene_reference: !<MatrixTransform> {matrix: [" +
                                 matrix +
                                 "]}\n"
                                 "  - !<ColorSpace>\n    name: studio_gamma\n    to_scene_reference: !<ExponentTransform> "
                                 "{value: [2.2, 2.2, 2.2, 1]}\n";
    ::setenv("OCIO", config.c_str(), 1);
    const glm::dvec3 value = aces.fromXyz * linearSrgbToXyz(glm::dvec3(800.0, 400.0, 100.0));
    const std::string plate = writePlate("ocio.exr", {{100, 80, value}});
    const std::string out = path("ocio-out.exr"), outAces = path("ocio-aces-out.exr");
    const test::CliRun r = test::runCli("composite " + plate + " " + kLens + " -o " + out + " --colorspace studio_cg");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    EXPECT_NE(r.out.find("studio_cg"), std::string::npos) << r.out;
    ASSERT_EQ(test::runCli("composite " + plate + " " + kLens + " -o " + outAces + " --colorspace ACEScg --quiet").exitCode, 0);
    const ImageLayer a = layer(out, "flare"), b = layer(outAces, "flare");
    double largest = 0.0;
    for (float v : b.rgb) largest = std::max(largest, std::abs(static_cast<double>(v)));
    for (size_t i = 0; i < a.rgb.size(); ++i) ASSERT_NEAR(a.rgb[i], b.rgb[i], 1e-4 * largest) << i;

    const std::string refused = path("gamma-out.exr");
    const test::CliRun g = test::runCli("composite " + plate + " " + kLens + " -o " + refused + " --colorspace studio_gamma");
    EXPECT_EQ(g.exitCode, 2) << g.out;
    EXPECT_NE(g.out.find("not scene-linear"), std::string::npos) << g.out;
    EXPECT_FALSE(std::filesystem::exists(refused));
    const test::CliRun u = test::runCli("composite " + plate + " " + kLens + " -o " + refused + " --colorspace studio_cgg");
    EXPECT_EQ(u.exitCode, 2) << u.out;
    EXPECT_NE(u.out.find("did you mean 'studio_cg'"), std::string::npos) << u.out;
    ::unsetenv("OCIO");
}

// --display and --view: the PNG through a config's view, here a matrix the test can apply (half the
// linear Rec.709 value, clamped), against the composite the EXR holds times the exposure; an
// unknown display or view, a display without $OCIO or without --png, exit 2 naming it.
TEST(CompositeCli, ThePngThroughAnOcioDisplayAndView) {
    const std::string fromXyz = ocioMatrix(0.5 * glm::dmat3(xyzToLinearSrgbMatrix()));  // halved
    const std::string config = path("display.ocio");
    std::ofstream(config) << "ocio_profile_version: 2\n"
                             "roles:\n  default: xyz\n  scene_linear: xyz\n  cie_xyz_d65_interchange: xyz\n"
                             "file_rules:\n  - !<Rule> {name: Default, colorspace: default}\n"
                             "displays:\n  studio:\n    - !<View> {name: half, colorspace: half709}\n"
                             "    - !<View> {name: raw, colorspace: xyz}\n"
                             "colorspaces:\n"
                             "  - !<ColorSpace>\n    name: xyz\n"
                             "  - !<ColorSpace>\n    name: half709\n    from_scene_reference: !<MatrixTransform> {matrix: [" +
                                 fromXyz + "]}\n";
    const std::string plate = writePlate("display.exr", {{100, 80, glm::dvec3(900.0, 500.0, 200.0)}}, nullptr,
                                         glm::dvec3(0.2, 0.5, 0.9));
    const std::string out = path("display-out.exr"), png = path("display-out.png");
    const std::string common = " " + kLens + " -o " + out + " --png " + png + " --quiet";
    ::unsetenv("OCIO");
    test::CliRun r = test::runCli("composite " + plate + common + " --display studio");
    EXPECT_EQ(r.exitCode, 2) << r.out;
    EXPECT_NE(r.out.find("$OCIO"), std::string::npos) << r.out;
    EXPECT_FALSE(std::filesystem::exists(out));
    ::setenv("OCIO", config.c_str(), 1);
    r = test::runCli("composite " + plate + common + " --display studio --view half --exposure 1");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    ASSERT_TRUE(png_image_begin_read_from_file(&image, png.c_str()));
    image.format = PNG_FORMAT_RGB;
    std::vector<std::uint8_t> pixels(PNG_IMAGE_SIZE(image));
    ASSERT_TRUE(png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr));
    const ImageLayer composite = layer(out, "");
    ASSERT_EQ(pixels.size(), composite.rgb.size());
    int wrong = 0, lit = 0;
    for (size_t i = 0; i < pixels.size(); ++i) {
        // The plate has no chromaticities: linear Rec.709. Float rounding in OpenColorIO: ±1 step.
        const double want = 255.0 * std::clamp(0.5 * 2.0 * composite.rgb[i], 0.0, 1.0);
        if (std::abs(pixels[i] - want) > 1.0) ++wrong;
        if (pixels[i] > 0 && pixels[i] < 255) ++lit;
    }
    EXPECT_EQ(wrong, 0);
    EXPECT_GT(lit, static_cast<int>(pixels.size() / 2));  // the background shows, unclipped
    // The default view is the display's first.
    r = test::runCli("composite " + plate + common + " --display studio --exposure 1");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    r = test::runCli("composite " + plate + common + " --display studo");
    EXPECT_EQ(r.exitCode, 2) << r.out;
    EXPECT_NE(r.out.find("studio: half, raw"), std::string::npos) << r.out;
    r = test::runCli("composite " + plate + common + " --display studio --view full");
    EXPECT_EQ(r.exitCode, 2) << r.out;
    EXPECT_NE(r.out.find("no view 'full'"), std::string::npos) << r.out;
    r = test::runCli("composite " + plate + " " + kLens + " -o " + out + " --display studio --quiet");
    EXPECT_EQ(r.exitCode, 2) << r.out;
    EXPECT_NE(r.out.find("--png"), std::string::npos) << r.out;
    ::unsetenv("OCIO");
}

// --extra-lights: a sun just outside the frame, which the plate cannot show, adds its whole image
// and ghosts as the `extra` layer (the flare holds it; composite − plate is still the flare), and
// its name may not repeat a plate source's.
TEST(CompositeCli, ExtraLightsAddTheirWholeFlare) {
    const std::string plate = writePlate("extra.exr", {{60, 40, glm::dvec3(500.0)}});
    const std::string scene = path("extra.json");
    std::ofstream(scene) << R"({"lens": "double-gauss-50mm", "lights": [{"type": "directional", "name": "sun",
        "field_deg": [22, 3], "angular_diameter_deg": 0.53, "power": 1000}]})";
    const std::string out = path("extra-out.exr");
    const test::CliRun r = test::runCli("composite " + plate + " " + kLens + " -o " + out + " --extra-lights " + scene + " --quiet");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    const ImageLayer extra = layer(out, "extra"), flare = layer(out, "flare"), ghost = layer(out, "ghost"),
                     starburst = layer(out, "starburst"), composite = layer(out, ""), plateLayer = layer(out, "plate");
    double extraSum = 0.0, largest = 0.0;
    for (size_t i = 0; i < extra.rgb.size(); ++i) {
        extraSum += extra.rgb[i];
        largest = std::max(largest, std::abs(static_cast<double>(composite.rgb[i])));
    }
    EXPECT_GT(extraSum, 0.0);
    for (size_t i = 0; i < flare.rgb.size(); ++i) {
        ASSERT_NEAR(flare.rgb[i], ghost.rgb[i] + starburst.rgb[i] + extra.rgb[i], 1e-6 * largest) << i;
        ASSERT_NEAR(composite.rgb[i] - plateLayer.rgb[i], flare.rgb[i], 1e-6 * largest) << i;
    }
    std::ofstream(scene) << R"({"lens": "double-gauss-50mm", "lights": [{"type": "directional", "name": "source0-0",
        "field_deg": [22, 3]}]})";
    const std::string clash = path("extra-clash.exr");
    const test::CliRun c = test::runCli("composite " + plate + " " + kLens + " -o " + clash + " --extra-lights " + scene);
    EXPECT_EQ(c.exitCode, 2) << c.out;
    EXPECT_FALSE(std::filesystem::exists(clash));
}

// A sequence (--frames, plate.####.exr): on a static plate the frame-to-frame change is within
// the render's estimated error (it is none: the same sources keep their random sequences); and
// when two sources swap which is brighter, each keeps its index and name (matched by position, not
// re-sorted by power, which would hand it the other's sequences).
TEST(CompositeCli, SequencesMatchSourcesFromFrameToFrame) {
    const glm::dvec3 a(600.0), b(300.0);
    for (int frame = 1; frame <= 3; ++frame) {
        char name[32];
        std::snprintf(name, sizeof name, "seq.%04d.exr", frame);
        // Frames 1 and 2 static; in frame 3 b grows brighter than a and moves one pixel.
        if (frame < 3) writePlate(name, {{60, 40, a}, {180, 110, b}});
        else writePlate(name, {{60, 40, a}, {181, 110, 3.0 * a}});
    }
    const std::string plates = (dir() / "seq.####.exr").string(), outs = (dir() / "seq-out.####.exr").string(),
                      lights = (dir() / "seq.####.json").string();
    const test::CliRun r = test::runCli("composite " + plates + " " + kLens + " -o " + outs + " --lights-json " + lights +
                                        " --frames 1-3");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    const size_t at = r.out.find("estimated ghost error ");
    ASSERT_NE(at, std::string::npos) << r.out;
    const double estimated = 0.01 * std::stod(r.out.substr(at + 22));
    const ImageLayer f1 = layer((dir() / "seq-out.0001.exr").string(), "flare"),
                     f2 = layer((dir() / "seq-out.0002.exr").string(), "flare");
    double diff = 0.0, norm = 0.0;
    for (size_t i = 0; i < f1.rgb.size(); ++i) {
        diff += (f2.rgb[i] - f1.rgb[i]) * (f2.rgb[i] - f1.rgb[i]);
        norm += f1.rgb[i] * f1.rgb[i];
    }
    EXPECT_LE(std::sqrt(diff / norm), estimated);
    const nlohmann::json l2 = readJson((dir() / "seq.0002.json").string())["lights"],
                         l3 = readJson((dir() / "seq.0003.json").string())["lights"];
    ASSERT_EQ(l2.size(), 2u);
    ASSERT_EQ(l3.size(), 2u);
    for (int i = 0; i < 2; ++i) {
        EXPECT_EQ(l3[i]["name"], l2[i]["name"]);
        EXPECT_NEAR(l3[i]["field_deg"][1].get<double>(), l2[i]["field_deg"][1].get<double>(), 0.01);
    }
    EXPECT_GT(l3[1]["power"].get<double>(), l3[0]["power"].get<double>());  // b, now the brighter, kept index 1

    const std::string bad = path("bad-seq.exr");
    const test::CliRun noHashes = test::runCli("composite " + plates + " " + kLens + " -o " + bad + " --frames 1-3");
    EXPECT_EQ(noHashes.exitCode, 2) << noHashes.out;
    EXPECT_NE(noHashes.out.find("must hold the frame number"), std::string::npos) << noHashes.out;
}

// Bad plates: exit 2, a message naming the problem, nothing written. A plate with nothing above
// the threshold: exit 0, a warning, the composite is the plate.
TEST(CompositeCli, BadPlatesAreRefusedAndADarkPlateIsItself) {
    const std::string out = path("bad-out.exr");
    const std::string text = path("not.exr");
    std::ofstream(text) << "not an image\n";
    test::CliRun r = test::runCli("composite " + text + " " + kLens + " -o " + out);
    EXPECT_EQ(r.exitCode, 2) << r.out;
    EXPECT_NE(r.out.find(text), std::string::npos) << r.out;
    EXPECT_FALSE(std::filesystem::exists(out));

    const std::string lumaOnly = path("y.exr");
    writeRawExr(lumaOnly, 8, 8, std::vector<float>(64, 1.0f), {"Y"});
    r = test::runCli("composite " + lumaOnly + " " + kLens + " -o " + out);
    EXPECT_EQ(r.exitCode, 2) << r.out;
    EXPECT_NE(r.out.find("no main RGB layer"), std::string::npos) << r.out;
    EXPECT_FALSE(std::filesystem::exists(out));

    std::vector<float> rgb(3 * 16 * 8, 0.5f);
    rgb[3 * (5 * 16 + 11) + 1] = std::nanf("");
    const std::string nan = path("nan.exr");
    writeRawExr(nan, 16, 8, rgb, {"R", "G", "B"});
    r = test::runCli("composite " + nan + " " + kLens + " -o " + out);
    EXPECT_EQ(r.exitCode, 2) << r.out;
    EXPECT_NE(r.out.find("pixel (11, 5)"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("NaN in G"), std::string::npos) << r.out;
    EXPECT_FALSE(std::filesystem::exists(out));
    rgb[3 * (5 * 16 + 11) + 1] = INFINITY;
    writeRawExr(nan, 16, 8, rgb, {"R", "G", "B"});
    r = test::runCli("composite " + nan + " " + kLens + " -o " + out);
    EXPECT_EQ(r.exitCode, 2) << r.out;
    EXPECT_NE(r.out.find("an infinity in G"), std::string::npos) << r.out;

    const std::string plate = writePlate("dark.exr", {{10, 10, glm::dvec3(5.0)}});
    r = test::runCli("composite " + plate + " " + kLens + " -o " + out + " --colorspace no-such-space");
    EXPECT_EQ(r.exitCode, 2) << r.out;
    EXPECT_NE(r.out.find("unknown colour space 'no-such-space'"), std::string::npos) << r.out;
    EXPECT_FALSE(std::filesystem::exists(out));

    r = test::runCli("composite " + plate + " " + kLens + " -o " + out + " --threshold 100");
    EXPECT_EQ(r.exitCode, 0) << r.out;
    EXPECT_NE(r.out.find("warning: no pixel"), std::string::npos) << r.out;
    EXPECT_EQ(layer(out, "").rgb, readExrLayer(plate, "").rgb);
}

}  // namespace
}  // namespace flare
