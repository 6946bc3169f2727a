// Scattering: the Henyey–Greenstein sampler against its density, Beer–Lambert through a
// homogeneous glass, through a constant OpenVDB grid and through a grid with a step (delta tracking in the photon tracer,
// ratio tracking for the guided weight), energy with nothing absorbing, the scatter layer against
// the scattering coefficient, zero coverage giving exactly the clean image, and the hybrid with
// dust and bulk scattering against naive tracing.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "RenderTestUtil.h"
#include "TestUtil.h"
#include "flare/core/Error.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/SequentialTracer.h"
#include "flare/photons/Phase.h"
#include "flare/photons/PhotonTracer.h"
#include "flare/render/Render.h"
#include "flare/scene/SceneScattering.h"

namespace flare {
namespace {

TEST(Scattering, HenyeyGreensteinSamplesFollowTheDensityAndTheMeanCosineIsG) {
    for (double g : {-0.5, 0.0, 0.3, 0.85}) {
        Rng rng(5, static_cast<std::uint64_t>(100 * (g + 1)));
        constexpr int kBins = 40;
        constexpr long kSamples = 200000;
        std::vector<long> observed(kBins, 0);
        double sum = 0.0, sumSquares = 0.0;
        for (long i = 0; i < kSamples; ++i) {
            const double mu = sampleHenyeyGreensteinCos(g, rng.uniform());
            observed[std::min(kBins - 1, static_cast<int>((mu + 1.0) / 2.0 * kBins))]++;
            sum += mu;
            sumSquares += mu * mu;
        }
        // Expected counts: the exact integral of 2π p(μ) over each bin (Simpson on 64 sub-steps,
        // far below the counts' noise).
        std::vector<double> expected(kBins);
        for (int b = 0; b < kBins; ++b) {
            const double lo = -1.0 + 2.0 * b / kBins, hi = lo + 2.0 / kBins;
            double integral = 0.0;
            constexpr int kSteps = 64;
            for (int k = 0; k <= kSteps; ++k) {
                const double w = (k == 0 || k == kSteps) ? 1.0 : (k % 2 ? 4.0 : 2.0);
                integral += w * 2.0 * std::numbers::pi * henyeyGreensteinPdf(lo + (hi - lo) * k / kSteps, g);
            }
            expected[b] = kSamples * integral * (hi - lo) / (3.0 * kSteps);
        }
        EXPECT_LT(test::pearsonChiSquared(observed, expected), test::chiSquaredUpperCritical(kBins - 1, 1e-4)) << g;
        const double mean = sum / kSamples;
        const double se = std::sqrt((sumSquares / kSamples - mean * mean) / kSamples);
        EXPECT_NEAR(mean, g, test::normalTwoSidedCritical(1e-4) * se) << g;
    }
}

// A 5 mm plate of n = 1.5 (the cell between surfaces 2 and 3 in file order is glass).
LensSystem plate() {
    return LensSystem::build(parseLensText(
        "name plate\nfocal_length_mm 1\nsensor width_mm=60 height_mm=60 reflectance=0\nsurfaces\n"
        " stop 1 air 10\n inf 5 n=1.5 12\n inf 10 air 12\n",
        "plate.lens"));
}

// Share of axial photons that arrive at the sensor directly (no reflection, no scattering).
double directShare(const PhotonTracer& tracer, long photons, std::uint64_t seed) {
    const SpectralIndices indices = tracer.lens().indicesAt(550.0);
    Rng rng(seed, 0);
    const auto scratch = tracer.makeScratch();
    PhotonHistory h;
    long direct = 0;
    for (long i = 0; i < photons; ++i) {
        const double r = 8.0 * std::sqrt(rng.uniform()), phi = 2.0 * std::numbers::pi * rng.uniform();
        tracer.trace(indices, Ray{{r * std::cos(phi), r * std::sin(phi), -5.0}, {0.0, 0.0, 1.0}}, rng, h, *scratch);
        for (int a = 0; a < h.arrivalCount; ++a) direct += h.arrivals[a].key == 0 && !h.arrivals[a].scattered;
    }
    return static_cast<double>(direct) / photons;
}

void expectBeerLambert(const BulkMedium& medium, double sigmaT, const char* what) {
    const LensSystem lens = plate();
    const PhotonTracer tracer(lens, {}, -1, {}, {medium});
    const double n = lens.indicesAt(550.0).n[2];
    const double Rn = std::pow((n - 1.0) / (n + 1.0), 2.0);
    const double expected = (1.0 - Rn) * (1.0 - Rn) * std::exp(-sigmaT * 5.0);
    const long N = 100000;
    const double share = directShare(tracer, N, 3);
    EXPECT_NEAR(share, expected, test::normalTwoSidedCritical(1e-4) * std::sqrt(expected * (1 - expected) / N)) << what;

    // Ratio tracking of the same path: its mean is the same transmittance.
    Rng rng(9, 0);
    const auto scratch = tracer.makeScratch();
    std::vector<glm::dvec3> points;
    std::vector<int> surfaces;
    TraceOptions options;
    options.pathPointsMm = &points;
    options.pathSurfaces = &surfaces;
    const TraceResult r = traceForward(lens, lens.indicesAt(550.0), Ray{{1.0, 2.0, -5.0}, {0.0, 0.0, 1.0}}, options);
    ASSERT_TRUE(r.ok());
    double sum = 0.0, sumSquares = 0.0;
    const int M = 20000;
    for (int i = 0; i < M; ++i) {
        const double t = tracer.clearTransmittance(points, surfaces, 550.0, rng, *scratch);
        sum += t, sumSquares += t * t;
    }
    const double mean = sum / M, se = std::sqrt(std::max(0.0, sumSquares / M - mean * mean) / M);
    EXPECT_NEAR(mean, std::exp(-sigmaT * 5.0), test::normalTwoSidedCritical(1e-4) * se + 1e-12) << what;
}

TEST(Scattering, BeerLambertThroughAHomogeneousGlass) {
    BulkMedium medium;
    medium.cell = 2;
    medium.scatteringPerMm = 0.06;
    medium.absorptionPerMm = 0.04;
    medium.g = 0.7;
    expectBeerLambert(medium, 0.10, "homogeneous");
}

TEST(Scattering, BeerLambertThroughAConstantVdbGrid) {
    BulkMedium medium;
    medium.cell = 2;
    medium.scatteringPerMm = 0.03;  // × density 2.5 = 0.075 per mm
    medium.absorptionPerMm = 0.02;  // × 2.5 = 0.05 per mm
    medium.grid = std::make_shared<VolumeGrid>(VolumeGrid::constant(2.5, {-13, -13, -1}, {13, 13, 6}, 0.5));
    expectBeerLambert(medium, 0.125, "constant grid");
}

TEST(Scattering, BeerLambertThroughAGridWithAStep) {
    // Density 0.8 in the front half of the plate, 3.2 in the back half: transmittance
    // exp(−σt·0.8·2.5 mm − σt·3.2·2.5 mm), the effective σt of the whole 5 mm is σt·(0.8 + 3.2)/2.
    VolumeGrid::Builder builder("density", 0.5, {-13.0, -13.0, 0.0});
    for (int i = 0; i < 52; ++i)
        for (int j = 0; j < 52; ++j)
            for (int k = 0; k < 10; ++k) builder.set(i, j, k, k < 5 ? 0.8 : 3.2);
    BulkMedium medium;
    medium.cell = 2;
    medium.scatteringPerMm = 0.03;
    medium.absorptionPerMm = 0.02;
    medium.grid = std::make_shared<VolumeGrid>(builder.build());
    expectBeerLambert(medium, 0.05 * (0.8 + 3.2) / 2.0, "step grid");
}

TEST(Scattering, NothingAbsorbingMeansEveryPhotonEscapesOrReachesTheSensor) {
    const LensSystem lens = test::loadLens("lenses/double-gauss-50mm.lens");
    InteriorMaterials white;
    white.housingAlbedo = white.edgeAlbedo = white.irisAlbedo = 0.6;
    white.housingGlossy = white.edgeGlossy = white.irisGlossy = 0.4;
    std::vector<SurfaceContamination> dirt(lens.surfaceCount());
    dirt[0].dustCoverage = 0.2;
    dirt[0].dustAlbedo = 1.0;
    BulkMedium medium;
    medium.cell = 1;
    medium.scatteringPerMm = 0.05;
    medium.g = 0.5;
    const PhotonTracer tracer(lens, white, -1, dirt, {medium});
    const SpectralIndices indices = lens.indicesAt(550.0);
    Rng rng(21, 0);
    const auto scratch = tracer.makeScratch();
    PhotonHistory h;
    long fates[static_cast<int>(PhotonFate::Count)] = {};
    const long N = 20000;
    for (long i = 0; i < N; ++i) {
        const double a = (2.0 * rng.uniform() - 1.0) * 12.0, b = (2.0 * rng.uniform() - 1.0) * 12.0;
        const glm::dvec3 d = glm::normalize(glm::dvec3(0.2, 0.1, 1.0));
        tracer.trace(indices, Ray{glm::dvec3(a, b, -5.0) - 10.0 * d, d}, rng, h, *scratch);
        ++fates[static_cast<int>(h.fate)];
    }
    // Glossy lobes can point into the paint and grease is absent: only those can absorb.
    const long out = fates[static_cast<int>(PhotonFate::Escaped)] + fates[static_cast<int>(PhotonFate::AbsorbedSensor)];
    EXPECT_EQ(fates[static_cast<int>(PhotonFate::AbsorbedDust)], 0);
    EXPECT_EQ(fates[static_cast<int>(PhotonFate::AbsorbedBulk)], 0);
    EXPECT_EQ(fates[static_cast<int>(PhotonFate::Lost)], 0);
    EXPECT_GT(out, N * 95 / 100);
}

Scene doubletScene(const std::string& scattering) {
    const auto dir = test::processTempDir("flare_scattering_test");
    std::filesystem::create_directories(dir);
    std::ofstream(dir / "doublet.lens") << test::kUncoatedDoublet;
    const std::string text = R"({ "lens": ")" + (dir / "doublet.lens").string() + R"(",
  "sensor": { "resolution": [120, 80] },
  "lights": [ { "type": "directional", "field_deg": [4.0, 2.5], "angular_diameter_deg": 0.53,
                "spectrum": { "blackbody_k": 5778 } } ],
  "scattering": )" + scattering + " }";
    return parseSceneText(text, "doublet.json", "");
}

