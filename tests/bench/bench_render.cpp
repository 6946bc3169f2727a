// Photon throughput of the final render on the default scene (the double Gauss at f/4, sun 13.5°
// off axis, 1536 × 1024): photons per second for the naive (unguided, non-sequential) and the
// guided mixture, on 1 and 2 threads. One iteration is one pass of 65 536 photons, splatting
// and merging included; the ghost analysis runs once, outside the timing.
#include <memory>

#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include "flare/Render.h"

namespace {

using namespace flare;

void renderPasses(benchmark::State& state, RenderOptions::Mode mode) {
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(state.range(0)));
    const Scene scene = defaultScene();
    const LensSystem lens = buildSceneLens(scene);
    RenderOptions options;
    options.mode = mode;
    options.film.widthPx = scene.sensor.widthPx;
    options.film.heightPx = scene.sensor.heightPx;
    options.film.widthMm = lens.sensor().widthMm;
    options.film.heightMm = lens.sensor().heightMm;
    Renderer renderer(lens, scene, options);
    for (auto _ : state) renderer.runPass();
    state.SetItemsProcessed(state.iterations() * options.photonsPerPass());
    state.counters["photons_per_s_per_thread"] = benchmark::Counter(
        static_cast<double>(state.iterations() * options.photonsPerPass()) / static_cast<double>(state.range(0)),
        benchmark::Counter::kIsRate);
}

void BM_RenderNaive(benchmark::State& state) { renderPasses(state, RenderOptions::Mode::Naive); }
void BM_RenderGuided(benchmark::State& state) { renderPasses(state, RenderOptions::Mode::Guided); }

BENCHMARK(BM_RenderNaive)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(BM_RenderGuided)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

}  // namespace
