// Micro-benchmarks of exact sequential tracing through the double Gauss: real rays per second and
// surface interactions per second, on one thread and on all threads (TBB); and parallel rays traced
// one at a time (tracePath), step-major (BundleTracer) and in SIMD packets (PacketTracer) on the
// same pupil points, so that one run gives their ratio.
#include <atomic>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <span>
#include <string>
#include <random>
#include <vector>

#include <benchmark/benchmark.h>
#include <glm/geometric.hpp>
#include <hwy/targets.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include "flare/optics/LensFile.h"
#include "flare/optics/LensSystem.h"
#include "flare/optics/PacketTracer.h"
#include "flare/optics/PupilGrid.h"
#include "flare/optics/RealRays.h"
#include "flare/optics/SequentialTracer.h"
#include "flare/optics/SpectralReflectance.h"

namespace {

using namespace flare;

const LensSystem& doubleGauss() {
    static const LensSystem lens =
        LensSystem::build(loadLensFile(std::string(FLARE_SOURCE_DIR) + "/lenses/double-gauss-50mm.lens"));
    return lens;
}

// Rays filling the front aperture within a ±10° cone: a mix of passing and vignetted rays, like
// the photons of a flare render.
std::vector<Ray> makeRays(const LensSystem& lens, size_t count) {
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const double z = objectSpaceStartZMm(lens);
    const double r = lens.surface(0).semiApertureMm;
    std::vector<Ray> rays;
    while (rays.size() < count) {
        const double x = r * u(rng), y = r * u(rng);
        if (x * x + y * y > r * r) continue;
        rays.push_back({{x, y, z}, glm::normalize(glm::dvec3(0.18 * u(rng), 0.18 * u(rng), 1.0))});
    }
    return rays;
}

// Argument 1: with Fresnel/thin-film weights (what a flare render needs); 0: geometry only.
void BM_TraceForwardSingleThread(benchmark::State& state) {
    const LensSystem& lens = doubleGauss();
    const SpectralIndices idx = lens.indicesAt(550.0);
    const std::vector<Ray> rays = makeRays(lens, 4096);
    TraceOptions options;
    options.fresnelWeights = state.range(0) != 0;
    std::int64_t interactions = 0, passed = 0;
    size_t i = 0;
    for (auto _ : state) {
        const TraceResult r = traceForward(lens, idx, rays[i++ & 4095], options);
        interactions += r.interactions;
        passed += r.ok();
        benchmark::DoNotOptimize(r);
    }
    state.SetItemsProcessed(state.iterations());
    state.counters["rays/s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
    state.counters["interactions/s"] = benchmark::Counter(static_cast<double>(interactions), benchmark::Counter::kIsRate);
    state.counters["pass_fraction"] = static_cast<double>(passed) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_TraceForwardSingleThread)->ArgName("fresnel")->Arg(1)->Arg(0);

// All hardware threads through TBB; wall-clock rate. The argument is the thread count.
void BM_TraceForwardThreads(benchmark::State& state) {
    const int threads = static_cast<int>(state.range(0));
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const LensSystem& lens = doubleGauss();
    const SpectralIndices idx = lens.indicesAt(550.0);
    const std::vector<Ray> rays = makeRays(lens, 1 << 20);
    std::atomic<std::int64_t> interactions{0};
    for (auto _ : state) {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), 4096), [&](const tbb::blocked_range<size_t>& range) {
            std::int64_t local = 0;
            for (size_t i = range.begin(); i != range.end(); ++i) local += traceForward(lens, idx, rays[i]).interactions;
            interactions += local;
        });
    }
    const double total = static_cast<double>(state.iterations()) * static_cast<double>(rays.size());
    state.counters["rays/s"] = benchmark::Counter(total, benchmark::Counter::kIsRate);
    state.counters["interactions/s"] = benchmark::Counter(static_cast<double>(interactions.load()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_TraceForwardThreads)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

// Parallel rays of a light 5° off axis, (3°, 4°), filling the front aperture's projection on the
// pupil plane: most land, some are vignetted or blocked by the iris, as in the preview's grids.
std::vector<glm::dvec2> makePupilPoints(const PupilGrid& grid, double radiusMm, size_t count) {
    std::mt19937_64 rng(2);
    std::uniform_real_distribution<double> u(-radiusMm, radiusMm);
    std::vector<glm::dvec2> points;
    while (points.size() < count) {
        const glm::dvec2 p(u(rng), u(rng));
        if (glm::dot(p, p) <= radiusMm * radiusMm) points.push_back(p);
    }
    return points;
}

// The three tracers of parallel rays. Arguments: `ghost` 0 the direct path, 1 the ghost reflecting
// at surfaces 5 and 2 (1-based); `fresnel` 0 geometry only, 1 with Fresnel/coating factors (for
// BundleTracer and PacketTracer from InterfaceTables, as the preview uses them; tracePath has only
// the exact thin-film response, several times dearer).
enum class ParallelTracer { TracePath, Bundle, Packet };

template <ParallelTracer kind>
void BM_TraceParallelRays(benchmark::State& state) {
    const LensSystem& lens = doubleGauss();
    const SpectralIndices idx = lens.indicesAt(550.0);
    const std::vector<int> reflections = state.range(0) != 0 ? std::vector<int>{4, 1} : std::vector<int>{};
    const bool fresnel = state.range(1) != 0;
    const PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(3.0, 4.0));
    const std::vector<glm::dvec2> points = makePupilPoints(grid, lens.surface(0).semiApertureMm, 4096);
    const InterfaceTables tables(lens, idx);
    const BundleTracer bundle(lens, idx, reflections, fresnel, fresnel ? &tables : nullptr);
    const PacketTracer packet(bundle);
    std::vector<BundleLanding> landings(points.size());
    SequentialPath path;
    path.reflections = reflections;
    TraceOptions options;
    options.fresnelWeights = fresnel;
    for (auto _ : state) {
        if constexpr (kind == ParallelTracer::TracePath) {
            for (size_t i = 0; i < points.size(); ++i) {
                const TraceResult r = tracePath(lens, idx, grid.ray(points[i].x, points[i].y), path, options);
                landings[i].status = r.status;
                landings[i].sensorMm = {r.ray.originMm.x, r.ray.originMm.y};
            }
        } else if constexpr (kind == ParallelTracer::Bundle) {
            bundle.trace(grid, points, landings);
        } else {
            packet.trace(grid, points, landings);
        }
        benchmark::DoNotOptimize(landings.data());
        benchmark::ClobberMemory();
    }
    std::int64_t passed = 0;
    for (const BundleLanding& l : landings) passed += l.ok();
    const double rays = static_cast<double>(state.iterations()) * static_cast<double>(points.size());
    state.SetItemsProcessed(static_cast<std::int64_t>(rays));
    state.counters["rays/s"] = benchmark::Counter(rays, benchmark::Counter::kIsRate);
    state.counters["pass_fraction"] = static_cast<double>(passed) / static_cast<double>(points.size());
    if constexpr (kind == ParallelTracer::Packet) state.SetLabel(PacketTracer::targetName());
}
BENCHMARK(BM_TraceParallelRays<ParallelTracer::TracePath>)->ArgNames({"ghost", "fresnel"})->ArgsProduct({{0, 1}, {0, 1}});
BENCHMARK(BM_TraceParallelRays<ParallelTracer::Bundle>)->ArgNames({"ghost", "fresnel"})->ArgsProduct({{0, 1}, {0, 1}});
BENCHMARK(BM_TraceParallelRays<ParallelTracer::Packet>)->ArgNames({"ghost", "fresnel"})->ArgsProduct({{0, 1}, {0, 1}});

