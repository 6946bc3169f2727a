// The adaptive pass plan (PassPlan.h): its choice against the analytic optimum of two independent
// estimators, and the render it plans: the image's expectation that of fixed passes (a z-test per
// layer, with the variances the passes' spread estimates), the same image for any thread count
// and after resuming from a checkpoint.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "flare/core/Replicates.h"
#include "flare/render/PassPlan.h"
#include "flare/render/Render.h"
#include "flare/scene/SceneRender.h"
#include "RenderTestUtil.h"

namespace flare {
namespace {

using renderer::choosePassSplit;
using renderer::PlanSplit;
using renderer::PlanTarget;

// The classic allocation: two independent estimators of variance v_i / n_i at cost c_i · n_i
// for a fixed total cost C have the least summed variance at n_i = C √(v_i / c_i) / Σ_j √(v_j c_j).
TEST(PassPlan, OneTargetTakesTheAnalyticOptimum) {
    struct Case {
        double a, c, beamCost, photonCost, accumulated;
    };
    const Case cases[] = {{1.0, 1.0, 1.0, 1.0, 0.0},   {4.0, 1.0, 2.0, 1.0, 0.0}, {0.3, 2.5, 3.0, 0.7, 5.0},
                          {7.0, 0.9, 1.0, 2.2, 40.0}, {1.0, 3.0, 1.0, 1.5, 1e3}};
    for (const Case& k : cases) {
        PlanTarget t;
        t.beamVariance = k.a;
        t.photonVariance = k.c;
        t.accumulated = k.accumulated;
        t.normTimesTarget2 = 0.37;
        const PlanSplit s = choosePassSplit({t}, k.beamCost, k.photonCost, 1e-3, 1e3);
        const double cost = k.beamCost + k.photonCost;
        const double sum = std::sqrt(k.a * k.beamCost) + std::sqrt(k.c * k.photonCost);
        const double beams = cost * std::sqrt(k.a / k.beamCost) / sum, photons = cost * std::sqrt(k.c / k.photonCost) / sum;
        // (The golden-section search ends within 10⁻¹⁶ of the interval: the split to ~1e-8, the
        // square root of the objective's flatness at its minimum in double precision.)
        EXPECT_NEAR(s.beamScale, beams, 1e-6 * beams) << k.a << " " << k.c;
        EXPECT_NEAR(s.photonScale, photons, 1e-6 * photons);
        EXPECT_NEAR(s.beamScale * k.beamCost + s.photonScale * k.photonCost, cost, 1e-12 * cost);
    }
}

// Two targets, one the beams' alone and one the photons' alone: the largest error over its target
// is least where both are equal, a1 / (β N1) = c2 / (π N2), at the pass's cost.
TEST(PassPlan, TwoTargetsAreBalanced) {
    PlanTarget ghost, scatter;
    ghost.beamVariance = 2.0, ghost.normTimesTarget2 = 0.5;
    scatter.photonVariance = 3.0, scatter.normTimesTarget2 = 4.0;
    const double beamCost = 3.0, photonCost = 1.0;
    const PlanSplit s = choosePassSplit({ghost, scatter}, beamCost, photonCost, 1e-3, 1e3);
    const double ratio = (2.0 / 0.5) / (3.0 / 4.0);  // β / π
    const double photons = (beamCost + photonCost) / (ratio * beamCost + photonCost);
    EXPECT_NEAR(s.photonScale, photons, 1e-6 * photons);
    EXPECT_NEAR(s.beamScale, ratio * photons, 1e-6 * ratio * photons);
    // The bounds hold: a target of beams alone takes every beam the bounds allow.
    const PlanSplit bounded = choosePassSplit({ghost}, beamCost, photonCost, 0.125, 4.0);
    EXPECT_NEAR(bounded.photonScale, 0.125, 1e-9);
    EXPECT_NEAR(bounded.beamScale, (beamCost + photonCost - 0.125 * photonCost) / beamCost, 1e-9);
    // Nothing measured, or no cost: the nominal pass.
    const PlanSplit none = choosePassSplit({PlanTarget{}}, beamCost, photonCost, 0.125, 4.0);
    EXPECT_EQ(none.beamScale, 1.0);
    EXPECT_EQ(none.photonScale, 1.0);
    EXPECT_EQ(choosePassSplit({ghost}, 0.0, photonCost, 0.125, 4.0).beamScale, 1.0);
}

std::string writeTemp(const std::string& name, const std::string& text) {
    const auto dir = test::processTempDir("flare_pass_plan_test");
    std::filesystem::create_directories(dir);
    const auto path = dir / name;
    std::ofstream(path) << text;
    return path.string();
}

// The uncoated doublet, a sun and a lamp (beams), with an interior that scatters (photons).
Scene planScene() {
    const std::string lens = writeTemp("doublet.lens", test::kUncoatedDoublet);
    Scene scene = parseSceneText(R"({
  "lens": ")" + lens + R"(",
  "sensor": { "resolution": [120, 80] },
  "lights": [ { "type": "directional", "field_deg": [4.0, 2.5], "angular_diameter_deg": 0.53, "spectrum": { "blackbody_k": 5778 } },
              { "type": "point", "position_mm": [30.0, 20.0, -600.0], "spectrum": { "blackbody_k": 2700 } } ]
})",
                                 "plan.json", "");
    return scene;
}

