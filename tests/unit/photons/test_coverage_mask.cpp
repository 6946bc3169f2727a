// Coverage masks for dust and grease: reading PNG (8/16-bit, grey, RGB) and EXR masks, placement
// and orientation on the surface, the share of photons a half-white mask lets dust scatter, a
// white quadrant scattering exactly the photons that cross it, an all-black mask giving exactly
// the clean image, the hybrid against naive tracing with masks, and bad mask files naming the
// scene file and key (exit code 2 from the CLI).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include <gtest/gtest.h>
#include <png.h>

#include "RenderTestUtil.h"
#include "TestUtil.h"
#include "flare/core/Error.h"
#include "flare/optics/LensFile.h"
#include "flare/photons/CoverageMask.h"
#include "flare/photons/PhotonTracer.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"
#include "flare/scene/SceneScattering.h"

namespace flare {
namespace {

namespace fs = std::filesystem;

fs::path testDir() {
    const fs::path dir = test::processTempDir("flare_coverage_mask_test");
    fs::create_directories(dir);
    return dir;
}

// Writes a PNG with libpng's simplified API; `samples` holds channels × bytes-per-sample values.
std::string writePng(const std::string& name, int width, int height, png_uint_32 format, const void* samples) {
    const std::string path = (testDir() / name).string();
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    image.width = width, image.height = height, image.format = format;
    EXPECT_TRUE(png_image_write_to_file(&image, path.c_str(), 0, samples, 0, nullptr)) << image.message;
    png_image_free(&image);
    return path;
}

std::string writeGreyExr(const std::string& name, int width, int height, const std::string& channel,
                         std::vector<float> values) {
    const std::string path = (testDir() / name).string();
    Imf::Header header(width, height);
    header.channels().insert(channel, Imf::Channel(Imf::FLOAT));
    Imf::OutputFile file(path.c_str(), header);
    Imf::FrameBuffer frameBuffer;
    frameBuffer.insert(channel, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(values.data()), sizeof(float),
                                           sizeof(float) * width));
    file.setFrameBuffer(frameBuffer);
    file.writePixels(height);
    return path;
}

TEST(CoverageMask, ReadsGreyAndRgbPngsAsStoredValuesAndExrChannels) {
    const std::uint8_t grey8[] = {0, 51, 255, 128};
    CoverageMask a = CoverageMask::load(writePng("grey8.png", 2, 2, PNG_FORMAT_GRAY, grey8));
    a.place(2.0, 2.0, {0.0, 0.0});
    // No gamma decoding: the value is the code value over 255.
    EXPECT_FLOAT_EQ(a.valueAt(-0.5, 0.5), 0.0f);
    EXPECT_FLOAT_EQ(a.valueAt(0.5, 0.5), 0.2f);
    EXPECT_FLOAT_EQ(a.valueAt(-0.5, -0.5), 1.0f);
    EXPECT_NEAR(a.valueAt(0.5, -0.5), 128.0 / 255.0, 1e-7);

    const std::uint16_t grey16[] = {0, 65535, 32768, 13107};
    CoverageMask b = CoverageMask::load(writePng("grey16.png", 2, 2, PNG_FORMAT_LINEAR_Y, grey16));
    b.place(2.0, 2.0, {0.0, 0.0});
    EXPECT_FLOAT_EQ(b.valueAt(0.5, 0.5), 1.0f);
    EXPECT_NEAR(b.valueAt(-0.5, -0.5), 32768.0 / 65535.0, 1e-7);
    EXPECT_NEAR(b.valueAt(0.5, -0.5), 0.2, 1e-7);

    // RGB: Rec.709 luminance of the code values.
    const std::uint8_t rgb[] = {255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255};
    CoverageMask c = CoverageMask::load(writePng("rgb.png", 4, 1, PNG_FORMAT_RGB, rgb));
    c.place(4.0, 1.0, {0.0, 0.0});
    EXPECT_NEAR(c.valueAt(-1.5, 0.0), 0.2126, 1e-6);
    EXPECT_NEAR(c.valueAt(-0.5, 0.0), 0.7152, 1e-6);
    EXPECT_NEAR(c.valueAt(0.5, 0.0), 0.0722, 1e-6);
    EXPECT_NEAR(c.valueAt(1.5, 0.0), 1.0, 1e-6);

    CoverageMask d = CoverageMask::load(writeGreyExr("y.exr", 2, 1, "Y", {0.25f, 0.75f}));
    d.place(2.0, 1.0, {0.0, 0.0});
    EXPECT_FLOAT_EQ(d.valueAt(-0.5, 0.0), 0.25f);
    EXPECT_FLOAT_EQ(d.valueAt(0.5, 0.0), 0.75f);
    EXPECT_DOUBLE_EQ(d.meanValue(), 0.5);
}

TEST(CoverageMask, PlacementPutsTheTopRowAtPlusYAndTheFirstColumnAtMinusX) {
    // 2 × 2 with only the top-right pixel white, laid 10 × 6 mm centred at (1, −2).
    CoverageMask m = CoverageMask::fromValues(2, 2, {0.0f, 1.0f, 0.0f, 0.0f});
    m.place(10.0, 6.0, {1.0, -2.0});
    EXPECT_EQ(m.valueAt(1.0 + 2.5, -2.0 + 1.5), 1.0);   // the +x, +y quadrant
    EXPECT_EQ(m.valueAt(1.0 - 2.5, -2.0 + 1.5), 0.0);
    EXPECT_EQ(m.valueAt(1.0 + 2.5, -2.0 - 1.5), 0.0);
    EXPECT_EQ(m.valueAt(1.0 + 5.5, -2.0 + 1.5), 0.0);   // beyond the right edge
    EXPECT_EQ(m.valueAt(1.0 + 2.5, -2.0 + 3.5), 0.0);   // above the top edge
    EXPECT_EQ(m.valueAt(std::nan(""), 0.0), 0.0);
    EXPECT_THROW(CoverageMask::fromValues(2, 2, {0.0f, 1.5f, 0.0f, 0.0f}), std::invalid_argument);
    EXPECT_THROW(CoverageMask::fromValues(2, 2, {0.0f}), std::invalid_argument);
    EXPECT_TRUE(CoverageMask::fromValues(1, 1, {0.0f}).allZero());
}

TEST(CoverageMask, BadFilesThrowInputErrorNamingTheFile) {
    const std::string garbage = (testDir() / "garbage.png").string();
    std::ofstream(garbage) << "not an image at all";
    const std::string truncated = (testDir() / "truncated.png").string();
    {
        const std::uint8_t grey8[64] = {};
        const std::string good = writePng("good.png", 8, 8, PNG_FORMAT_GRAY, grey8);
        std::ifstream in(good, std::ios::binary);
        std::string bytes((std::istreambuf_iterator<char>(in)), {});
        std::ofstream(truncated, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    }
    const std::string outOfRange = writeGreyExr("bright.exr", 2, 1, "Y", {0.5f, 3.0f});
    const std::string twoChannels = [&] {
        const std::string path = (testDir() / "uv.exr").string();
        Imf::Header header(1, 1);
        header.channels().insert("U", Imf::Channel(Imf::FLOAT));
        header.channels().insert("V", Imf::Channel(Imf::FLOAT));
        float u = 0.0f, v = 0.0f;
        Imf::OutputFile file(path.c_str(), header);
        Imf::FrameBuffer fb;
        fb.insert("U", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(&u), sizeof(float), sizeof(float)));
        fb.insert("V", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(&v), sizeof(float), sizeof(float)));
        file.setFrameBuffer(fb);
        file.writePixels(1);
        return path;
    }();
    for (const auto& [file, part] : std::vector<std::pair<std::string, std::string>>{
             {(testDir() / "missing.png").string(), "no such file"},
             {garbage, "neither a PNG nor an OpenEXR"},
             {truncated, "cannot read the PNG"},
             {outOfRange, "outside [0, 1]"},
             {twoChannels, "single channel"}}) {
        try {
            CoverageMask::load(file);
            ADD_FAILURE() << "no InputError for " << file;
        } catch (const InputError& e) {
            EXPECT_EQ(e.file(), file);
            EXPECT_NE(e.problem().find(part), std::string::npos) << e.problem();
        }
    }
}

