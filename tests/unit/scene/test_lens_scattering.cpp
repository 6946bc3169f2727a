// Scattering stated by a .lens file: `finish` and `gloss_exponent` header lines and the dust= and
// grease= row options, their errors (file, line, problem), and how a scene's `scattering` block
// overrides them.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "flare/core/Error.h"
#include "flare/optics/LensFile.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"
#include "flare/scene/SceneScattering.h"
#include "TestUtil.h"

namespace flare {
namespace {

namespace fs = std::filesystem;

const char* kDirtyDoublet = R"(name dirty doublet
focal_length_mm 50
sensor width_mm=36 height_mm=24 reflectance=0.02
finish housing diffuse=0.05 glossy=0.02
finish iris diffuse=0.1
gloss_exponent 12
surfaces
   35.0    6.0    n=1.62     13   dust=0.004 dust_albedo=0.7 dust_diameter_um=30 dust_sigma=0.4
  -90.0    3.0    air        13   grease=0.2 grease_roughness=0.05
   stop    4.0    air        9
  -60.0    2.5    n=1.72     11
  400.0    auto   air        11   dust=0.001
)";

TEST(LensScattering, FinishLinesAndRowOptionsAreRead) {
    const LensPrescription p = parseLensText(kDirtyDoublet, "dirty.lens");
    ASSERT_TRUE(p.housingFinish && p.irisFinish);
    EXPECT_FALSE(p.edgeFinish);
    EXPECT_EQ(p.housingFinish->diffuse, 0.05);
    EXPECT_EQ(p.housingFinish->glossy, 0.02);
    EXPECT_EQ(p.irisFinish->diffuse, 0.1);
    EXPECT_EQ(p.irisFinish->glossy, 0.0);
    EXPECT_EQ(p.glossExponent, 12.0);
    ASSERT_TRUE(p.rows[0].dust);
    EXPECT_EQ(p.rows[0].dust->coverage, 0.004);
    EXPECT_EQ(p.rows[0].dust->albedo, 0.7);
    EXPECT_EQ(p.rows[0].dust->diameterUm, 30.0);
    EXPECT_EQ(p.rows[0].dust->diameterSigma, 0.4);
    EXPECT_FALSE(p.rows[0].grease);
    ASSERT_TRUE(p.rows[1].grease);
    EXPECT_EQ(p.rows[1].grease->coverage, 0.2);
    EXPECT_EQ(p.rows[1].grease->roughness, 0.05);
    ASSERT_TRUE(p.rows[4].dust);
    EXPECT_EQ(p.rows[4].dust->albedo, 0.5);  // the default
    EXPECT_FALSE(p.rows[3].dust || p.rows[3].grease || p.rows[2].dust);
}

// Replaces line `line` (1-based) of the dirty doublet and expects an InputError on it.
void expectError(int line, const std::string& text, const std::string& problemPart) {
    std::string lens = kDirtyDoublet;
    std::size_t start = 0;
    for (int i = 1; i < line; ++i) start = lens.find('\n', start) + 1;
    lens.replace(start, lens.find('\n', start) - start, text);
    try {
        parseLensText(lens, "bad.lens");
        ADD_FAILURE() << "accepted: " << text;
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), "bad.lens") << text;
        EXPECT_EQ(e.line(), line) << text << ": " << e.what();
        EXPECT_NE(e.problem().find(problemPart), std::string::npos) << text << ": " << e.problem();
    }
}

TEST(LensScattering, ErrorsNameFileLineAndProblem) {
    expectError(4, "finish barrel diffuse=0.1", "unknown finish part 'barrel'");
    expectError(4, "finish housing diffuse=0.8 glossy=0.4", "must not exceed 1");
    expectError(4, "finish housing diffuse=-0.1", "must lie in [0, 1]");
    expectError(4, "finish housing shiny=0.1", "unknown finish option 'shiny'");
    expectError(4, "finish housing", "needs a part");
    expectError(5, "finish housing diffuse=0.1", "given twice");
    expectError(6, "gloss_exponent many", "not a number");
    expectError(8, "   35.0    6.0    n=1.62     13   dust=1.5", "dust coverage must lie in [0, 1]");
    expectError(8, "   35.0    6.0    n=1.62     13   dust_albedo=0.5", "need dust=COVERAGE");
    expectError(8, "   35.0    6.0    n=1.62     13   dust=0.1 dust_colour=3", "unknown surface option 'dust_colour'");
    expectError(9, "  -90.0    3.0    air        13   grease=0.2 grease_roughness=0", "grease_roughness must be positive");
    expectError(10, "   stop    4.0    air        9   dust=0.1", "the stop row takes no surface options");
}