RenderOptions planOptions(const Scene& scene, const LensSystem& lens) {
    RenderOptions o;
    o.mode = RenderOptions::Mode::Guided;
    o.seed = 5;
    o.batchesPerPass = 16;
    o.beamsPerPass = 32;
    o.materials = {0.3, 0.3, 0.3};
    o.film.widthPx = scene.sensor.widthPx;
    o.film.heightPx = scene.sensor.heightPx;
    o.film.widthMm = lens.sensor().widthMm;
    o.film.heightMm = lens.sensor().heightMm;
    // The ghosts targeted alone: the plan moves the photons' cost to the beams, far from the
    // nominal pass (each photon then weighs up to 8 times a nominal one).
    o.errorTargets = {{kGroupGhost, 0.01}};
    return o;
}

// A layer's Y power in the film's image (W): Σ irradiance × pixel area.
double layerPowerY(const Renderer& r, int layer) {
    const std::vector<float> xyz = r.layerXyz(layer);
    const double pixelM = r.options().film.widthMm / r.options().film.widthPx * 1e-3;
    double sum = 0.0;
    for (size_t i = 1; i < xyz.size(); i += 3) sum += xyz[i];
    return sum * pixelM * pixelM;
}

// A render's per-layer power and the variance of that mean, from each pass's own estimate
// (p·T_p − (p − 1)·T_{p−1}) grouped by replicate (its passes are correlated, replicates are not).
struct LayerPowers {
    double power[kFixedLayerCount] = {};
    double variance[kFixedLayerCount] = {};
};
LayerPowers renderPowers(const Scene& scene, const LensSystem& lens, const RenderOptions& o, int passes,
                         bool* planMoved = nullptr) {
    Renderer r(lens, scene.lights, o);
    std::vector<double> sums[kFixedLayerCount];
    for (auto& s : sums) s.assign(static_cast<size_t>(o.beamReplicates), 0.0);
    double previous[kFixedLayerCount] = {};
    for (int p = 0; p < passes; ++p) {
        r.runPass();
        for (int l = 0; l < kFixedLayerCount; ++l) {
            const double total = layerPowerY(r, l);
            sums[l][static_cast<size_t>(p % o.beamReplicates)] += total * (p + 1) - previous[l] * p;
            previous[l] = total;
        }
    }
    LayerPowers out;
    for (int l = 0; l < kFixedLayerCount; ++l) {
        out.power[l] = previous[l];
        out.variance[l] = replicateVarianceOfMean(sums[l].data(), o.beamReplicates, passes);
    }
    if (planMoved) {
        *planMoved = false;
        for (const auto& [beamScale, batches] : r.passPlan())
            *planMoved = *planMoved || beamScale > 1.5 || batches * 2 < o.batchesPerPass;
    }
    return out;
}