// ---- In the tracer -------------------------------------------------------------------------------

// A 5 mm plate of index 1.0001 behind a stop: its faces reflect ~2.5e-9 of the light, so a photon
// crosses the front face (surface 2) once, and dust there is the only thing that can scatter it.
LensSystem faintPlate() {
    return LensSystem::build(parseLensText(
        "name faint plate\nfocal_length_mm 1\nsensor width_mm=60 height_mm=60 reflectance=0\nsurfaces\n"
        " stop 1 air 10\n inf 5 n=1.0001 12\n inf 10 air 12\n",
        "faint-plate.lens"));
}

struct DustCount {
    long photons = 0, scattered = 0;
    long scatteredInWhite = 0, scatteredElsewhere = 0, inWhite = 0;
};

// Axial photons spread uniformly over a disk of radius 8 mm; `white` says whether a start point
// lies where the mask is white.
template <class White>
DustCount countDust(const SurfaceContamination& dust, long photons, White white) {
    const LensSystem lens = faintPlate();
    std::vector<SurfaceContamination> contamination(lens.surfaceCount());
    contamination[1] = dust;
    const PhotonTracer tracer(lens, {}, -1, contamination, {});
    const SpectralIndices indices = lens.indicesAt(550.0);
    Rng rng(31, 0);
    const auto scratch = tracer.makeScratch();
    PhotonHistory h;
    DustCount count;
    for (long i = 0; i < photons; ++i) {
        const double r = 8.0 * std::sqrt(rng.uniform()), phi = 2.0 * std::numbers::pi * rng.uniform();
        const double x = r * std::cos(phi), y = r * std::sin(phi);
        tracer.trace(indices, Ray{{x, y, -5.0}, {0.0, 0.0, 1.0}}, rng, h, *scratch);
        ++count.photons;
        const bool scattered = h.scatters > 0;  // interior albedo 0, dust albedo 1: only dust scatters
        count.scattered += scattered;
        count.inWhite += white(x, y);
        (white(x, y) ? count.scatteredInWhite : count.scatteredElsewhere) += scattered;
    }
    return count;
}

