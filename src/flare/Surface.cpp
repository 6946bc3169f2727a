#include "flare/Surface.h"

#include <cmath>

#include <glm/geometric.hpp>

namespace flare {

bool Surface::hasPolynomial() const {
    for (double a : asphere)
        if (a != 0.0) return true;
    return false;
}

bool Surface::sagMm(double r2, double* sag) const {
    const double c = curvature();
    const double q = 1.0 - (1.0 + conic) * c * c * r2;
    if (q < 0.0) return false;
    // c r² / (1 + √q) avoids the cancellation of the textbook R − √(R² − r²).
    double z = c * r2 / (1.0 + std::sqrt(q));
    double power = r2 * r2;  // r⁴
    for (double a : asphere) {
        z += a * power;
        power *= r2;
    }
    *sag = z;
    return true;
}

double Surface::sagSlope(double r2) const {
    const double c = curvature();
    const double q = 1.0 - (1.0 + conic) * c * c * r2;
    double slope = q > 0.0 ? 0.5 * c / std::sqrt(q) : 0.0;
    double power = r2;  // d(A_{2m} r^{2m})/d(r²) = m A_{2m} r^{2(m-1)}
    for (int i = 0; i < kAsphereTerms; ++i) {
        slope += (i + 2) * asphere[i] * power;
        power *= r2;
    }
    return slope;
}

glm::dvec3 Surface::normalAt(const glm::dvec3& p) const {
    const bool polynomial = hasPolynomial();
    if (radiusMm == 0.0 && !polynomial) return {0.0, 0.0, 1.0};
    // A sphere's normal points from the surface to its centre (0, 0, vertex + R); dividing by R
    // orients it towards +z for either sign of R.
    if (conic == 0.0 && !polynomial) return (glm::dvec3(0.0, 0.0, vertexZMm + radiusMm) - p) / radiusMm;
    const double s = sagSlope(p.x * p.x + p.y * p.y);
    return glm::normalize(glm::dvec3(-2.0 * s * p.x, -2.0 * s * p.y, 1.0));
}

namespace {

// Roots of a t² + 2 b t + c = 0 without cancellation. Returns the number of real roots.
int solveQuadratic(double a, double b, double c, double* t0, double* t1) {
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
SurfaceHit intersectConic(const Surface& s, const glm::dvec3& o, const glm::dvec3& d, double tMin) {
    const double c = s.curvature();
    const double k1 = 1.0 + s.conic;
    const double a = c * (d.x * d.x + d.y * d.y + k1 * d.z * d.z);
    const double b = c * (o.x * d.x + o.y * d.y + k1 * o.z * d.z) - d.z;
    const double cc = c * (o.x * o.x + o.y * o.y + k1 * o.z * o.z) - 2.0 * o.z;
    double t0 = 0.0, t1 = 0.0;
    if (solveQuadratic(a, b, cc, &t0, &t1) == 0) return {};
    for (double t : {t0, t1}) {
        if (t <= tMin) continue;
        const double z = o.z + t * d.z;
        if (1.0 - c * k1 * z > 0.0) return {HitStatus::Hit, t};
    }
    return {};
}

}  // namespace

SurfaceHit intersect(const Surface& s, const Ray& ray, double tMinMm) {
    const glm::dvec3 o = ray.originMm - glm::dvec3(0.0, 0.0, s.vertexZMm);
    const glm::dvec3& d = ray.direction;
    SurfaceHit hit = intersectConic(s, o, d, tMinMm);
    if (!s.hasPolynomial()) return hit;

    // Newton on F(t) = z(t) − sag(r²(t)), started from the conic hit (or the vertex plane).
    double t = hit.status == HitStatus::Hit ? hit.tMm : (d.z != 0.0 ? -o.z / d.z : 0.0);
    for (int i = 0; i < kMaxNewtonIterations; ++i) {
        const glm::dvec3 p = o + t * d;
        const double r2 = p.x * p.x + p.y * p.y;
        double sag = 0.0;
        if (!s.sagMm(r2, &sag)) return {HitStatus::NewtonDiverged, 0.0};
        const double f = p.z - sag;
        const double df = d.z - 2.0 * s.sagSlope(r2) * (p.x * d.x + p.y * d.y);
        if (df == 0.0 || !std::isfinite(df)) return {HitStatus::NewtonDiverged, 0.0};
        const double step = f / df;
        t -= step;
        if (std::abs(step) < 1e-12 * (1.0 + std::abs(t))) {
            if (t <= tMinMm) return {};
            return {HitStatus::Hit, t};
        }
    }
    return {HitStatus::NewtonDiverged, 0.0};
}

}  // namespace flare