// The adaptive plan's image has the fixed plan's expectation, layer by layer: a z-test of the two
// renders' powers (independent seeds) against the variances their replicates' spread estimates.
// With 8 replicates the estimates have 7 degrees of freedom each; the bound is Student's t at a
// family-wise 1e-4 over the layers (t_7 quantile for 1.25e-5 two-sided: 9.0 would be exact;
// the Welch-style sum of two such estimates has more degrees of freedom, so 8.0 is conservative
// enough and a dropped weight, a factor of 2 to 8 in a layer, is hundreds of standard errors).
TEST(PassPlan, AdaptivePassesKeepTheImagesExpectation) {
    const Scene scene = planScene();
    const LensSystem lens = buildSceneLens(scene);
    RenderOptions adaptive = planOptions(scene, lens);
    adaptive.beamReplicates = 8;
    RenderOptions fixed = adaptive;
    fixed.passPlan = RenderOptions::PassPlan::Fixed;
    fixed.seed = 6;
    bool moved = false;
    const LayerPowers a = renderPowers(scene, lens, adaptive, 24, &moved);
    const LayerPowers f = renderPowers(scene, lens, fixed, 24);
    EXPECT_TRUE(moved) << "the plan kept the nominal pass: the test would not see a dropped weight";
    int compared = 0;
    for (int l : {kLayerDirect, kLayerGhost, kLayerScatter}) {
        ASSERT_GT(f.power[l], 0.0) << renderLayerName(l);
        const double se = std::sqrt(a.variance[l] + f.variance[l]);
        ASSERT_GT(se, 0.0) << renderLayerName(l);
        EXPECT_LT(std::abs(a.power[l] - f.power[l]), 8.0 * se)
            << renderLayerName(l) << ": adaptive " << a.power[l] << ", fixed " << f.power[l] << " ± " << se;
        // (And the test can see a weight: a factor of two in the photons' direct layer or the
        // beams' ghost layer is far outside the bound; the scattered light is too noisy here for
        // that, and a photon weight dropped shows in the direct layer.)
        if (l != kLayerScatter) EXPECT_GT(0.5 * f.power[l], 8.0 * se) << renderLayerName(l);
        ++compared;
    }
    EXPECT_EQ(compared, 3);
}

void expectSameRender(const Renderer& a, const Renderer& b) {
    ASSERT_EQ(a.layerNames(), b.layerNames());
    for (int l = 0; l < static_cast<int>(a.layerNames().size()); ++l) EXPECT_EQ(a.layerXyz(l), b.layerXyz(l)) << l;
    EXPECT_EQ(a.film().varianceRgb(), b.film().varianceRgb());
    EXPECT_EQ(a.passPlan(), b.passPlan());
    EXPECT_EQ(a.statistics().photons, b.statistics().photons);
    EXPECT_EQ(a.statistics().beams, b.statistics().beams);
}

TEST(PassPlan, SamePlanAndImageForOneAndTwoThreadsAndAfterResuming) {
    const Scene scene = planScene();
    const LensSystem lens = buildSceneLens(scene);
    const RenderOptions o = planOptions(scene, lens);
    constexpr int kPasses = 6;
    auto renderWith = [&](int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        auto r = std::make_unique<Renderer>(lens, scene.lights, o);
        for (int p = 0; p < kPasses; ++p) r->runPass();
        return r;
    };
    const auto one = renderWith(1);
    const auto two = renderWith(2);
    ASSERT_TRUE(one->adaptivePassPlan());
    // The plan moved away from the nominal pass (else this test would prove little).
    bool moved = false;
    for (const auto& [beamScale, batches] : one->passPlan()) moved = moved || beamScale != 1.0 || batches != o.batchesPerPass;
    EXPECT_TRUE(moved);
    expectSameRender(*one, *two);

    // Stopped after three passes (the plan had decided passes 3 and 4), resumed for three more.
    const std::string checkpoint = writeTemp("plan.checkpoint", "");
    {
        Renderer first(lens, scene.lights, o);
        for (int p = 0; p < 3; ++p) first.runPass();
        first.saveCheckpoint(checkpoint);
    }
    Renderer resumed(lens, scene.lights, o);
    resumed.loadCheckpoint(checkpoint);
    for (int p = 3; p < kPasses; ++p) resumed.runPass();
    expectSameRender(*one, resumed);

    // A render with other targets plans other passes: its checkpoint is refused.
    RenderOptions other = o;
    other.errorTargets = {{kGroupFlare, 0.05}};
    Renderer otherRender(lens, scene.lights, other);
    EXPECT_THROW(otherRender.loadCheckpoint(checkpoint), std::exception);
}

}  // namespace
}  // namespace flare
