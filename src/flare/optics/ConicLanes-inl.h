// intersect() in SIMD lanes: the conic's quadratic and an asphere's Newton iteration, shared by
// the packet kernels (PacketKernel.cpp, whose steps hold one surface, and PhotonPacket.cpp, whose
// lanes each meet their own). Included by those files inside Highway's per-target compilation, so
// it is compiled once per instruction set with their flags (no fused multiply-adds): a Highway
// "-inl.h" header, whose include guard toggles with HWY_TARGET_TOGGLE.
#if defined(FLARE_OPTICS_CONIC_LANES_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef FLARE_OPTICS_CONIC_LANES_INL_H_
#undef FLARE_OPTICS_CONIC_LANES_INL_H_
#else
#define FLARE_OPTICS_CONIC_LANES_INL_H_
#endif

#include <hwy/highway.h>

#include "flare/optics/Surface.h"

HWY_BEFORE_NAMESPACE();
namespace flare {
namespace HWY_NAMESPACE {

// intersectConic's quadratic c r² − 2z + c(1+k)z² = 0 along the rays, in vertex-local
// coordinates (x and y unshifted, oz0 = z − vertex), and solveQuadratic's roots t0 ≤ t1 (the
// cancellation-free form; a plane's single root twice), in their order of operations. `roots`
// marks the lanes that have any; qc (the conic's value at the origin) is for the far-origin test.
template <class D, class V = hwy::HWY_NAMESPACE::Vec<D>>
struct ConicRoots {
    V qc, t0, t1;
    hwy::HWY_NAMESPACE::Mask<D> roots;
};
template <class D, class V = hwy::HWY_NAMESPACE::Vec<D>>
HWY_INLINE ConicRoots<D> ConicQuadratic(D d, V c, V k1, V ox, V oy, V oz0, V dx, V dy, V dz) {
    namespace hn = hwy::HWY_NAMESPACE;
    const V zero = hn::Zero(d), two = hn::Set(d, 2.0);
    const V qa = hn::Mul(c, hn::Add(hn::Add(hn::Mul(dx, dx), hn::Mul(dy, dy)), hn::Mul(hn::Mul(k1, dz), dz)));
    const V qb = hn::Sub(hn::Mul(c, hn::Add(hn::Add(hn::Mul(ox, dx), hn::Mul(oy, dy)), hn::Mul(hn::Mul(k1, oz0), dz))), dz);
    const V qc = hn::Sub(hn::Mul(c, hn::Add(hn::Add(hn::Mul(ox, ox), hn::Mul(oy, oy)), hn::Mul(hn::Mul(k1, oz0), oz0))),
                         hn::Mul(two, oz0));
    const auto linear = hn::Eq(qa, zero);
    // Only a plane (or a ray along a conic's axis at its vertex) is linear: skip the division.
    const V tLinear = hn::AllFalse(d, linear) ? zero : hn::Div(hn::Neg(qc), hn::Mul(two, qb));
    const V disc = hn::Sub(hn::Mul(qb, qb), hn::Mul(qa, qc));
    const V q = hn::Neg(hn::Add(qb, hn::CopySign(hn::Sqrt(disc), qb)));
    const V r0 = hn::Div(q, qa);
    const V r1 = hn::IfThenElse(hn::Ne(q, zero), hn::Div(qc, q), r0);
    const auto swap = hn::Gt(r0, r1);
    return {qc, hn::IfThenElse(linear, tLinear, hn::IfThenElse(swap, r1, r0)),
            hn::IfThenElse(linear, tLinear, hn::IfThenElse(swap, r0, r1)),
            hn::Or(hn::And(linear, hn::Ne(qb, zero)), hn::AndNot(linear, hn::Not(hn::Lt(disc, zero))))};
}

// Newton on F(t) = z(t) − sag(r²(t)) for the lanes of `running`, in intersect()'s order of
// operations: from the conic hit where `conicHit` (tConic), else the vertex plane, at most
// kMaxNewtonIterations steps, each lane stopping where intersect() returns. The origin is
// vertex-local (x and y unshifted, oz0 = z − vertex); c the curvature, kc2 = (1 + k) c²;
// coefficient(m) gives the lanes' slope coefficient (m + 2) A_{2m+4} and A_{2m+4}. Returns the
// lanes' t and sets `failed` where intersect() reports NewtonDiverged (outside the conic's
// domain, a flat or non-finite slope, out of iterations); the caller applies tMin.
template <class D, class M, class Coefficient, class V = hwy::HWY_NAMESPACE::Vec<D>>
HWY_INLINE V AsphereNewton(D d, M running, M conicHit, V tConic, V ox, V oy, V oz0, V dx, V dy, V dz, V c, V kc2,
                           const Coefficient& coefficient, M& failed) {
    namespace hn = hwy::HWY_NAMESPACE;
    const V zero = hn::Zero(d), one = hn::Set(d, 1.0), two = hn::Set(d, 2.0);
    const V halfC = hn::Mul(hn::Set(d, 0.5), c);
    V t = hn::IfThenElse(conicHit, tConic, hn::IfThenElse(hn::Ne(dz, zero), hn::Div(hn::Neg(oz0), dz), zero));
    failed = hn::FirstN(d, 0);
    for (int iteration = 0; iteration < kMaxNewtonIterations && !hn::AllFalse(d, running); ++iteration) {
        const V px = hn::Add(ox, hn::Mul(t, dx)), py = hn::Add(oy, hn::Mul(t, dy)), pz = hn::Add(oz0, hn::Mul(t, dz));
        const V r2 = hn::Add(hn::Mul(px, px), hn::Mul(py, py));
        const V q = hn::Sub(one, hn::Mul(kc2, r2));
        const M outside = hn::And(running, hn::Lt(q, zero));
        failed = hn::Or(failed, outside);
        running = hn::AndNot(outside, running);
        const V root = hn::Sqrt(q);
        V sag = hn::Div(hn::Mul(c, r2), hn::Add(one, root));
        V slope = hn::IfThenElse(hn::Gt(q, zero), hn::Div(halfC, root), zero);
        V power = r2;
        for (int m = 0; m < kAsphereTerms; ++m) {
            const auto [slopeCoefficient, asphere] = coefficient(m);
            slope = hn::Add(slope, hn::Mul(slopeCoefficient, power));
            power = hn::Mul(power, r2);
            sag = hn::Add(sag, hn::Mul(asphere, power));
        }
        const V f = hn::Sub(pz, sag);
        const V df = hn::Sub(dz, hn::Mul(hn::Mul(two, slope), hn::Add(hn::Mul(px, dx), hn::Mul(py, dy))));
        const M flat = hn::And(running, hn::Or(hn::Eq(df, zero), hn::Not(hn::IsFinite(df))));
        failed = hn::Or(failed, flat);
        running = hn::AndNot(flat, running);
        const V step = hn::Div(f, df);
        t = hn::IfThenElse(running, hn::Sub(t, step), t);
        const M converged = hn::And(running, hn::Lt(hn::Abs(step), hn::Mul(hn::Set(d, 1e-12), hn::Add(one, hn::Abs(t)))));
        running = hn::AndNot(converged, running);
    }
    failed = hn::Or(failed, running);  // out of iterations
    return t;
}

}  // namespace HWY_NAMESPACE
}  // namespace flare
HWY_AFTER_NAMESPACE();

#endif  // FLARE_OPTICS_CONIC_LANES_INL_H_ (per target)
