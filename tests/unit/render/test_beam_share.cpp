// The beams shared among all lights' paths by predicted variance (BeamShare.h, BeamVariance.h): the
// water-filling against the constrained optimum computed independently, the probes' image variance
// against images built pixel by pixel, and the render with the new shares against the central
// probe's shares, path by path (unbiased: weights follow the rates).
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "RenderTestUtil.h"
#include "TestUtil.h"
#include "flare/core/Random.h"
#include "flare/core/Spectrum.h"
#include "flare/render/BeamShare.h"
#include "flare/render/BeamVariance.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"
#include "flare/scene/SceneRender.h"

namespace flare {
namespace {

double objective(const std::vector<double>& v, const std::vector<double>& n) {
    double sum = 0.0;
    for (size_t p = 0; p < v.size(); ++p) sum += v[p] / n[p];
    return sum;
}

// Without floors, the optimum of Σ v/n at fixed cost Σ c n is n ∝ √(v/c) (Lagrange): the rates are
// exactly that, scaled to the budget.
TEST(BeamShare, WithoutFloorsTheRatesAreTheSquareRootAllocation) {
    const std::vector<double> v{4.0, 1.0, 9.0, 0.25}, c{1.0, 4.0, 1.0, 2.0};
    std::vector<double> s, zero(v.size(), 0.0);
    double total = 0.0;
    for (size_t p = 0; p < v.size(); ++p) s.push_back(std::sqrt(v[p] / c[p])), total += s.back();
    const std::vector<double> rate = renderer::waterFillRates(s, zero, 1000.0);
    for (size_t p = 0; p < v.size(); ++p) EXPECT_NEAR(rate[p], 1000.0 * s[p] / total, 1e-12 * 1000.0) << p;
}

// With floors, against an independent solution (bisection on the multiplier), the KKT conditions,
// and random feasible moves of cost between paths, none of which lowers Σ v/n.
TEST(BeamShare, WithFloorsTheRatesAreTheConstrainedOptimum) {
    Rng rng(27, 41);
    for (int trial = 0; trial < 20; ++trial) {
        const int paths = 3 + trial;
        std::vector<double> v, c, s, f;
        for (int p = 0; p < paths; ++p) {
            v.push_back(std::exp(6.0 * rng.uniform() - 3.0));  // variances over six decades
            c.push_back(0.5 + 2.0 * rng.uniform());
            s.push_back(std::sqrt(v.back() / c.back()));
            f.push_back(rng.uniform() < 0.5 ? 1.0 : 0.2 + 3.0 * rng.uniform());
        }
        const double budget = 10.0 * paths;
        const std::vector<double> n = renderer::waterFillRates(s, f, budget);
        double sum = 0.0;
        for (double r : n) sum += r;
        EXPECT_NEAR(sum, budget, 1e-9 * budget);
        // Bisection on λ in Σ max(f, λ s) = budget.
        double lo = 0.0, hi = 1.0;
        auto total = [&](double lambda) {
            double t = 0.0;
            for (int p = 0; p < paths; ++p) t += std::max(f[p], lambda * s[p]);
            return t;
        };
        while (total(hi) < budget) hi *= 2.0;
        for (int i = 0; i < 200; ++i) (total(0.5 * (lo + hi)) < budget ? lo : hi) = 0.5 * (lo + hi);
        const double lambda = 0.5 * (lo + hi);
        for (int p = 0; p < paths; ++p) EXPECT_NEAR(n[p], std::max(f[p], lambda * s[p]), 1e-9 * n[p]) << trial << " " << p;
        // KKT: v/(c n²) is one μ on the free paths, at most μ on the floored ones.
        double mu = 0.0;
        for (int p = 0; p < paths; ++p)
            if (n[p] > f[p] * (1.0 + 1e-12)) mu = v[p] / (c[p] * n[p] * n[p]);
        ASSERT_GT(mu, 0.0);
        for (int p = 0; p < paths; ++p) {
            const double m = v[p] / (c[p] * n[p] * n[p]);
            if (n[p] > f[p] * (1.0 + 1e-12)) EXPECT_NEAR(m, mu, 1e-8 * mu);
            else EXPECT_LE(m, mu * (1.0 + 1e-8));
        }
        // Moving cost δ from path a to path b (keeping Σ c n and the floors) never helps.
        const double best = objective(v, n);
        for (int move = 0; move < 200; ++move) {
            const int a = static_cast<int>(rng.uniform() * paths), b = static_cast<int>(rng.uniform() * paths);
            if (a == b) continue;
            const double room = (n[a] - f[a]) * c[a];
            if (!(room > 0.0)) continue;
            const double delta = room * rng.uniform();
            std::vector<double> m = n;
            m[a] -= delta / c[a];
            m[b] += delta / c[b];
            EXPECT_GE(objective(v, m), best * (1.0 - 1e-12)) << trial;
        }
    }
}

TEST(BeamShare, FloorsAloneAndBadInput) {
    // Floors that reach the budget, and paths without strength, stay on their floors.
    EXPECT_EQ(renderer::waterFillRates({1.0, 2.0}, {3.0, 4.0}, 5.0), (std::vector<double>{3.0, 4.0}));
    const std::vector<double> r = renderer::waterFillRates({0.0, 1.0, 3.0}, {1.0, 1.0, 1.0}, 11.0);
    EXPECT_EQ(r[0], 1.0);
    EXPECT_NEAR(r[1], 2.5, 1e-12);
    EXPECT_NEAR(r[2], 7.5, 1e-12);
    EXPECT_THROW(renderer::waterFillRates({1.0}, {1.0, 1.0}, 4.0), std::invalid_argument);
    EXPECT_THROW(renderer::waterFillRates({-1.0}, {1.0}, 4.0), std::invalid_argument);
    EXPECT_THROW(renderer::waterFillRates({NAN}, {1.0}, 4.0), std::invalid_argument);
    EXPECT_THROW(renderer::waterFillRates({1.0}, {1.0}, -4.0), std::invalid_argument);
}

// A square of uniform irradiance, its images moved by known whole pixels: the sample variance of
// the rasterised images equals the one of images built pixel by pixel (centres inside the square),
// and, for two images d pixels apart, the closed form d L E² ‖M s‖² (M: XYZ to Rec.709).
constexpr int kWidth = 64, kHeight = 48;  // two film bands (Film::kBandRows = 32)

GhostBeam squareBeam(double x0, double y0, double side, double irradiance) {
    auto vertex = [&](BeamTriangle& t, int k, double x, double y) {
        t.pixel[k] = {x, y};
        t.pupilMm[k] = {0.1 * x, 0.1 * y};
        t.irradiance[k] = irradiance;
        t.throughput[k] = irradiance;
    };
    BeamTriangle a, b;
    vertex(a, 0, x0, y0), vertex(a, 1, x0 + side, y0), vertex(a, 2, x0 + side, y0 + side);
    vertex(b, 0, x0, y0), vertex(b, 1, x0 + side, y0 + side), vertex(b, 2, x0, y0 + side);
    for (BeamTriangle* t : {&a, &b}) t->imageAreaPx2 = 0.5 * side * side, t->pupilAreaMm2 = 0.005 * side * side;
    return GhostBeam::fromTriangles({a, b}, {kWidth, kHeight, 12.8, 9.6, 0.2});
}

TEST(BeamShare, ProbeVarianceOfShiftedImagesIsTheDirectOne) {
    const FilmFrame frame{kWidth, kHeight, 12.8, 9.6, 0.2};
    const double side = 12.0, irradiance = 2.0;
    const glm::dvec3 scale(0.3, 0.5, 0.2);
    const glm::dvec3 rgb = xyzToLinearSrgb(scale * irradiance);
    for (int count : {2, 3, 5}) {
        const int shift = 3;
        std::vector<GhostBeam> beams;
        for (int k = 0; k < count; ++k) beams.push_back(squareBeam(5.0 + shift * k, 25.0 + k, side, irradiance));
        std::vector<renderer::BeamImage> images;
        for (const GhostBeam& b : beams) images.push_back({&b, {0.0, 0.0}, scale, 1});
        // Pixel by pixel: pixel (i, j) holds the square's value where its centre lies inside.
        double direct = 0.0;
        for (int j = 0; j < kHeight; ++j)
            for (int i = 0; i < kWidth; ++i) {
                std::vector<glm::dvec3> values;
                glm::dvec3 mean(0.0);
                for (int k = 0; k < count; ++k) {
                    const double x0 = 5.0 + shift * k, y0 = 25.0 + k;
                    const bool inside = i + 0.5 > x0 && i + 0.5 < x0 + side && j + 0.5 > y0 && j + 0.5 < y0 + side;
                    values.push_back(inside ? rgb : glm::dvec3(0.0));
                    mean += values.back() / static_cast<double>(count);
                }
                for (const glm::dvec3& x : values) direct += glm::dot(x - mean, x - mean);
            }
        direct /= count - 1;
        const double probe = renderer::imageSampleVariance(images, frame);
        EXPECT_NEAR(probe, direct, 1e-12 * direct) << count << " images";
        if (count == 2) {
            // Moved by (3, 1): the two images differ on 2 × (12 × 12 − 9 × 11) pixels.
            const double differing = 2.0 * (side * side - (side - shift) * (side - 1.0));
            EXPECT_NEAR(probe, 0.5 * differing * glm::dot(rgb, rgb), 1e-12 * probe);
        }
    }
    // The same image K times: no spread.
    const GhostBeam same = squareBeam(5.0, 25.0, side, irradiance);
    EXPECT_EQ(renderer::imageSampleVariance({{&same, {0.0, 0.0}, scale, 1}, {&same, {0.0, 0.0}, scale, 1}}, frame), 0.0);
    EXPECT_THROW(renderer::imageSampleVariance({{&same, {0.0, 0.0}, scale, 1}}, frame), std::invalid_argument);
}

// Student's t: the two-sided critical value with `dof` degrees of freedom, from its density
// integrated by Simpson's rule (bisection on the tail).
double studentTwoSidedCritical(int dof, double alpha) {
    const double nu = dof;
    const double norm = std::exp(std::lgamma(0.5 * (nu + 1.0)) - std::lgamma(0.5 * nu)) / std::sqrt(nu * std::numbers::pi);
    auto density = [&](double t) { return norm * std::pow(1.0 + t * t / nu, -0.5 * (nu + 1.0)); };
    auto centralMass = [&](double x) {  // P(|T| < x)
        constexpr int kSteps = 4000;
        const double h = x / kSteps;
        double sum = density(0.0) + density(x);
        for (int i = 1; i < kSteps; ++i) sum += (i % 2 ? 4.0 : 2.0) * density(i * h);
        return 2.0 * sum * h / 3.0;
    };
    double lo = 0.0, hi = 1.0;
    while (1.0 - centralMass(hi) > alpha) hi *= 2.0;
    for (int i = 0; i < 100; ++i) (1.0 - centralMass(0.5 * (lo + hi)) > alpha ? lo : hi) = 0.5 * (lo + hi);
    return 0.5 * (lo + hi);
}

struct PathPower {
    double mean = 0.0, variance = 0.0;  // the estimate and its variance, from the replicates
};

// Per tally: the beams' power estimate over `passes` passes of `replicates` replicates (pass p in
// replicate p mod K) and its variance from the replicates' spread.
std::vector<PathPower> beamPowers(const Renderer& r, int passes, int replicates) {
    std::vector<PathPower> out;
    for (const PathTally& t : r.tallies()) {
        PathPower p;
        std::vector<double> means;
        for (int k = 0; k < replicates; ++k) {
            const int n = passes / replicates + (k < passes % replicates ? 1 : 0);
            means.push_back(t.replicateSums[k] / n);
            p.mean += t.replicateSums[k] / passes;
        }
        for (int k = 0; k < replicates; ++k) {
            const int n = passes / replicates + (k < passes % replicates ? 1 : 0);
            p.variance += n * (means[k] - p.mean) * (means[k] - p.mean);
        }
        p.variance /= (replicates - 1.0) * passes;
        out.push_back(p);
    }
    return out;
}

Scene twoLightScene() {
    const std::string lens = test::writeUncoatedDoublet("flare_beam_share_test");
    return parseSceneText(R"({
  "lens": ")" + lens + R"(",
  "sensor": { "resolution": [240, 160] },
  "lights": [
    { "type": "directional", "field_deg": [4.0, 2.5], "angular_diameter_deg": 0.53, "spectrum": { "blackbody_k": 5778 } },
    { "type": "disk", "position_mm": [-300, 150, -3000], "radius_mm": 60, "spectrum": "d65", "power": 4.0 }
  ],
  "render": { "diffraction": false, "beams_per_pass": 96, "seed": 5 }
})",
                          "share.json", "");
}

