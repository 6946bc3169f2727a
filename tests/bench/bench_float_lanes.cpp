// Float lanes against double lanes (issue 15 asks where single precision is safe): a path of the
// double Gauss (round iris, 550 nm, geometry only) traced with the operations of PacketTracer's
// sphere and plane steps (vertex-local cancellation-free quadratic, clear aperture, normal from
// the centre of curvature, Snell or mirror), in float lanes (twice as many per register), and
// compared ray by ray with PacketTracer's double landings of the same rays. Arguments: `ghost` 0
// the direct path, 1 the ghost reflecting at surfaces 5 and 2; `double` 1 times PacketTracer on
// the same rays instead (the ratio of the two rates is the float lanes' gain). Counters: rays/s,
// and against double the largest and RMS landing error (µm) and the share of rays whose fate
// differs (landed in one, stopped in the other). An experiment, not a tracer: the engine keeps
// double lanes (docs/BENCHMARKS.md, issue 15, third part, says why).
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <glm/geometric.hpp>

#include "flare/optics/LensFile.h"
#include "flare/optics/LensSystem.h"
#include "flare/optics/PacketTracer.h"
#include "flare/optics/PupilGrid.h"

#ifndef FLARE_BENCH_FLOAT_LANES_ONCE
#define FLARE_BENCH_FLOAT_LANES_ONCE
namespace flare::floatlanes {

// One surface of the path in float: a sphere or plane with its clear aperture, or the stop (a
// plane with a round opening).
struct Step {
    float vertexZMm = 0.0f, curvaturePerMm = 0.0f, radiusMm = 0.0f, centreZMm = 0.0f;
    float aperture2Mm2 = 0.0f, eta = 1.0f;
    bool plane = false, stop = false, reflect = false;
};

// Rays in float, one array per coordinate; `alive` 1 while going.
struct Rays {
    std::vector<float> ox, oy, oz, dx, dy, dz, alive;
    explicit Rays(size_t n) : ox(n), oy(n), oz(n), dx(n), dy(n), dz(n), alive(n) {}
};

}  // namespace flare::floatlanes
#endif

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "bench_float_lanes.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace flare::floatlanes {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Every step for rays [0, count) (a multiple of the float vector length), then the sensor plane:
// on return (ox, oy) is the landing of the rays still alive.
void TraceFloat(const Step* steps, int stepCount, float sensorZMm, Rays& r, size_t count) {
    const hn::ScalableTag<float> d;
    using V = hn::Vec<decltype(d)>;
    const V zero = hn::Zero(d), one = hn::Set(d, 1.0f), two = hn::Set(d, 2.0f);
    for (size_t i = 0; i < count; i += hn::Lanes(d)) {
        V ox = hn::LoadU(d, &r.ox[i]), oy = hn::LoadU(d, &r.oy[i]), oz = hn::LoadU(d, &r.oz[i]);
        V dx = hn::LoadU(d, &r.dx[i]), dy = hn::LoadU(d, &r.dy[i]), dz = hn::LoadU(d, &r.dz[i]);
        auto alive = hn::Eq(hn::LoadU(d, &r.alive[i]), one);
        for (int k = 0; k < stepCount && !hn::AllFalse(d, alive); ++k) {
            const Step& s = steps[k];
            const V oz0 = hn::Sub(oz, hn::Set(d, s.vertexZMm));
            V t;
            if (s.plane) {
                t = hn::Div(hn::Neg(oz0), dz);
                alive = hn::And(alive, hn::Gt(t, hn::Set(d, 1e-6f)));
            } else {
                const V c = hn::Set(d, s.curvaturePerMm);
                const V qa = hn::Mul(c, hn::Add(hn::Add(hn::Mul(dx, dx), hn::Mul(dy, dy)), hn::Mul(dz, dz)));
                const V qb = hn::Sub(hn::Mul(c, hn::Add(hn::Add(hn::Mul(ox, dx), hn::Mul(oy, dy)), hn::Mul(oz0, dz))), dz);
                const V qc = hn::Sub(hn::Mul(c, hn::Add(hn::Add(hn::Mul(ox, ox), hn::Mul(oy, oy)), hn::Mul(oz0, oz0))),
                                     hn::Mul(two, oz0));
                const V disc = hn::Sub(hn::Mul(qb, qb), hn::Mul(qa, qc));
                alive = hn::And(alive, hn::Ge(disc, zero));
                const V q = hn::Neg(hn::Add(qb, hn::CopySign(hn::Sqrt(hn::Max(disc, zero)), qb)));
                const V r0 = hn::Div(q, qa), r1 = hn::Div(qc, q);
                const V t0 = hn::Min(r0, r1), t1 = hn::Max(r0, r1);
                // The first root beyond tMin on the vertex branch (1 − c z > 0).
                const V tMin = hn::Set(d, 1e-6f);
                const auto ok0 = hn::And(hn::Gt(t0, tMin), hn::Gt(hn::Sub(one, hn::Mul(c, hn::Add(oz0, hn::Mul(t0, dz)))), zero));
                const auto ok1 = hn::And(hn::Gt(t1, tMin), hn::Gt(hn::Sub(one, hn::Mul(c, hn::Add(oz0, hn::Mul(t1, dz)))), zero));
                alive = hn::And(alive, hn::Or(ok0, ok1));
                t = hn::IfThenElse(ok0, t0, t1);
            }
            const V px = hn::Add(ox, hn::Mul(t, dx)), py = hn::Add(oy, hn::Mul(t, dy)), pz = hn::Add(oz, hn::Mul(t, dz));
            alive = hn::And(alive, hn::Le(hn::Add(hn::Mul(px, px), hn::Mul(py, py)), hn::Set(d, s.aperture2Mm2)));
            ox = hn::IfThenElse(alive, px, ox), oy = hn::IfThenElse(alive, py, oy), oz = hn::IfThenElse(alive, pz, oz);
            if (s.stop) continue;
            V nx = zero, ny = zero, nz = one;
            if (!s.plane) {
                const V radius = hn::Set(d, s.radiusMm);
                nx = hn::Div(hn::Neg(px), radius);
                ny = hn::Div(hn::Neg(py), radius);
                nz = hn::Div(hn::Sub(hn::Set(d, s.centreZMm), pz), radius);
            }
            if (s.reflect) {
                const V k2 = hn::Mul(two, hn::Add(hn::Add(hn::Mul(dx, nx), hn::Mul(dy, ny)), hn::Mul(dz, nz)));
                dx = hn::IfThenElse(alive, hn::Sub(dx, hn::Mul(k2, nx)), dx);
                dy = hn::IfThenElse(alive, hn::Sub(dy, hn::Mul(k2, ny)), dy);
                dz = hn::IfThenElse(alive, hn::Sub(dz, hn::Mul(k2, nz)), dz);
                continue;
            }
            V cosI = hn::Neg(hn::Add(hn::Add(hn::Mul(dx, nx), hn::Mul(dy, ny)), hn::Mul(dz, nz)));
            const auto flip = hn::Lt(cosI, zero);
            nx = hn::IfThenElse(flip, hn::Neg(nx), nx), ny = hn::IfThenElse(flip, hn::Neg(ny), ny);
            nz = hn::IfThenElse(flip, hn::Neg(nz), nz), cosI = hn::Abs(cosI);
            const V eta = hn::Set(d, s.eta);
            const V sin2T = hn::Mul(hn::Mul(eta, eta), hn::Max(hn::Sub(one, hn::Mul(cosI, cosI)), zero));
            alive = hn::And(alive, hn::Lt(sin2T, one));
            const V kk = hn::Sub(hn::Mul(eta, cosI), hn::Sqrt(hn::Max(hn::Sub(one, sin2T), zero)));
            V ex = hn::Add(hn::Mul(eta, dx), hn::Mul(kk, nx)), ey = hn::Add(hn::Mul(eta, dy), hn::Mul(kk, ny));
            V ez = hn::Add(hn::Mul(eta, dz), hn::Mul(kk, nz));
            const V inverse = hn::Div(one, hn::Sqrt(hn::Add(hn::Add(hn::Mul(ex, ex), hn::Mul(ey, ey)), hn::Mul(ez, ez))));
            dx = hn::IfThenElse(alive, hn::Mul(ex, inverse), dx);
            dy = hn::IfThenElse(alive, hn::Mul(ey, inverse), dy);
            dz = hn::IfThenElse(alive, hn::Mul(ez, inverse), dz);
        }
        const V t = hn::Div(hn::Sub(hn::Set(d, sensorZMm), oz), dz);
        alive = hn::And(alive, hn::Gt(dz, zero));
        hn::StoreU(hn::Add(ox, hn::Mul(t, dx)), d, &r.ox[i]);
        hn::StoreU(hn::Add(oy, hn::Mul(t, dy)), d, &r.oy[i]);
        hn::StoreU(hn::IfThenElseZero(alive, one), d, &r.alive[i]);
    }
}

