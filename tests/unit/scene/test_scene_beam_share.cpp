// A pass's beams shared among a scene's lights by their power (SceneBeamShare.h,
// render.beams_by_power): the split, and the preview's ghosts with it against equal beams.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "flare/scene/Scene.h"
#include "flare/scene/SceneBeamShare.h"
#include "flare/scene/ScenePreview.h"

namespace flare {
namespace {

TEST(SceneBeamShare, SharesFollowThePowerWithAFloor) {
    const std::vector<int> beams = beamsByPowerShare({100.0, 10.0, 1.0, 0.0}, 4 * 256, 16);
    ASSERT_EQ(beams.size(), 4u);
    // 1024 × 100/111, × 10/111, × 1/111 rounded; the floor for the weak and the dark.
    EXPECT_EQ(beams[0], 923);
    EXPECT_EQ(beams[1], 92);
    EXPECT_EQ(beams[2], 16);
    EXPECT_EQ(beams[3], 16);
    // Without power, every light the floor; bad input refused.
    EXPECT_EQ(beamsByPowerShare({0.0, 0.0}, 512, 16), (std::vector<int>{16, 16}));
    EXPECT_THROW(beamsByPowerShare({1.0, -1.0}, 512, 16), std::invalid_argument);
    EXPECT_THROW(beamsByPowerShare({1.0, NAN}, 512, 16), std::invalid_argument);
    EXPECT_THROW(beamsByPowerShare({1.0}, 512, 0), std::invalid_argument);
}

TEST(SceneBeamShare, PointLightsShareByTheirIrradianceAtTheLens) {
    LightSpec sun, lamp;
    sun.power = 3.0;  // W/m²
    lamp.type = LightSpec::Type::Point;
    lamp.positionMm = {0.0, 0.0, -2000.0};
    lamp.power = 4.0;  // W/sr at 2 m: 1 W/m²
    const std::vector<int> beams = lightBeamsByPower({sun, lamp}, 128);
    EXPECT_EQ(beams[0], 192);
    EXPECT_EQ(beams[1], 64);
}

// The double Gauss at f/4 on a small sensor, without diffraction: the previews below are ghosts only.
Scene smallScene() {
    Scene scene;
    scene.lens = "double-gauss-50mm";
    scene.lensState.fNumber = 4.0;
    scene.sensor.widthPx = 192;
    scene.sensor.heightPx = 128;
    scene.render.diffraction = false;
    return scene;
}

// Two lights a hundred to one in power: with the beams by power the preview's ghosts estimate the
// same image as with equal beams (both unbiased: their difference within its estimated spread),
// and, at the same total of beams, with a smaller estimated error.
TEST(SceneBeamShare, ByPowerIsUnbiasedAndLowersTheError) {
    Scene scene = smallScene();
    LightSpec bright, dim;
    bright.name = "bright", bright.fieldXDeg = 8.0, bright.fieldYDeg = 3.0, bright.power = 100.0;
    dim.name = "dim", dim.fieldXDeg = -6.0, dim.fieldYDeg = -4.0, dim.power = 1.0;
    scene.lights = {bright, dim};
    const LensSystem lens = buildSceneLens(scene);
    PreviewBudget budget;
    budget.passes = 8;
    budget.beamsPerPass = 64;
    budget.direct = false;
    const ScenePreview equal = previewScene(scene, lens, false, budget);
    scene.render.beamsByPower = true;
    const ScenePreview byPower = previewScene(scene, lens, false, budget);
    ASSERT_GT(equal.ghostEstimatedError, 0.0);
    ASSERT_GT(byPower.ghostEstimatedError, 0.0);
    // The same beams in all (128 for two lights, 127 + 16 by power: the floor adds a little).
    EXPECT_LT(byPower.ghostEstimatedError, equal.ghostEstimatedError);
    double diff2 = 0.0, norm2 = 0.0, sumA = 0.0, sumB = 0.0;
    for (size_t i = 1; i < equal.ghosts.size(); i += 3) {
        const double d = double(byPower.ghosts[i]) - equal.ghosts[i];
        diff2 += d * d;
        norm2 += double(equal.ghosts[i]) * equal.ghosts[i];
        sumA += equal.ghosts[i], sumB += byPower.ghosts[i];
    }
    // Independent estimates (the beams differ): their difference's relative L2 is about the two
    // errors in quadrature; 3 × that, for the spread of the estimates themselves (two replicates).
    const double spread = std::hypot(equal.ghostEstimatedError, byPower.ghostEstimatedError);
    EXPECT_LT(std::sqrt(diff2 / norm2), 3.0 * spread);
    EXPECT_NEAR(sumB / sumA, 1.0, 3.0 * spread);
}

// The small scene with one sun at (8°, 3°), and a budget of 32 beams a pass for its ghosts alone:
// what the target-error tests continue passes on.
Scene oneSunScene() {
    Scene scene = smallScene();
    LightSpec light;
    light.fieldXDeg = 8.0, light.fieldYDeg = 3.0;
    scene.lights = {light};
    return scene;
}

PreviewBudget ghostsOnlyBudget() {
    PreviewBudget budget;
    budget.beamsPerPass = 32;
    budget.direct = false;
    return budget;
}

// A target error continues the passes made (whole rounds) rather than starting again: the image is
// that of a fixed count of the same passes, to the bit, and its estimated error meets the target.
TEST(SceneBeamShare, TargetErrorContinuesThePasses) {
    const Scene scene = oneSunScene();
    const LensSystem lens = buildSceneLens(scene);
    PreviewBudget budget = ghostsOnlyBudget();
    const ScenePreview two = previewScene(scene, lens, false, budget);
    budget.targetError = 0.6 * two.ghostEstimatedError;
    const ScenePreview reached = previewScene(scene, lens, false, budget);
    EXPECT_GT(reached.passes, 2);
    EXPECT_EQ(reached.passes % 2, 0);
    EXPECT_LE(reached.ghostEstimatedError, budget.targetError);
    PreviewBudget fixed = budget;
    fixed.targetError = 0.0;
    fixed.passes = reached.passes;
    const ScenePreview same = previewScene(scene, lens, false, fixed);
    EXPECT_EQ(same.ghosts, reached.ghosts);
    // A target the first passes meet: no more passes.
    budget.targetError = 2.0 * two.ghostEstimatedError;
    EXPECT_EQ(previewScene(scene, lens, false, budget).passes, 2);
}

// A target far below the first passes' error is approached in two forecasts: the first, from the
// two passes, goes halfway to its count, where the error is estimated again (the passes made
// kept) and the rest forecast from there. The pass counts follow from fixed runs of the same
// passes (each to the bit the continued run's first passes): the rule's, computed here from their
// estimated errors; the one-step forecast would stop elsewhere on this scene.
TEST(SceneBeamShare, TargetErrorForecastsAgainHalfway) {
    const Scene scene = oneSunScene();
    const LensSystem lens = buildSceneLens(scene);
    PreviewBudget budget = ghostsOnlyBudget();
    const double e2 = previewScene(scene, lens, false, budget).ghostEstimatedError;
    ASSERT_GT(e2, 0.0);
    const double target = 0.3 * e2;
    auto roundsOf = [](double passes) { return 2 * static_cast<int>(std::ceil(passes / 2.0)); };
    // From 2 passes: (e2/target)² × 2 × 1.1 = 24.4 → 25, more than twice 2: halfway, 2 + 12 = 14.
    const double oneStep = std::ceil(2.0 * (e2 / target) * (e2 / target) * 1.1);
    const int halfway = roundsOf(2.0 + std::ceil(0.5 * (oneStep - 2.0)));
    ASSERT_EQ(halfway, 14);
    PreviewBudget fixed = budget;
    fixed.passes = halfway;
    const ScenePreview atHalfway = previewScene(scene, lens, false, fixed);
    // Met there, the passes stop; else the rest is forecast from there (halfway again if far).
    int expected = halfway;
    if (atHalfway.ghostEstimatedError > target) {
        const double ratio = atHalfway.ghostEstimatedError / target;
        double next = std::ceil(halfway * ratio * ratio * 1.1);
        if (next > 2.0 * halfway) next = halfway + std::ceil(0.5 * (next - halfway));
        expected = std::max(halfway + 2, roundsOf(next));
    }
    budget.targetError = target;
    const ScenePreview reached = previewScene(scene, lens, false, budget);
    fixed.passes = expected;
    const ScenePreview atExpected = expected == halfway ? atHalfway : previewScene(scene, lens, false, fixed);
    ASSERT_LE(atExpected.ghostEstimatedError, target);
    EXPECT_EQ(reached.passes, expected);
    EXPECT_EQ(reached.ghosts, atExpected.ghosts);
    EXPECT_LE(reached.ghostEstimatedError, target);
    EXPECT_NE(reached.passes, roundsOf(oneStep));  // where the one-step forecast stopped
}

}  // namespace
}  // namespace flare
