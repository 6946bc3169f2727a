#include "flare/optics/Surface.h"

#include <algorithm>
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

double Surface::profileSagMm(double rMm, double edgeMm) const {
    double r2 = std::min(rMm, edgeMm);
    r2 *= r2;
    // A prolate ellipsoid or sphere (1 + k > 0) exists out to r² = 1 / ((1 + k) c²).
    const double k1c2 = (1.0 + conic) * curvature() * curvature();
    if (k1c2 > 0.0) r2 = std::min(r2, 1.0 / k1c2);
    double sag = 0.0;
    while (!sagMm(r2, &sag)) r2 *= 0.998;  // rounding at the conic's end
    return sag;
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

SurfaceHit intersectConicFromAfar(const Surface& s, const glm::dvec3& o, const glm::dvec3& d, double tMin) {
    // Out of line: both intersect() and the batch tracers call this same code, so their results
    // still agree to the last bit.
    const double tShift = -glm::dot(o, d) / glm::dot(d, d);
    SurfaceHit hit = intersectConic(s, o + tShift * d, d, tMin - tShift, true);
    if (hit.status == HitStatus::Hit) hit.tMm += tShift;
    return hit;
}

SurfaceHit intersect(const Surface& s, const Ray& ray, double tMinMm) {
    const glm::dvec3 o = ray.originMm - glm::dvec3(0.0, 0.0, s.vertexZMm);
    const glm::dvec3& d = ray.direction;
    SurfaceHit hit = intersectConic(s, o, d, tMinMm);
    if (!s.hasPolynomial()) return hit;

    // Newton on F(t) = z(t) − sag(r²(t)), started from the conic hit (or the vertex plane). The
    // sag and its slope are evaluated together (the values of sagMm and sagSlope, sharing the
    // curvature, the square root and the powers of r²): this loop is most of an asphere's cost.
    const double c = s.curvature();
    const double conicFactor = (1.0 + s.conic) * c * c;
    double t = hit.status == HitStatus::Hit ? hit.tMm : (d.z != 0.0 ? -o.z / d.z : 0.0);
    for (int i = 0; i < kMaxNewtonIterations; ++i) {
        const glm::dvec3 p = o + t * d;
        const double r2 = p.x * p.x + p.y * p.y;
        const double q = 1.0 - conicFactor * r2;
        if (q < 0.0) return {HitStatus::NewtonDiverged, 0.0};
        const double root = std::sqrt(q);
        double sag = c * r2 / (1.0 + root);
        double slope = q > 0.0 ? 0.5 * c / root : 0.0;
        double power = r2;  // r^(2k−2) for the term A_{2k} r^{2k}, k = m + 2
        for (int m = 0; m < kAsphereTerms; ++m) {
            slope += (m + 2) * s.asphere[m] * power;
            power *= r2;
            sag += s.asphere[m] * power;
        }
        const double f = p.z - sag;
        const double df = d.z - 2.0 * slope * (p.x * d.x + p.y * d.y);
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