size_t FloatLanes() { return hn::Lanes(hn::ScalableTag<float>()); }

}  // namespace HWY_NAMESPACE
}  // namespace flare::floatlanes
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace flare::floatlanes {
HWY_EXPORT(TraceFloat);
HWY_EXPORT(FloatLanes);

namespace {

using namespace flare;

void BM_FloatLanesAgainstDouble(benchmark::State& state) {
    // The double Gauss with a round iris (the lanes' stop), at 550 nm, the direct path.
    LensPrescription prescription = loadLensFile(std::string(FLARE_SOURCE_DIR) + "/lenses/double-gauss-50mm.lens");
    prescription.iris.blades = 0;
    const LensSystem lens = LensSystem::build(prescription);
    const SpectralIndices indices = lens.indicesAt(550.0);
    const PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(3.0, 4.0));
    // The path's surfaces in order: forward to the first reflection, back to the second, forward
    // to the sensor (state.range(0): 0 the direct path, 1 the ghost reflecting at surfaces 5 and 2).
    const std::vector<int> reflections = state.range(0) != 0 ? std::vector<int>{4, 1} : std::vector<int>{};
    std::vector<Step> steps;
    auto add = [&](int k, int direction, bool reflect) {
        const Surface& s = lens.surface(k);
        Step step;
        step.vertexZMm = static_cast<float>(s.vertexZMm);
        step.plane = s.radiusMm == 0.0;
        step.stop = s.isStop;
        step.reflect = reflect;
        step.curvaturePerMm = static_cast<float>(s.curvature());
        step.radiusMm = static_cast<float>(s.radiusMm);
        step.centreZMm = static_cast<float>(s.vertexZMm + s.radiusMm);
        const double aperture = s.isStop ? lens.iris().radiusMm() : s.semiApertureMm;
        step.aperture2Mm2 = static_cast<float>(aperture * aperture);
        step.eta = static_cast<float>(direction > 0 ? indices.n[k] / indices.n[k + 1] : indices.n[k + 1] / indices.n[k]);
        steps.push_back(step);
    };
    if (reflections.empty()) {
        for (int k = 0; k < lens.surfaceCount(); ++k) add(k, 1, false);
    } else {
        const int a = reflections[0], b = reflections[1];
        for (int k = 0; k < a; ++k) add(k, 1, false);
        add(a, 1, true);
        for (int k = a - 1; k > b; --k) add(k, -1, false);
        add(b, -1, true);
        for (int k = b + 1; k < lens.surfaceCount(); ++k) add(k, 1, false);
    }
    // Parallel rays filling the front aperture's projection (as BM_TraceParallelRays).
    // Timed on 4096 rays; the errors counted on 2^18 (a fate that differs once in a few thousand
    // rays would show).
    std::mt19937_64 rng(2);
    const double radius = lens.surface(0).semiApertureMm;
    std::uniform_real_distribution<double> u(-radius, radius);
    auto pupilPoints = [&](size_t n) {
        std::vector<glm::dvec2> points;
        while (points.size() < n) {
            const glm::dvec2 p(u(rng), u(rng));
            if (glm::dot(p, p) <= radius * radius) points.push_back(p);
        }
        return points;
    };
    auto floatRays = [&](const std::vector<glm::dvec2>& points) {
        Rays rays(points.size());
        for (size_t i = 0; i < points.size(); ++i) {
            const Ray ray = grid.ray(points[i].x, points[i].y);
            rays.ox[i] = static_cast<float>(ray.originMm.x), rays.oy[i] = static_cast<float>(ray.originMm.y);
            rays.oz[i] = static_cast<float>(ray.originMm.z);
            rays.dx[i] = static_cast<float>(ray.direction.x), rays.dy[i] = static_cast<float>(ray.direction.y);
            rays.dz[i] = static_cast<float>(ray.direction.z);
            rays.alive[i] = 1.0f;
        }
        return rays;
    };
    const PacketTracer packet(BundleTracer(lens, indices, reflections, false));
    const float sensorZMm = static_cast<float>(lens.sensorZMm());
    // The double lanes' rate on the same rays (state.range(1) = 1): the ratio is the float lanes' gain.
    const bool timeDouble = state.range(1) != 0;
    const size_t count = 4096;
    const std::vector<glm::dvec2> points = pupilPoints(count);
    const Rays start = floatRays(points);
    Rays rays = start;
    std::vector<BundleLanding> landings(count);
    for (auto _ : state) {
        if (timeDouble) {
            packet.trace(grid, points, landings);
            benchmark::DoNotOptimize(landings.data());
        } else {
            rays = start;
            HWY_DYNAMIC_DISPATCH(TraceFloat)(steps.data(), static_cast<int>(steps.size()), sensorZMm, rays, count);
            benchmark::DoNotOptimize(rays.ox.data());
        }
        benchmark::ClobberMemory();
    }

    const std::vector<glm::dvec2> checked = pupilPoints(size_t{1} << 18);
    std::vector<BundleLanding> reference(checked.size());
    packet.trace(grid, checked, reference);
    Rays traced = floatRays(checked);
    HWY_DYNAMIC_DISPATCH(TraceFloat)(steps.data(), static_cast<int>(steps.size()), sensorZMm, traced, checked.size());
    double largest = 0.0, sumSquares = 0.0;
    long both = 0, differ = 0;
    for (size_t i = 0; i < checked.size(); ++i) {
        const bool landed = traced.alive[i] == 1.0f, landedDouble = reference[i].ok();
        if (landed != landedDouble) {
            ++differ;
            continue;
        }
        if (!landed) continue;
        const double e = std::hypot(traced.ox[i] - reference[i].sensorMm.x, traced.oy[i] - reference[i].sensorMm.y) * 1e3;
        largest = std::max(largest, e);
        sumSquares += e * e;
        ++both;
    }
    state.counters["rays/s"] =
        benchmark::Counter(static_cast<double>(state.iterations()) * static_cast<double>(count), benchmark::Counter::kIsRate);
    state.counters["max_error_um"] = largest;
    state.counters["rms_error_um"] = both > 0 ? std::sqrt(sumSquares / static_cast<double>(both)) : 0.0;
    state.counters["fate_differs"] = static_cast<double>(differ);
    state.counters["checked"] = static_cast<double>(checked.size());
    state.counters["landed"] = static_cast<double>(both) / static_cast<double>(checked.size());
    state.SetLabel((timeDouble ? std::string("double lanes, ")
                               : std::to_string(HWY_DYNAMIC_DISPATCH(FloatLanes)()) + " float lanes, ") +
                   PacketTracer::targetName());
}
BENCHMARK(BM_FloatLanesAgainstDouble)->ArgNames({"ghost", "double"})->ArgsProduct({{0, 1}, {0, 1}});

}  // namespace
}  // namespace flare::floatlanes
#endif  // HWY_ONCE
