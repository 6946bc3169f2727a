// One optical surface of a lens at a resolved zoom/focus state: a rotationally symmetric even
// asphere (sphere, plane and conic are special cases) or the aperture stop (a plane carrying the
// iris). Sag is measured from the surface's vertex along +z.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include "flare/core/Ray.h"

namespace flare {

inline constexpr int kAsphereTerms = 7;  // A4, A6, ..., A16

struct Surface {
    double radiusMm = 0.0;  // 0 for a plane; > 0 when the centre of curvature is on the sensor side
    double conic = 0.0;     // k: 0 sphere, −1 paraboloid
    std::array<double, kAsphereTerms> asphere{};  // A4 r⁴ + A6 r⁶ + ... + A16 r¹⁶
    double semiApertureMm = 0.0;     // clear radius
    double mechSemiDiameterMm = 0.0; // element edge radius (≥ semiApertureMm)
    double vertexZMm = 0.0;
    bool isStop = false;
    int fileLine = 0;  // line of the row in its prescription file (0 if generated)

    double curvature() const { return radiusMm == 0.0 ? 0.0 : 1.0 / radiusMm; }
    bool hasPolynomial() const;
    bool isPlane() const { return radiusMm == 0.0 && !hasPolynomial(); }

    // Sag z(r) relative to the vertex as a function of r² (mm²). Returns false where the conic
    // square root is undefined (beyond the surface's extent).
    bool sagMm(double r2, double* sag) const;
    // The sag of the surface as mounted: the surface out to radius edgeMm (its clear radius), flat
    // beyond it (the element's bevel under its retaining ring lies at the rim's z), and flat beyond
    // the end of a conic that closes before edgeMm. The photon tracer closes its cells this way,
    // and the builder checks surfaces against each other along the same profile.
    double profileSagMm(double rMm, double edgeMm) const;
    // dz/d(r²), used for normals and the Newton step.
    double sagSlope(double r2) const;
    // Unit normal at a point on the surface (lens space), pointing towards +z.
    glm::dvec3 normalAt(const glm::dvec3& pointMm) const;
};

enum class HitStatus : std::uint8_t { Hit, Miss, NewtonDiverged };

struct SurfaceHit {
    HitStatus status = HitStatus::Miss;
    double tMm = 0.0;
};

// Nearest intersection with t > tMinMm of the ray with the surface's vertex-side branch.
// Spheres and conics are solved in closed form with a cancellation-free quadratic; aspheres are
// refined by Newton's method from the conic solution, at most kMaxNewtonIterations steps.
inline constexpr int kMaxNewtonIterations = 32;
SurfaceHit intersect(const Surface& surface, const Ray& ray, double tMinMm = 1e-9);

// The two helpers below are inline so that batch tracers (BundleTracer) compile the same
// operations as intersect() into their own loops and get the same results to the last bit.

// Roots of a t² + 2 b t + c = 0 without cancellation. Returns the number of real roots.
inline int solveQuadratic(double a, double b, double c, double* t0, double* t1) {
    if (a == 0.0) {
        if (b == 0.0) return 0;
        *t0 = *t1 = -c / (2.0 * b);
        return 1;
    }
    const double disc = b * b - a * c;
    if (disc < 0.0) return 0;
    const double q = -(b + std::copysign(std::sqrt(disc), b));
    *t0 = q / a;
    *t1 = q != 0.0 ? c / q : *t0;
    if (*t0 > *t1) std::swap(*t0, *t1);
    return 2;
}

// Intersection with the conic part (polynomial terms ignored), in vertex-local coordinates.
// The conic r² − 2Rz + (1+k)z² = 0 is written with curvature c as c r² − 2z + c(1+k)z² = 0, which
// stays finite for a plane (c = 0). The vertex branch satisfies 1 − c(1+k)z > 0.
//
// From an origin o far from the vertex the quadratic's coefficients grow as c |o|² while its roots
// do not: the discriminant cancels, and the hit misses the surface by ~ε |o|² |c| / cos θ. So when
// |c cc| (≈ (|c| |o|)², cc being the conic's value at o) exceeds kConicFarOrigin², the ray is solved
// from its point nearest the vertex instead (intersectConicFromAfar): that costs one rounding of
// that point, ε |o|, as if the ray had been given there. Nearer origins lose a few ε at most and
// pay only for the test.
inline constexpr double kConicFarOrigin = 4.0;  // in radii of curvature
[[gnu::cold]] SurfaceHit intersectConicFromAfar(const Surface& s, const glm::dvec3& o, const glm::dvec3& d, double tMin);

inline SurfaceHit intersectConic(const Surface& s, const glm::dvec3& o, const glm::dvec3& d, double tMin,
                                 bool nearest = false) {
    const double c = s.curvature();
    const double k1 = 1.0 + s.conic;
    const double a = c * (d.x * d.x + d.y * d.y + k1 * d.z * d.z);
    const double b = c * (o.x * d.x + o.y * d.y + k1 * o.z * d.z) - d.z;
    const double cc = c * (o.x * o.x + o.y * o.y + k1 * o.z * o.z) - 2.0 * o.z;
    if (!nearest && std::abs(c * cc) > kConicFarOrigin * kConicFarOrigin) [[unlikely]]
        return intersectConicFromAfar(s, o, d, tMin);
    double t0 = 0.0, t1 = 0.0;
    if (solveQuadratic(a, b, cc, &t0, &t1) == 0) return {};
    for (double t : {t0, t1}) {
        if (t <= tMin) continue;
        const double z = o.z + t * d.z;
        if (1.0 - c * k1 * z > 0.0) return {HitStatus::Hit, t};
    }
    return {};
}

}  // namespace flare
