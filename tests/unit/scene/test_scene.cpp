// Scene files: the embedded default scene and the examples parse to the expected values, the
// light-direction convention matches where a real lens images the light, and every bad input
// gives one InputError naming the file, the line of the offending value and its key path.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/core/Error.h"
#include "flare/optics/Glass.h"
#include "flare/optics/Paraxial.h"
#include "flare/optics/RealRays.h"
#include "flare/optics/SequentialTracer.h"
#include "flare/scene/Scene.h"
#include "flare/scene/SceneRender.h"

namespace flare {
namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

InputError sceneError(const std::string& text) {
    try {
        parseSceneText(text, "bad.json", "");
    } catch (const InputError& e) {
        return e;
    }
    ADD_FAILURE() << "no error for:\n" << text;
    return InputError("", 0, "");
}

// Each fragment must appear in the problem text.
void expectError(const std::string& text, int line, std::initializer_list<std::string> fragments) {
    const InputError e = sceneError(text);
    EXPECT_EQ(e.file(), "bad.json");
    EXPECT_EQ(e.line(), line) << e.what();
    for (const std::string& fragment : fragments)
        EXPECT_NE(e.problem().find(fragment), std::string::npos) << "missing '" << fragment << "' in: " << e.what();
}

// A valid scene with `lightBody` as the only light's members (starting on line 4) and `extra`
// top-level members after the lights (starting on line 6).
std::string scene(const std::string& lightBody, const std::string& extra = "") {
    return "{\n"
           "  \"lens\": \"double-gauss-50mm\",\n"
           "  \"lights\": [ {\n" +
           lightBody +
           "\n"
           "  } ]" +
           (extra.empty() ? "" : ",\n" + extra) + "\n}\n";
}
const std::string kSun = R"(    "type": "directional", "field_deg": [1, 2])";

std::string readText(const std::string& path) {
    std::ifstream in(path);
    std::ostringstream out;
    out << in.rdbuf();
    return out.str();
}

TEST(Scene, DefaultSceneHasTheDocumentedValues) {
    const Scene s = defaultScene();
    EXPECT_EQ(s.lens, "double-gauss-50mm");
    EXPECT_EQ(s.lensState.zoom, "");
    EXPECT_FALSE(s.lensState.objectDistanceMm);
    ASSERT_TRUE(s.lensState.fNumber);
    EXPECT_EQ(*s.lensState.fNumber, 4.0);
    ASSERT_EQ(s.lights.size(), 1u);
    const LightSpec& sun = s.lights[0];
    EXPECT_EQ(sun.type, LightSpec::Type::Directional);
    EXPECT_EQ(sun.name, "sun");
    EXPECT_EQ(sun.fieldXDeg, 11.0);
    EXPECT_EQ(sun.fieldYDeg, 8.0);
    EXPECT_EQ(sun.angularDiameterDeg, 0.53);
    EXPECT_EQ(sun.spectrum.kind, SpectrumSpec::Kind::Blackbody);
    EXPECT_EQ(sun.spectrum.temperatureK, 5778.0);
    EXPECT_EQ(sun.power, 1.0);
    // About 13.5° off axis, diagonally.
    EXPECT_NEAR(std::acos(sun.travelDirection().z) / kDegToRad, 13.5, 0.1);
    EXPECT_EQ(*s.sensor.widthMm, 36.0);
    EXPECT_EQ(*s.sensor.heightMm, 24.0);
    EXPECT_EQ(s.sensor.widthPx, 1536);
    EXPECT_EQ(s.sensor.heightPx, 1024);
    EXPECT_EQ(s.render.previewWavelengths, 7);
    EXPECT_EQ(s.render.ghostOrder, 2);
    EXPECT_EQ(s.render.pruneKeepShare, 0.999);
    EXPECT_EQ(s.render.pruneRelativeThreshold, 1e-5);
    EXPECT_EQ(s.render.photons, 10'000'000);
    EXPECT_EQ(s.render.seed, 1u);
    EXPECT_EQ(s.render.maxBounces, -1);
    EXPECT_TRUE(s.render.includeSensorGhosts);
    // The lens builds at the scene's state.
    const LensSystem lens = buildSceneLens(s);
    EXPECT_EQ(lens.name(), "Double Gauss 50mm f/2");
}

TEST(Scene, DefaultSceneTextEqualsTheDocumentedExample) {
    EXPECT_EQ(readText(test::sourcePath("docs/examples/default.json")), defaultSceneText());
    const Scene fromFile = loadScene(test::sourcePath("docs/examples/default.json"));
    const Scene embedded = defaultScene();
    EXPECT_EQ(fromFile.lens, embedded.lens);
    EXPECT_EQ(fromFile.description, embedded.description);
    ASSERT_EQ(fromFile.lights.size(), embedded.lights.size());
    EXPECT_EQ(fromFile.lights[0].fieldXDeg, embedded.lights[0].fieldXDeg);
    EXPECT_EQ(fromFile.lights[0].fieldYDeg, embedded.lights[0].fieldYDeg);
    EXPECT_EQ(fromFile.render.previewWavelengths, embedded.render.previewWavelengths);
    EXPECT_EQ(fromFile.lensState.fNumber, embedded.lensState.fNumber);
}

TEST(Scene, EveryExampleParsesAndBuildsItsLens) {
    int count = 0;
    for (const auto& entry : std::filesystem::directory_iterator(test::sourcePath("docs/examples"))) {
        if (entry.path().extension() != ".json") continue;
        ++count;
        SCOPED_TRACE(entry.path().string());
        const Scene s = loadScene(entry.path().string());
        EXPECT_FALSE(s.lights.empty());
        EXPECT_FALSE(s.description.empty());
        const LensSystem lens = buildSceneLens(s);
        const glm::dvec2 size = sensorSizeMm(s, lens.sensor());
        EXPECT_NEAR(size.x / s.sensor.widthPx, size.y / s.sensor.heightPx, 1e-3 * size.x / s.sensor.widthPx);
    }
    EXPECT_GE(count, 3);
}

TEST(Scene, StreetLightsExampleHasEveryLightType) {
    const Scene s = loadScene(test::sourcePath("docs/examples/street-lights.json"));
    ASSERT_EQ(s.lights.size(), 3u);
    EXPECT_EQ(s.lights[0].type, LightSpec::Type::Point);
    EXPECT_EQ(s.lights[0].positionMm, glm::dvec3(600, 400, -4000));
    EXPECT_EQ(s.lights[0].spectrum.temperatureK, 2200.0);
    EXPECT_EQ(s.lights[1].type, LightSpec::Type::Disk);
    EXPECT_EQ(s.lights[1].radiusMm, 90.0);
    EXPECT_EQ(s.lights[1].spectrum.kind, SpectrumSpec::Kind::D65);
    EXPECT_EQ(s.lights[2].type, LightSpec::Type::Directional);
    EXPECT_EQ(*s.lensState.objectDistanceMm, 4000.0);
    EXPECT_EQ(s.render.seed, 7u);
    EXPECT_EQ(s.render.photons, 20'000'000);
    // Defaults for the keys the example leaves out.
    EXPECT_EQ(s.render.pruneKeepShare, 0.999);
    EXPECT_EQ(s.render.maxBounces, -1);
}

TEST(Scene, ZoomExampleSelectsTheTelePosition) {
    const Scene s = loadScene(test::sourcePath("docs/examples/zoom-tele.json"));
    EXPECT_EQ(s.lensState.zoom, "tele");
    EXPECT_TRUE(std::isinf(*s.lensState.objectDistanceMm));
    EXPECT_FALSE(s.sensor.widthMm);
    const LensSystem lens = buildSceneLens(s);
    EXPECT_EQ(lens.zoomName(), "tele");
    EXPECT_EQ(sensorSizeMm(s, lens.sensor()), glm::dvec2(36.0, 24.0));
}

TEST(Scene, DefaultsAndOptionalForms) {
    const Scene s = parseSceneText(scene(kSun, R"(  "zoom": 35, "focus_distance_mm": 2000, "sensor": { "width_mm": 24, "resolution": [1000, 1500] })"),
                                   "good.json", "");
    EXPECT_EQ(s.lensState.zoom, "35");
    EXPECT_EQ(*s.lensState.objectDistanceMm, 2000.0);
    EXPECT_EQ(*s.sensor.heightMm, 36.0);  // derived: square pixels
    EXPECT_EQ(s.lights[0].name, "light0");
    EXPECT_EQ(s.lights[0].spectrum.kind, SpectrumSpec::Kind::Blackbody);
    EXPECT_EQ(s.lights[0].angularDiameterDeg, 0.0);
    EXPECT_EQ(s.render.previewWavelengths, 5);
    EXPECT_EQ(s.render.photons, 10'000'000);
    // Comments are allowed; photons may be written 1e7; seeds use the full 64-bit range.
    const Scene t = parseSceneText(scene(kSun + ", // the sun\n    \"spectrum\": \"equal_energy\"",
                                         R"(  "render": { "photons": 1e7, "seed": 18446744073709551615 })"),
                                   "good.json", "");
    EXPECT_EQ(t.lights[0].spectrum.kind, SpectrumSpec::Kind::EqualEnergy);
    EXPECT_EQ(t.render.photons, 10'000'000);
    EXPECT_EQ(t.render.seed, 18446744073709551615u);
}

// The scene's coating replaces the lens's on every air–glass surface (the double Gauss is coated
// with mgf2 by its file).
TEST(Scene, CoatingReplacesTheLensCoatings) {
    const LensSystem flat = buildSceneLens(parseSceneText(scene(kSun, R"(  "coating": { "ideal_reflectance": 0.01 })"), "c.json", ""));
    const LensSystem table = buildSceneLens(parseSceneText(
        scene(kSun, R"(  "coating": { "ideal_reflectance": [[450, 0.02], [650, 0.01]] })"), "c.json", ""));
    const LensSystem bare = buildSceneLens(parseSceneText(scene(kSun, R"(  "coating": "none")"), "c.json", ""));
    int coated = 0;
    for (int i = 0; i < flat.surfaceCount(); ++i) {
        EXPECT_EQ(bare.coating(i), nullptr);
        if (!flat.coating(i)) continue;
        ++coated;
        EXPECT_EQ(flat.coating(i)->ideal->at(500.0), 0.01);
        EXPECT_NEAR(table.coating(i)->ideal->at(550.0), 0.015, 1e-15);
    }
    EXPECT_EQ(coated, 8);  // the double Gauss: 10 interfaces, 2 of them cemented
    expectError(scene(kSun, R"(  "coating": { "ideal_reflectance": 1.5 })"), 6, {"coating.ideal_reflectance"});
    expectError(scene(kSun, R"(  "coating": { "ideal_reflectance": [[550, 0.01], [450, 0.02]] })"), 6, {"increase"});
    expectError(scene(kSun, R"(  "coating": 3)"), 6, {"coating", "ideal_reflectance"});
    try {
        buildSceneLens(parseSceneText(scene(kSun, R"(  "coating": "gold")"), "c.json", ""));
        ADD_FAILURE() << "unknown coating accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.line(), 6);
        EXPECT_NE(e.problem().find("no coating 'gold'"), std::string::npos) << e.what();
    }
}

TEST(Scene, LensPathIsRelativeToTheSceneFile) {
    const Scene s = loadScene(test::sourcePath("tests/data/scenes/relative-lens.json"));
    EXPECT_EQ(std::filesystem::path(s.lens).lexically_normal(),
              std::filesystem::path(test::sourcePath("tests/data/dgauss.50mm.dat")).lexically_normal());
    EXPECT_EQ(s.lights[0].type, LightSpec::Type::Point);
    EXPECT_EQ(buildSceneLens(s).name(), "dgauss.50mm");
    // A shipped name with the extension also resolves.
    const Scene named = parseSceneText(R"({"lens": "fisheye-16mm.lens", "lights": [{"type": "point", "position_mm": [0, 0, -10]}]})",
                                       "good.json", test::sourcePath("tests/data/scenes"));
    EXPECT_EQ(named.lens, "fisheye-16mm");
}

TEST(Scene, TravelDirectionFollowsTheFieldConvention) {
    LightSpec light;
    EXPECT_EQ(light.travelDirection(), glm::dvec3(0.0, 0.0, 1.0));
    light.fieldXDeg = 10.0;
    const glm::dvec3 d = light.travelDirection();
    // Seen to the right: the rays travel towards −x, at 10° to the axis.
    EXPECT_NEAR(d.x / d.z, -std::tan(10.0 * kDegToRad), 1e-15);
    EXPECT_EQ(d.y, 0.0);
    EXPECT_NEAR(glm::length(d), 1.0, 1e-15);
    light.fieldXDeg = 0.0;
    light.fieldYDeg = -20.0;
    EXPECT_NEAR(light.travelDirection().y / light.travelDirection().z, std::tan(20.0 * kDegToRad), 1e-15);

    LightSpec point;
    point.type = LightSpec::Type::Point;
    point.positionMm = {300.0, 0.0, -4000.0};
    EXPECT_NEAR(point.travelDirection().x / point.travelDirection().z, -300.0 / 4000.0, 1e-15);
}

TEST(Scene, LightSeenRightImagesAtNegativeSensorXShownRight) {
    // Trace the ray along the light's direction through the entrance pupil's centre: the lens
    // inverts, so it lands at sensor x < 0, which the picture (rotated 180°, see
    // docs/scene-format.md) shows right of centre.
    const LensSystem lens = test::loadLens("lenses/double-gauss-50mm.lens");
    const SpectralIndices indices = lens.indicesAt(kLineDNm);
    LightSpec light;
    light.fieldXDeg = 10.0;
    const glm::dvec3 d = light.travelDirection();
    const ParaxialData para = analyseParaxial(lens, kLineDNm);
    Ray ray{glm::dvec3(0.0, 0.0, para.entrancePupilZMm) - 200.0 * d, d};
    ray.originMm = ray.at((objectSpaceStartZMm(lens) - ray.originMm.z) / d.z);
    TraceOptions options;
    options.clipApertures = false;
    const TraceResult hit = traceForward(lens, indices, ray, options);
    ASSERT_TRUE(hit.ok()) << toString(hit.status);
    EXPECT_NEAR(hit.ray.originMm.x, -50.0 * std::tan(10.0 * kDegToRad), 0.3);
    EXPECT_NEAR(hit.ray.originMm.y, 0.0, 1e-9);
    const double widthMm = 36.0;
    const int widthPx = 1536;
    const double column = widthPx * (0.5 - hit.ray.originMm.x / widthMm);
    EXPECT_GT(column, widthPx / 2.0);
}

// ---- errors -------------------------------------------------------------------------------

TEST(SceneErrors, MissingFileIsLineZero) {
    try {
        loadScene("/no/such/scene.json");
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), "/no/such/scene.json");
        EXPECT_EQ(e.line(), 0);
        EXPECT_NE(e.problem().find("cannot open scene file"), std::string::npos) << e.what();
    }
}