// The packet tracer's direct path, geometry only, on each instruction set that this processor
// runs and Highway compiled (the argument indexes them, best first; the label names it).
void BM_PacketTracerPerTarget(benchmark::State& state) {
    const std::vector<std::int64_t> targets = hwy::SupportedAndGeneratedTargets();
    if (static_cast<size_t>(state.range(0)) >= targets.size()) {
        state.SkipWithError("no such instruction set here");
        return;
    }
    hwy::SetSupportedTargetsForTest(targets[state.range(0)]);
    const LensSystem& lens = doubleGauss();
    const SpectralIndices idx = lens.indicesAt(550.0);
    const PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(3.0, 4.0));
    const std::vector<glm::dvec2> points = makePupilPoints(grid, lens.surface(0).semiApertureMm, 4096);
    const PacketTracer packet(BundleTracer(lens, idx, {}, false));
    std::vector<BundleLanding> landings(points.size());
    for (auto _ : state) {
        packet.trace(grid, points, landings);
        benchmark::DoNotOptimize(landings.data());
        benchmark::ClobberMemory();
    }
    const double rays = static_cast<double>(state.iterations()) * static_cast<double>(points.size());
    state.counters["rays/s"] = benchmark::Counter(rays, benchmark::Counter::kIsRate);
    state.SetLabel(PacketTracer::targetName());
    hwy::SetSupportedTargetsForTest(0);
}
BENCHMARK(BM_PacketTracerPerTarget)->DenseRange(0, 4);