TEST(CoverageMask, HalfWhiteMaskLetsDustScatterHalfTheCoverage) {
    // Left half black, right half white, laid over the surface's clear diameter (24 mm): a photon
    // meets dust with probability coverage × [x > 0], so over the symmetric disk the scattered
    // share is coverage / 2 exactly (reflections at the 1.0001 faces add ~1e-9). Binomial test.
    SurfaceContamination dust;
    dust.dustCoverage = 0.3;
    dust.dustAlbedo = 1.0;
    auto mask = CoverageMask::fromValues(2, 1, {0.0f, 1.0f});
    mask.place(24.0, 24.0, {0.0, 0.0});
    dust.dustMask = std::make_shared<const CoverageMask>(mask);
    const long N = 200000;
    const DustCount count = countDust(dust, N, [](double x, double) { return x > 0.0; });
    const double p = dust.dustCoverage / 2.0;
    const double share = static_cast<double>(count.scattered) / N;
    EXPECT_NEAR(share, p, test::normalTwoSidedCritical(1e-4) * std::sqrt(p * (1.0 - p) / N));
    EXPECT_EQ(count.scatteredElsewhere, 0);
}

TEST(CoverageMask, WhiteQuadrantScattersExactlyThePhotonsThatCrossIt) {
    // Coverage 1 under the white (+x, +y) quadrant: every photon crossing it meets dust, no other.
    SurfaceContamination dust;
    dust.dustCoverage = 1.0;
    dust.dustAlbedo = 1.0;
    auto mask = CoverageMask::fromValues(2, 2, {0.0f, 1.0f, 0.0f, 0.0f});
    mask.place(24.0, 24.0, {0.0, 0.0});
    dust.dustMask = std::make_shared<const CoverageMask>(mask);
    const DustCount count = countDust(dust, 20000, [](double x, double y) { return x > 0.0 && y > 0.0; });
    EXPECT_EQ(count.scatteredElsewhere, 0);
    EXPECT_EQ(count.scatteredInWhite, count.inWhite);
    EXPECT_GT(count.inWhite, 0);
}

// ---- Scenes -----------------------------------------------------------------------------------------

std::string sceneText(const std::string& scattering) {
    std::ofstream(testDir() / "doublet.lens") << test::kUncoatedDoublet;
    return R"({ "lens": "doublet.lens",
  "sensor": { "resolution": [120, 80] },
  "lights": [ { "type": "directional", "field_deg": [4.0, 2.5], "angular_diameter_deg": 0.53,
                "spectrum": { "blackbody_k": 5778 } } ],
  "render": { "photons": 20000 },
  "scattering": )" + scattering + " }";
}

Scene maskScene(const std::string& scattering) {
    return parseSceneText(sceneText(scattering), "masked.json", testDir().string());
}

TEST(CoverageMask, AllBlackMaskGivesExactlyTheCleanImage) {
    const std::uint8_t black[16] = {};
    writePng("black.png", 4, 4, PNG_FORMAT_GRAY, black);
    const Scene clean = maskScene(R"({ "housing": { "diffuse": 0.03 } })");
    const Scene masked = maskScene(R"({ "housing": { "diffuse": 0.03 },
        "dust": [ { "surface": 1, "coverage": 0.5, "mask": "black.png" } ],
        "grease": [ { "surface": 4, "coverage": 1, "mask": "black.png", "mask_size_mm": [30, 20], "mask_centre_mm": [1, 2] } ] })");
    const LensSystem lens = buildSceneLens(clean);
    Renderer a(lens, clean.lights, test::sceneRenderOptions(clean, lens, RenderOptions::Mode::Guided));
    Renderer b(lens, masked.lights, test::sceneRenderOptions(masked, lens, RenderOptions::Mode::Guided));
    a.runPass();
    b.runPass();
    for (int l = 0; l < kFixedLayerCount; ++l) EXPECT_EQ(a.layerXyz(l), b.layerXyz(l)) << l;
}

