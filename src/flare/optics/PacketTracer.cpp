#include "flare/optics/PacketTracer.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <utility>

#include "flare/optics/Fresnel.h"

// The state of a batch of rays, one array per coordinate (structure of arrays), so that a vector
// register loads consecutive rays' x, then their y, and so on. Defined once: foreach_target.h
// below compiles the rest of this file again for every instruction set.
#ifndef FLARE_OPTICS_PACKET_TRACER_LANES
#define FLARE_OPTICS_PACKET_TRACER_LANES
namespace flare::detail {

// Rays per batch: every array of the batch stays in L1 (11 × 1 KiB), and the kernel's loop over
// a step has 16 to 128 independent iterations, enough to overlap the divisions and square roots.
inline constexpr int kPacketBatch = 128;
// The widest vector holds 8 doubles (AVX-512): batches are padded to a multiple of it.
inline constexpr int kPacketMaxLanes = 8;

struct PacketLanes {
    alignas(64) double ox[kPacketBatch], oy[kPacketBatch], oz[kPacketBatch];
    alignas(64) double dx[kPacketBatch], dy[kPacketBatch], dz[kPacketBatch];
    alignas(64) double throughput[kPacketBatch];
    // 0 while the ray is going; else 1 + status + 8 × (the step where it ended).
    alignas(64) double fate[kPacketBatch];
    // Set by a vector step for rays it left unchanged for the scalar step (1), else 0.
    alignas(64) double deferred[kPacketBatch];
    // The incidence cosine at a weighted step, and 1 where its Fresnel/coating factor is left to
    // the scalar code (no tables, or a cosine in the tables' exact zone).
    alignas(64) double cosine[kPacketBatch];
    alignas(64) double scalarWeight[kPacketBatch];
    // The step's constraint as StepOutcome::margin (when the step is asked for margins).
    alignas(64) double margin[kPacketBatch];
    // n1 / n2 of each lane's own wavelength at a refraction (rays at wavelengths of their own).
    alignas(64) double eta[kPacketBatch];
};

// Which margins a step writes: none (trace), those BundleTracer::advance gives without margins
// (a clear aperture's, −1 through the iris), or all of them (the iris's, total internal
// reflection's too).
enum class PacketMargins : std::uint8_t { None, Cheap, All };

// What a vector step left to the scalar code (flags), and how many rays it left going.
inline constexpr int kDeferredRays = 1, kScalarWeights = 2;
struct PacketStepResult {
    int left = 0;
    int going = 0;  // not counting the deferred rays
};

inline double fateCode(int step, TraceStatus status) { return 1.0 + static_cast<double>(status) + 8.0 * step; }
// The status part of a fate that no TraceStatus uses: a ray at a wavelength of its own that a
// refracting step left to the scalar code, to be traced again by tracePath.
inline constexpr int kRetraceStatus = 7;
static_assert(static_cast<int>(TraceStatus::WrongExit) < kRetraceStatus);
inline double retraceCode(int step) { return 1.0 + kRetraceStatus + 8.0 * step; }

}  // namespace flare::detail
#endif

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "flare/optics/PacketTracer.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "flare/optics/ConicLanes-inl.h"