TEST(LensScattering, CementedAndAirToAirSurfacesCarryNoDirt) {
    const std::string cemented = R"(name cemented
focal_length_mm 50
surfaces
   35.0    6.0    n=1.62     13
  -90.0    3.0    n=1.72     13   grease=0.1
  200      3.0    air        13
   stop    4.0    air        9
  -60.0    auto   air        11   dust=0.1
)";
    try {
        parseLensText(cemented, "cemented.lens");
        FAIL() << "grease on a cemented surface accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.line(), 5);
        EXPECT_NE(e.problem().find("cemented"), std::string::npos) << e.problem();
    }
    std::string airToAir = cemented;
    airToAir.replace(airToAir.find("   grease=0.1"), 13, "");
    try {
        parseLensText(airToAir, "air.lens");
        FAIL() << "dust between air and air accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.line(), 8);
        EXPECT_NE(e.problem().find("equal media"), std::string::npos) << e.problem();
    }
}

// A scene on dirty.lens (kDirtyDoublet) or clean.lens (the same without scattering), with the
// given scattering block ("" = none).
Scene sceneWith(const std::string& lensFile, const std::string& scattering) {
    const fs::path dir = test::processTempDir("flare_lens_scattering_test");
    fs::create_directories(dir);
    std::ofstream(dir / "dirty.lens") << kDirtyDoublet;
    std::ofstream(dir / "clean.lens") << R"(name clean doublet
focal_length_mm 50
surfaces
   35.0    6.0    n=1.62     13
  -90.0    3.0    air        13
   stop    4.0    air        9
  -60.0    2.5    n=1.72     11
  400.0    auto   air        11
)";
    return parseSceneText(R"({ "lens": ")" + lensFile + R"(",
  "lights": [ { "type": "directional", "field_deg": [4.0, 2.5] } ])" +
                              (scattering.empty() ? "" : ", \"scattering\": " + scattering) + " }",
                          "scene.json", dir.string());
}

RenderOptions applied(const Scene& scene) {
    const LensSystem lens = buildSceneLens(scene);
    RenderOptions o;
    applySceneScattering(scene, lens, o);
    return o;
}

TEST(LensScattering, TheLensFileSetsDefaultsWhenTheSceneIsSilent) {
    const RenderOptions o = applied(sceneWith("dirty.lens", ""));
    EXPECT_EQ(o.materials.housingAlbedo, 0.05);
    EXPECT_EQ(o.materials.housingGlossy, 0.02);
    EXPECT_EQ(o.materials.edgeAlbedo, FinishSpec{}.diffuse);  // not in the lens file: built-in default
    EXPECT_EQ(o.materials.irisAlbedo, 0.1);
    EXPECT_EQ(o.materials.glossExponent, 12.0);
    ASSERT_EQ(o.contamination.size(), 5u);
    EXPECT_EQ(o.contamination[0].dustCoverage, 0.004);
    EXPECT_EQ(o.contamination[0].dustAlbedo, 0.7);
    EXPECT_EQ(o.contamination[1].greaseCoverage, 0.2);
    EXPECT_EQ(o.contamination[4].dustCoverage, 0.001);
    EXPECT_FALSE(o.contamination[3].any());
}

TEST(LensScattering, TheSceneOverridesFinishesAndEachSurfacesDirt) {
    const RenderOptions o = applied(sceneWith("dirty.lens", R"({ "housing": { "diffuse": 0.01 }, "gloss_exponent": 50,
        "dust": [ { "surface": 1, "coverage": 0 } ], "grease": [ { "surface": 5, "coverage": 0.3 } ] })"));
    EXPECT_EQ(o.materials.housingAlbedo, 0.01);
    EXPECT_EQ(o.materials.housingGlossy, 0.0);  // the scene's finish replaces the lens's whole
    EXPECT_EQ(o.materials.irisAlbedo, 0.1);     // the lens's, not overridden
    EXPECT_EQ(o.materials.glossExponent, 50.0);
    EXPECT_EQ(o.contamination[0].dustCoverage, 0.0);    // the scene cleaned surface 1
    EXPECT_EQ(o.contamination[1].greaseCoverage, 0.2);  // the lens's grease on surface 2 stays
    EXPECT_EQ(o.contamination[4].dustCoverage, 0.001);  // the lens's dust on surface 5 stays...
    EXPECT_EQ(o.contamination[4].greaseCoverage, 0.3);  // ...next to the scene's grease
}

TEST(LensScattering, NoScatteringAnywhereMeansTheBuiltInDefaultsAndNoDirt) {
    const RenderOptions o = applied(sceneWith("clean.lens", ""));
    EXPECT_EQ(o.materials.housingAlbedo, FinishSpec{}.diffuse);
    EXPECT_EQ(o.materials.glossExponent, InteriorMaterials{}.glossExponent);
    EXPECT_TRUE(o.contamination.empty());
}

}  // namespace
}  // namespace flare