// The one rule with masks: the guided weight uses the same local coverage as the photon tracer.
TEST(CoverageMask, GuidedAgreesWithNaiveWithMaskedDustAndGrease) {
    const std::uint8_t halves[] = {0, 255};
    writePng("halves.png", 2, 1, PNG_FORMAT_GRAY, halves);
    const std::string fingerprint = test::sourcePath("docs/examples/masks/fingerprint.png");
    const Scene scene = maskScene(R"({ "housing": { "diffuse": 0.05 },
        "dust": [ { "surface": 1, "coverage": 0.1, "albedo": 0.6, "mask": "halves.png" } ],
        "grease": [ { "surface": 5, "coverage": 0.8, "roughness": 0.1, "mask": ")" + fingerprint + R"(" } ] })");
    const LensSystem lens = buildSceneLens(scene);
    Renderer naive(lens, scene.lights, test::sceneRenderOptions(scene, lens, RenderOptions::Mode::Naive));
    Renderer guided(lens, scene.lights, test::sceneRenderOptions(scene, lens, RenderOptions::Mode::Guided));
    for (int p = 0; p < 120; ++p) naive.runPass();
    for (int p = 0; p < 32; ++p) guided.runPass();
    test::expectGuidedAgreesWithNaive(guided, naive, {kLayerDirect, kLayerGhost, kLayerScatter});
    EXPECT_GT(naive.tallyPowerW(naive.scatterSourceTallies()[static_cast<int>(ScatterSource::Dust) - 1]), 0.0);
    EXPECT_GT(naive.tallyPowerW(naive.scatterSourceTallies()[static_cast<int>(ScatterSource::Grease) - 1]), 0.0);
}

TEST(CoverageMask, BadMaskNamesTheSceneFileAndKey) {
    const std::string scattering = R"({ "grease": [ { "surface": 1, "coverage": 0.2 },
        { "surface": 4, "coverage": 0.2, "mask": "nope.png" } ] })";
    const Scene missing = maskScene(scattering);
    const std::string text = sceneText(scattering);
    const int maskLine = 1 + static_cast<int>(std::count(text.begin(), text.begin() + text.find("nope.png"), '\n'));
    const LensSystem lens = buildSceneLens(missing);
    RenderOptions o;
    try {
        applySceneScattering(missing, lens, o);
        FAIL() << "a missing mask accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), "masked.json");
        EXPECT_EQ(e.line(), maskLine);
        EXPECT_NE(e.problem().find("scattering.grease[1].mask"), std::string::npos) << e.problem();
        EXPECT_NE(e.problem().find("nope.png"), std::string::npos) << e.problem();
    }
    // Placement keys without a mask, and bad sizes, fail when the scene is read.
    EXPECT_THROW(maskScene(R"({ "dust": [ { "surface": 1, "coverage": 0.2, "mask_size_mm": 10 } ] })"), InputError);
    EXPECT_THROW(maskScene(R"({ "dust": [ { "surface": 1, "coverage": 0.2, "mask": "a.png", "mask_size_mm": -1 } ] })"),
                 InputError);
    EXPECT_THROW(maskScene(R"({ "dust": [ { "surface": 1, "coverage": 0.2, "mask": "a.png", "mask_centre_mm": [1] } ] })"),
                 InputError);

    // Through the CLI: one message naming the scene file and the key, exit code 2, no image.
    const fs::path scenePath = testDir() / "bad-mask.json";
    std::ofstream(testDir() / "garbage-mask.png") << "not a png";
    std::ofstream(scenePath) << sceneText(R"({ "dust": [ { "surface": 1, "coverage": 0.2, "mask": "garbage-mask.png" } ] })");
    const fs::path out = testDir() / "bad-mask.exr";
    fs::remove(out);
    const test::CliRun run = test::runCli("render " + scenePath.string() + " -o " + out.string() + " --quiet");
    EXPECT_EQ(run.exitCode, 2) << run.out;
    EXPECT_NE(run.out.find("bad-mask.json"), std::string::npos) << run.out;
    EXPECT_NE(run.out.find("scattering.dust[0].mask"), std::string::npos) << run.out;
    EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace flare
