#include "flare/wave/PsfGroups.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

namespace flare {

namespace {

constexpr double kPi = std::numbers::pi;

// The polygon's area centroid (shoelace); the vertices' mean for a degenerate one.
glm::dvec2 polygonCentroid(const std::vector<glm::dvec2>& p) {
    double area2 = 0.0;
    glm::dvec2 sum{0.0}, mean{0.0};
    for (size_t i = 0; i < p.size(); ++i) {
        const glm::dvec2& a = p[i];
        const glm::dvec2& b = p[(i + 1) % p.size()];
        const double cross = a.x * b.y - a.y * b.x;
        area2 += cross;
        sum += (a + b) * cross;
        mean += a;
    }
    if (std::abs(area2) < 1e-300) return mean / double(p.size());
    return sum / (3.0 * area2);
}

// The farthest crossing of the ray from `centre` along `dir` with the polygon's edges (the
// polygon is star-shaped about its centroid: one crossing; the farthest is robust to a vertex
// hit twice).
double rayReach(const std::vector<glm::dvec2>& p, const glm::dvec2& centre, const glm::dvec2& dir) {
    double reach = 0.0;
    for (size_t i = 0; i < p.size(); ++i) {
        const glm::dvec2 a = p[i] - centre, b = p[(i + 1) % p.size()] - centre;
        const glm::dvec2 e = b - a;
        const double denom = dir.x * e.y - dir.y * e.x;
        if (std::abs(denom) < 1e-300) continue;
        // centre + t·dir = a + s·e: t = (a × e)/(dir × e), s = (a × dir)/(dir × e).
        const double t = (a.x * e.y - a.y * e.x) / denom;
        const double s = (a.x * dir.y - a.y * dir.x) / denom;
        if (s >= 0.0 && s <= 1.0 && t > reach) reach = t;
    }
    return reach;
}

}  // namespace

PsfShape psfShape(const PupilOutline& outline, const std::vector<SpectralSample>& spectrum) {
    PsfShape shape;
    if (!outline.found || outline.outlineMm.size() < 3 || std::abs(glm::determinant(outline.pxPerRad)) == 0.0)
        return shape;
    // Q = radPerPxᵀ P: the pupil in the coordinates dual to the pixel offsets.
    const glm::dmat2 toQ = glm::transpose(glm::inverse(outline.pxPerRad));
    std::vector<glm::dvec2> q;
    q.reserve(outline.outlineMm.size());
    for (const glm::dvec2& p : outline.outlineMm) q.push_back(toQ * p);
    const glm::dvec2 centre = polygonCentroid(q);
    shape.radius.resize(PsfShape::kAngles);
    for (int a = 0; a < PsfShape::kAngles; ++a) {
        const double phi = 2.0 * kPi * (a + 0.5) / PsfShape::kAngles;
        shape.radius[a] = rayReach(q, centre, {std::cos(phi), std::sin(phi)});
    }
    glm::dvec3 weight{0.0}, weighted{0.0};
    for (const SpectralSample& s : spectrum) {
        weight += s.xyzWeight;
        weighted += s.xyzWeight * s.wavelengthNm;
    }
    for (int c = 0; c < 3; ++c) shape.meanWavelengthNm[c] = weight[c] > 0.0 ? weighted[c] / weight[c] : 550.0;
    shape.found = true;
    return shape;
}

double psfShapeDifference(const PsfShape& a, const PsfShape& b) {
    if (!a.found || !b.found) return std::numeric_limits<double>::infinity();
    double largest = 0.0;
    for (int c = 0; c < 3; ++c) {
        // Q/λ: a's radii scaled to b's wavelength in this channel.
        const double scale = b.meanWavelengthNm[c] / a.meanWavelengthNm[c];
        double difference = 0.0, area = 0.0;
        for (int i = 0; i < PsfShape::kAngles; ++i) {
            const double ra = scale * a.radius[i], rb = b.radius[i];
            difference += std::abs(ra * ra - rb * rb);  // both × ½ Δφ: the ratio drops them
            area += rb * rb;
        }
        largest = std::max(largest, area > 0.0 ? difference / area : std::numeric_limits<double>::infinity());
    }
    return largest;
}

std::vector<int> groupByPsf(const std::vector<PsfShape>& shapes, double tolerance, std::vector<int>* founders) {
    std::vector<int> group(shapes.size(), -1), founder;
    for (size_t l = 0; l < shapes.size(); ++l) {
        for (size_t g = 0; g < founder.size() && group[l] < 0; ++g)
            if (psfShapeDifference(shapes[l], shapes[static_cast<size_t>(founder[g])]) <= tolerance)
                group[l] = static_cast<int>(g);
        if (group[l] < 0) {
            group[l] = static_cast<int>(founder.size());
            founder.push_back(static_cast<int>(l));
        }
    }
    if (founders) *founders = std::move(founder);
    return group;
}

}  // namespace flare