TEST(Scattering, ZeroCoverageGivesExactlyTheCleanImage) {
    const Scene clean = doubletScene(R"({ "housing": { "diffuse": 0.03 } })");
    const Scene zero = doubletScene(
        R"({ "housing": { "diffuse": 0.03 }, "dust": [ { "surface": 1, "coverage": 0 } ],
             "grease": [ { "surface": 4, "coverage": 0, "roughness": 0.2 } ] })");
    const LensSystem lens = buildSceneLens(clean);
    Renderer a(lens, clean.lights, test::sceneRenderOptions(clean, lens, RenderOptions::Mode::Guided));
    Renderer b(lens, zero.lights, test::sceneRenderOptions(zero, lens, RenderOptions::Mode::Guided));
    a.runPass();
    b.runPass();
    for (int l = 0; l < kFixedLayerCount; ++l) EXPECT_EQ(a.layerXyz(l), b.layerXyz(l)) << l;
}

TEST(Scattering, ScatterLayerGrowsWithTheScatteringCoefficient) {
    double power[2], error[2];
    for (int i = 0; i < 2; ++i) {
        const double sigma = 0.002 * (i + 1);
        const Scene scene = doubletScene(R"({ "housing": { "diffuse": 0 }, "edges": { "diffuse": 0 }, "iris": { "diffuse": 0 },
            "bulk": [ { "element": 1, "scattering_per_mm": )" + std::to_string(sigma) + R"(, "g": 0.5 } ] })");
        const LensSystem lens = buildSceneLens(scene);
        Renderer r(lens, scene.lights, test::sceneRenderOptions(scene, lens, RenderOptions::Mode::Guided));
        for (int p = 0; p < 6; ++p) r.runPass();
        power[i] = r.tallyPowerW(r.layerTallies()[kLayerScatter]);
        error[i] = r.tallyStandardErrorW(r.layerTallies()[kLayerScatter]);
        EXPECT_EQ(power[i], r.tallyPowerW(r.scatterSourceTallies()[static_cast<int>(ScatterSource::Bulk) - 1]));
    }
    // Single scattering dominates at σs·6 mm ≈ 1–2 %: doubling σs doubles the scattered power, up to
    // the extinction of the once-scattered light (a few per cent) and the noise.
    const double ratio = power[1] / power[0];
    const double ratioError = ratio * std::hypot(error[0] / power[0], error[1] / power[1]);
    EXPECT_NEAR(ratio, 2.0, 0.05 * 2.0 + test::normalTwoSidedCritical(1e-3) * ratioError);
}

