#include "flare/optics/PupilGrid.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <stdexcept>

#include <glm/geometric.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include "flare/optics/RealRays.h"

namespace flare {

glm::dvec3 directionFromFieldDeg(double fieldXDeg, double fieldYDeg) {
    const double toRad = std::numbers::pi / 180.0;
    return glm::normalize(glm::dvec3(-std::tan(fieldXDeg * toRad), -std::tan(fieldYDeg * toRad), 1.0));
}

PupilGrid PupilGrid::forDirection(const LensSystem& lens, const glm::dvec3& direction) {
    PupilGrid grid;
    grid.direction = glm::normalize(direction);
    // e1 stays horizontal (⟂ y), so that the grid's axes follow the image's for any light.
    const glm::dvec3 side = glm::cross(glm::dvec3(0.0, 1.0, 0.0), grid.direction);
    grid.e1 = glm::length(side) > 1e-12 ? glm::normalize(side) : glm::dvec3(1.0, 0.0, 0.0);
    grid.e2 = glm::normalize(glm::cross(grid.direction, grid.e1));
    const Surface& first = lens.surface(0);
    grid.centreMm = glm::dvec3(0.0, 0.0, first.vertexZMm);
    // The aperture's points lie within r0 of the axis and within the sag range in z; their
    // projections lie within r0 + |sag|·sinθ of the centre.
    double maxSag = 0.0;
    for (int k = 0; k <= 32; ++k) {
        const double r = first.semiApertureMm * k / 32.0;
        double sag = 0.0;
        if (first.sagMm(r * r, &sag)) maxSag = std::max(maxSag, std::abs(sag));
    }
    const double sinTheta = std::sqrt(std::max(0.0, 1.0 - grid.direction.z * grid.direction.z));
    grid.halfSizeMm = 1.01 * (first.semiApertureMm + maxSag * sinTheta) + 1e-3;
    // Start every ray in front of the lens's first point.
    const double zStart = objectSpaceStartZMm(lens);
    grid.backOffMm = (first.vertexZMm - zStart + grid.halfSizeMm * sinTheta) / std::max(grid.direction.z, 1e-3) + 1.0;
    return grid;
}

namespace {

// Of the first surface: its largest |sag| over the clear aperture, and how far it reaches
// towards the object side (a concave front's rim lies ahead of its vertex).
struct FrontSag {
    double maxMm = 0.0, aheadMm = 0.0;
};
FrontSag frontSag(const Surface& first) {
    FrontSag out;
    for (int k = 0; k <= 32; ++k) {
        const double r = first.semiApertureMm * k / 32.0;
        double sag = 0.0;
        if (!first.sagMm(r * r, &sag)) continue;
        out.maxMm = std::max(out.maxMm, std::abs(sag));
        out.aheadMm = std::max(out.aheadMm, -sag);
    }
    return out;
}

// How far ahead of the plane through the vertex, normal to `direction`, an aperture point can lie.
double reachMm(const Surface& first, const FrontSag& sag, const glm::dvec3& direction) {
    const double sinTheta = std::sqrt(std::max(0.0, 1.0 - direction.z * direction.z));
    return sag.aheadMm + first.semiApertureMm * sinTheta;
}

}  // namespace

bool PupilGrid::inFront(const LensSystem& lens, const glm::dvec3& sourceMm) {
    const Surface& first = lens.surface(0);
    const glm::dvec3 toVertex = glm::dvec3(0.0, 0.0, first.vertexZMm) - sourceMm;
    const double distanceMm = glm::length(toVertex);
    if (!(toVertex.z > 0.0)) return false;
    return distanceMm > reachMm(first, frontSag(first), toVertex / distanceMm) + 1e-6;
}

PupilGrid PupilGrid::forPoint(const LensSystem& lens, const glm::dvec3& sourceMm) {
    if (!inFront(lens, sourceMm))
        throw std::invalid_argument("PupilGrid::forPoint: the source is not in front of the lens's front surface");
    const Surface& first = lens.surface(0);
    const glm::dvec3 vertexMm(0.0, 0.0, first.vertexZMm);
    PupilGrid grid = forDirection(lens, vertexMm - sourceMm);
    grid.fromPoint = true;
    grid.sourceMm = sourceMm;
    const double distanceMm = glm::length(vertexMm - sourceMm);
    // An aperture point lies within r0 + |sag|·sinθ of the central ray and at most `reach` ahead
    // of the plane along it; the ray from the source through it crosses the plane at most
    // D / (D − reach) times farther out (D: the source's distance from the plane; points behind
    // the plane cross it nearer the centre).
    const FrontSag sag = frontSag(first);
    const double sinTheta = std::sqrt(std::max(0.0, 1.0 - grid.direction.z * grid.direction.z));
    const double reach = reachMm(first, sag, grid.direction);
    grid.halfSizeMm = 1.01 * (first.semiApertureMm + sag.maxMm * sinTheta) * distanceMm / (distanceMm - reach) + 1e-3;
    // Each ray starts on its own way in front of the lens's first point (rayFrom), not a fixed
    // distance back: a disk light's other points send steeper rays than its centre's.
    grid.backOffMm = 0.0;
    grid.startZMm = objectSpaceStartZMm(lens);
    return grid;
}

double PupilGrid::enteringAreaMm2(const LensSystem& lens, int cells) const {
    const Surface& first = lens.surface(0);
    const double cell = 2.0 * halfSizeMm / cells;
    // Rows in parallel; the count is an integer, the same whatever the threads.
    const long hits = tbb::parallel_reduce(
        tbb::blocked_range<int>(0, cells), 0L,
        [&](const tbb::blocked_range<int>& rows, long count) {
            for (int j = rows.begin(); j != rows.end(); ++j)
                for (int i = 0; i < cells; ++i) {
                    const Ray r = ray(-halfSizeMm + (i + 0.5) * cell, -halfSizeMm + (j + 0.5) * cell);
                    const SurfaceHit hit = intersect(first, r);
                    if (hit.status != HitStatus::Hit) continue;
                    const glm::dvec3 p = r.at(hit.tMm);
                    count += p.x * p.x + p.y * p.y <= first.semiApertureMm * first.semiApertureMm;
                }
            return count;
        },
        std::plus<long>());
    return static_cast<double>(hits) * cell * cell;
}

}  // namespace flare
