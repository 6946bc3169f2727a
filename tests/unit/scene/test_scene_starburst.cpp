// The starburst in the scene's preview and render: with diffraction off every image is what it
// was without it (bit for bit); with it the main image holds the diffracted direct image, which
// keeps the direct image's energy less what leaves the frame, and nothing else changes.
#include <gtest/gtest.h>

#include <numeric>

#include "flare/film/ImageIO.h"
#include "flare/scene/Scene.h"
#include "flare/scene/ScenePreview.h"
#include "flare/scene/SceneRender.h"
#include "flare/scene/SceneStarburst.h"

namespace flare {
namespace {

Scene smallScene(bool diffraction) {
    Scene scene = parseSceneText(R"({"lens": "double-gauss-50mm", "f_number": 8,
        "sensor": {"resolution": [384, 256]},
        "lights": [{"type": "directional", "field_deg": [11, 8], "angular_diameter_deg": 0.53}],
        "render": {"preview_wavelengths": 3, "diffraction_wavelengths": 8}})",
                                 "small.json", ".");
    scene.render.diffraction = diffraction;
    return scene;
}

const ImageLayer& layer(const std::vector<ImageLayer>& layers, const std::string& name) {
    for (const ImageLayer& l : layers)
        if (l.name == name) return l;
    throw std::runtime_error("no layer " + name);
}

double sumY(const std::vector<float>& xyz) {
    double sum = 0.0;
    for (size_t i = 1; i < xyz.size(); i += 3) sum += xyz[i];
    return sum;
}

TEST(SceneStarburst, PreviewWithoutDiffractionIsTheGeometricImageAndWithItConservesEnergy) {
    const Scene off = smallScene(false), on = smallScene(true);
    const LensSystem lens = buildSceneLens(off);
    ScenePreview plain = previewScene(off, lens, false);
    ScenePreview diffracted = previewScene(on, lens, false);
    ASSERT_FALSE(plain.starburst.has_value());
    ASSERT_TRUE(diffracted.starburst.has_value());
    // The geometric layers do not depend on the switch.
    EXPECT_EQ(plain.direct, diffracted.direct);
    EXPECT_EQ(plain.ghosts, diffracted.ghosts);

    // Off: the main image is direct + ghosts, summed as ever, and no starburst layer.
    std::vector<float> expected = plain.direct;
    for (size_t i = 0; i < expected.size(); ++i) expected[i] += plain.ghosts[i];
    const std::vector<ImageLayer> plainLayers = previewLayers(plain, true);
    EXPECT_EQ(plainLayers.front().rgb, rgbLayerFromXyz("", expected, 384, 256).rgb);
    EXPECT_THROW(layer(plainLayers, "starburst"), std::runtime_error);

    // On: the starburst replaces the direct image in the main image.
    const StarburstImage& s = *diffracted.starburst;
    ASSERT_EQ(s.lights.size(), 1u);
    ASSERT_TRUE(s.lights[0].diffracted) << s.lights[0].why;
    std::vector<float> withStar = s.xyz;
    for (size_t i = 0; i < withStar.size(); ++i) withStar[i] += diffracted.ghosts[i];
    const std::vector<ImageLayer> layers = previewLayers(diffracted, true);
    EXPECT_EQ(layers.front().rgb, rgbLayerFromXyz("", withStar, 384, 256).rgb);
    EXPECT_EQ(layer(layers, "direct").rgb, layer(plainLayers, "direct").rgb);
    EXPECT_NO_THROW(layer(layers, "starburst"));
    EXPECT_NE(s.xyz, plain.direct);
    // Energy: the starburst holds the direct image's energy but what its report says left the
    // frame (to the float sums' rounding), and spreads it: less of it in the brightest pixel.
    const double direct = sumY(plain.direct), star = sumY(s.xyz);
    const double diffractedY = s.lights[0].diffractedShare * direct;
    EXPECT_NEAR(star, direct - diffractedY * s.lights[0].outsideFrameShare, 1e-5 * direct);
    EXPECT_GT(s.lights[0].outsideFrameShare, 0.0);
    EXPECT_LT(s.lights[0].outsideFrameShare, 0.05);
    float peakDirect = 0.0f, peakStar = 0.0f;
    for (size_t i = 1; i < s.xyz.size(); i += 3) peakDirect = std::max(peakDirect, plain.direct[i]), peakStar = std::max(peakStar, s.xyz[i]);
    EXPECT_LT(peakStar, peakDirect);
}