TEST(SceneErrors, FilesInTestData) {
    struct Case {
        const char* file;
        int line;
        const char* fragment;
    };
    for (const Case& c : {Case{"bad-syntax.json", 4, "trailing comma"},
                          Case{"bad-missing-lens.json", 3, "no lens file"},
                          Case{"bad-typo.json", 7, "did you mean 'angular_diameter_deg'"}}) {
        const std::string path = test::sourcePath(std::string("tests/data/scenes/") + c.file);
        try {
            loadScene(path);
            ADD_FAILURE() << "no error for " << c.file;
        } catch (const InputError& e) {
            EXPECT_EQ(e.file(), path);
            EXPECT_EQ(e.line(), c.line) << e.what();
            EXPECT_NE(e.problem().find(c.fragment), std::string::npos) << e.what();
        }
    }
}

TEST(SceneErrors, Syntax) {
    expectError("{\n  \"lens\": \"double-gauss-50mm\"\n  \"lights\": []\n}", 3, {"invalid JSON at column", "unexpected"});
    expectError("{\n  \"lens\": \"double-gauss-50mm\",\n  \"lights\": [\n", 3, {"invalid JSON", "end of input"});
    expectError("{\n  \"lens\": tru\n}", 2, {"invalid JSON"});
    expectError("{ \"lens\": \"a\",\n \"f_number\": 1e999 }", 2, {"number overflow"});
    expectError("", 1, {"invalid JSON"});
    expectError("[1, 2]", 1, {"scene: must be an object"});
}

