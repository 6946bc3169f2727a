// PhotonTracer::tracePacket: photon walks whose stretches between interfaces run in SIMD lanes.
//
// A walk in a clean lens is mostly one kind of event: the photon crosses its cell to the surface
// ahead or behind and reflects or refracts there. That is the same computation for every photon
// with its cell's constants, so up to kPhotonBatch walks are kept in flight and each round runs
// two vector passes over them (Highway's run-time dispatch): SearchPhotons finds every walk's next
// boundary (the cell's two surfaces, an asphere by intersect()'s Newton iteration, the sensor
// plane, the wall's cylinder, the two annuli; the constants gathered per lane), and MeetSurfaces
// meets a sphere or a plane (the normal, the incidence cosine, the coating's reflectance bound,
// the refracted and the reflected directions). Between the two, each walk's event is sorted one
// at a time and its draw taken from its own generator; after them, the choice is made (the exact
// response only for draws below the bound) and the walks still going are moved down.
//
// Every operation is trace()'s, in its order (no fused multiply-adds: this file is compiled with
// -ffp-contract=off), so each lane finds the same boundary and direction to the last bit. At any
// event the lanes do not take (a wall, a retaining ring, the sensor, dust, grease, a medium,
// blades that scatter, a hit within the seam tolerance of where the photon stands, an origin far
// from a conic, a further crossing beyond a surface's rim), the photon leaves the lanes:
// trace()'s loop (traceFrom) goes on from the state before that event. The photon's history is
// then the one trace() gives, and test_photon_packet.cpp holds them to it bit for bit on every
// instruction set.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <utility>

#include <glm/geometric.hpp>

#include "flare/optics/Fresnel.h"
#include "flare/optics/SequentialTracer.h"
#include "flare/photons/PhotonTracer.h"

#ifndef FLARE_PHOTONS_PHOTON_PACKET_LANES
#define FLARE_PHOTONS_PHOTON_PACKET_LANES
namespace flare::detail {

// Walks in flight: enough independent lanes to overlap the divisions' latency, few enough that
// the lanes' arrays (about 12 KiB) stay in L1.
inline constexpr int kPhotonBatch = 128;

// The search's constants: per surface k (the surface behind cell k + 1 and ahead of cell k) and
// per cell g, each as trace() computes it (the products in its order).
struct PhotonSearchConstants {
    int surfaces = 0;
    double sensorZMm = 0.0;
    double vertexZMm[kMaxSurfaces] = {}, curvaturePerMm[kMaxSurfaces] = {}, conicFactor[kMaxSurfaces] = {};
    double branchFactor[kMaxSurfaces] = {};  // curvature × conicFactor: the vertex branch, 1 − c k1 z > 0
    double rimOuter2Mm2[kMaxSurfaces] = {};  // extent² (1 + seam tolerance): a surface hit within its rim
    double rimInner2Mm2[kMaxSurfaces] = {};  // extent² (1 − seam tolerance): an annulus hit beyond it
    double rimZMm[kMaxSurfaces] = {};
    // An asphere (polynomial terms): intersect()'s Newton iteration, with (1 + k) c², the
    // coefficients A4..A16 and their slope coefficients (m + 2) A_{2m+4}, term by term.
    bool anyPolynomial = false;
    double polynomial[kMaxSurfaces] = {};
    double newtonConicFactor[kMaxSurfaces] = {};
    double asphere[kAsphereTerms][kMaxSurfaces] = {}, slopeCoefficient[kAsphereTerms][kMaxSurfaces] = {};
    // Meeting a surface: a sphere's radius and centre (normalAt), a plane's flag, and a
    // single-layer coating's film index (0: no bound, the exact response decides).
    double radiusMm[kMaxSurfaces] = {}, centreZMm[kMaxSurfaces] = {}, plane[kMaxSurfaces] = {};
    double filmIndex[kMaxSurfaces] = {};
    double wall2Mm2[kMaxSurfaces + 1] = {};  // the cell's wall radius squared
    double wallOuter2Mm2[kMaxSurfaces + 1] = {};  // that × (1 + seam tolerance)
    double hasMedium[kMaxSurfaces + 1] = {};
};

// The walks in flight, one array per quantity. The search writes `kind` (0: the photon leaves the
// lanes at this event, 1: it meets the surface behind, 2: the one ahead) and `t`, the distance.
struct PhotonSearchLanes {
    alignas(64) double ox[kPhotonBatch], oy[kPhotonBatch], oz[kPhotonBatch];
    alignas(64) double dx[kPhotonBatch], dy[kPhotonBatch], dz[kPhotonBatch];
    alignas(64) std::int64_t cell[kPhotonBatch], onSurface[kPhotonBatch];
    alignas(64) double t[kPhotonBatch], kind[kPhotonBatch];
    // Meeting the surface found (MeetSurfaces), for the walks with meet = 1: the hit point, the
    // indices before and after, the direction of travel (±1), the surface and the photon's draw;
    // out, the incidence cosine, whether the draw lies above the coating's bound (certain), the
    // refracted direction unless total internal reflection (tir) and the reflected one.
    alignas(64) double meet[kPhotonBatch];
    alignas(64) double px[kPhotonBatch], py[kPhotonBatch], pz[kPhotonBatch];
    alignas(64) double n1[kPhotonBatch], n2[kPhotonBatch], direction[kPhotonBatch], u[kPhotonBatch];
    alignas(64) std::int64_t surface[kPhotonBatch];
    alignas(64) double cosine[kPhotonBatch], certain[kPhotonBatch], tir[kPhotonBatch];
    alignas(64) double rx[kPhotonBatch], ry[kPhotonBatch], rz[kPhotonBatch];
    alignas(64) double fx[kPhotonBatch], fy[kPhotonBatch], fz[kPhotonBatch];
};

}  // namespace flare::detail
#endif

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "flare/photons/PhotonPacket.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "flare/optics/ConicLanes-inl.h"