// The scatter layer estimated as smooth (RenderOptions::smoothNeighbours): the same photons
// splatted by an adaptive kernel instead of the 1-px tent. Against a long fixed-kernel reference
// the smoothed image is closer than the fixed one of the same photons (its bias is below the
// noise it removes), its estimated error is smaller, and the layer's power is the same.
TEST(Scattering, SmoothScatterLayerIsCloserToTheReferenceThanTheSharpOne) {
    const Scene scene = doubletScene(R"({ "bulk": [ { "element": 1, "scattering_per_mm": 0.01, "g": 0.3 } ] })");
    const LensSystem lens = buildSceneLens(scene);
    RenderOptions sharpOptions = test::sceneRenderOptions(scene, lens, RenderOptions::Mode::Guided, 7);
    sharpOptions.smoothNeighbours = 0;
    RenderOptions smoothOptions = sharpOptions;
    smoothOptions.smoothNeighbours = 256;
    RenderOptions referenceOptions = sharpOptions;
    referenceOptions.seed = 8;
    Renderer sharp(lens, scene.lights, sharpOptions), smooth(lens, scene.lights, smoothOptions);
    Renderer reference(lens, scene.lights, referenceOptions);
    for (int p = 0; p < 3; ++p) sharp.runPass(), smooth.runPass();
    for (int p = 0; p < 24; ++p) reference.runPass();
    const std::vector<float> r = reference.layerXyz(kLayerScatter), a = sharp.layerXyz(kLayerScatter),
                             b = smooth.layerXyz(kLayerScatter);
    double sharpDistance = 0.0, smoothDistance = 0.0, norm = 0.0;
    for (size_t i = 1; i < r.size(); i += 3) {
        sharpDistance += std::pow(a[i] - r[i], 2);
        smoothDistance += std::pow(b[i] - r[i], 2);
        norm += r[i] * r[i];
    }
    ASSERT_GT(norm, 0.0);
    EXPECT_LT(smoothDistance, 0.5 * sharpDistance) << "relative L2: smooth " << std::sqrt(smoothDistance / norm)
                                                    << ", sharp " << std::sqrt(sharpDistance / norm);
    EXPECT_LT(smooth.estimatedRelativeError(kGroupScatter), sharp.estimatedRelativeError(kGroupScatter));
    // Same seed, same photons: the tallies do not depend on the kernel.
    EXPECT_EQ(smooth.tallyPowerW(smooth.layerTallies()[kLayerScatter]), sharp.tallyPowerW(sharp.layerTallies()[kLayerScatter]));
}