TEST(SceneStarburst, RenderMainImageTakesTheStarburstInPlaceOfTheDirectLayer) {
    const Scene scene = smallScene(true);
    const LensSystem lens = buildSceneLens(scene);
    SceneRenderOverrides overrides;
    RenderOptions options = sceneRenderOptions(scene, lens, overrides);
    options.batchesPerPass = 4;
    options.beamsPerPass = 64;
    Renderer renderer(lens, scene.lights, options);
    renderer.runPass();
    renderer.runPass();
    const std::vector<ImageLayer> plain = renderLayers(renderer);
    const StarburstImage star = sceneStarburst(scene, lens, renderer.layerXyz(kLayerDirect), 384, 256);
    const std::vector<ImageLayer> diffracted = renderLayers(renderer, &star);
    // Every film layer is untouched; the starburst is added after them.
    ASSERT_EQ(diffracted.size(), plain.size() + 1);
    for (size_t i = 1; i < plain.size() && plain[i].name != "variance"; ++i) EXPECT_EQ(diffracted[i].rgb, plain[i].rgb);
    EXPECT_EQ(layer(diffracted, "starburst").rgb, rgbLayerFromXyz("starburst", star.xyz, 384, 256).rgb);
    // Main image: the fixed layers with the starburst for the direct layer.
    std::vector<float> total(star.xyz);
    for (int l = kLayerGhost; l < kFixedLayerCount; ++l) {
        const std::vector<float> xyz = renderer.layerXyz(l);
        for (size_t i = 0; i < total.size(); ++i) total[i] += xyz[i];
    }
    const std::vector<float> expected = rgbLayerFromXyz("", total, 384, 256).rgb;
    ASSERT_EQ(diffracted.front().rgb.size(), expected.size());
    for (size_t i = 0; i < expected.size(); ++i)
        EXPECT_NEAR(diffracted.front().rgb[i], expected[i], 1e-6f * std::abs(expected[i]) + 1e-30f) << i;
}

// Dust on the front element adds its diffraction glow: `coverage` of the diffracted light, spread
// about the light's image, and nothing else changes.
TEST(SceneStarburst, DustAddsItsGlowWithTheCoveragesEnergy) {
    const std::string text = R"({"lens": "double-gauss-50mm", "f_number": 8,
        "sensor": {"resolution": [384, 256]},
        "lights": [{"type": "directional", "field_deg": [5, 3], "angular_diameter_deg": 0.53}],
        "render": {"preview_wavelengths": 3, "diffraction_wavelengths": 8},
        "scattering": {"dust": [{"surface": 1, "coverage": COVER, "diameter_um": 20}]}})";
    auto withCoverage = [&](const std::string& c) {
        std::string t = text;
        t.replace(t.find("COVER"), 5, c);
        return parseSceneText(t, "dusty.json", ".");
    };
    const Scene clean = withCoverage("0"), dusty = withCoverage("0.03");
    const LensSystem lens = buildSceneLens(clean);
    const ScenePreview a = previewScene(clean, lens, false);
    const StarburstImage plain = sceneStarburst(clean, lens, a.direct, 384, 256);
    const StarburstImage glowing = sceneStarburst(dusty, lens, a.direct, 384, 256);
    ASSERT_EQ(glowing.lights[0].dustSurfaces, 1);
    EXPECT_EQ(plain.lights[0].dustSurfaces, 0);
    EXPECT_DOUBLE_EQ(glowing.lights[0].dustGlowShare, 0.03);
    const double cropY = plain.lights[0].diffractedShare * sumY(a.direct);
    const double added = sumY(glowing.xyz) - sumY(plain.xyz);
    EXPECT_NEAR(added, 0.03 * cropY * glowing.lights[0].dustGlowInFrameShare, 1e-4 * added);
    // A 20 µm particle's glow is a few degrees wide: most of it lands on a 36 mm frame at 50 mm.
    EXPECT_GT(glowing.lights[0].dustGlowInFrameShare, 0.8);
    EXPECT_LE(glowing.lights[0].dustGlowInFrameShare, 1.0);
    // Centred on the light's image: its centroid within a few pixels of the starburst's.
    glm::dvec2 glowCentre{0.0}, starCentre{0.0};
    double glowSum = 0.0, starSum = 0.0;
    for (int y = 0; y < 256; ++y)
        for (int x = 0; x < 384; ++x) {
            const size_t i = 3 * (static_cast<size_t>(y) * 384 + x) + 1;
            const double g = double(glowing.xyz[i]) - plain.xyz[i];
            glowCentre += g * glm::dvec2(x, y), glowSum += g;
            starCentre += double(plain.xyz[i]) * glm::dvec2(x, y), starSum += plain.xyz[i];
        }
    // The glow is cut by the frame's edges, which pulls its centroid towards the frame's centre.
    EXPECT_LT(glm::length(glowCentre / glowSum - starCentre / starSum), 25.0);
}

}  // namespace
}  // namespace flare