TEST(SceneErrors, MissingRequiredKeys) {
    expectError("{\n  \"lights\": []\n}", 1, {"missing required key 'lens'", "double-gauss-50mm"});
    expectError("{\n  \"lens\": \"double-gauss-50mm\"\n}", 1, {"missing required key 'lights'"});
    expectError("{\n  \"lens\": \"double-gauss-50mm\",\n  \"lights\": [\n  ]\n}", 3, {"lights: must hold at least one light"});
    expectError(scene(R"(    "field_deg": [1, 2])"), 3, {"lights[0]: missing required key 'type'"});
    expectError(scene(R"(    "type": "directional")"), 3, {"lights[0]: missing required key 'field_deg'"});
    expectError(scene(R"(    "type": "point")"), 3, {"lights[0]: missing required key 'position_mm'"});
    expectError(scene("    \"type\": \"disk\",\n    \"position_mm\": [0, 0, -100]"), 3,
                {"lights[0]: missing required key 'radius_mm'"});
}

TEST(SceneErrors, WrongTypes) {
    expectError("{\n  \"lens\": 50,\n  \"lights\": []\n}", 2, {"lens: must be a string", "got 50"});
    expectError(scene(kSun, "  \"f_number\": \"f/4\""), 6, {"f_number: must be a number", "the string \"f/4\""});
    expectError(scene(kSun, "  \"lights2\": 1,\n  \"render\": { \"sensor_ghosts\": 1 }"), 6, {"unknown key 'lights2'"});
    expectError(scene(kSun, "  \"render\": {\n    \"sensor_ghosts\": \"yes\"\n  }"), 7,
                {"render.sensor_ghosts: must be true or false"});
    expectError(scene(kSun, "  \"render\": [1]"), 6, {"render: must be an object"});
    expectError(scene(kSun, "  \"zoom\": true"), 6, {"zoom: must be a zoom position name"});
    expectError(scene(kSun, "  \"focus_distance_mm\": \"far\""), 6, {"focus_distance_mm", "\"infinity\""});
    expectError(scene("    \"type\": \"directional\",\n    \"field_deg\": 5"), 5,
                {"lights[0].field_deg: must be an array of 2 numbers"});
    expectError(scene("    \"type\": \"directional\",\n    \"field_deg\": [5, \"up\"]"), 5,
                {"lights[0].field_deg[1]: must be a number"});
    expectError(scene("    \"type\": \"point\",\n    \"position_mm\": [1, 2]"), 5,
                {"lights[0].position_mm: must be an array of 3 numbers"});
    expectError(scene(kSun + ",\n    \"name\": 3"), 5, {"lights[0].name: must be a string"});
    expectError("{\n  \"lens\": \"double-gauss-50mm\",\n  \"lights\": [\n    \"sun\"\n  ]\n}", 4,
                {"lights[0]: must be an object"});
}