HWY_BEFORE_NAMESPACE();
namespace flare {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// glm::normalize: v · (1 / √(v·v)), the dot product summed left to right.
template <class V>
HWY_INLINE void Normalize(V& x, V& y, V& z) {
    const hn::DFromV<V> d;
    const V inverse = hn::Div(hn::Set(d, 1.0), hn::Sqrt(hn::Add(hn::Add(hn::Mul(x, x), hn::Mul(y, y)), hn::Mul(z, z))));
    x = hn::Mul(x, inverse);
    y = hn::Mul(y, inverse);
    z = hn::Mul(z, inverse);
}

// InterfaceTables::lookup for the lanes of `tabled` (the others give 0), in its order of operations.
template <class D, class V = hn::Vec<D>>
HWY_INLINE V LookupTable(D d, const detail::PacketStep& s, hn::Mask<D> tabled, V c) {
    const hn::RebindToSigned<D> di;
    const V x = hn::Mul(c, hn::Set(d, s.tableIntervals));
    // Lanes outside the table (NaN, going nowhere) read entry 0.
    const V i = hn::IfThenElseZero(tabled, hn::Min(hn::Floor(x), hn::Set(d, s.tableIntervals - 1.0)));
    const auto index = hn::ConvertTo(di, i);
    const V u = hn::Sub(x, i), h = hn::Set(d, 1.0 / s.tableIntervals);
    const V u2 = hn::Mul(u, u), u3 = hn::Mul(u2, u);
    const V two = hn::Set(d, 2.0), three = hn::Set(d, 3.0);
    const V a = hn::Mul(hn::Add(hn::Sub(hn::Mul(two, u3), hn::Mul(three, u2)), hn::Set(d, 1.0)),
                        hn::GatherIndex(d, s.tableValue, index));
    const V b = hn::Mul(hn::Mul(hn::Add(hn::Sub(u3, hn::Mul(two, u2)), u), h), hn::GatherIndex(d, s.tableSlope, index));
    const V e = hn::Mul(hn::Add(hn::Mul(hn::Set(d, -2.0), u3), hn::Mul(three, u2)), hn::GatherIndex(d, s.tableValue + 1, index));
    const V f = hn::Mul(hn::Mul(hn::Sub(u3, u2), h), hn::GatherIndex(d, s.tableSlope + 1, index));
    return hn::Add(hn::Add(hn::Add(a, b), e), f);
}

// Iris::margin of a polygonal iris at (x, y), r2 = x² + y², in its order of operations: the
// sector whose edge's mid-normal has the largest projection (the first of equals), then the
// opening's radius in the point's direction.
template <class V>
HWY_INLINE V PolygonMargin(const detail::PacketStep& s, V x, V y, V r2) {
    const hn::DFromV<V> d;
    const V zero = hn::Zero(d), one = hn::Set(d, 1.0);
    V projection = hn::Set(d, -1e300);
    V nx = hn::Set(d, s.edgeNormalX[0]), ny = hn::Set(d, s.edgeNormalY[0]);
    for (int k = 0; k < s.blades; ++k) {
        const V kx = hn::Set(d, s.edgeNormalX[k]), ky = hn::Set(d, s.edgeNormalY[k]);
        const V p = hn::Add(hn::Mul(x, kx), hn::Mul(y, ky));
        const auto larger = hn::Gt(p, projection);
        projection = hn::IfThenElse(larger, p, projection);
        nx = hn::IfThenElse(larger, kx, nx);
        ny = hn::IfThenElse(larger, ky, ny);
    }
    const V r = hn::Sqrt(r2);
    const V c = hn::Div(projection, r);
    const V sine = hn::Div(hn::Sub(hn::Mul(nx, y), hn::Mul(ny, x)), r);
    const V rho = s.arcRadiusMm == 0.0
                      ? hn::Div(hn::Set(d, s.apothemMm), c)
                      : hn::Add(hn::Mul(hn::Set(d, s.arcCentreMm), c),
                                hn::Sqrt(hn::Sub(hn::Set(d, s.arcRadiusMm * s.arcRadiusMm),
                                                 hn::Mul(hn::Mul(hn::Set(d, s.arcCentreMm * s.arcCentreMm), sine), sine))));
    return hn::IfThenElse(hn::Eq(r2, zero), hn::Set(d, -1.0), hn::Sub(hn::Div(r2, hn::Mul(rho, rho)), one));
}

// intersect()'s Newton iteration on an asphere, F(t) = z(t) − sag(r²(t)), for the lanes of
// `alive`, in its order of operations: from the conic hit where there is one (else the vertex
// plane), at most kMaxNewtonIterations steps, each lane stopping where intersect() returns.
// Lanes that diverge or converge behind the origin are failed (NewtonDiverged, Missed); returns
// the hits' t (vertex-local origin: x and y unshifted, z − vertex).
template <class V, class M, class Fail>
HWY_INLINE V NewtonAsphere(const detail::PacketStep& s, M alive, M conicHit, V ox, V oy, V oz0, V dx, V dy, V dz, V t,
                           Fail& fail) {
    const hn::DFromV<V> d;
    const V c = hn::Set(d, s.curvaturePerMm), kc2 = hn::Set(d, s.conicFactor * s.curvaturePerMm * s.curvaturePerMm);
    M failed;
    t = AsphereNewton(d, alive, conicHit, t, ox, oy, oz0, dx, dy, dz, c, kc2,
                      [&](int m) { return std::pair{hn::Set(d, s.slopeCoefficient[m]), hn::Set(d, s.asphere[m])}; }, failed);
    fail(failed, TraceStatus::NewtonDiverged);
    fail(hn::Le(t, hn::Set(d, 1e-9)), TraceStatus::Missed);  // (intersect()'s tMin)
    return t;
}

// One step for `count` rays (a multiple of the vector length): the operations of
// BundleTracer::applyStep in the same order, with a ray's failure recorded in its fate. Rays
// whose step needs the scalar code are left unchanged and marked deferred, factors left to the
// scalar code are marked in scalarWeight; returns which of the two happened (kDeferredRays,
// kScalarWeights) and how many rays it left going.
//
// A refraction runs as two loops over the batch, the intersection and then the new direction:
// each iteration's chain of divisions and square roots is then short enough for the processor
// to overlap several iterations (one loop doing both was bound by their latency).
//
// With margins, every ray going into the step gets its StepOutcome::margin in b.margin, the same
// bits as BundleTracer::applyStep's (deferred rays excepted: the scalar step gives theirs).
//
// With `ownIndices` (rays at wavelengths of their own), a refraction takes each lane's n1 / n2
// from b.eta, and every factor of a laneWeighted step is left to the scalar code (tables hold
// one wavelength).
detail::PacketStepResult AdvancePacket(const detail::PacketStep& s, int step, detail::PacketLanes& b, size_t count,
                                       detail::PacketMargins margins, bool ownIndices) {
    using Kind = detail::PacketStep::Kind;
    const hn::ScalableTag<double> d;
    using V = hn::Vec<decltype(d)>;
    using M = hn::Mask<decltype(d)>;
    const size_t lanes = hn::Lanes(d);
    const V zero = hn::Zero(d), one = hn::Set(d, 1.0), two = hn::Set(d, 2.0);
    const V undefined = hn::Set(d, std::numeric_limits<double>::quiet_NaN());
    const bool anyMargins = margins != detail::PacketMargins::None;
    const double base = detail::fateCode(step, TraceStatus::Ok);
    int left = 0;
    size_t going = 0;

    // Pass 1: where each ray meets the surface (the sensor: all of that step), and the clipping.
    for (size_t i = 0; i < count; i += lanes) {
        V fate = hn::Load(d, b.fate + i);
        M alive = hn::Eq(fate, zero);
        M deferred = hn::FirstN(d, 0);
        // Ends the rays of `failed` that are still going with `status`.
        auto fail = [&](M failed, TraceStatus status) {
            failed = hn::And(failed, alive);
            fate = hn::IfThenElse(failed, hn::Set(d, base + static_cast<double>(status)), fate);
            alive = hn::AndNot(failed, alive);
        };
        auto defer = [&](M later) {
            later = hn::And(later, alive);
            deferred = hn::Or(deferred, later);
            alive = hn::AndNot(later, alive);
        };
        if (hn::AllFalse(d, alive)) {
            hn::Store(zero, d, b.deferred + i);
            continue;
        }
        const V ox = hn::Load(d, b.ox + i), oy = hn::Load(d, b.oy + i), oz = hn::Load(d, b.oz + i);
        const V dx = hn::Load(d, b.dx + i), dy = hn::Load(d, b.dy + i), dz = hn::Load(d, b.dz + i);
        V px = ox, py = oy, pz = oz;
        V margin = undefined;  // a ray that misses the surface has none

        if (s.kind == Kind::Sensor) {
            fail(hn::Le(dz, zero), TraceStatus::Missed);
            const V t = hn::Div(hn::Sub(hn::Set(d, s.sensorZMm), oz), dz);
            px = hn::Add(ox, hn::Mul(t, dx));
            py = hn::Add(oy, hn::Mul(t, dy));
            pz = hn::Add(oz, hn::Mul(t, dz));
            if (s.wrongExit) fail(alive, TraceStatus::WrongExit);
            if (s.reflect) {
                fail(hn::Or(hn::Gt(hn::Abs(px), hn::Set(d, s.halfWidthMm)), hn::Gt(hn::Abs(py), hn::Set(d, s.halfHeightMm))),
                     TraceStatus::Vignetted);
                // reflect(direction, (0, 0, 1)), with its multiplications by the normal's zeros.
                const V k = hn::Mul(two, hn::Add(hn::Add(hn::Mul(dx, zero), hn::Mul(dy, zero)), hn::Mul(dz, one)));
                hn::Store(hn::IfThenElse(alive, hn::Sub(dx, hn::Mul(k, zero)), dx), d, b.dx + i);
                hn::Store(hn::IfThenElse(alive, hn::Sub(dy, hn::Mul(k, zero)), dy), d, b.dy + i);
                hn::Store(hn::IfThenElse(alive, hn::Sub(dz, hn::Mul(k, one)), dz), d, b.dz + i);
                if (s.sensorWeighted) {
                    const V w = hn::Load(d, b.throughput + i);
                    hn::Store(hn::IfThenElse(alive, hn::Mul(w, hn::Set(d, s.sensorReflectance)), w), d, b.throughput + i);
                }
            }
        } else {
            // intersectConic in vertex-local coordinates (x and y are unchanged by the shift).
            const V c = hn::Set(d, s.curvaturePerMm), k1 = hn::Set(d, s.conicFactor);
            const V oz0 = hn::Sub(oz, hn::Set(d, s.vertexZMm));
            const auto conic = ConicQuadratic(d, c, k1, ox, oy, oz0, dx, dy, dz);
            defer(hn::Gt(hn::Abs(hn::Mul(c, conic.qc)), hn::Set(d, kConicFarOrigin * kConicFarOrigin)));
            const V t0 = conic.t0, t1 = conic.t1;
            const M roots = conic.roots;
            // The first root beyond tMin on the vertex branch (1 − c k z > 0).
            const V tMin = hn::Set(d, 1e-9), ck = hn::Set(d, s.curvaturePerMm * s.conicFactor);
            const M ok0 = hn::And(hn::Not(hn::Le(t0, tMin)), hn::Gt(hn::Sub(one, hn::Mul(ck, hn::Add(oz0, hn::Mul(t0, dz)))), zero));
            const M ok1 = hn::And(hn::Not(hn::Le(t1, tMin)), hn::Gt(hn::Sub(one, hn::Mul(ck, hn::Add(oz0, hn::Mul(t1, dz)))), zero));
            const M conicHit = hn::And(roots, hn::Or(ok0, ok1));
            V t = hn::IfThenElse(ok0, t0, t1);
            if (s.polynomial) {
                t = NewtonAsphere(s, alive, conicHit, ox, oy, oz0, dx, dy, dz, t, fail);
            } else {
                fail(hn::Not(conicHit), TraceStatus::Missed);
            }
            px = hn::Add(ox, hn::Mul(t, dx));
            py = hn::Add(oy, hn::Mul(t, dy));
            pz = hn::Add(oz, hn::Mul(t, dz));
            const V r2 = hn::Add(hn::Mul(px, px), hn::Mul(py, py));
            if (s.kind == Kind::Stop) {
                if (s.roundIris) {
                    // Iris::margin of a round iris; −1 without margins (undefined where blocked).
                    const M blocked = hn::Not(hn::Le(r2, hn::Set(d, s.irisInner2Mm2)));
                    if (margins == detail::PacketMargins::All)
                        margin = hn::IfThenElse(alive, hn::Sub(hn::Div(r2, hn::Set(d, s.irisInner2Mm2)), one), margin);
                    else if (margins == detail::PacketMargins::Cheap)
                        margin = hn::IfThenElse(hn::AndNot(blocked, alive), hn::Set(d, -1.0), margin);
                    fail(blocked, TraceStatus::BlockedByIris);
                } else {
                    if (margins == detail::PacketMargins::All) margin = hn::IfThenElse(alive, PolygonMargin(s, px, py, r2), margin);
                    fail(hn::Gt(r2, hn::Set(d, s.irisOuter2Mm2)), TraceStatus::BlockedByIris);
                    defer(hn::Not(hn::Le(r2, hn::Set(d, s.irisInner2Mm2))));  // near the blades: Iris::contains
                    if (margins == detail::PacketMargins::Cheap) margin = hn::IfThenElse(alive, hn::Set(d, -1.0), margin);
                }
            } else {
                if (anyMargins) margin = hn::IfThenElse(alive, hn::Sub(hn::Mul(r2, hn::Set(d, s.inverseAperture2PerMm2)), one), margin);
                fail(hn::Gt(r2, hn::Set(d, s.aperture2Mm2)), TraceStatus::Vignetted);
            }
        }
        if (anyMargins) hn::Store(margin, d, b.margin + i);
        hn::Store(hn::IfThenElse(alive, px, ox), d, b.ox + i);
        hn::Store(hn::IfThenElse(alive, py, oy), d, b.oy + i);
        hn::Store(hn::IfThenElse(alive, pz, oz), d, b.oz + i);
        hn::Store(fate, d, b.fate + i);
        hn::Store(hn::IfThenElseZero(deferred, one), d, b.deferred + i);
        if (!hn::AllFalse(d, deferred)) left |= detail::kDeferredRays;
        if (s.kind != Kind::Conic) going += hn::CountTrue(d, alive);
    }
    if (s.kind != Kind::Conic) return {left, static_cast<int>(going)};
    const bool weighted = ownIndices ? s.laneWeighted : s.weighted;

    // Pass 2: the normal at the hit, the factor and the reflected or refracted direction.
    for (size_t i = 0; i < count; i += lanes) {
        V fate = hn::Load(d, b.fate + i);
        M alive = hn::AndNot(hn::Eq(hn::Load(d, b.deferred + i), one), hn::Eq(fate, zero));
        if (hn::AllFalse(d, alive)) {
            hn::Store(zero, d, b.scalarWeight + i);
            continue;
        }
        const V px = hn::Load(d, b.ox + i), py = hn::Load(d, b.oy + i), pz = hn::Load(d, b.oz + i);
        const V dx0 = hn::Load(d, b.dx + i), dy0 = hn::Load(d, b.dy + i), dz0 = hn::Load(d, b.dz + i);
        V dx = dx0, dy = dy0, dz = dz0;
        V nx = zero, ny = zero, nz = one;
        if (s.normal == detail::PacketStep::Normal::Sphere) {
            const V radius = hn::Set(d, s.radiusMm);
            nx = hn::Div(hn::Sub(zero, px), radius);
            ny = hn::Div(hn::Sub(zero, py), radius);
            nz = hn::Div(hn::Sub(hn::Set(d, s.centreZMm), pz), radius);
        } else if (s.normal == detail::PacketStep::Normal::Conic) {
            // Surface::sagSlope (a conic's polynomial terms, all zero, add +0) and normalAt.
            const V r2 = hn::Add(hn::Mul(px, px), hn::Mul(py, py));
            const V q2 = hn::Sub(one, hn::Mul(hn::Set(d, s.conicFactor * s.curvaturePerMm * s.curvaturePerMm), r2));
            V slope = hn::IfThenElse(hn::Gt(q2, zero), hn::Div(hn::Set(d, 0.5 * s.curvaturePerMm), hn::Sqrt(q2)), zero);
            if (s.polynomial) {
                V power = r2;
                for (int m = 0; m < kAsphereTerms; ++m) {
                    slope = hn::Add(slope, hn::Mul(hn::Set(d, s.slopeCoefficient[m]), power));
                    power = hn::Mul(power, r2);
                }
            } else {
                slope = hn::Add(slope, zero);
            }
            slope = hn::Mul(hn::Set(d, -2.0), slope);
            nx = hn::Mul(slope, px);
            ny = hn::Mul(slope, py);
            Normalize(nx, ny, nz);
        }
        const V dot = hn::Add(hn::Add(hn::Mul(dx, nx), hn::Mul(dy, ny)), hn::Mul(dz, nz));
        V factor = one;  // the Fresnel/coating factor from the tables
        M tabled = alive;  // the lanes that have it
        if (weighted) {
            const V cosine = hn::Abs(dot);
            hn::Store(cosine, d, b.cosine + i);
            if (s.tableValue && !ownIndices) {
                // std::clamp(cosine, 0, 1); NaN and the exact zone go to the scalar code.
                const V c = hn::IfThenElse(hn::Lt(cosine, zero), zero, hn::IfThenElse(hn::Lt(one, cosine), one, cosine));
                const M exact = hn::And(hn::Ge(c, hn::Set(d, s.tableExactFrom)), hn::Le(c, hn::Set(d, s.tableExactTo)));
                tabled = hn::AndNot(hn::Or(exact, hn::IsNaN(c)), alive);
                factor = LookupTable(d, s, tabled, c);
            } else {
                tabled = hn::FirstN(d, 0);
            }
        }
        if (s.reflect) {
            const V k = hn::Mul(two, dot);
            dx = hn::Sub(dx, hn::Mul(k, nx));
            dy = hn::Sub(dy, hn::Mul(k, ny));
            dz = hn::Sub(dz, hn::Mul(k, nz));
        } else {
            // refract(): the normal turned against the ray, Snell, total internal reflection.
            V cosI = hn::Neg(dot);
            const M flip = hn::Lt(cosI, zero);
            nx = hn::IfThenElse(flip, hn::Neg(nx), nx);
            ny = hn::IfThenElse(flip, hn::Neg(ny), ny);
            nz = hn::IfThenElse(flip, hn::Neg(nz), nz);
            cosI = hn::IfThenElse(flip, hn::Neg(cosI), cosI);
            // (refract()'s eta * eta * max(…): the lane's product is the scalar one's bits.)
            const V eta = ownIndices ? hn::Load(d, b.eta + i) : hn::Set(d, s.eta);
            const V eta2 = ownIndices ? hn::Mul(eta, eta) : hn::Set(d, s.eta * s.eta);
            const V sin2I = hn::Sub(one, hn::Mul(cosI, cosI));
            const V sin2T = hn::Mul(eta2, hn::IfThenElse(hn::Lt(zero, sin2I), sin2I, zero));
            const M tir = hn::And(hn::Ge(sin2T, one), alive);
            if (anyMargins) {
                // The test refract() makes, as a margin: sin²θt − 1 (std::max's operand order).
                V m = hn::Load(d, b.margin + i);
                if (margins == detail::PacketMargins::All) {
                    const V tirMargin = hn::Sub(sin2T, one);
                    m = hn::IfThenElse(alive, hn::IfThenElse(hn::Lt(m, tirMargin), tirMargin, m), m);
                    m = hn::IfThenElse(tir, hn::IfThenElse(hn::Lt(m, zero), zero, m), m);
                } else {
                    m = hn::IfThenElse(tir, undefined, m);
                }
                hn::Store(m, d, b.margin + i);
            }
            fate = hn::IfThenElse(tir, hn::Set(d, base + static_cast<double>(TraceStatus::TotalInternalReflection)), fate);
            alive = hn::AndNot(tir, alive);
            const V k = hn::Sub(hn::Mul(eta, cosI), hn::Sqrt(hn::Sub(one, sin2T)));
            dx = hn::Add(hn::Mul(eta, dx), hn::Mul(k, nx));
            dy = hn::Add(hn::Mul(eta, dy), hn::Mul(k, ny));
            dz = hn::Add(hn::Mul(eta, dz), hn::Mul(k, nz));
        }
        Normalize(dx, dy, dz);
        hn::Store(hn::IfThenElse(alive, dx, dx0), d, b.dx + i);
        hn::Store(hn::IfThenElse(alive, dy, dy0), d, b.dy + i);
        hn::Store(hn::IfThenElse(alive, dz, dz0), d, b.dz + i);
        hn::Store(fate, d, b.fate + i);
        if (weighted) {
            const V w = hn::Load(d, b.throughput + i);
            hn::Store(hn::IfThenElse(hn::And(alive, tabled), hn::Mul(w, factor), w), d, b.throughput + i);
            const M scalarWeight = hn::AndNot(tabled, alive);
            hn::Store(hn::IfThenElseZero(scalarWeight, one), d, b.scalarWeight + i);
            if (!hn::AllFalse(d, scalarWeight)) left |= detail::kScalarWeights;
        }
        going += hn::CountTrue(d, alive);
    }
    return {left, static_cast<int>(going)};
}

const char* KernelTargetName() { return hwy::TargetName(HWY_TARGET); }

}  // namespace HWY_NAMESPACE
}  // namespace flare
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace flare {

HWY_EXPORT(AdvancePacket);
HWY_EXPORT(KernelTargetName);

const char* PacketTracer::targetName() { return HWY_DYNAMIC_DISPATCH(KernelTargetName)(); }

PacketTracer::PacketTracer(const BundleTracer& path) : path_(path) {
    using Kind = BundleTracer::Step::Kind;
    const LensSystem& lens = *path_.lens_;
    for (const BundleTracer::Step& bs : path_.steps_) {
        detail::PacketStep s;
        s.surface = bs.surface;
        s.direction = bs.direction;
        switch (bs.kind) {
            case Kind::WrongExit: s.kind = detail::PacketStep::Kind::WrongExit; break;
            case Kind::SensorEnd:
            case Kind::SensorWrongExit:
            case Kind::SensorReflect:
                s.kind = detail::PacketStep::Kind::Sensor;
                s.wrongExit = bs.kind == Kind::SensorWrongExit;
                s.reflect = bs.kind == Kind::SensorReflect;
                s.sensorWeighted = path_.fresnelWeights_;
                s.sensorZMm = lens.sensorZMm();
                s.halfWidthMm = 0.5 * lens.sensor().widthMm;
                s.halfHeightMm = 0.5 * lens.sensor().heightMm;
                s.sensorReflectance = lens.sensor().reflectance;
                break;
            case Kind::Stop:
            case Kind::Refract:
            case Kind::Reflect: {
                const Surface& surface = lens.surface(bs.surface);
                if (surface.hasPolynomial() && bs.kind == Kind::Stop) {
                    s.kind = detail::PacketStep::Kind::Scalar;
                    break;
                }
                s.polynomial = surface.hasPolynomial();
                for (int m = 0; m < kAsphereTerms; ++m) {
                    s.asphere[m] = surface.asphere[m];
                    s.slopeCoefficient[m] = (m + 2) * surface.asphere[m];
                }
                s.kind = bs.kind == Kind::Stop ? detail::PacketStep::Kind::Stop : detail::PacketStep::Kind::Conic;
                s.reflect = bs.kind == Kind::Reflect;
                s.weighted = bs.kind != Kind::Stop && bs.weighted;
                s.laneWeighted = bs.kind != Kind::Stop && path_.fresnelWeights_;
                if (s.weighted && path_.tables_) {
                    const InterfaceTables::Table& t = path_.tables_->table(bs.surface, bs.direction, s.reflect);
                    s.tableValue = t.value.data();
                    s.tableSlope = t.slope.data();
                    s.tableIntervals = path_.tables_->intervals_;
                    s.tableExactFrom = t.exactFrom;
                    s.tableExactTo = t.exactTo;
                }
                s.vertexZMm = surface.vertexZMm;
                s.curvaturePerMm = surface.curvature();
                s.conicFactor = 1.0 + surface.conic;
                s.radiusMm = surface.radiusMm;
                s.centreZMm = surface.vertexZMm + surface.radiusMm;
                s.aperture2Mm2 = surface.semiApertureMm * surface.semiApertureMm;
                s.inverseAperture2PerMm2 = 1.0 / s.aperture2Mm2;
                s.eta = bs.n1 / bs.n2;
                s.normal = s.polynomial                ? detail::PacketStep::Normal::Conic
                           : surface.radiusMm == 0.0   ? detail::PacketStep::Normal::Plane
                           : surface.conic == 0.0      ? detail::PacketStep::Normal::Sphere
                                                       : detail::PacketStep::Normal::Conic;
                const Iris& iris = lens.iris();
                s.roundIris = iris.blades() == 0;
                s.irisInner2Mm2 = s.roundIris ? iris.radiusMm() * iris.radiusMm() : iris.apothemMm() * iris.apothemMm();
                s.irisOuter2Mm2 = iris.circumradiusMm() * iris.circumradiusMm();
                s.blades = iris.blades();
                for (int k = 0; k < std::min(s.blades, detail::PacketStep::kLaneBlades); ++k) {
                    s.edgeNormalX[k] = iris.edgeNormalX(k);
                    s.edgeNormalY[k] = iris.edgeNormalY(k);
                }
                s.apothemMm = iris.apothemMm();
                s.arcCentreMm = iris.arcCentreMm();
                s.arcRadiusMm = iris.arcRadiusMm();
                break;
            }
        }
        steps_.push_back(s);
    }
}

namespace {

// BundleTracer's own step for the listed rays of a batch (all going), written back into the lanes
// (with their margins when asked); returns how many are still going.
int scalarStep(const BundleTracer& path, int step, detail::PacketLanes& b, const int* which, int count,
               bool margins = false) {
    BundleRay rays[detail::kPacketBatch];
    StepOutcome outcomes[detail::kPacketBatch];
    for (int j = 0; j < count; ++j) {
        const int i = which[j];
        rays[j] = {{{b.ox[i], b.oy[i], b.oz[i]}, {b.dx[i], b.dy[i], b.dz[i]}}, b.throughput[i]};
    }
    path.advance(step, std::span<BundleRay>(rays, count), std::span<StepOutcome>(outcomes, count), margins);
    int going = 0;
    for (int j = 0; j < count; ++j) {
        const int i = which[j];
        if (margins) b.margin[i] = outcomes[j].margin;
        if (!outcomes[j].alive) {
            b.fate[i] = detail::fateCode(step, outcomes[j].failure);
            continue;
        }
        ++going;
        const Ray& r = rays[j].ray;
        b.ox[i] = r.originMm.x, b.oy[i] = r.originMm.y, b.oz[i] = r.originMm.z;
        b.dx[i] = r.direction.x, b.dy[i] = r.direction.y, b.dz[i] = r.direction.z;
        b.throughput[i] = rays[j].throughput;
    }
    return going;
}

// Once a quarter of a batch's `active` lanes have ended, moves the `going` ones to the front (their
// inputs in `index` with them) and pads with ended lanes to whole vectors, after `leave(i)` for
// each lane that ended; returns the lanes now active (unchanged if it did not compact).
template <class Leave>
int compactLanes(detail::PacketLanes& b, int* index, int active, int going, Leave&& leave) {
    constexpr int kLanes = detail::kPacketMaxLanes;
    const int needed = (going + kLanes - 1) / kLanes * kLanes;
    if (4 * needed > 3 * active) return active;
    int m = 0;
    for (int i = 0; i < active; ++i) {
        if (b.fate[i] != 0.0) {
            leave(i);
            continue;
        }
        b.ox[m] = b.ox[i], b.oy[m] = b.oy[i], b.oz[m] = b.oz[i];
        b.dx[m] = b.dx[i], b.dy[m] = b.dy[i], b.dz[m] = b.dz[i];
        b.throughput[m] = b.throughput[i];
        b.fate[m] = 0.0;
        index[m++] = index[i];
    }
    for (; m < needed; ++m) {
        b.fate[m] = 1.0;
        index[m] = -1;
    }
    return needed;
}

}  // namespace

void PacketTracer::scalarWeights(const detail::PacketStep& s, detail::PacketLanes& b, int active) const {
    // BundleTracer's factors, one ray at a time (deferred rays get theirs in the scalar step).
    const InterfaceTables* tables = path_.tables_;
    for (int i = 0; i < active; ++i) {
        if (b.scalarWeight[i] == 0.0) continue;
        const double c = b.cosine[i];
        if (tables) {
            b.throughput[i] *= s.reflect ? tables->reflectance(s.surface, s.direction, c)
                                         : tables->transmittance(s.surface, s.direction, c);
        } else {
            const FresnelTerms f = interfaceResponse(*path_.lens_, path_.indices_, s.surface, s.direction, c);
            b.throughput[i] *= s.reflect ? f.reflectance() : f.transmittance();
        }
    }
}

int PacketTracer::runStep(int step, detail::PacketLanes& b, int active, bool margins) const {
    using Kind = detail::PacketStep::Kind;
    const detail::PacketStep& s = steps_[step];
    int which[detail::kPacketBatch];
    int n = 0;
    // BundleTracer's step for every going ray: aspheric iris planes, and, when margins are asked,
    // the sensor (its rectangle's margin), a wrong exit and an iris with more blades than the
    // lanes hold.
    if (s.kind == Kind::Scalar ||
        (margins && (s.kind == Kind::Sensor || s.kind == Kind::WrongExit ||
                     (s.kind == Kind::Stop && s.blades > detail::PacketStep::kLaneBlades)))) {
        for (int i = 0; i < active; ++i)
            if (b.fate[i] == 0.0) which[n++] = i;
        return scalarStep(path_, step, b, which, n, margins);
    }
    if (s.kind == Kind::WrongExit) {  // every going ray ends here
        for (int i = 0; i < active; ++i)
            if (b.fate[i] == 0.0) b.fate[i] = detail::fateCode(step, TraceStatus::WrongExit);
        return 0;
    }
    const detail::PacketStepResult result = HWY_DYNAMIC_DISPATCH(AdvancePacket)(
        s, step, b, static_cast<size_t>(active), margins ? detail::PacketMargins::All : detail::PacketMargins::None,
        false);
    int going = result.going;
    if (result.left & detail::kScalarWeights) scalarWeights(s, b, active);
    if (result.left & detail::kDeferredRays) {
        for (int i = 0; i < active; ++i)
            if (b.deferred[i] != 0.0) which[n++] = i;
        going += scalarStep(path_, step, b, which, n, margins);
    }
    return going;
}

void PacketTracer::advance(int first, int last, std::span<BundleRay> rays, std::span<End> ends,
                           std::span<double* const> margins) const {
    constexpr int kLanes = detail::kPacketMaxLanes;
    const bool withMargins = !margins.empty();
    detail::PacketLanes b;
    int index[detail::kPacketBatch];  // the ray in each lane, −1 for padding
    for (size_t begin = 0; begin < rays.size(); begin += detail::kPacketBatch) {
        const int count = static_cast<int>(std::min<size_t>(detail::kPacketBatch, rays.size() - begin));
        int active = (count + kLanes - 1) / kLanes * kLanes;
        for (int i = 0; i < active; ++i) {
            const BundleRay r = i < count ? rays[begin + i] : BundleRay{};
            b.ox[i] = r.ray.originMm.x, b.oy[i] = r.ray.originMm.y, b.oz[i] = r.ray.originMm.z;
            b.dx[i] = r.ray.direction.x, b.dy[i] = r.ray.direction.y, b.dz[i] = r.ray.direction.z;
            b.throughput[i] = r.throughput;
            b.fate[i] = i < count ? 0.0 : 1.0;  // padding lanes never run
            index[i] = i < count ? static_cast<int>(begin) + i : -1;
        }
        // A lane leaving the batch: its ray's new state, or where it ended.
        auto leave = [&](int i) {
            if (index[i] < 0) return;
            if (b.fate[i] == 0.0) {
                BundleRay& r = rays[index[i]];
                r.ray.originMm = {b.ox[i], b.oy[i], b.oz[i]};
                r.ray.direction = {b.dx[i], b.dy[i], b.dz[i]};
                r.throughput = b.throughput[i];
                ends[index[i]] = End{};
                return;
            }
            const int code = static_cast<int>(b.fate[i]) - 1;
            ends[index[i]] = End{code / 8, static_cast<TraceStatus>(code % 8)};
        };
        for (int step = first; step <= last; ++step) {
            const int going = runStep(step, b, active, withMargins);
            if (withMargins) {
                // The rays that entered this step: going on, or ended here.
                const double endedHere = detail::fateCode(step, TraceStatus::Ok);
                for (int i = 0; i < active; ++i)
                    if (index[i] >= 0 && (b.fate[i] == 0.0 || (b.fate[i] >= endedHere && b.fate[i] < endedHere + 8.0)))
                        margins[index[i]][step] = b.margin[i];
            }
            // Once a quarter of the lanes have ended, the going ones move together (as trace()).
            active = compactLanes(b, index, active, going, leave);
        }
        for (int i = 0; i < active; ++i) leave(i);
    }
}

int PacketTracer::runStepOwnIndices(int step, detail::PacketLanes& b, int active, const int* index,
                                    std::span<const SpectralIndices* const> indices) const {
    using Kind = detail::PacketStep::Kind;
    const detail::PacketStep& s = steps_[step];
    // Steps that do not refract or weigh do not depend on the wavelength: runStep's own.
    if (s.kind != Kind::Conic) return runStep(step, b, active, false);
    const int k = s.surface;
    // The lane's n1 and n2 as tracePath takes them.
    auto media = [&](int i) {
        const SpectralIndices& n = *indices[index[i]];
        return s.direction > 0 ? std::pair{n.n[k], n.n[k + 1]} : std::pair{n.n[k + 1], n.n[k]};
    };
    if (!s.reflect)
        for (int i = 0; i < active; ++i) {
            if (b.fate[i] != 0.0) continue;
            const auto [n1, n2] = media(i);
            b.eta[i] = n1 / n2;
        }
    const detail::PacketStepResult result =
        HWY_DYNAMIC_DISPATCH(AdvancePacket)(s, step, b, static_cast<size_t>(active), detail::PacketMargins::None, true);
    if (result.left & detail::kScalarWeights) {
        for (int i = 0; i < active; ++i) {
            if (b.scalarWeight[i] == 0.0) continue;
            const auto [n1, n2] = media(i);
            if (!s.reflect && n1 == n2) continue;  // (tracePath weighs no refraction between equal indices)
            const FresnelTerms f = interfaceResponse(*path_.lens_, *indices[index[i]], k, s.direction, b.cosine[i]);
            b.throughput[i] *= s.reflect ? f.reflectance() : f.transmittance();
        }
    }
    int going = result.going;
    if (result.left & detail::kDeferredRays)
        for (int i = 0; i < active; ++i)
            if (b.deferred[i] != 0.0) b.fate[i] = detail::retraceCode(step);
    return going;
}

template <bool kOwnIndices, class RayAt>
void PacketTracer::traceRays(size_t count, const RayAt& rayAt, std::span<const SpectralIndices* const> indices,
                             std::span<BundleLanding> out) const {
    constexpr int kLanes = detail::kPacketMaxLanes;
    detail::PacketLanes b;
    int index[detail::kPacketBatch];  // the input of each lane, −1 for padding
    const LensSystem& lens = *path_.lens_;
    std::vector<int> retrace;  // (own indices) rays left to the scalar code at a refraction
    for (size_t begin = 0; begin < count; begin += detail::kPacketBatch) {
        const int batch = static_cast<int>(std::min<size_t>(detail::kPacketBatch, count - begin));
        int active = (batch + kLanes - 1) / kLanes * kLanes;  // lanes in use, whole vectors
        for (int i = 0; i < active; ++i) {
            const Ray r = i < batch ? rayAt(begin + i) : Ray{};
            b.ox[i] = r.originMm.x, b.oy[i] = r.originMm.y, b.oz[i] = r.originMm.z;
            b.dx[i] = r.direction.x, b.dy[i] = r.direction.y, b.dz[i] = r.direction.z;
            b.throughput[i] = 1.0;
            b.fate[i] = i < batch ? 0.0 : 1.0;  // padding lanes never run
            if constexpr (kOwnIndices) b.eta[i] = 1.0;
            index[i] = i < batch ? static_cast<int>(begin) + i : -1;
        }
        auto land = [&](int i) {
            if (index[i] < 0) return;
            BundleLanding& o = out[index[i]];
            o = BundleLanding{};
            if (b.fate[i] == 0.0) {
                o.sensorMm = {b.ox[i], b.oy[i]};
                o.throughput = b.throughput[i];
                o.status = TraceStatus::Ok;
                o.surface = lens.surfaceCount();
                return;
            }
            const int code = static_cast<int>(b.fate[i]) - 1;
            if (kOwnIndices && code % 8 == detail::kRetraceStatus) {
                retrace.push_back(index[i]);
                return;
            }
            o.status = static_cast<TraceStatus>(code % 8);
            o.surface = path_.stepSurface(code / 8);
        };
        for (int step = 0; step < static_cast<int>(steps_.size()); ++step) {
            int going;
            if constexpr (kOwnIndices) going = runStepOwnIndices(step, b, active, index, indices);
            else going = runStep(step, b, active, false);
            // A ghost path loses most rays within a few steps: once a quarter of the lanes are
            // dead, the ended rays land and the going ones move together, so that later steps
            // run fewer vectors (moving a ray costs far less than a step).
            active = compactLanes(b, index, active, going, land);
        }
        for (int i = 0; i < active; ++i) land(i);
    }
    if (!kOwnIndices || retrace.empty()) return;
    SequentialPath path;
    path.reflections = path_.reflections();
    TraceOptions options;
    options.fresnelWeights = path_.fresnelWeights_;
    for (const int j : retrace) {
        const TraceResult r = tracePath(lens, *indices[j], rayAt(static_cast<size_t>(j)), path, options);
        BundleLanding& o = out[j];
        o = BundleLanding{};
        o.status = r.status;
        o.surface = r.surface;
        o.throughput = r.throughput;
        if (r.ok()) o.sensorMm = {r.ray.originMm.x, r.ray.originMm.y};
    }
}

void PacketTracer::trace(const PupilGrid& grid, std::span<const glm::dvec2> pupilMm, std::span<BundleLanding> out) const {
    traceRays<false>(pupilMm.size(), [&](size_t i) { return grid.ray(pupilMm[i].x, pupilMm[i].y); }, {}, out);
}

void PacketTracer::trace(std::span<const Ray> rays, std::span<const SpectralIndices* const> indices,
                         std::span<BundleLanding> out) const {
    traceRays<true>(rays.size(), [&](size_t i) { return rays[i]; }, indices, out);
}

}  // namespace flare
#endif  // HWY_ONCE