HWY_BEFORE_NAMESPACE();
namespace flare {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// intersect()'s Newton iteration (AsphereNewton) for the lanes of `polynomial`, each with its own
// surface's coefficients: the converged t, NaN where it fails. Out of line, so that the lanes of
// a lens without aspheres keep their registers.
template <class D, class V = hn::Vec<D>, class VI, class M>
HWY_NOINLINE V NewtonLanes(const detail::PhotonSearchConstants& k, VI surface, M polynomial, M conicHit, V tConic, V ox, V oy,
                           V oz0, V dx, V dy, V dz, V c) {
    const D d;
    M failed;
    const V t = AsphereNewton(d, polynomial, conicHit, tConic, ox, oy, oz0, dx, dy, dz, c,
                              hn::GatherIndex(d, k.newtonConicFactor, surface), [&](int m) {
                                  return std::pair{hn::GatherIndex(d, k.slopeCoefficient[m], surface),
                                                   hn::GatherIndex(d, k.asphere[m], surface)};
                              }, failed);
    return hn::IfThenElse(failed, hn::Set(d, std::numeric_limits<double>::quiet_NaN()), t);
}

// trace()'s search for the next boundary of walks [0, count) (count a multiple of the vector
// length; the lanes beyond the walks hold copies of a walk): trySurface behind and ahead, the
// sensor plane, the wall's cylinder and the two annuli, in that order, with its tolerances.
void SearchPhotons(const detail::PhotonSearchConstants& k, detail::PhotonSearchLanes& b, size_t count) {
    const hn::ScalableTag<double> d;
    const hn::RebindToSigned<decltype(d)> di;
    using V = hn::Vec<decltype(d)>;
    using M = hn::Mask<decltype(d)>;
    const V zero = hn::Zero(d), one = hn::Set(d, 1.0);
    const V inf = hn::Set(d, std::numeric_limits<double>::infinity());
    const V onBoundary = hn::Set(d, kOnBoundaryMm), leaveSurface = hn::Set(d, kLeaveSurfaceMm);
    const auto lastSurface = hn::Set(di, static_cast<std::int64_t>(k.surfaces - 1));
    const auto surfaceCount = hn::Set(di, static_cast<std::int64_t>(k.surfaces));

    for (size_t i = 0; i < count; i += hn::Lanes(d)) {
        const V ox = hn::Load(d, b.ox + i), oy = hn::Load(d, b.oy + i), oz = hn::Load(d, b.oz + i);
        const V dx = hn::Load(d, b.dx + i), dy = hn::Load(d, b.dy + i), dz = hn::Load(d, b.dz + i);
        const auto cell = hn::Load(di, b.cell + i), onSurface = hn::Load(di, b.onSurface + i);
        const M inside = hn::RebindMask(d, hn::Gt(cell, hn::Zero(di)));  // cell > 0: it has walls
        const M beforeSensor = hn::RebindMask(d, hn::Lt(cell, surfaceCount));
        M leave = hn::Ne(hn::GatherIndex(d, k.hasMedium, cell), zero);
        V best = inf, kind = zero;

        // trySurface(k, which): the conic's first hit beyond tMin on its vertex branch.
        auto trySurface = [&](M active, decltype(cell) surface, double which) {
            const V vertexZ = hn::GatherIndex(d, k.vertexZMm, surface);
            const V c = hn::GatherIndex(d, k.curvaturePerMm, surface), k1 = hn::GatherIndex(d, k.conicFactor, surface);
            const V ck = hn::GatherIndex(d, k.branchFactor, surface), rim = hn::GatherIndex(d, k.rimOuter2Mm2, surface);
            const V tMin = hn::IfThenElse(hn::RebindMask(d, hn::Eq(surface, onSurface)), leaveSurface, hn::Neg(onBoundary));
            const V oz0 = hn::Sub(oz, vertexZ);
            const auto conic = ConicQuadratic(d, c, k1, ox, oy, oz0, dx, dy, dz);
            leave = hn::Or(leave, hn::And(active, hn::Gt(hn::Abs(hn::Mul(c, conic.qc)), hn::Set(d, kConicFarOrigin * kConicFarOrigin))));
            const V t0 = conic.t0, t1 = conic.t1;
            const M roots = hn::And(active, conic.roots);
            const M branch0 = hn::Gt(hn::Sub(one, hn::Mul(ck, hn::Add(oz0, hn::Mul(t0, dz)))), zero);
            const M branch1 = hn::Gt(hn::Sub(one, hn::Mul(ck, hn::Add(oz0, hn::Mul(t1, dz)))), zero);
            const M ok0 = hn::And(roots, hn::And(hn::Not(hn::Le(t0, tMin)), branch0));
            const M ok1 = hn::And(roots, hn::And(hn::Not(hn::Le(t1, tMin)), branch1));
            V tA = hn::IfThenElse(ok0, t0, t1);
            M hit = hn::Or(ok0, ok1);
            // A far root beyond the first crossing (for an asphere, any further crossing) is left
            // to trace() below.
            M further = hn::And(ok0, ok1);
            const M polynomial = k.anyPolynomial ? hn::And(active, hn::Ne(hn::GatherIndex(d, k.polynomial, surface), zero))
                                                 : hn::FirstN(d, 0);
            if (k.anyPolynomial && !hn::AllFalse(d, polynomial)) {
                const V t = NewtonLanes<decltype(d)>(k, surface, polynomial, hit, tA, ox, oy, oz0, dx, dy, dz, c);
                tA = hn::IfThenElse(polynomial, t, tA);
                // intersect(): a hit only beyond tMin (a failed lane's t is NaN: none).
                hit = hn::Or(hn::AndNot(polynomial, hit), hn::And(polynomial, hn::Gt(t, tMin)));
                further = hn::Or(further, polynomial);
            }
            // The first crossing, if nearer than the best so far.
            const M first = hn::And(hit, hn::Lt(tA, best));
            // A hit where the photon stands needs the normal to tell whether it leaves the cell.
            const M clear = hn::Ge(tA, onBoundary);
            leave = hn::Or(leave, hn::AndNot(clear, first));
            const V ax = hn::Add(ox, hn::Mul(tA, dx)), ay = hn::Add(oy, hn::Mul(tA, dy));
            const M withinA = hn::Le(hn::Add(hn::Mul(ax, ax), hn::Mul(ay, ay)), rim);
            const M acceptA = hn::And(hn::And(first, clear), withinA);
            // Beyond the rim, trace() looks for a further crossing: rare enough (a steep ray near
            // the wall) to leave to it whenever there may be one.
            leave = hn::Or(leave, hn::AndNot(withinA, hn::And(hn::And(first, clear), further)));
            best = hn::IfThenElse(acceptA, tA, best);
            kind = hn::IfThenElse(acceptA, hn::Set(d, which), kind);
        };
        trySurface(inside, hn::Max(hn::Sub(cell, hn::Set(di, 1)), hn::Zero(di)), 1.0);
        trySurface(beforeSensor, hn::Min(cell, lastSurface), 2.0);

        // Any other boundary nearer than the surface found: the sensor plane, the wall, an annulus.
        const M atSensor = hn::And(hn::Not(beforeSensor), hn::Gt(dz, zero));
        const V tSensor = hn::Div(hn::Sub(hn::Set(d, k.sensorZMm), oz), dz);
        leave = hn::Or(leave, hn::And(atSensor, hn::And(hn::Ge(tSensor, hn::Neg(onBoundary)), hn::Lt(tSensor, best))));

        // cylinderExit(ray, wall radius).
        const V wall2 = hn::GatherIndex(d, k.wall2Mm2, cell), wallOuter = hn::GatherIndex(d, k.wallOuter2Mm2, cell);
        const V ca = hn::Add(hn::Mul(dx, dx), hn::Mul(dy, dy));
        const V cb = hn::Add(hn::Mul(ox, dx), hn::Mul(oy, dy));
        const V cc = hn::Sub(hn::Add(hn::Mul(ox, ox), hn::Mul(oy, oy)), wall2);
        const V cdisc = hn::Sub(hn::Mul(cb, cb), hn::Mul(ca, cc));
        const V s = hn::Sqrt(hn::Max(cdisc, zero));
        V tWall = hn::IfThenElse(hn::Le(cb, zero), hn::Div(hn::Sub(s, cb), ca), hn::Div(hn::Neg(cc), hn::Add(cb, s)));
        tWall = hn::IfThenElse(hn::Lt(cdisc, zero), inf, tWall);
        tWall = hn::IfThenElse(hn::And(hn::Gt(cc, zero), hn::Or(hn::Ge(cb, zero), hn::Lt(cdisc, zero))), zero, tWall);
        tWall = hn::IfThenElse(hn::Lt(ca, hn::Set(d, 1e-300)), inf, tWall);
        leave = hn::Or(leave, hn::And(inside, hn::Lt(tWall, best)));

        // The annuli at the rims behind (facing +z) and ahead (facing −z).
        auto annulus = [&](M active, decltype(cell) surface) {
            const V t = hn::Div(hn::Sub(hn::GatherIndex(d, k.rimZMm, surface), oz), dz);
            const V px = hn::Add(ox, hn::Mul(t, dx)), py = hn::Add(oy, hn::Mul(t, dy));
            const V r2 = hn::Add(hn::Mul(px, px), hn::Mul(py, py));
            const M met = hn::And(hn::And(hn::Not(hn::Lt(t, hn::Neg(onBoundary))), hn::Lt(t, best)),
                                  hn::And(hn::Not(hn::Lt(r2, hn::GatherIndex(d, k.rimInner2Mm2, surface))),
                                          hn::Not(hn::Gt(r2, wallOuter))));
            leave = hn::Or(leave, hn::And(active, met));
        };
        annulus(hn::And(inside, hn::Lt(dz, zero)), hn::Max(hn::Sub(cell, hn::Set(di, 1)), hn::Zero(di)));
        annulus(hn::And(hn::And(inside, beforeSensor), hn::Gt(dz, zero)), hn::Min(cell, lastSurface));

        leave = hn::Or(leave, hn::Eq(kind, zero));  // nothing found: escaped or lost
        hn::Store(best, d, b.t + i);
        hn::Store(hn::IfThenElse(leave, zero, kind), d, b.kind + i);
    }
}

// trace()'s meeting of a sphere or a plane for the walks with meet = 1 (count a multiple of the
// vector length), each operation as the scalar code does it: Surface::normalAt, the incidence
// cosine, interfaceReflectanceBound (thinFilmReflectanceBound and its margin), refract() and
// glm::normalize(reflect()). The choice between the two directions stays with the caller.
void MeetSurfaces(const detail::PhotonSearchConstants& k, detail::PhotonSearchLanes& b, size_t count) {
    const hn::ScalableTag<double> d;
    const hn::RebindToSigned<decltype(d)> di;
    using V = hn::Vec<decltype(d)>;
    using M = hn::Mask<decltype(d)>;
    const V zero = hn::Zero(d), one = hn::Set(d, 1.0), two = hn::Set(d, 2.0);
    auto normalize = [&](V& x, V& y, V& z) {  // glm::normalize: v · (1 / √(v·v))
        const V inverse = hn::Div(one, hn::Sqrt(hn::Add(hn::Add(hn::Mul(x, x), hn::Mul(y, y)), hn::Mul(z, z))));
        x = hn::Mul(x, inverse), y = hn::Mul(y, inverse), z = hn::Mul(z, inverse);
    };
    for (size_t i = 0; i < count; i += hn::Lanes(d)) {
        const M active = hn::Eq(hn::Load(d, b.meet + i), one);
        if (hn::AllFalse(d, active)) continue;
        const auto surface = hn::Load(di, b.surface + i);
        const V px = hn::Load(d, b.px + i), py = hn::Load(d, b.py + i), pz = hn::Load(d, b.pz + i);
        const V dx = hn::Load(d, b.dx + i), dy = hn::Load(d, b.dy + i), dz = hn::Load(d, b.dz + i);
        const V n1 = hn::Load(d, b.n1 + i), n2 = hn::Load(d, b.n2 + i);
        // Surface::normalAt: (0, 0, 1) for a plane, (centre − p) / R for a sphere.
        const M plane = hn::Ne(hn::GatherIndex(d, k.plane, surface), zero);
        const V radius = hn::IfThenElse(plane, one, hn::GatherIndex(d, k.radiusMm, surface));
        const V nx = hn::IfThenElse(plane, zero, hn::Div(hn::Sub(zero, px), radius));
        const V ny = hn::IfThenElse(plane, zero, hn::Div(hn::Sub(zero, py), radius));
        const V nz = hn::IfThenElse(plane, one, hn::Div(hn::Sub(hn::GatherIndex(d, k.centreZMm, surface), pz), radius));
        const V dot = hn::Add(hn::Add(hn::Mul(nx, dx), hn::Mul(ny, dy)), hn::Mul(nz, dz));
        const V c = hn::Min(one, hn::Abs(dot));
        hn::Store(c, d, b.cosine + i);

        // interfaceReflectanceBound with n0 = n1 (the incident medium) and nSub = n2.
        const V film = hn::GatherIndex(d, k.filmIndex, surface);
        const V cc = hn::Min(hn::Max(c, zero), one);
        const V sin2 = hn::Max(zero, hn::Sub(one, hn::Mul(cc, cc)));
        const V ratioFilm = hn::Div(n1, hn::IfThenElse(hn::Eq(film, zero), one, film)), ratioSub = hn::Div(n1, n2);
        const V sin2Sub = hn::Mul(hn::Mul(ratioSub, ratioSub), sin2);
        const V cosFilm = hn::Sqrt(hn::Max(zero, hn::Sub(one, hn::Mul(hn::Mul(ratioFilm, ratioFilm), sin2))));
        const V cosSub = hn::Sqrt(hn::Max(zero, hn::Sub(one, sin2Sub)));
        const V eta0 = hn::Mul(n1, cc), eta1 = hn::Mul(film, cosFilm), eta2 = hn::Mul(n2, cosSub);
        const V a1 = hn::Abs(hn::Sub(eta0, eta1)), a2 = hn::Add(eta0, eta1);
        const V b1 = hn::Abs(hn::Sub(eta1, eta2)), b2 = hn::Add(eta1, eta2);
        const V g = hn::Div(hn::Add(hn::Mul(a1, b2), hn::Mul(b1, a2)), hn::Add(hn::Mul(a2, b2), hn::Mul(a1, b1)));
        V bound = hn::Mul(g, g);
        const M none = hn::Or(hn::Or(hn::Eq(film, zero), hn::Eq(cc, zero)), hn::Ge(sin2Sub, one));
        bound = hn::IfThenElse(hn::Or(none, hn::Ge(bound, one)), one,
                               hn::Add(hn::Mul(bound, hn::Set(d, 1.0 + kReflectanceBoundMargin)),
                                       hn::Set(d, kReflectanceBoundFloor)));
        const M certain = hn::Ge(hn::Load(d, b.u + i), bound);
        hn::Store(hn::IfThenElseZero(certain, one), d, b.certain + i);

        // refract(direction, normal, n1, n2): the normal turned against the ray.
        const V cosIn = hn::Neg(hn::Add(hn::Add(hn::Mul(dx, nx), hn::Mul(dy, ny)), hn::Mul(dz, nz)));
        const M flip = hn::Lt(cosIn, zero);
        const V mx = hn::IfThenElse(flip, hn::Neg(nx), nx), my = hn::IfThenElse(flip, hn::Neg(ny), ny);
        const V mz = hn::IfThenElse(flip, hn::Neg(nz), nz), cosI = hn::IfThenElse(flip, hn::Neg(cosIn), cosIn);
        const V eta = hn::Div(n1, n2);
        const V sin2T = hn::Mul(hn::Mul(eta, eta), hn::Max(zero, hn::Sub(one, hn::Mul(cosI, cosI))));
        const M tir = hn::Ge(sin2T, one);
        hn::Store(hn::IfThenElseZero(tir, one), d, b.tir + i);
        const V cosT = hn::Sqrt(hn::Max(zero, hn::Sub(one, sin2T)));
        const V f = hn::Sub(hn::Mul(eta, cosI), cosT);
        V rx = hn::Add(hn::Mul(eta, dx), hn::Mul(f, mx)), ry = hn::Add(hn::Mul(eta, dy), hn::Mul(f, my));
        V rz = hn::Add(hn::Mul(eta, dz), hn::Mul(f, mz));
        normalize(rx, ry, rz);
        hn::Store(rx, d, b.rx + i), hn::Store(ry, d, b.ry + i), hn::Store(rz, d, b.rz + i);

        // glm::normalize(reflect(direction, normal)): d − (2 (d·n)) n.
        const V k2 = hn::Mul(two, hn::Add(hn::Add(hn::Mul(dx, nx), hn::Mul(dy, ny)), hn::Mul(dz, nz)));
        V fx = hn::Sub(dx, hn::Mul(k2, nx)), fy = hn::Sub(dy, hn::Mul(k2, ny)), fz = hn::Sub(dz, hn::Mul(k2, nz));
        normalize(fx, fy, fz);
        hn::Store(fx, d, b.fx + i), hn::Store(fy, d, b.fy + i), hn::Store(fz, d, b.fz + i);
    }
}

}  // namespace HWY_NAMESPACE
}  // namespace flare
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace flare {

HWY_EXPORT(SearchPhotons);
HWY_EXPORT(MeetSurfaces);

std::shared_ptr<const detail::PhotonSearchConstants> PhotonTracer::makePacketConstants() const {
    const LensSystem& lens = *lens_;
    const int n = lens.surfaceCount();
    auto made = std::make_shared<detail::PhotonSearchConstants>();
    detail::PhotonSearchConstants& constants = *made;
    constants.surfaces = n;
    constants.sensorZMm = lens.sensorZMm();
    for (int s = 0; s < n; ++s) {
        const Surface& surface = lens.surface(s);
        constants.vertexZMm[s] = surface.vertexZMm;
        constants.curvaturePerMm[s] = surface.curvature();
        constants.conicFactor[s] = 1.0 + surface.conic;
        constants.branchFactor[s] = constants.curvaturePerMm[s] * constants.conicFactor[s];
        constants.rimOuter2Mm2[s] = rims_[s].extentMm * rims_[s].extentMm * (1.0 + kSeamTolerance);
        constants.rimInner2Mm2[s] = rims_[s].extentMm * rims_[s].extentMm * (1.0 - kSeamTolerance);
        constants.rimZMm[s] = rims_[s].zMm;
        if (surface.hasPolynomial()) {
            const double c = surface.curvature();
            constants.anyPolynomial = true;
            constants.polynomial[s] = 1.0;
            constants.newtonConicFactor[s] = (1.0 + surface.conic) * c * c;
            for (int m = 0; m < kAsphereTerms; ++m) {
                constants.asphere[m][s] = surface.asphere[m];
                constants.slopeCoefficient[m][s] = (m + 2) * surface.asphere[m];
            }
        }
        constants.plane[s] = surface.isPlane() ? 1.0 : 0.0;
        constants.radiusMm[s] = surface.radiusMm;
        constants.centreZMm[s] = surface.vertexZMm + surface.radiusMm;
        const Coating* coating = lens.coating(s);
        if (coating && coating->layers.size() == 1 && !coating->ideal) constants.filmIndex[s] = coating->layers.front().index;
    }
    for (int g = 0; g <= n; ++g) {
        const double wall = cells_[g].wallRadiusMm;
        constants.wall2Mm2[g] = wall * wall;
        constants.wallOuter2Mm2[g] = wall * wall * (1.0 + kSeamTolerance);
        constants.hasMedium[g] = mediumOfCell_[g] >= 0 ? 1.0 : 0.0;
    }
    return made;
}

std::int64_t PhotonTracer::tracePacket(std::span<PacketPhoton> photons, std::span<PhotonHistory> histories,
                                       Scratch& scratch) const {
    // A bounce limit is checked at every reflection: such studies trace one photon at a time.
    if (maxBounces_ >= 0) {
        for (size_t i = 0; i < photons.size(); ++i)
            trace(*photons[i].indices, photons[i].ray, photons[i].rng, histories[i], scratch);
        return 0;
    }
    const LensSystem& lens = *lens_;
    const detail::PhotonSearchConstants& constants = *packetConstants_;

    // The walks in flight: their rays and cells in the lanes, the rest here.
    struct Walk {
        int photon = 0, reflections = 0, events = 0;
        PathKey key = 0;
        bool entered = false;
    };
    auto lanes = std::make_unique<detail::PhotonSearchLanes>();
    detail::PhotonSearchLanes& b = *lanes;
    Walk walks[detail::kPhotonBatch];
    int live = 0;
    size_t next = 0;
    std::int64_t laneEvents = 0;
    auto rayOf = [&](int j) {
        return Ray{{b.ox[j], b.oy[j], b.oz[j]}, {b.dx[j], b.dy[j], b.dz[j]}};
    };
    auto store = [&](int j, const Ray& ray) {
        b.ox[j] = ray.originMm.x, b.oy[j] = ray.originMm.y, b.oz[j] = ray.originMm.z;
        b.dx[j] = ray.direction.x, b.dy[j] = ray.direction.y, b.dz[j] = ray.direction.z;
    };
    // The photon leaves the lanes: trace()'s loop from the state before this event.
    auto handOver = [&](int j) {
        const Walk& w = walks[j];
        PacketPhoton& photon = photons[w.photon];
        const WalkStart start{rayOf(j), static_cast<int>(b.cell[j]), static_cast<int>(b.onSurface[j]),
                              w.reflections, w.events, w.key, w.entered};
        traceFrom(*photon.indices, start, photon.rng, histories[w.photon], scratch);
    };
    while (true) {
        while (live < detail::kPhotonBatch && next < photons.size()) {
            store(live, photons[next].ray);
            b.cell[live] = 0, b.onSurface[live] = -1;
            walks[live] = Walk{static_cast<int>(next)};
            ++live, ++next;
        }
        if (live == 0) break;
        // Pad to whole vectors of the widest kind (8 doubles) with copies of the first walk (their
        // results are not read).
        const int padded = (live + 7) / 8 * 8;
        for (int j = live; j < padded; ++j) {
            store(j, rayOf(0));
            b.cell[j] = b.cell[0], b.onSurface[j] = b.onSurface[0];
        }
        HWY_DYNAMIC_DISPATCH(SearchPhotons)(constants, b, static_cast<size_t>(padded));

        // Each walk's event: those that leave the lanes go to trace()'s loop, a surface between
        // equal media and the iris's opening are crossed here, and an interface is set up for
        // MeetSurfaces (its draw taken now: each photon has its own generator).
        bool leaves[detail::kPhotonBatch];
        for (int j = 0; j < live; ++j) {
            Walk& w = walks[j];
            b.meet[j] = 0.0;
            leaves[j] = true;
            const int cell = static_cast<int>(b.cell[j]);
            if (b.kind[j] == 0.0 || w.events >= kMaxPhotonEvents) {
                handOver(j);
                continue;
            }
            // trace()'s handling of a clean interface; anything else leaves the lanes first.
            const SpectralIndices& indices = *photons[w.photon].indices;
            const bool forward = b.kind[j] == 2.0;
            const int s = forward ? cell : cell - 1;
            const int other = forward ? cell + 1 : cell - 1;
            const Surface& surface = lens.surface(s);
            const glm::dvec3 p = rayOf(j).at(b.t[j]);
            const bool equalMedia = indices.n[cell] == indices.n[other];
            if (surface.isStop && !lens.iris().contains(p.x, p.y)) {
                // The blades. trace()'s scatterOff: an analog walk draws whether the paint
                // scatters; absorbed (most of the time, and always on black blades), the walk ends
                // here, as trace() would end it. Scattered, or with stray light weights, it goes to
                // trace() from before the draw.
                const double paint = materials_.irisAlbedo + materials_.irisGlossy;
                Rng rng = photons[w.photon].rng;
                const bool black = materials_.irisAlbedo <= 0.0 && materials_.irisGlossy <= 0.0;
                if (!stray_.weighted && (black || rng.uniform() >= paint)) {
                    photons[w.photon].rng = rng;
                    PhotonHistory& h = histories[w.photon];
                    h.restart();
                    h.fate = PhotonFate::AbsorbedIris;
                    h.entered = w.entered;
                    h.reflections = w.reflections;
                    h.events = w.events + 1;
                    ++laneEvents;
                } else {
                    handOver(j);
                }
                continue;
            }
            if ((!surface.isStop && p.x * p.x + p.y * p.y > surface.semiApertureMm * surface.semiApertureMm) ||
                (!surface.isStop && !equalMedia && hasContamination_ && contamination_[s].any())) {
                handOver(j);  // a retaining ring, dust or grease
                continue;
            }
            leaves[j] = false;
            ++w.events;
            ++laneEvents;
            b.ox[j] = p.x, b.oy[j] = p.y, b.oz[j] = p.z;
            b.onSurface[j] = s;
            if (surface.isStop || equalMedia) {
                if (s == 0 && forward && !surface.isStop) w.entered = true;
                b.cell[j] = other;
                continue;
            }
            b.px[j] = p.x, b.py[j] = p.y, b.pz[j] = p.z;
            b.n1[j] = indices.n[cell], b.n2[j] = indices.n[other];
            b.direction[j] = forward ? 1.0 : -1.0;
            b.surface[j] = s;
            b.u[j] = photons[w.photon].rng.uniform();
            // Spheres and planes in the lanes; a conic's normal (Surface::sagSlope) here.
            b.meet[j] = surface.isPlane() || (surface.conic == 0.0 && !surface.hasPolynomial()) ? 1.0 : 2.0;
        }
        for (int j = live; j < padded; ++j) b.meet[j] = 0.0;
        HWY_DYNAMIC_DISPATCH(MeetSurfaces)(constants, b, static_cast<size_t>(padded));

        int kept = 0;
        for (int j = 0; j < live; ++j) {
            if (leaves[j]) continue;
            Walk& w = walks[j];
            Ray ray = rayOf(j);
            if (b.meet[j] != 0.0) {
                const SpectralIndices& indices = *photons[w.photon].indices;
                const int s = static_cast<int>(b.surface[j]);
                const int direction = b.direction[j] > 0.0 ? 1 : -1;
                bool reflected = false;
                if (b.meet[j] == 1.0) {
                    // (A draw above the bound refracts: reflects() would answer false at once.)
                    reflected = (b.certain[j] == 0.0 && reflects(indices, s, direction, b.cosine[j], b.u[j])) || b.tir[j] != 0.0;
                    ray.direction = reflected ? glm::dvec3(b.fx[j], b.fy[j], b.fz[j]) : glm::dvec3(b.rx[j], b.ry[j], b.rz[j]);
                } else {
                    const glm::dvec3 normal = lens.surface(s).normalAt(ray.originMm);
                    const double cosThetaI = std::min(1.0, std::abs(glm::dot(normal, ray.direction)));
                    glm::dvec3 refracted;
                    reflected = reflects(indices, s, direction, cosThetaI, b.u[j]) ||
                                !refract(ray.direction, normal, b.n1[j], b.n2[j], &refracted);
                    ray.direction = reflected ? glm::normalize(reflect(ray.direction, normal)) : refracted;
                }
                if (reflected) {
                    w.key = withReflection(w.key, w.reflections++, s);
                } else {
                    if (s == 0 && direction > 0) w.entered = true;
                    b.cell[j] = direction > 0 ? s + 1 : s;
                }
            }
            // Keep the walk, moved down over those that left.
            store(kept, ray);
            if (kept != j) {
                b.cell[kept] = b.cell[j], b.onSurface[kept] = b.onSurface[j];
                walks[kept] = w;
            }
            ++kept;
        }
        live = kept;
    }
    return laneEvents;
}

}  // namespace flare
#endif  // HWY_ONCE
