// Photon throughput of the final render on the default scene (the double Gauss at f/4, sun 13.5°
// off axis, 1536 × 1024): photons per second for the naive (unguided, non-sequential) and the
// guided mixture, on 1 and 2 threads. One iteration is one pass of 65 536 photons, splatting
// and merging included; the ghost analysis runs once, outside the timing.
#include <memory>

#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include "flare/photons/VolumeGrid.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"

namespace {

using namespace flare;

// Bulk scattering in every glass element: none (0), homogeneous (1), or the haze grid (2).
void addBulk(const LensSystem& lens, int kind, RenderOptions& options) {
    if (kind == 0) return;
    auto haze = kind == 2 ? std::make_shared<VolumeGrid>(VolumeGrid::load(FLARE_SOURCE_DIR "/volumes/haze.vdb")) : nullptr;
    for (int cell = 1; cell < lens.surfaceCount(); ++cell) {
        if (lens.mediumBefore(cell).isAir()) continue;
        BulkMedium medium;
        medium.cell = cell;
        medium.scatteringPerMm = 0.01;
        medium.g = 0.7;
        medium.grid = haze;
        options.media.push_back(medium);
    }
}

void renderPasses(benchmark::State& state, RenderOptions::Mode mode, int bulk = 0) {
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(state.range(0)));
    const Scene scene = defaultScene();
    const LensSystem lens = buildSceneLens(scene);
    RenderOptions options;
    options.mode = mode;
    options.film.widthPx = scene.sensor.widthPx;
    options.film.heightPx = scene.sensor.heightPx;
    options.film.widthMm = lens.sensor().widthMm;
    options.film.heightMm = lens.sensor().heightMm;
    addBulk(lens, bulk, options);
    Renderer renderer(lens, scene.lights, options);
    for (auto _ : state) renderer.runPass();
    const RenderStatistics& s = renderer.statistics();
    if (s.realCollisions + s.nullCollisions > 0)
        state.counters["null_collision_ratio"] =
            static_cast<double>(s.nullCollisions) / static_cast<double>(s.realCollisions + s.nullCollisions);
    state.SetItemsProcessed(state.iterations() * options.photonsPerPass());
    state.counters["photons_per_s_per_thread"] = benchmark::Counter(
        static_cast<double>(state.iterations() * options.photonsPerPass()) / static_cast<double>(state.range(0)),
        benchmark::Counter::kIsRate);
}

void BM_RenderNaive(benchmark::State& state) { renderPasses(state, RenderOptions::Mode::Naive); }
void BM_RenderGuided(benchmark::State& state) { renderPasses(state, RenderOptions::Mode::Guided); }
void BM_RenderNaiveBulkHomogeneous(benchmark::State& state) { renderPasses(state, RenderOptions::Mode::Naive, 1); }
void BM_RenderNaiveBulkHazeGrid(benchmark::State& state) { renderPasses(state, RenderOptions::Mode::Naive, 2); }

BENCHMARK(BM_RenderNaive)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(BM_RenderGuided)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
// Cost of bulk scattering in every element (6 elements of the double Gauss, σs = 0.01/mm).
BENCHMARK(BM_RenderNaiveBulkHomogeneous)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(BM_RenderNaiveBulkHazeGrid)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

}  // namespace