// With per-path layers, the scatter layer is also split by source into layers of their own,
// for the sources the scene has; with the same kernel they add up to the scatter layer pixel by
// pixel, and each holds its source's share of the power.
TEST(Scattering, ScatterSourceLayersAddUpToTheScatterLayer) {
    const Scene scene = doubletScene(R"({ "housing": { "diffuse": 0.3 },
        "dust": [ { "surface": 1, "coverage": 0.05, "albedo": 0.6 } ],
        "bulk": [ { "element": 4, "scattering_per_mm": 0.02, "g": 0.6 } ] })");
    const LensSystem lens = buildSceneLens(scene);
    RenderOptions o = test::sceneRenderOptions(scene, lens, RenderOptions::Mode::Guided);
    o.perGhostLayers = true;
    o.smoothNeighbours = 0;  // the tent for all: sums are then exact pixel by pixel
    Renderer r(lens, scene.lights, o);
    for (int p = 0; p < 3; ++p) r.runPass();
    const std::vector<std::string>& names = r.layerNames();
    std::vector<int> sources;
    for (size_t l = 0; l < names.size(); ++l)
        if (names[l].rfind("scatter_", 0) == 0) sources.push_back(static_cast<int>(l));
    ASSERT_EQ(sources.size(), 3u);  // housing, dust, bulk; no grease in this scene
    EXPECT_EQ(names[sources[0]], "scatter_housing");
    EXPECT_EQ(names[sources[1]], "scatter_dust");
    EXPECT_EQ(names[sources[2]], "scatter_bulk");
    const std::vector<float> total = r.layerXyz(kLayerScatter);
    std::vector<double> sum(total.size(), 0.0);
    for (int l : sources) {
        const std::vector<float> part = r.layerXyz(l);
        double y = 0.0;
        for (size_t i = 0; i < part.size(); ++i) sum[i] += part[i], y += i % 3 == 1 ? part[i] : 0.0;
        EXPECT_GT(y, 0.0) << names[l];
    }
    double largest = 0.0;
    for (float v : total) largest = std::max(largest, static_cast<double>(v));
    ASSERT_GT(largest, 0.0);
    for (size_t i = 0; i < total.size(); ++i) ASSERT_NEAR(sum[i], total[i], 1e-5 * largest) << i;
}

