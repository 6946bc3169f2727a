// Scaling micro-benchmarks: photons per second against the photon count (should be linear: a
// constant rate), against the number of surfaces (the five shipped lenses), and preview ghosts
// per second on 1 and 2 threads. Counters are Google Benchmark user counters (rates are per
// wall-clock second).
#include <array>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <glm/geometric.hpp>
#include <tbb/global_control.h>

#include "flare/ghosts/Preview.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/PupilGrid.h"
#include "flare/optics/RealRays.h"
#include "flare/optics/SequentialTracer.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"

namespace {

using namespace flare;

// Shipped lenses in order of surface count (the zoom at its wide position).
const std::array<const char*, 5> kLenses = {"double-gauss-50mm", "telephoto-180mm", "wide-angle-28mm", "fisheye-16mm",
                                            "zoom-24-70mm"};

Scene sceneFor(const std::string& lens, int widthPx = 384) {
    return parseSceneText(R"({ "lens": ")" + lens + R"(", "f_number": 4.0, "sensor": { "resolution": [)" +
                              std::to_string(widthPx) + "," + std::to_string(widthPx * 2 / 3) + R"(] },
  "lights": [ { "type": "directional", "name": "sun", "field_deg": [11, 8], "angular_diameter_deg": 0.53,
                "spectrum": { "blackbody_k": 5778 } } ] })",
                          "benchmark scene", "");
}

RenderOptions optionsFor(const Scene& scene, const LensSystem& lens, RenderOptions::Mode mode) {
    RenderOptions o;
    o.mode = mode;
    o.analysis.order = scene.render.ghostOrder;
    o.film.widthPx = scene.sensor.widthPx;
    o.film.heightPx = scene.sensor.heightPx;
    o.film.widthMm = lens.sensor().widthMm;
    o.film.heightMm = lens.sensor().heightMm;
    return o;
}

// Photons per second against the photon count: one iteration renders range(0) photons with a new
// renderer (its construction, the ghost analysis, is not timed). range(1): 0 naive, 1 guided.
void BM_RenderPhotonCount(benchmark::State& state) {
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
    const Scene scene = sceneFor("double-gauss-50mm");
    const LensSystem lens = buildSceneLens(scene);
    const auto mode = state.range(1) ? RenderOptions::Mode::Guided : RenderOptions::Mode::Naive;
    const std::int64_t photons = state.range(0);
    for (auto _ : state) {
        state.PauseTiming();
        RenderOptions o = optionsFor(scene, lens, mode);
        Renderer r(lens, scene.lights, o);
        state.ResumeTiming();
        while (r.statistics().photons < photons) r.runPass();
    }
    state.counters["photons"] = static_cast<double>(photons);
    state.counters["photons/s"] =
        benchmark::Counter(static_cast<double>(photons) * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderPhotonCount)
    ->ArgNames({"photons", "guided"})
    ->ArgsProduct({{1 << 16, 1 << 18, 1 << 20, 1 << 22}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(1.0);

// Naive photons per second on one thread against the number of surfaces (the shipped lenses).
void BM_RenderNaiveLens(benchmark::State& state) {
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 1);
    const Scene scene = sceneFor(kLenses[state.range(0)]);
    const LensSystem lens = buildSceneLens(scene);
    Renderer r(lens, scene.lights, optionsFor(scene, lens, RenderOptions::Mode::Naive));
    for (auto _ : state) r.runPass();
    state.SetLabel(kLenses[state.range(0)]);
    state.counters["surfaces"] = lens.surfaceCount();
    state.counters["photons/s"] = benchmark::Counter(
        static_cast<double>(state.iterations() * r.options().photonsPerPass()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderNaiveLens)->DenseRange(0, 4)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

// Sequential tracing (Fresnel + coating weights, one thread) against the number of surfaces:
// rays filling the front aperture within a ±10° cone.
void BM_TraceForwardLens(benchmark::State& state) {
    const LensSystem lens = buildSceneLens(sceneFor(kLenses[state.range(0)]));
    const SpectralIndices idx = lens.indicesAt(550.0);
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const double z = objectSpaceStartZMm(lens), rMm = lens.surface(0).semiApertureMm;
    std::vector<Ray> rays;
    while (rays.size() < 4096) {
        const double x = rMm * u(rng), y = rMm * u(rng);
        if (x * x + y * y <= rMm * rMm) rays.push_back({{x, y, z}, glm::normalize(glm::dvec3(0.18 * u(rng), 0.18 * u(rng), 1.0))});
    }
    TraceOptions options;
    options.fresnelWeights = true;
    std::int64_t interactions = 0;
    size_t i = 0;
    for (auto _ : state) {
        const TraceResult r = traceForward(lens, idx, rays[i++ & 4095], options);
        interactions += r.interactions;
        benchmark::DoNotOptimize(r);
    }
    state.SetLabel(kLenses[state.range(0)]);
    state.counters["surfaces"] = lens.surfaceCount();
    state.counters["rays/s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
    state.counters["interactions/s"] = benchmark::Counter(static_cast<double>(interactions), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_TraceForwardLens)->DenseRange(0, 4);

// Preview ghosts per second (analysis + rendering, 1024 px, 3 wavelengths) on range(1) threads.
void BM_PreviewThreads(benchmark::State& state) {
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(state.range(1)));
    const LensSystem lens = LensSystem::build(loadLens(kLenses[state.range(0)]));
    PreviewLight light;
    light.direction = directionFromFieldDeg(11.0, 8.0);
    light.spectrum = spectralQuadrature(Spectrum::blackbody(5778.0), 3);
    PreviewOptions options;
    options.widthPx = 1024;
    options.heightPx = static_cast<int>(1024 * lens.sensor().heightMm / lens.sensor().widthMm + 0.5);
    double ghosts = 0;
    for (auto _ : state) {
        const GhostReport report = analyseGhosts(lens, light.direction, GhostAnalysisOptions{});
        const PreviewImage image = renderPreview(lens, light, report, options);
        ghosts += static_cast<double>(image.tracedRays.size());
        benchmark::DoNotOptimize(image.ghosts.xyz.data());
    }
    state.SetLabel(kLenses[state.range(0)]);
    state.counters["ghosts"] = ghosts / static_cast<double>(state.iterations());
    state.counters["ghosts/s"] = benchmark::Counter(ghosts, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_PreviewThreads)
    ->ArgNames({"lens", "threads"})
    ->Args({0, 1})
    ->Args({0, 2})
    ->Args({3, 1})
    ->Args({3, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(1.0);

}  // namespace