TEST(SceneErrors, UnknownKeysNameTheAllowedOnes) {
    expectError(scene(kSun, "  \"fnumber\": 4"), 6, {"scene: unknown key 'fnumber'", "did you mean 'f_number'", "allowed keys"});
    expectError(scene(kSun + ",\n    \"angular_diameter\": 0.5"), 5,
                {"lights[0]: unknown key 'angular_diameter'", "angular_diameter_deg"});
    expectError(scene(kSun + ",\n    \"radius_mm\": 5"), 5, {"unknown key 'radius_mm'", "for a directional light"});
    expectError(scene(kSun, "  \"render\": {\n    \"ghost_order\": 2,\n    \"photon\": 5\n  }"), 8,
                {"render: unknown key 'photon'", "did you mean 'photons'"});
    expectError(scene(kSun, "  \"sensor\": { \"width\": 36 }"), 6, {"sensor: unknown key 'width'", "width_mm"});
    expectError(scene(kSun + ",\n    \"spectrum\": { \"blackbody\": 5000 }"), 5, {"lights[0].spectrum: unknown key 'blackbody'"});
    expectError(scene(kSun, "  \"f_number\": 4,\n  \"f_number\": 5.6"), 7, {"f_number: given twice (first on line 6)"});
}

TEST(SceneErrors, OutOfRange) {
    expectError(scene(kSun + ",\n    \"angular_diameter_deg\": -3"), 5,
                {"lights[0].angular_diameter_deg: must lie in [0, 20] degrees, got -3"});
    expectError(scene("    \"type\": \"directional\",\n    \"field_deg\": [90, 0]"), 5,
                {"lights[0].field_deg[0]: must lie in [-89.9, 89.9] degrees, got 90"});
    expectError(scene(kSun + ",\n    \"power\": 0"), 5, {"lights[0].power: must lie in (0,", "W/m^2"});
    expectError(scene("    \"type\": \"point\",\n    \"position_mm\": [0, 0, 10]"), 5,
                {"lights[0].position_mm[2]: must be negative"});
    expectError(scene("    \"type\": \"disk\",\n    \"position_mm\": [300, 0, -100],\n    \"radius_mm\": 200"), 6,
                {"lights[0].radius_mm: the disk's rim reaches z ="});
    expectError(scene(kSun + ",\n    \"spectrum\": { \"blackbody_k\": 100 }"), 5,
                {"lights[0].spectrum.blackbody_k: must lie in [1000, 40000] K"});
    expectError(scene(kSun, "  \"f_number\": 0"), 6, {"f_number: must lie in [0.5, 128]"});
    expectError(scene(kSun, "  \"zoom\": -35"), 6, {"zoom: must lie in (0,"});
    expectError(scene(kSun, "  \"focus_distance_mm\": -1"), 6, {"focus_distance_mm: must lie in (0,"});
    expectError(scene(kSun, "  \"render\": { \"preview_wavelengths\": 0 }"), 6, {"render.preview_wavelengths: must be an integer in [1, 64]"});
    expectError(scene(kSun, "  \"render\": { \"photons\": 2.5 }"), 6, {"render.photons: must be an integer"});
    expectError(scene(kSun, "  \"render\": { \"prune_keep_share\": 1.5 }"), 6, {"render.prune_keep_share: must lie in (0, 1]"});
    expectError(scene(kSun, "  \"render\": { \"prune_relative_threshold\": 1 }"), 6,
                {"render.prune_relative_threshold: must lie in [0, 1)"});
    expectError(scene(kSun, "  \"render\": { \"max_bounces\": -2 }"), 6, {"render.max_bounces: must be an integer in [-1, 10000]"});
    expectError(scene(kSun, "  \"render\": { \"seed\": -1 }"), 6, {"render.seed"});
    expectError(scene(kSun, "  \"render\": { \"beams_per_pass\": 8 }"), 6,
                {"render.beams_per_pass: must be an integer in [16, 65536]"});
}

