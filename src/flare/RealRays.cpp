#include "flare/RealRays.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>

#include "flare/Fresnel.h"
#include "flare/Paraxial.h"
#include "flare/SequentialTracer.h"

namespace flare {

namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

// Refracts through surfaces 0..stop−1 and returns the point on the stop plane (no clipping).
std::optional<glm::dvec3> pointOnStop(const LensSystem& lens, const SpectralIndices& indices, Ray ray) {
    const int stop = lens.stopIndex();
    for (int k = 0; k < stop; ++k) {
        const Surface& s = lens.surface(k);
        const SurfaceHit hit = intersect(s, ray);
        if (hit.status != HitStatus::Hit) return std::nullopt;
        ray.originMm = ray.at(hit.tMm);
        glm::dvec3 refracted;
        if (!refract(ray.direction, s.normalAt(ray.originMm), indices.n[k], indices.n[k + 1], &refracted))
            return std::nullopt;
        ray.direction = refracted;
    }
    if (ray.direction.z <= 0.0) return std::nullopt;
    const double t = (lens.surface(stop).vertexZMm - ray.originMm.z) / ray.direction.z;
    return ray.at(t);
}

}  // namespace

double objectSpaceStartZMm(const LensSystem& lens) {
    const Surface& first = lens.surface(0);
    double lowest = 0.0;
    for (int k = 0; k <= 16; ++k) {
        const double r = first.semiApertureMm * k / 16.0;
        double sag = 0.0;
        if (first.sagMm(r * r, &sag)) lowest = std::min(lowest, sag);
    }
    return first.vertexZMm + lowest - 1.0;
}

std::optional<Ray> aimAtStop(const LensSystem& lens, const SpectralIndices& indices, double fieldRad,
                             double stopXMm, double stopYMm, const Ray* guess) {
    const double zStart = objectSpaceStartZMm(lens);
    const glm::dvec3 direction(std::sin(fieldRad), 0.0, std::cos(fieldRad));
    double x = 0.0, y = 0.0;
    if (guess) {
        const double t = (zStart - guess->originMm.z) / guess->direction.z;
        x = guess->originMm.x + t * guess->direction.x;
        y = guess->originMm.y + t * guess->direction.y;
    } else {
        const ParaxialData para = analyseParaxial(lens, indices.wavelengthNm);
        const double m = para.entrancePupilDiameterMm / (2.0 * lens.iris().radiusMm());
        x = stopXMm * m + (zStart - para.entrancePupilZMm) * std::tan(fieldRad);
        y = stopYMm * m;
    }
    auto residual = [&](double px, double py, glm::dvec2* r) {
        const std::optional<glm::dvec3> p = pointOnStop(lens, indices, Ray{{px, py, zStart}, direction});
        if (!p) return false;
        *r = glm::dvec2(p->x - stopXMm, p->y - stopYMm);
        return true;
    };
    glm::dvec2 r;
    if (!residual(x, y, &r)) return std::nullopt;
    const double scale = std::max(1.0, lens.iris().radiusMm());
    for (int iteration = 0; iteration < 60; ++iteration) {
        if (glm::length(r) < 1e-10 * scale) return Ray{{x, y, zStart}, direction};
        const double h = 1e-6 * scale;
        glm::dvec2 rx, ry;
        if (!residual(x + h, y, &rx) || !residual(x, y + h, &ry)) return std::nullopt;
        const double a = (rx.x - r.x) / h, b = (ry.x - r.x) / h;
        const double c = (rx.y - r.y) / h, d = (ry.y - r.y) / h;
        const double det = a * d - b * c;
        if (det == 0.0 || !std::isfinite(det)) return std::nullopt;
        double dx = -(d * r.x - b * r.y) / det;
        double dy = -(-c * r.x + a * r.y) / det;
        // Damping: halve the step until the residual decreases.
        for (int halving = 0; halving < 30; ++halving) {
            glm::dvec2 trial;
            if (residual(x + dx, y + dy, &trial) && glm::length(trial) < glm::length(r)) {
                x += dx;
                y += dy;
                r = trial;
                break;
            }
            dx *= 0.5;
            dy *= 0.5;
            if (halving == 29) return std::nullopt;
        }
    }
    return std::nullopt;
}

std::optional<double> chiefRayImageHeightMm(const LensSystem& lens, const SpectralIndices& indices,
                                            double fieldRad, const Ray* guess) {
    const std::optional<Ray> chief = aimAtStop(lens, indices, fieldRad, 0.0, 0.0, guess);
    if (!chief) return std::nullopt;
    TraceOptions options;
    options.clipApertures = false;
    options.fresnelWeights = false;
    const TraceResult result = traceForward(lens, indices, *chief, options);
    if (!result.ok()) return std::nullopt;
    return result.ray.originMm.x;
}

std::optional<double> realFieldOfViewDeg(const LensSystem& lens, double wavelengthNm) {
    const SpectralIndices indices = lens.indicesAt(wavelengthNm);
    const double target = lens.sensorHalfDiagonalMm();
    // Walk out in field with continuation (each solution seeds the next), then bisect.
    std::optional<Ray> previous;
    double previousDeg = 0.0;
    for (double deg = 0.5; deg <= 89.5 + 1e-9; deg += 0.5) {
        const std::optional<Ray> chief =
            aimAtStop(lens, indices, deg * kDegToRad, 0.0, 0.0, previous ? &*previous : nullptr);
        if (!chief) return std::nullopt;
        const std::optional<double> h = chiefRayImageHeightMm(lens, indices, deg * kDegToRad, &*chief);
        if (!h) return std::nullopt;
        if (std::abs(*h) >= target) {
            double lo = previousDeg, hi = deg;
            Ray seed = *chief;
            for (int i = 0; i < 40; ++i) {
                const double mid = 0.5 * (lo + hi);
                const std::optional<Ray> aimed = aimAtStop(lens, indices, mid * kDegToRad, 0.0, 0.0, &seed);
                if (!aimed) break;
                const std::optional<double> hm = chiefRayImageHeightMm(lens, indices, mid * kDegToRad, &*aimed);
                if (!hm) break;
                seed = *aimed;
                (std::abs(*hm) >= target ? hi : lo) = mid;
            }
            return 2.0 * 0.5 * (lo + hi);
        }
        previous = chief;
        previousDeg = deg;
    }
    return std::nullopt;
}

}  // namespace flare