// The one rule with scattering: guided paths own only unscattered light, weighted by the
// probability of crossing dust and the bulk clear; the sum still equals plain Fresnel roulette.
TEST(Scattering, GuidedAgreesWithNaiveWithDustAndBulkScattering) {
    const Scene scene = doubletScene(R"({ "housing": { "diffuse": 0.05 },
        "dust": [ { "surface": 1, "coverage": 0.05, "albedo": 0.6 } ],
        "bulk": [ { "element": 4, "scattering_per_mm": 0.02, "absorption_per_mm": 0.01, "g": 0.6 } ] })");
    const LensSystem lens = buildSceneLens(scene);
    Renderer naive(lens, scene.lights, test::sceneRenderOptions(scene, lens, RenderOptions::Mode::Naive));
    Renderer guided(lens, scene.lights, test::sceneRenderOptions(scene, lens, RenderOptions::Mode::Guided));
    for (int p = 0; p < 120; ++p) naive.runPass();
    for (int p = 0; p < 32; ++p) guided.runPass();
    // Direct, ghost and scatter: the layers the clear-crossing weight and the ownership rule act
    // on. (`higher` comes from a few rare photons in this short guided run, too few for its
    // standard error to mean much; Render.GuidedAgreesWithNaivePerGhostAndPerLayer covers it.)
    test::expectGuidedAgreesWithNaive(guided, naive, {kLayerDirect, kLayerGhost, kLayerScatter});
    EXPECT_GT(naive.tallyPowerW(naive.scatterSourceTallies()[static_cast<int>(ScatterSource::Dust) - 1]), 0.0);
}

TEST(Scattering, SceneErrorsNameTheLine) {
    const Scene onStop = doubletScene(R"({ "dust": [ { "surface": 3, "coverage": 0.1 } ] })");
    const LensSystem lens = buildSceneLens(onStop);
    RenderOptions o;
    try {
        applySceneScattering(onStop, lens, o);
        FAIL() << "dust on the stop accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), "doublet.json");
        EXPECT_GT(e.line(), 0);
    }
    const Scene inAir = doubletScene(R"({ "bulk": [ { "element": 2, "scattering_per_mm": 0.1 } ] })");
    EXPECT_THROW(applySceneScattering(inAir, lens, o), InputError);
    const Scene missingGrid = doubletScene(R"({ "bulk": [ { "element": 1, "scattering_per_mm": 0.1, "grid": "nope.vdb" } ] })");
    EXPECT_THROW(applySceneScattering(missingGrid, lens, o), InputError);
    EXPECT_THROW(doubletScene(R"({ "dust": [ { "surface": 1, "coverage": 1.5 } ] })"), InputError);
    EXPECT_THROW(doubletScene(R"({ "housing": { "diffuse": 0.8, "glossy": 0.4 } })"), InputError);
    EXPECT_THROW(doubletScene(R"({ "smoke": 1 })"), InputError);
}

}  // namespace
}  // namespace flare