TEST(Scene, BeamsPerPassReachesTheRenderOptions) {
    const Scene s = parseSceneText(scene(kSun, "  \"render\": { \"beams_per_pass\": 4096 }"), "good.json", "");
    EXPECT_EQ(s.render.beamsPerPass, 4096);
    const LensSystem lens = buildSceneLens(s);
    EXPECT_EQ(sceneRenderOptions(s, lens, {}).beamsPerPass, 4096);
    SceneRenderOverrides overrides;
    overrides.beamsPerPass = 512;
    EXPECT_EQ(sceneRenderOptions(s, lens, overrides).beamsPerPass, 512);
    EXPECT_EQ(sceneRenderOptions(parseSceneText(scene(kSun, ""), "default.json", ""), lens, {}).beamsPerPass, 1024);
}

TEST(SceneErrors, GhostOrderIsTwoOrFour) {
    expectError(scene(kSun, "  \"render\": {\n    \"ghost_order\": 3\n  }"), 7, {"render.ghost_order: must be 2 or 4", "got 3"});
    EXPECT_EQ(parseSceneText(scene(kSun, "  \"render\": { \"ghost_order\": 4 }"), "good.json", "").render.ghostOrder, 4);
}

TEST(SceneErrors, UnknownLightTypeAndSpectrum) {
    expectError(scene("    \"type\": \"spot\",\n    \"field_deg\": [0, 0]"), 4,
                {"lights[0].type: unknown light type \"spot\"", "directional, region, point or disk"});
    expectError(scene(kSun + ",\n    \"spectrum\": \"d50\""), 5, {"lights[0].spectrum: unknown spectrum \"d50\"", "equal_energy"});
    expectError(scene(kSun + ",\n    \"spectrum\": \"blackbody\""), 5, {"blackbody_k"});
    expectError(scene(kSun + ",\n    \"spectrum\": 5778"), 5, {"lights[0].spectrum: must be"});
}