// PacketTracer on 1 and 2 threads (TBB, wall-clock rate): the direct path, geometry only, 2^18
// parallel rays in chunks of 4096 (each chunk one trace call, as the mesher makes them).
void BM_PacketTracerThreads(benchmark::State& state) {
    const int threads = static_cast<int>(state.range(0));
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const LensSystem& lens = doubleGauss();
    const SpectralIndices idx = lens.indicesAt(550.0);
    const PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(3.0, 4.0));
    const std::vector<glm::dvec2> points = makePupilPoints(grid, lens.surface(0).semiApertureMm, 1 << 18);
    const PacketTracer packet(BundleTracer(lens, idx, {}, false));
    std::vector<BundleLanding> landings(points.size());
    constexpr size_t kChunk = 4096;
    for (auto _ : state) {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, points.size() / kChunk, 1), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t c = r.begin(); c != r.end(); ++c)
                packet.trace(grid, std::span<const glm::dvec2>(points.data() + c * kChunk, kChunk),
                             std::span<BundleLanding>(landings.data() + c * kChunk, kChunk));
        });
        benchmark::ClobberMemory();
    }
    state.counters["rays/s"] =
        benchmark::Counter(static_cast<double>(state.iterations()) * static_cast<double>(points.size()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_PacketTracerThreads)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

// The photon tracer's reflectance (one interface event): the exact coating response against the
// SpectralReflectance table, on the double Gauss with its single MgF2 layer (coating 0) and with
// a four-layer broadband stack on every air-glass surface (coating 1). Random interfaces,
// directions, wavelengths and cosines, the same for both.
void BM_Reflectance(benchmark::State& state) {
    const bool tabled = state.range(0) != 0;
    std::ifstream file(std::string(FLARE_SOURCE_DIR) + "/lenses/double-gauss-50mm.lens");
    std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
    const std::string single = "default_coating mgf2";
    if (state.range(1) != 0)
        text.replace(text.find(single), single.size(),
                     "coating bbar stack 1.38:99.6 2.10:114.5 1.62:84.9 2.10:30.0\ndefault_coating bbar");
    const LensSystem lens = LensSystem::build(parseLensText(text, "double-gauss-50mm.lens"));
    const SpectralReflectance table(lens, SpectralReflectance::Tabulate::All);
    struct Event {
        int surface, direction;
        double wavelengthNm, cosine;
        SpectralIndices indices;
    };
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<Event> events;
    while (events.size() < 4096) {
        const int k = static_cast<int>(u(rng) * lens.surfaceCount());
        if (k >= lens.surfaceCount() || lens.surface(k).isStop) continue;
        const double wavelengthNm = 400.0 + 300.0 * u(rng);
        events.push_back({k, u(rng) < 0.5 ? -1 : 1, wavelengthNm, 0.5 + 0.5 * u(rng), lens.indicesAt(wavelengthNm)});
    }
    double sum = 0.0;
    for (auto _ : state) {
        for (const Event& e : events) {
            if (tabled) {
                sum += table.reflectance(e.surface, e.direction, e.wavelengthNm, e.indices, e.cosine);
            } else {
                const FresnelTerms r = interfaceResponse(lens, e.indices, e.surface, e.direction, e.cosine);
                sum += r.totalInternalReflection ? 1.0 : r.reflectance();
            }
        }
    }
    benchmark::DoNotOptimize(sum);
    state.counters["ns_per_event"] =
        benchmark::Counter(static_cast<double>(events.size()) * 1e-9, benchmark::Counter::kIsIterationInvariantRate |
                                                                         benchmark::Counter::kInvert);
}
BENCHMARK(BM_Reflectance)->ArgNames({"table", "stack"})->ArgsProduct({{0, 1}, {0, 1}});

}  // namespace


