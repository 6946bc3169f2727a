#include "flare/optics/RealRays.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>

#include "flare/optics/Fresnel.h"
#include "flare/optics/Paraxial.h"
#include "flare/optics/SequentialTracer.h"

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
    // Rays of one field are parallel; each is named by where it crosses the plane through the
    // paraxial entrance pupil's centre perpendicular to the direction (coordinates x along e1, y
    // along e2). This stays well conditioned up to 90° fields, where a plane z = const does not.
    const ParaxialData para = analyseParaxial(lens, indices.wavelengthNm);
    const glm::dvec3 direction(std::sin(fieldRad), 0.0, std::cos(fieldRad));
    const glm::dvec3 e1(std::cos(fieldRad), 0.0, -std::sin(fieldRad));
    const glm::dvec3 e2(0.0, 1.0, 0.0);
    const glm::dvec3 pupil(0.0, 0.0, para.entrancePupilZMm);
    double farMm = lens.totalTrackMm() + std::abs(para.entrancePupilZMm);
    for (int i = 0; i < lens.surfaceCount(); ++i) farMm += lens.surface(i).semiApertureMm;
    auto rayAt = [&](double a, double b) { return Ray{pupil + a * e1 + b * e2 - farMm * direction, direction}; };

    double x = 0.0, y = 0.0;
    if (guess) {
        x = glm::dot(guess->originMm - pupil, e1);
        y = glm::dot(guess->originMm - pupil, e2);
    } else {
        const double m = para.entrancePupilDiameterMm / (2.0 * lens.iris().radiusMm());
        x = stopXMm * m * std::cos(fieldRad);
        y = stopYMm * m;
    }
    auto residual = [&](double a, double b, glm::dvec2* r) {
        const std::optional<glm::dvec3> p = pointOnStop(lens, indices, rayAt(a, b));
        if (!p) return false;
        *r = glm::dvec2(p->x - stopXMm, p->y - stopYMm);
        return true;
    };
    glm::dvec2 r;
    if (!residual(x, y, &r)) return std::nullopt;
    const double scale = std::max(1.0, lens.iris().radiusMm());
    for (int iteration = 0; iteration < 60; ++iteration) {
        if (glm::length(r) < 1e-10 * scale) {
            // Report the ray from a point just in front of the lens, on its own line.
            Ray ray = rayAt(x, y);
            const double zStart = objectSpaceStartZMm(lens);
            if (direction.z > 1e-6 && ray.originMm.z < zStart)
                ray.originMm = ray.at((zStart - ray.originMm.z) / direction.z);
            return ray;
        }
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

RealFieldOfView realFieldOfView(const LensSystem& lens, double wavelengthNm) {
    const SpectralIndices indices = lens.indicesAt(wavelengthNm);
    const double target = lens.sensorHalfDiagonalMm();
    // Walk out in field with continuation (each solution seeds the next), then bisect.
    std::optional<Ray> previous;
    double previousDeg = 0.0;
    double last = 0.0;
    for (double deg = 0.5; deg <= 89.9 + 1e-9; deg += deg < 89.5 ? 0.5 : 0.4) {
        const std::optional<Ray> chief =
            aimAtStop(lens, indices, deg * kDegToRad, 0.0, 0.0, previous ? &*previous : nullptr);
        if (!chief) return {};
        const std::optional<double> h = chiefRayImageHeightMm(lens, indices, deg * kDegToRad, &*chief);
        if (!h) return {};
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
            return {RealFieldOfView::Kind::Reached, lo + hi, 0.0};
        }
        previous = chief;
        previousDeg = deg;
        last = *h;
    }
    return {RealFieldOfView::Kind::Beyond180, 0.0, std::abs(last)};
}

}  // namespace flare
