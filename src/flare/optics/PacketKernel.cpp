// PacketKernel.h's step, compiled once per instruction set: foreach_target.h includes this file
// again for each target Highway builds (HWY_TARGET_INCLUDE), each time with that target's
// HWY_NAMESPACE; the dispatch table and the plain functions that use it are defined once, at the
// end (HWY_ONCE).
#include "flare/optics/PacketKernel.h"

#include <cstddef>
#include <limits>
#include <utility>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "flare/optics/PacketKernel.cpp"
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

namespace detail {

PacketStepResult advancePacket(const PacketStep& s, int step, PacketLanes& b, std::size_t count, PacketMargins margins,
                               bool ownIndices) {
    return HWY_DYNAMIC_DISPATCH(AdvancePacket)(s, step, b, count, margins, ownIndices);
}

const char* packetTargetName() { return HWY_DYNAMIC_DISPATCH(KernelTargetName)(); }

}  // namespace detail
}  // namespace flare
#endif  // HWY_ONCE
