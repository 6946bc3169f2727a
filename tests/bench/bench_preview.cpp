// Preview timing: enumeration + sparse analysis + rendering of every two-reflection ghost at 1024
// pixels across and 3 wavelengths, for the double Gauss (55 paths) and the 24–70 zoom (378 paths
// with the sensor, 351 without).
#include <benchmark/benchmark.h>

#include "flare/ghosts/Preview.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/PupilGrid.h"

namespace {

using namespace flare;

void previewOnce(benchmark::State& state, const char* lensName, double fieldX, double fieldY) {
    const LensSystem lens = LensSystem::build(loadLens(lensName));
    const glm::dvec3 direction = directionFromFieldDeg(fieldX, fieldY);
    PreviewLight light;
    light.direction = direction;
    light.spectrum = spectralQuadrature(Spectrum::blackbody(5778.0), 3);
    PreviewOptions options;
    options.widthPx = 1024;
    options.heightPx = static_cast<int>(1024 * lens.sensor().heightMm / lens.sensor().widthMm + 0.5);
    long rays = 0, ghosts = 0;
    for (auto _ : state) {
        const GhostReport report = analyseGhosts(lens, direction, GhostAnalysisOptions{});
        const PreviewImage image = renderPreview(lens, light, report, options);
        ghosts = static_cast<long>(image.tracedRays.size());
        rays = 0;
        for (long r : image.tracedRays) rays += r;
        benchmark::DoNotOptimize(image.ghosts.xyz.data());
    }
    state.counters["ghosts_rendered"] = static_cast<double>(ghosts);
    state.counters["preview_rays"] = static_cast<double>(rays);
}

void BM_PreviewDoubleGauss(benchmark::State& state) { previewOnce(state, "double-gauss-50mm", 11.0, 8.0); }
void BM_PreviewZoom2470(benchmark::State& state) { previewOnce(state, "zoom-24-70mm", 11.0, 8.0); }

BENCHMARK(BM_PreviewDoubleGauss)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);
BENCHMARK(BM_PreviewZoom2470)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

}  // namespace
BENCHMARK_MAIN();
