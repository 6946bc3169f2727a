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

}  // namespace
}  // namespace flare
