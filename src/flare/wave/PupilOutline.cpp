#include "flare/wave/PupilOutline.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>

#include "flare/optics/SequentialTracer.h"

namespace flare {

namespace {

constexpr double kPi = std::numbers::pi;

struct PlaneTracer {
    const LensSystem& lens;
    SpectralIndices indices;
    glm::dvec3 originMm, u, v;
    double halfWMm, halfHMm, pixelMm;
    long* traced;

    // Where the ray through plane point p travelling along `direction` lands, if it does.
    bool land(const glm::dvec2& p, const glm::dvec3& direction, glm::dvec2* pixel = nullptr) const {
        ++*traced;
        TraceOptions options;
        options.fresnelWeights = false;
        const TraceResult r = traceForward(lens, indices, Ray{originMm + p.x * u + p.y * v, direction}, options);
        if (!r.ok()) return false;
        if (pixel)  // camera orientation: the sensor image rotated by 180° (as the preview)
            *pixel = {(halfWMm - r.ray.originMm.x) / pixelMm, (halfHMm + r.ray.originMm.y) / pixelMm};
        return true;
    }

    glm::dvec2 centroidPx(const std::vector<glm::dvec2>& points, const glm::dvec3& direction, int* count) const {
        glm::dvec2 sum{0.0};
        int n = 0;
        for (const glm::dvec2& p : points) {
            glm::dvec2 px;
            if (land(p, direction, &px)) sum += px, ++n;
        }
        *count = n;
        return n > 0 ? sum / double(n) : sum;
    }
};

}  // namespace

PupilOutline tracePupilOutline(const LensSystem& lens, const glm::dvec3& directionIn, const PupilOutlineOptions& options) {
    PupilOutline out;
    const glm::dvec3 d = glm::normalize(directionIn);
    glm::dvec3 u = glm::dvec3(1.0, 0.0, 0.0) - d.x * d;
    if (glm::length(u) < 1e-6) u = glm::dvec3(0.0, 1.0, 0.0) - d.y * d;
    u = glm::normalize(u);
    out.axisU = u;
    out.axisV = glm::cross(d, u);

    double largestSemiMm = 0.0;
    for (const Surface& s : lens.surfaces()) largestSemiMm = std::max(largestSemiMm, s.semiApertureMm);
    const double frontZ = lens.surfaceCount() > 0 ? lens.surface(0).vertexZMm : 0.0;
    const double startZ = frontZ - 2.0 * largestSemiMm - 10.0;
    const double tanField = std::sqrt(std::max(0.0, 1.0 - d.z * d.z)) / std::max(d.z, 0.05);
    const double searchMm = 1.5 * largestSemiMm + (lens.sensorZMm() - startZ) * tanField;

    const double pixelMm = lens.sensor().widthMm / options.widthPx;
    PlaneTracer tracer{lens, lens.indicesAt(options.wavelengthNm), {0.0, 0.0, startZ}, u, out.axisV,
                       0.5 * lens.sensor().widthMm, 0.5 * lens.sensor().heightMm, pixelMm, &out.tracedRays};

    // The live region on a seed grid: its centroid, and the points well inside it (all four
    // neighbours live) whose image moves with the direction without edge noise.
    const int n = options.seedGrid;
    const double step = 2.0 * searchMm / n;
    std::vector<char> live(static_cast<size_t>(n) * n, 0);
    glm::dvec2 centre{0.0};
    int liveCount = 0;
    auto gridPoint = [&](int i, int j) { return glm::dvec2(-searchMm + (i + 0.5) * step, -searchMm + (j + 0.5) * step); };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
            if (tracer.land(gridPoint(i, j), d)) {
                live[static_cast<size_t>(j) * n + i] = 1;
                centre += gridPoint(i, j);
                ++liveCount;
            }
    if (liveCount == 0) return out;
    centre /= double(liveCount);
    if (!tracer.land(centre, d)) {  // not star-shaped about its centroid: start from the nearest live point
        double best = 1e300;
        glm::dvec2 nearest = centre;
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                if (live[static_cast<size_t>(j) * n + i] && glm::length(gridPoint(i, j) - centre) < best)
                    best = glm::length(gridPoint(i, j) - centre), nearest = gridPoint(i, j);
        centre = nearest;
    }
    std::vector<glm::dvec2> interior;
    for (int j = 1; j + 1 < n; ++j)
        for (int i = 1; i + 1 < n; ++i) {
            auto at = [&](int a, int b) { return live[static_cast<size_t>(b) * n + a] != 0; };
            if (at(i, j) && at(i - 1, j) && at(i + 1, j) && at(i, j - 1) && at(i, j + 1)) interior.push_back(gridPoint(i, j));
        }
    if (interior.empty()) interior.push_back(centre);

    // Each outline vertex: march out from the centre by half a grid step until the ray dies, then
    // bisect between the last live and the first dead point.
    out.outlineMm.reserve(options.angles);
    for (int a = 0; a < options.angles; ++a) {
        const double phi = 2.0 * kPi * a / options.angles;
        const glm::dvec2 dir{std::cos(phi), std::sin(phi)};
        double lo = 0.0, hi = 0.5 * step;
        while (hi < 4.0 * searchMm && tracer.land(centre + hi * dir, d)) lo = hi, hi += 0.5 * step;
        for (int b = 0; b < options.bisections; ++b) {
            const double mid = 0.5 * (lo + hi);
            (tracer.land(centre + mid * dir, d) ? lo : hi) = mid;
        }
        out.outlineMm.push_back(centre + lo * dir);
    }

    // The image's centroid and its motion with the direction (central differences).
    int count = 0;
    out.imagePx = tracer.centroidPx(interior, d, &count);
    const double tilt = 1e-5;
    const glm::dvec3 axes[2] = {u, out.axisV};
    for (int c = 0; c < 2; ++c) {
        int plus = 0, minus = 0;
        const glm::dvec2 p = tracer.centroidPx(interior, glm::normalize(d + tilt * axes[c]), &plus);
        const glm::dvec2 m = tracer.centroidPx(interior, glm::normalize(d - tilt * axes[c]), &minus);
        if (plus != count || minus != count) return out;  // the bundle is cut: no stable image
        out.pxPerRad[c] = (p - m) / (2.0 * tilt);
    }
    out.found = count > 0;
    return out;
}

std::vector<glm::dvec2> irisOutline(const Iris& iris, int samples) {
    std::vector<double> angles;
    for (int i = 0; i < samples; ++i) angles.push_back(2.0 * kPi * i / samples);
    for (int k = 0; k < iris.blades(); ++k)
        angles.push_back(std::fmod(iris.rotationRad() + 2.0 * kPi * k / iris.blades() + 4.0 * kPi, 2.0 * kPi));
    std::sort(angles.begin(), angles.end());
    std::vector<glm::dvec2> outline;
    const double r = iris.radiusMm();
    for (double phi : angles) {
        const glm::dvec2 dir{std::cos(phi), std::sin(phi)};
        // margin = (r/ρ(φ))² − 1 at any point of direction φ, so ρ(φ) = r/√(margin + 1).
        const double rho = r / std::sqrt(iris.margin(r * dir.x, r * dir.y) + 1.0);
        if (!outline.empty() && glm::length(rho * dir - outline.back()) < 1e-12 * r) continue;
        outline.push_back(rho * dir);
    }
    return outline;
}

}  // namespace flare