TEST(SceneErrors, SecondLightIsNamedByIndex) {
    const std::string text = "{\n"
                             "  \"lens\": \"double-gauss-50mm\",\n"
                             "  \"lights\": [\n"
                             "    { \"type\": \"directional\", \"field_deg\": [0, 0], \"name\": \"a\" },\n"
                             "    { \"type\": \"directional\",\n"
                             "      \"field_deg\": [0, 0],\n"
                             "      \"angular_diameter_deg\": -3 }\n"
                             "  ]\n"
                             "}\n";
    expectError(text, 7, {"lights[1].angular_diameter_deg: must lie in [0, 20] degrees, got -3"});
    const std::string twice = "{\n"
                              "  \"lens\": \"double-gauss-50mm\",\n"
                              "  \"lights\": [\n"
                              "    { \"type\": \"directional\", \"field_deg\": [0, 0], \"name\": \"a\" },\n"
                              "    { \"type\": \"point\", \"position_mm\": [0, 0, -5],\n"
                              "      \"name\": \"a\" }\n"
                              "  ]\n"
                              "}\n";
    expectError(twice, 6, {"lights[1].name", "already the name of lights[0]"});
}

TEST(SceneErrors, Resolution) {
    expectError(scene(kSun, "  \"sensor\": {\n    \"resolution\": [1536]\n  }"), 7, {"sensor.resolution: must be 2 integers"});
    expectError(scene(kSun, "  \"sensor\": {\n    \"resolution\": \"1536x1024\"\n  }"), 7, {"sensor.resolution: must be 2 integers"});
    expectError(scene(kSun, "  \"sensor\": {\n    \"resolution\": [1536, 0]\n  }"), 7,
                {"sensor.resolution[1]: must be an integer in [1, 16384]"});
    expectError(scene(kSun, "  \"sensor\": {\n    \"resolution\": [1536.5, 1024]\n  }"), 7, {"sensor.resolution[0]: must be an integer"});
    expectError(scene(kSun, "  \"sensor\": {\n    \"resolution\": [20000, 1024]\n  }"), 7, {"sensor.resolution[0]", "16384"});
    expectError(scene(kSun, "  \"sensor\": {\n    \"width_mm\": 0,\n    \"resolution\": [20, 10]\n  }"), 7, {"sensor.width_mm: must lie in (0, 1000] mm"});
}

