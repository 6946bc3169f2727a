// One optical surface of a lens at a resolved zoom/focus state: a rotationally symmetric even
// asphere (sphere, plane and conic are special cases) or the aperture stop (a plane carrying the
// iris). Sag is measured from the surface's vertex along +z.
#pragma once

#include <array>
#include <cstdint>

#include "flare/Ray.h"

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

}  // namespace flare
