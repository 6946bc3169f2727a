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

// The plane normal to the light in front of the lens, and the live region's seed grid on it.
struct SeedRegion {
    glm::dvec3 direction, u, v;
    double searchMm = 0.0, step = 0.0;
    glm::dvec2 centre{0.0};
    std::vector<glm::dvec2> interior;  // live seed points whose four neighbours are live
    bool found = false;
};

PlaneTracer planeTracer(const LensSystem& lens, const glm::dvec3& directionIn, const PupilOutlineOptions& options,
                        long* traced, SeedRegion& region) {
    const glm::dvec3 d = glm::normalize(directionIn);
    glm::dvec3 u = glm::dvec3(1.0, 0.0, 0.0) - d.x * d;
    if (glm::length(u) < 1e-6) u = glm::dvec3(0.0, 1.0, 0.0) - d.y * d;
    u = glm::normalize(u);
    region.direction = d;
    region.u = u;
    region.v = glm::cross(d, u);

    double largestSemiMm = 0.0;
    for (const Surface& s : lens.surfaces()) largestSemiMm = std::max(largestSemiMm, s.semiApertureMm);
    const double frontZ = lens.surfaceCount() > 0 ? lens.surface(0).vertexZMm : 0.0;
    const double startZ = frontZ - 2.0 * largestSemiMm - 10.0;
    const double tanField = std::sqrt(std::max(0.0, 1.0 - d.z * d.z)) / std::max(d.z, 0.05);
    region.searchMm = 1.5 * largestSemiMm + (lens.sensorZMm() - startZ) * tanField;
    const double pixelMm = lens.sensor().widthMm / options.widthPx;
    return PlaneTracer{lens, lens.indicesAt(options.wavelengthNm), {0.0, 0.0, startZ}, u, region.v,
                       0.5 * lens.sensor().widthMm, 0.5 * lens.sensor().heightMm, pixelMm, traced};
}

// The live region on a seed grid: its centroid, and the points well inside it (all four
// neighbours live) whose image moves with the direction without edge noise. A region smaller
// than the grid's cells (a fisheye's pupil seen from far off axis, a small stop) is looked for on
// grids up to eight times finer, centred on the first live point found.
void seedRegion(const PlaneTracer& tracer, const PupilOutlineOptions& options, SeedRegion& region) {
    const glm::dvec3 d = region.direction;
    glm::dvec2 gridCentre{0.0};
    double halfExtent = region.searchMm;
    int n = options.seedGrid;
    for (int refinement = 0; refinement < 5; ++refinement) {
        const double step = 2.0 * halfExtent / n;
        std::vector<char> live(static_cast<size_t>(n) * n, 0);
        int liveCount = 0;
        glm::dvec2 centre{0.0};
        auto gridPoint = [&](int i, int j) {
            return gridCentre + glm::dvec2(-halfExtent + (i + 0.5) * step, -halfExtent + (j + 0.5) * step);
        };
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                if (tracer.land(gridPoint(i, j), d)) {
                    live[static_cast<size_t>(j) * n + i] = 1;
                    centre += gridPoint(i, j);
                    ++liveCount;
                }
        std::vector<glm::dvec2> interior;
        for (int j = 1; j + 1 < n; ++j)
            for (int i = 1; i + 1 < n; ++i) {
                auto at = [&](int a, int b) { return live[static_cast<size_t>(b) * n + a] != 0; };
                if (at(i, j) && at(i - 1, j) && at(i + 1, j) && at(i, j - 1) && at(i, j + 1)) interior.push_back(gridPoint(i, j));
            }
        if (liveCount == 0) {  // nothing: a twice finer grid over the same area
            n *= 2;
            continue;
        }
        centre /= double(liveCount);
        if (interior.size() < 8 && refinement < 4) {  // too few cells inside: zoom onto the region
            double reach = 0.0;
            for (int j = 0; j < n; ++j)
                for (int i = 0; i < n; ++i)
                    if (live[static_cast<size_t>(j) * n + i]) reach = std::max(reach, glm::length(gridPoint(i, j) - centre));
            gridCentre = centre;
            halfExtent = reach + 2.0 * step;
            n = options.seedGrid;
            continue;
        }
        region.step = step;
        region.centre = centre;
        if (!tracer.land(region.centre, d)) {  // not star-shaped about its centroid: the nearest live point
            double best = 1e300;
            for (int j = 0; j < n; ++j)
                for (int i = 0; i < n; ++i)
                    if (live[static_cast<size_t>(j) * n + i] && glm::length(gridPoint(i, j) - centre) < best)
                        best = glm::length(gridPoint(i, j) - centre), region.centre = gridPoint(i, j);
        }
        region.interior = interior.empty() ? std::vector<glm::dvec2>{region.centre} : interior;
        region.found = true;
        return;
    }
}

}  // namespace