TEST(SceneErrors, NonSquarePixels) {
    expectError(scene(kSun, "  \"sensor\": {\n    \"width_mm\": 36, \"height_mm\": 24,\n    \"resolution\": [1536, 1536]\n  }"), 8,
                {"sensor: pixels are not square"});
    // Within 0.1 % is accepted.
    EXPECT_NO_THROW(parseSceneText(scene(kSun, R"(  "sensor": { "width_mm": 36, "height_mm": 24.02, "resolution": [1536, 1024] })"),
                                   "good.json", ""));
    // Without a size, the lens's sensor must match the resolution's aspect.
    const Scene s = parseSceneText(scene(kSun, "  \"sensor\": {\n    \"resolution\": [1000, 1000]\n  }"), "good.json", "");
    try {
        sensorSizeMm(s, SensorSpec{});
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), "good.json");
        EXPECT_EQ(e.line(), 7);
        EXPECT_NE(e.problem().find("not square"), std::string::npos) << e.what();
    }
}

TEST(SceneErrors, LensNotFound) {
    expectError(scene(kSun).replace(scene(kSun).find("double-gauss-50mm"), 17, "no-such-lens"), 2,
                {"lens: no lens file 'no-such-lens'", "or library lens 'no-such-lens'", "double-gauss-50mm",
                 "was searched"});
    // A mistyped library id is answered with the ids nearest to it.
    expectError(scene(kSun).replace(scene(kSun).find("double-gauss-50mm"), 17, "nikon-nikkor-50mm-f1.4"), 2,
                {"nearest: nikon-nikkor-50mm-f1.4s"});
}

TEST(SceneErrors, LensSettingsTheLensCannotTakePointIntoTheScene) {
    auto buildError = [](const std::string& extra) {
        const Scene s = parseSceneText(scene(kSun, extra), "lensy.json", "");
        try {
            buildSceneLens(s);
        } catch (const InputError& e) {
            return e;
        }
        ADD_FAILURE() << "no error for " << extra;
        return InputError("", 0, "");
    };
    const InputError zoom = buildError("  \"zoom\": \"tele\"");
    EXPECT_EQ(zoom.file(), "lensy.json");
    EXPECT_EQ(zoom.line(), 6);
    EXPECT_NE(zoom.problem().find("zoom: "), std::string::npos) << zoom.what();
    expectError(scene(kSun, "  \"zoom\": \"\""), 6, {"zoom: must be a zoom position name"});
    const InputError fNumber = buildError("  \"focus_distance_mm\": 5000,\n  \"f_number\": 1.0");
    EXPECT_EQ(fNumber.line(), 7) << fNumber.what();
    EXPECT_NE(fNumber.problem().find("f_number: f/1 is not available"), std::string::npos) << fNumber.what();
}

}  // namespace
}  // namespace flare