// The probes, their shares and the beams they plan are the same bits with one thread as with two.
TEST(BeamShare, SharesAndImageDoNotDependOnTheThreads) {
    const Scene scene = twoLightScene();
    const LensSystem doublet = buildSceneLens(scene);
    RenderOptions options = sceneRenderOptions(scene, doublet, {});
    options.tracePhotons = false;
    auto render = [&](int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        Renderer r(doublet, scene.lights, options);
        r.runPass();
        std::vector<double> rates;
        for (int l = 0; l < 2; ++l)
            for (int slot = 0; slot <= static_cast<int>(r.ghostReport(l).ghosts.size()); ++slot) rates.push_back(r.plannedBeamRate(l, slot));
        return std::make_pair(rates, r.layerXyz(kLayerGhost));
    };
    const auto one = render(1), two = render(2);
    EXPECT_EQ(one.first, two.first);
    EXPECT_EQ(one.second, two.second);
}

// A sun and a disk light through the uncoated doublet, beams only: each path's power with the
// shares by predicted variance against the central probe's shares, a t-test per path
// (Bonferroni). The new shares must differ (else the test shows nothing), and the same estimates
// with each beam weighted by one over the other plan's rate (a weight that ignores its rate) fail.
TEST(BeamShare, PathPowersWithTheVarianceSharesAgreeWithTheCentralProbesShares) {
    const Scene scene = twoLightScene();
    const LensSystem doublet = buildSceneLens(scene);
    constexpr int kReplicates = 8, kPasses = 16;
    SceneRenderOverrides overrides;
    overrides.beamReplicates = kReplicates;
    RenderOptions options = sceneRenderOptions(scene, doublet, overrides);
    options.tracePhotons = false;
    RenderOptions central = options;
    central.beamVarianceProbes = 0;
    ASSERT_GT(options.beamVarianceProbes, 1);
    Renderer shared(doublet, scene.lights, options), fixed(doublet, scene.lights, central);
    for (int p = 0; p < kPasses; ++p) shared.runPass(), fixed.runPass();
    const std::vector<PathPower> a = beamPowers(shared, kPasses, kReplicates), b = beamPowers(fixed, kPasses, kReplicates);

    std::vector<size_t> beamTallies;
    std::vector<double> rateRatio;  // the shared plan's rate over the central probe's
    int slot = 0, light = -1;
    for (size_t t = 0; t < shared.tallies().size(); ++t) {
        const PathTally& tally = shared.tallies()[t];
        if (tally.kind == PathTally::Kind::Higher || tally.kind == PathTally::Kind::Scatter) continue;
        slot = tally.light == light ? slot + 1 : 0;
        light = tally.light;
        if (tally.strategy != PathStrategy::Beams) continue;
        ASSERT_EQ(fixed.tallies()[t].strategy, PathStrategy::Beams);
        beamTallies.push_back(t);
        rateRatio.push_back(shared.plannedBeamRate(light, slot) / fixed.plannedBeamRate(light, slot));
    }
    ASSERT_GE(beamTallies.size(), 10u);
    // Both plans give each light about its beams per pass in all; the shares moved.
    const double moved = *std::max_element(rateRatio.begin(), rateRatio.end()) /
                         *std::min_element(rateRatio.begin(), rateRatio.end());
    EXPECT_GT(moved, 3.0);

    const double critical = studentTwoSidedCritical(kReplicates - 1, 1e-3 / beamTallies.size());
    auto failures = [&](bool ignoreRate) {
        int failed = 0;
        for (size_t i = 0; i < beamTallies.size(); ++i) {
            const size_t t = beamTallies[i];
            // Ignoring its rate: each shared-plan beam weighted by one over the central plan's rate.
            const double f = ignoreRate ? rateRatio[i] : 1.0;
            const double difference = a[t].mean * f - b[t].mean;
            const double spread = std::sqrt(a[t].variance * f * f + b[t].variance);
            if (std::abs(difference) > critical * spread) ++failed;
        }
        return failed;
    };
    EXPECT_EQ(failures(false), 0);
    EXPECT_GT(failures(true), 0);
}

}  // namespace
}  // namespace flare