PupilOutline tracePupilOutline(const LensSystem& lens, const glm::dvec3& directionIn, const PupilOutlineOptions& options) {
    PupilOutline out;
    SeedRegion region;
    const PlaneTracer tracer = planeTracer(lens, directionIn, options, &out.tracedRays, region);
    out.axisU = region.u;
    out.axisV = region.v;
    seedRegion(tracer, options, region);
    if (!region.found) return out;
    const glm::dvec3 d = region.direction;
    const glm::dvec2 centre = region.centre;
    const double step = region.step, searchMm = region.searchMm;
    const std::vector<glm::dvec2>& interior = region.interior;

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
    const glm::dvec3 axes[2] = {region.u, region.v};
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

SurfaceDeflection traceSurfaceDeflection(const LensSystem& lens, const glm::dvec3& directionIn, int surface,
                                         const PupilOutlineOptions& options) {
    SurfaceDeflection out;
    long traced = 0;
    SeedRegion region;
    const PlaneTracer tracer = planeTracer(lens, directionIn, options, &traced, region);
    seedRegion(tracer, options, region);
    if (!region.found || surface < 0 || surface >= lens.surfaceCount()) return out;
    out.mediumIndex = tracer.indices.n[surface];

    // Each interior ray's segment arriving at the surface: where it starts (a surface, or the
    // plane) and its direction; the deflection axes are normal to the first one.
    struct Segment {
        glm::dvec3 originMm, direction;
        int start;
    };
    std::vector<Segment> segments;
    for (const glm::dvec2& p : region.interior) {
        std::vector<glm::dvec3> points;
        std::vector<int> surfaces;
        TraceOptions trace;
        trace.fresnelWeights = false;
        trace.pathPointsMm = &points;
        trace.pathSurfaces = &surfaces;
        const Ray ray{tracer.originMm + p.x * tracer.u + p.y * tracer.v, region.direction};
        if (!traceForward(lens, tracer.indices, ray, trace).ok()) continue;
        for (size_t i = 1; i < surfaces.size(); ++i)
            if (surfaces[i] == surface) {
                segments.push_back({points[i - 1], glm::normalize(points[i] - points[i - 1]), surfaces[i - 1]});
                break;
            }
    }
    if (segments.empty()) return out;
    const glm::dvec3 mean = segments.front().direction;
    glm::dvec3 a1 = glm::dvec3(1.0, 0.0, 0.0) - mean.x * mean;
    if (glm::length(a1) < 1e-6) a1 = glm::dvec3(0.0, 1.0, 0.0) - mean.y * mean;
    a1 = glm::normalize(a1);
    const glm::dvec3 axes[2] = {a1, glm::cross(mean, a1)};

    // Central differences of the landings' centroid, over the rays whose four variants all land.
    const double tilt = 1e-5;
    glm::dvec2 sums[4] = {glm::dvec2(0.0), glm::dvec2(0.0), glm::dvec2(0.0), glm::dvec2(0.0)};
    int kept = 0;
    for (const Segment& s : segments) {
        glm::dvec2 landed[4];
        bool all = true;
        for (int k = 0; k < 4 && all; ++k) {
            const glm::dvec3 dir = glm::normalize(s.direction + (k % 2 ? -tilt : tilt) * axes[k / 2]);
            SequentialPath path;
            path.start = s.start;
            TraceOptions trace;
            trace.fresnelWeights = false;
            const TraceResult r = tracePath(lens, tracer.indices, Ray{s.originMm, dir}, path, trace);
            all = r.ok();
            landed[k] = {(tracer.halfWMm - r.ray.originMm.x) / tracer.pixelMm, (tracer.halfHMm + r.ray.originMm.y) / tracer.pixelMm};
        }
        if (!all) continue;
        for (int k = 0; k < 4; ++k) sums[k] += landed[k];
        ++kept;
    }
    if (kept == 0) return out;
    for (int c = 0; c < 2; ++c) out.pxPerRad[c] = (sums[2 * c] - sums[2 * c + 1]) / (2.0 * tilt * kept);
    out.found = true;
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
