#include "flare/render/BeamRim.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <glm/geometric.hpp>

#include "flare/core/FresnelIntegrals.h"
#include "flare/core/RoundingClones.h"
#include "flare/film/Film.h"
#include "flare/ghosts/KeyIndex.h"
#include "flare/render/BeamRimRow.h"

namespace flare {

namespace {

double cross(const glm::dvec2& a, const glm::dvec2& b) { return a.x * b.y - a.y * b.x; }

// The mesh places a vertex where the rays leave the sensor by interpolating their margins across a
// cell: on the default scene within 0.3 px of the edge (half a pixel here). A real rim that runs
// along the sensor's edge within that distance loses nothing visible by it.
constexpr double kOnEdgePx = 0.5;

// Vertices are shared exactly by neighbouring triangles, except where the guide mask's clip cut
// an edge twice (once from each side, interpolating in opposite directions): a key on a 1e-9 mm
// grid of the pupil joins those too.
std::uint64_t vertexKey(const glm::dvec2& pupilMm) {
    const auto qx = static_cast<std::uint64_t>(std::llround(pupilMm.x * 1e9));
    const auto qy = static_cast<std::uint64_t>(std::llround(pupilMm.y * 1e9));
    return qx * 0x9E3779B97F4A7C15ull ^ (qy + 0x632BE59BD9B4E019ull + (qx << 6) + (qx >> 2));
}

}  // namespace

BeamRim BeamRim::build(const std::vector<RimTriangle>& triangles, double edgeScalePx, int widthPx, int heightPx,
                       const std::function<bool(const glm::dvec2& pupilMm)>& covered) {
    BeamRim rim;
    rim.edgeScalePx_ = edgeScalePx;
    if (!(edgeScalePx > 0.0) || triangles.empty()) return rim;
    // Vertex ids, and how many triangles hold each edge (open addressing, KeyIndex: node-based
    // maps' allocations cost more than the rim's own work).
    KeyIndex idOf;
    idOf.reserve(triangles.size());
    int vertexCount = 0;
    auto id = [&](const glm::dvec2& p) {
        const auto [vertex, inserted] = idOf.emplace(keyIndexKey(vertexKey(p)), vertexCount);
        if (inserted) ++vertexCount;
        return vertex;
    };
    struct EdgeUse {
        int count = 0;
        int triangle = 0, corner = 0;  // the first triangle holding it: edge corner → corner + 1
    };
    KeyIndex edgeOf;  // (smaller id, larger id) → its EdgeUse (never ~0: ids are below 2³¹)
    edgeOf.reserve(2 * triangles.size());
    std::vector<EdgeUse> edges;
    edges.reserve(2 * triangles.size());
    std::vector<std::array<int, 3>> ids(triangles.size());
    for (size_t n = 0; n < triangles.size(); ++n)
        for (int k = 0; k < 3; ++k) ids[n][k] = id(triangles[n].v[k].pupilMm);
    for (size_t n = 0; n < triangles.size(); ++n)
        for (int k = 0; k < 3; ++k) {
            const int i = ids[n][k], j = ids[n][(k + 1) % 3];
            if (i == j) continue;
            const std::uint64_t key = (static_cast<std::uint64_t>(std::min(i, j)) << 32) | static_cast<std::uint32_t>(std::max(i, j));
            const auto [edge, inserted] = edgeOf.emplace(key, static_cast<int>(edges.size()));
            if (inserted) edges.push_back({0, static_cast<int>(n), k});
            ++edges[edge].count;
        }
    // The rim's segments, in a fixed order (the triangles' and their corners').
    std::vector<std::pair<int, int>> rimEdges;  // (triangle, corner)
    for (const EdgeUse& use : edges)
        if (use.count == 1 && !triangles[use.triangle].small) rimEdges.emplace_back(use.triangle, use.corner);
    std::sort(rimEdges.begin(), rimEdges.end());
    // Just beyond the edge's middle, in the pupil: covered where the edge meets finer cells.
    std::erase_if(rimEdges, [&](const std::pair<int, int>& e) {
        const RimTriangle& t = triangles[e.first];
        const glm::dvec2 a = t.v[e.second].pupilMm, b = t.v[(e.second + 1) % 3].pupilMm, c = t.v[(e.second + 2) % 3].pupilMm;
        glm::dvec2 outward(b.y - a.y, a.x - b.x);
        if (glm::dot(outward, c - a) > 0.0) outward = -outward;
        return covered(0.5 * (a + b) + 1e-6 * outward);
    });
    std::vector<std::array<int, 2>> ends;  // vertex ids of each segment's a and b
    // Per vertex: how many segments end there, and the first two.
    std::vector<int> endsAt(static_cast<size_t>(vertexCount), 0);
    std::vector<std::array<int, 2>> firstAt(static_cast<size_t>(vertexCount), {-1, -1});
    auto addEnd = [&](int vertex, int segment) {
        if (endsAt[vertex] < 2) firstAt[vertex][endsAt[vertex]] = segment;
        ++endsAt[vertex];
    };
    for (const auto& [n, k] : rimEdges) {
        const RimTriangle& t = triangles[n];
        const RimVertex &a = t.v[k], &b = t.v[(k + 1) % 3], &c = t.v[(k + 2) % 3];
        Segment s;
        s.a = a.pixel;
        s.b = b.pixel;
        s.length = glm::length(s.b - s.a);
        if (!(s.length > 1e-9)) continue;
        // Along the sensor's edge.
        auto along = [&](double p, double q, double line) { return std::abs(p - line) < kOnEdgePx && std::abs(q - line) < kOnEdgePx; };
        if (along(s.a.x, s.b.x, 0.0) || along(s.a.x, s.b.x, widthPx) || along(s.a.y, s.b.y, 0.0) ||
            along(s.a.y, s.b.y, heightPx))
            continue;
        s.along = (s.b - s.a) / s.length;
        s.inward = {-s.along.y, s.along.x};
        const double side = glm::dot(c.pixel - s.a, s.inward);
        if (side == 0.0) continue;
        if (side < 0.0) s.inward = -s.inward;
        s.irradianceA = a.irradiance;
        s.irradianceB = b.irradiance;
        const int index = static_cast<int>(rim.segments_.size());
        rim.segments_.push_back(s);
        ends.push_back({ids[n][k], ids[n][(k + 1) % 3]});
        addEnd(ends.back()[0], index);
        addEnd(ends.back()[1], index);
    }
    // Each end's bisector: where the rim turns at a vertex shared by two segments, the line
    // halfway between their normals; elsewhere (an open end, a vertex where the rim touches
    // itself, a hairpin) the segment's own normal.
    const double reach = FresnelEdgeExcess::kReach * edgeScalePx;
    std::vector<Segment> kept;
    for (size_t i = 0; i < rim.segments_.size(); ++i) {
        Segment& s = rim.segments_[i];
        auto bisector = [&](int vertex) {
            if (endsAt[vertex] != 2) return s.inward;
            const std::array<int, 2>& at = firstAt[vertex];
            const Segment& other = rim.segments_[at[0] == static_cast<int>(i) ? at[1] : at[0]];
            const glm::dvec2 sum = s.inward + other.inward;
            const double norm = glm::length(sum);
            if (!(norm > 1e-6)) return s.inward;
            const glm::dvec2 m = sum / norm;
            return glm::dot(m, s.inward) > 0.2 ? m : s.inward;
        };
        s.bisectorA = bisector(ends[i][0]);
        s.bisectorB = bisector(ends[i][1]);
        s.sideA = cross(s.bisectorA, s.b - s.a) > 0.0 ? 1.0 : -1.0;
        s.sideB = cross(s.bisectorB, s.a - s.b) > 0.0 ? 1.0 : -1.0;
        // The wedge within the reach: its four corners along the bisectors.
        const double ra = reach / glm::dot(s.bisectorA, s.inward), rb = reach / glm::dot(s.bisectorB, s.inward);
        const glm::dvec2 corners[4] = {s.a + ra * s.bisectorA, s.a - ra * s.bisectorA, s.b + rb * s.bisectorB,
                                       s.b - rb * s.bisectorB};
        s.rowMin = s.rowMax = corners[0].y;
        s.columnMin = s.columnMax = corners[0].x;
        for (const glm::dvec2& p : corners) {
            s.rowMin = std::min(s.rowMin, p.y), s.rowMax = std::max(s.rowMax, p.y);
            s.columnMin = std::min(s.columnMin, p.x), s.columnMax = std::max(s.columnMax, p.x);
        }
        kept.push_back(s);
    }
    rim.segments_.swap(kept);
    rim.indexBands(heightPx);
    return rim;
}

BeamRim BeamRim::fromSegments(std::vector<Segment> segments, double edgeScalePx, int heightPx) {
    BeamRim rim;
    rim.edgeScalePx_ = edgeScalePx;
    rim.segments_ = std::move(segments);
    if (!rim.segments_.empty()) rim.indexBands(heightPx);
    return rim;
}

std::vector<std::uint32_t> BeamRim::segmentsReaching(int firstBand, int lastBand) const {
    const int bands = static_cast<int>(bandStart_.size()) - 1;
    firstBand = std::max(firstBand, 0);
    lastBand = std::min(lastBand, bands - 1);
    if (firstBand > lastBand) return {};
    std::vector<std::uint32_t> reaching(bandSegments_.begin() + bandStart_[firstBand],
                                        bandSegments_.begin() + bandStart_[lastBand + 1]);
    std::sort(reaching.begin(), reaching.end());
    reaching.erase(std::unique(reaching.begin(), reaching.end()), reaching.end());
    return reaching;
}

void BeamRim::widenByBand(int band, double& xMinPx, double& xMaxPx) const {
    const int bands = static_cast<int>(bandStart_.size()) - 1;
    if (band < 0 || band >= bands) return;
    for (int k = bandStart_[band]; k < bandStart_[band + 1]; ++k) {
        const Segment& s = segments_[bandSegments_[k]];
        if (!std::isfinite(s.columnMin) || !std::isfinite(s.columnMax)) {
            xMinPx = -1e300, xMaxPx = 1e300;
            return;
        }
        xMinPx = std::min(xMinPx, s.columnMin);
        xMaxPx = std::max(xMaxPx, s.columnMax);
    }
}

void BeamRim::indexBands(int heightPx) {
    // By band, as GhostBeam's triangles: the rows a segment's wedge reaches ± the jitter.
    const int bands = std::max(1, (heightPx + Film::kBandRows - 1) / Film::kBandRows);
    auto bandRange = [&](const Segment& s) {
        const int first = std::clamp(static_cast<int>(std::floor((s.rowMin - 2.0) / Film::kBandRows)), 0, bands - 1);
        const int last = std::clamp(static_cast<int>(std::floor((s.rowMax + 2.0) / Film::kBandRows)), 0, bands - 1);
        return std::pair{first, last};
    };
    bandStart_.assign(bands + 1, 0);
    for (const Segment& s : segments_) {
        const auto [first, last] = bandRange(s);
        for (int b = first; b <= last; ++b) ++bandStart_[b + 1];
    }
    for (int b = 0; b < bands; ++b) bandStart_[b + 1] += bandStart_[b];
    bandSegments_.resize(bandStart_[bands]);
    std::vector<int> next(bandStart_.begin(), bandStart_.end() - 1);
    for (int n = 0; n < static_cast<int>(segments_.size()); ++n) {
        const auto [first, last] = bandRange(segments_[n]);
        for (int b = first; b <= last; ++b) bandSegments_[next[b]++] = n;
    }
}

FLARE_ROUNDING_CLONES
void BeamRim::rasterise(int band, const glm::dvec2& jitterPx, const glm::dvec3& scale, int widthPx, int heightPx,
                        double* rows) const {
    const int bands = static_cast<int>(bandStart_.size()) - 1;
    if (segments_.empty() || band < 0 || band >= bands) return;
    const double inverseScale = 1.0 / edgeScalePx_;
    const double reach = FresnelEdgeExcess::kReach * edgeScalePx_;
    const int rowBegin = band * Film::kBandRows, rowEnd = std::min(heightPx, rowBegin + Film::kBandRows);
    // Pixels whose jittered centre lies on the sensor (GhostBeam::rasterise).
    const int columnLo = std::max(0, static_cast<int>(std::ceil(-0.5 - jitterPx.x)));
    const int columnHi = std::min(widthPx - 1, static_cast<int>(std::ceil(widthPx - 0.5 - jitterPx.x)) - 1);
    const int rowLo = std::max(rowBegin, static_cast<int>(std::ceil(-0.5 - jitterPx.y)));
    const int rowHi = std::min(rowEnd - 1, static_cast<int>(std::ceil(heightPx - 0.5 - jitterPx.y)) - 1);
    for (int k = bandStart_[band]; k < bandStart_[band + 1]; ++k) {
        const Segment& s = segments_[bandSegments_[k]];
        // Pixel centres + jitter within the wedge's bounding box.
        const int r0 = std::max(rowLo, static_cast<int>(std::ceil(s.rowMin - 0.5 - jitterPx.y)));
        const int r1 = std::min(rowHi, static_cast<int>(std::floor(s.rowMax - 0.5 - jitterPx.y)));
        const int c0 = std::max(columnLo, static_cast<int>(std::ceil(s.columnMin - 0.5 - jitterPx.x)));
        const int c1 = std::min(columnHi, static_cast<int>(std::floor(s.columnMax - 0.5 - jitterPx.x)));
        // The segment's rows in this band (at most Film::kBandRows), handed to the SIMD loop at once.
        detail::RimRowSpan spans[Film::kBandRows];
        size_t count = 0;
        for (int row = r0; row <= r1; ++row) {
            // The row's span where the pixel can pass the tests below, from their three linear
            // constraints in x (within the band of the reach, on the wedge's side of either
            // bisector), widened by a pixel: the tests themselves decide.
            const double y = row + 0.5 + jitterPx.y;
            double lo = -1e300, hi = 1e300;
            auto keep = [&](double k0, double k1) {  // k0 + k1·x ≥ 0
                if (std::abs(k1) < 1e-12) {
                    if (k0 < 0.0) lo = 1e300;
                } else if (k1 > 0.0) {
                    lo = std::max(lo, -k0 / k1);
                } else {
                    hi = std::min(hi, -k0 / k1);
                }
            };
            const double acrossAtZero = s.inward.y * (y - s.a.y) - s.inward.x * s.a.x;
            keep(reach - acrossAtZero, -s.inward.x);
            keep(reach + acrossAtZero, s.inward.x);
            keep(s.sideA * (s.bisectorA.x * (y - s.a.y) + s.bisectorA.y * s.a.x), -s.sideA * s.bisectorA.y);
            keep(s.sideB * (s.bisectorB.x * (y - s.b.y) + s.bisectorB.y * s.b.x), -s.sideB * s.bisectorB.y);
            if (!(lo <= hi)) continue;
            const int first = std::max(c0, static_cast<int>(std::max(std::ceil(lo - 0.5 - jitterPx.x) - 1.0, -1e9)));
            const int last = std::min(c1, static_cast<int>(std::min(std::floor(hi - 0.5 - jitterPx.x) + 1.0, 1e9)));
            if (first > last) continue;
            // The pixels themselves, several at a time (BeamRimRow.h: the same arithmetic).
            detail::RimRowSpan& span = spans[count++];
            span.y = y;
            span.jitterX = jitterPx.x;
            span.first = first;
            span.last = last;
            span.reach = reach;
            span.inverseScale = inverseScale;
            span.row = rows + (static_cast<size_t>(row - rowBegin) * widthPx + first) * 3;
        }
        if (count > 0) detail::addRimRows(s, spans, count, scale);
    }
}

}  // namespace flare
