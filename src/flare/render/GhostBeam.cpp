#include "flare/render/GhostBeam.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <stdexcept>
#include <utility>

#include <glm/geometric.hpp>
#include <glm/mat2x2.hpp>
#include <glm/matrix.hpp>

#include "flare/core/Random.h"
#include "flare/core/RoundingClones.h"
#include "flare/film/Film.h"
#include "flare/ghosts/KeyIndex.h"
#include "flare/render/BeamTriangleRow.h"

namespace flare {

namespace {

// A triangle whose image covers less than this many square pixels splats its power at a random
// point rather than being sampled at pixel centres: a sampled grid would find its few pixels by
// chance, each with the whole triangle's density.
constexpr double kSmallImagePx2 = 1.0;
// The points a small triangle's power is split over: twice its longest side in pixels, within.
constexpr int kSmallPointsMin = 4, kSmallPointsMax = 64;
// A triangle's rows handed to the SIMD loop at a time (Film::kBandRows at most reach it in a band).
constexpr size_t kSpansPerCall = 32;
// How many triangles ahead rasterise asks for a triangle's memory.
constexpr int kPrefetchAhead = 4;

double signedArea(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c) {
    return 0.5 * ((b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y));
}

// A convex polygon in the pupil with the barycentric coordinates of its vertices in the triangle
// it was cut from, clipped by an axis-aligned half-plane (Sutherland–Hodgman).
struct Corner {
    glm::dvec2 pupilMm;
    glm::dvec3 bary;
};
using Polygon = std::vector<Corner>;

Polygon clip(const Polygon& in, int axis, double bound, bool keepBelow) {
    Polygon out;
    const size_t n = in.size();
    for (size_t k = 0; k < n; ++k) {
        const Corner& p = in[k];
        const Corner& q = in[(k + 1) % n];
        const double dp = keepBelow ? bound - p.pupilMm[axis] : p.pupilMm[axis] - bound;
        const double dq = keepBelow ? bound - q.pupilMm[axis] : q.pupilMm[axis] - bound;
        if (dp >= 0.0) out.push_back(p);
        if ((dp >= 0.0) != (dq >= 0.0)) {
            const double t = dp / (dp - dq);
            out.push_back({p.pupilMm + t * (q.pupilMm - p.pupilMm), p.bary + t * (q.bary - p.bary)});
        }
    }
    return out;
}

}  // namespace

glm::dvec2 tentJitter(double u1, double u2) {
    // Inverse of the tent's distribution function on [−1, 1].
    auto inverse = [](double u) { return u < 0.5 ? std::sqrt(2.0 * u) - 1.0 : 1.0 - std::sqrt(2.0 * (1.0 - u)); };
    return {inverse(u1), inverse(u2)};
}

GhostBeam GhostBeam::build(const BundleTracer& tracer, const PupilGrid& grid, const PupilLattice& lattice,
                           const GuideMask& mask, const FilmFrame& frame, const PupilRemeshOptions& options,
                           const std::function<double(const glm::dvec2& pupilMm)>& vertexFactor) {
    GhostBeam beam;
    beam.frame_ = frame;
    if (lattice.empty() || mask.empty()) return beam;
    PupilMesh mesh = remeshLiveRegion(tracer, grid, lattice, options);
    beam.tracedRays_ = mesh.tracedRays;

    // The map's Jacobian (d sensor / d pupil) per triangle, and per vertex the area-weighted mean
    // of its triangles' (vertices are shared exactly: they are lattice points or edge points found
    // once per cell side).
    struct Vertex {
        glm::dmat2 weightedJacobian{0.0};
        double area = 0.0;
        bool positive = false, negative = false;
        double smallestDet = 1e300;
    };
    std::vector<Vertex> vertices;
    std::vector<std::array<int, 3>> corners(mesh.triangles.size());
    std::vector<glm::dmat2> jacobians(mesh.triangles.size());
    // (Open addressing, KeyIndex: a node-based map's allocations were a tenth of the beam's build.)
    KeyIndex idOf;
    idOf.reserve(mesh.triangles.size());  // (a lattice mesh has about half as many vertices)
    vertices.reserve(mesh.triangles.size());
    auto vertexId = [&](const glm::dvec2& p) {
        std::uint64_t hx, hy;
        std::memcpy(&hx, &p.x, sizeof hx);
        std::memcpy(&hy, &p.y, sizeof hy);
        const auto [id, inserted] = idOf.emplace(keyIndexKey(hx * 0x9E3779B97F4A7C15ull ^ hy), static_cast<int>(vertices.size()));
        if (inserted) vertices.emplace_back();
        return id;
    };
    for (size_t n = 0; n < mesh.triangles.size(); ++n) {
        const PupilTriangle& t = mesh.triangles[n];
        const glm::dmat2 pupil(t.v[1].pupilMm - t.v[0].pupilMm, t.v[2].pupilMm - t.v[0].pupilMm);
        const glm::dmat2 sensor(t.v[1].sensorMm - t.v[0].sensorMm, t.v[2].sensorMm - t.v[0].sensorMm);
        const double pupilDet = glm::determinant(pupil);
        jacobians[n] = pupilDet != 0.0 ? sensor * glm::inverse(pupil) : glm::dmat2(0.0);
        const double det = glm::determinant(jacobians[n]);
        for (int k = 0; k < 3; ++k) {
            corners[n][k] = vertexId(t.v[k].pupilMm);
            Vertex& v = vertices[corners[n][k]];
            v.weightedJacobian += std::abs(pupilDet) * jacobians[n];
            v.area += std::abs(pupilDet);
            (det > 0.0 ? v.positive : v.negative) = true;
            v.smallestDet = std::min(v.smallestDet, std::abs(det));
        }
    }
    if (vertexFactor) {
        std::vector<double> factor(vertices.size(), -1.0);
        for (size_t n = 0; n < mesh.triangles.size(); ++n)
            for (int k = 0; k < 3; ++k) {
                double& f = factor[corners[n][k]];
                if (f < 0.0) f = vertexFactor(mesh.triangles[n].v[k].pupilMm);
                mesh.triangles[n].v[k].throughput *= f;
            }
    }
    // A vertex where the map folds, or whose triangles' Jacobians differ too much for their mean
    // to stand for any of them, gives its triangles their own irradiance.
    constexpr double kFoldRatio = 0.5;
    const double pixelMm2 = frame.pixelMm * frame.pixelMm;
    std::vector<double> vertexIrradiance(vertices.size(), -1.0);  // pupil mm² per px² (throughput 1)
    for (size_t v = 0; v < vertices.size(); ++v) {
        const Vertex& vertex = vertices[v];
        if (vertex.positive && vertex.negative) continue;
        const double det = std::abs(glm::determinant(vertex.weightedJacobian / vertex.area));
        if (!(det > 0.0) || vertex.smallestDet < kFoldRatio * det) continue;
        vertexIrradiance[v] = pixelMm2 / det;
    }

    auto add = [&](size_t n, const Corner& a, const Corner& b, const Corner& c) {
        const PupilTriangle& t = mesh.triangles[n];
        BeamTriangle out;
        const Corner* cs[3] = {&a, &b, &c};
        const double own = std::abs(glm::determinant(jacobians[n]));
        const bool recovered = std::all_of(corners[n].begin(), corners[n].end(),
                                           [&](int v) { return vertexIrradiance[v] >= 0.0; });
        // The parent triangle's vertex irradiances: recovered ones are rescaled so that the
        // triangle keeps its exact power (pupil area × mean throughput), which keeps the image's
        // power exact and leaves only second-order jumps between triangles.
        double e[3];
        for (int c = 0; c < 3; ++c)
            e[c] = t.v[c].throughput * (recovered ? vertexIrradiance[corners[n][c]] : pixelMm2 / own);
        if (recovered) {
            const double exact = (t.v[0].throughput + t.v[1].throughput + t.v[2].throughput) * pixelMm2 / own;
            const double sum = e[0] + e[1] + e[2];
            if (sum > 0.0)
                for (double& v : e) v *= exact / sum;
        }
        for (int k = 0; k < 3; ++k) {
            const glm::dvec3& w = cs[k]->bary;
            out.pupilMm[k] = cs[k]->pupilMm;
            out.pixel[k] = frame.toPixel(w.x * t.v[0].sensorMm + w.y * t.v[1].sensorMm + w.z * t.v[2].sensorMm);
            out.throughput[k] = w.x * t.v[0].throughput + w.y * t.v[1].throughput + w.z * t.v[2].throughput;
            out.irradiance[k] = w.x * e[0] + w.y * e[1] + w.z * e[2];
        }
        out.pupilAreaMm2 = std::abs(signedArea(out.pupilMm[0], out.pupilMm[1], out.pupilMm[2]));
        out.imageAreaPx2 = std::abs(signedArea(out.pixel[0], out.pixel[1], out.pixel[2]));
        if (!(out.pupilAreaMm2 > 0.0)) return;
        // A triangle mapped onto a line or a point (a perfect focus) has no density on the grid.
        out.small = !(out.imageAreaPx2 >= kSmallImagePx2) || !(own > 0.0);
        beam.triangles_.push_back(out);
    };

    const double cell = mask.cellMm();
    for (size_t n = 0; n < mesh.triangles.size(); ++n) {
        const PupilTriangle& t = mesh.triangles[n];
        const Corner a{t.v[0].pupilMm, {1, 0, 0}}, b{t.v[1].pupilMm, {0, 1, 0}}, c{t.v[2].pupilMm, {0, 0, 1}};
        const glm::dvec2 lo = glm::min(a.pupilMm, glm::min(b.pupilMm, c.pupilMm));
        const glm::dvec2 hi = glm::max(a.pupilMm, glm::max(b.pupilMm, c.pupilMm));
        const int i0 = static_cast<int>(std::floor((lo.x - mask.aMinMm()) / cell));
        const int i1 = static_cast<int>(std::floor((hi.x - mask.aMinMm()) / cell));
        const int j0 = static_cast<int>(std::floor((lo.y - mask.bMinMm()) / cell));
        const int j1 = static_cast<int>(std::floor((hi.y - mask.bMinMm()) / cell));
        bool whole = true;
        for (int j = j0; j <= j1 && whole; ++j)
            for (int i = i0; i <= i1 && whole; ++i) whole = mask.liveCell(i, j);
        if (whole) {
            add(n, a, b, c);
            continue;
        }
        // The guided strategy owns only the paths that start inside the mask: keep the parts of
        // the triangle over runs of live cells, row by row.
        for (int j = j0; j <= j1; ++j)
            for (int i = i0; i <= i1;) {
                if (!mask.liveCell(i, j)) {
                    ++i;
                    continue;
                }
                int end = i;
                while (end + 1 <= i1 && mask.liveCell(end + 1, j)) ++end;
                Polygon piece{a, b, c};
                piece = clip(piece, 0, mask.aMinMm() + i * cell, false);
                piece = clip(piece, 0, mask.aMinMm() + (end + 1) * cell, true);
                piece = clip(piece, 1, mask.bMinMm() + j * cell, false);
                piece = clip(piece, 1, mask.bMinMm() + (j + 1) * cell, true);
                for (size_t k = 1; k + 1 < piece.size(); ++k) add(n, piece[0], piece[k], piece[k + 1]);
                i = end + 1;
            }
    }
    beam.bucketByBand();
    return beam;
}

GhostBeam GhostBeam::fromTriangles(std::vector<BeamTriangle> triangles, const FilmFrame& frame, long tracedRays,
                                   std::vector<std::uint32_t> seedIndices) {
    if (!seedIndices.empty() && seedIndices.size() != triangles.size())
        throw std::invalid_argument("GhostBeam::fromTriangles: one seed index per triangle");
    GhostBeam beam;
    beam.frame_ = frame;
    beam.tracedRays_ = tracedRays;
    beam.triangles_ = std::move(triangles);
    beam.seedIndices_ = std::move(seedIndices);
    beam.bucketByBand();
    return beam;
}

std::vector<std::uint32_t> GhostBeam::trianglesReaching(int firstBand, int lastBand) const {
    const int bands = static_cast<int>(bandStart_.size()) - 1;
    firstBand = std::max(firstBand, 0);
    lastBand = std::min(lastBand, bands - 1);
    if (firstBand > lastBand) return {};
    std::vector<std::uint32_t> reaching(bandTriangles_.begin() + bandStart_[firstBand],
                                        bandTriangles_.begin() + bandStart_[lastBand + 1]);
    std::sort(reaching.begin(), reaching.end());
    reaching.erase(std::unique(reaching.begin(), reaching.end()), reaching.end());
    return reaching;
}

void GhostBeam::ring(double edgeScalePx) {
    std::vector<RimTriangle> rimTriangles(triangles_.size());
    for (size_t n = 0; n < triangles_.size(); ++n) {
        const BeamTriangle& t = triangles_[n];
        for (int k = 0; k < 3; ++k) rimTriangles[n].v[k] = {t.pupilMm[k], t.pixel[k], t.irradiance[k]};
        rimTriangles[n].small = t.small;
    }
    std::call_once(*indexOnce_, [this] { index(); });
    rim_ = BeamRim::build(rimTriangles, edgeScalePx, frame_.widthPx, frame_.heightPx, [this](const glm::dvec2& pupilMm) {
        double l1 = 0.0, l2 = 0.0;
        return locate(pupilMm, &l1, &l2) != nullptr;
    });
}

void GhostBeam::bucketByBand() {
    const int bands = std::max(1, (frame_.heightPx + Film::kBandRows - 1) / Film::kBandRows);
    // Rows a triangle may touch: its image ± the jitter (1 px) ± a splat's reach (1 px).
    auto bandRange = [&](const BeamTriangle& t) {
        const double lo = std::min({t.pixel[0].y, t.pixel[1].y, t.pixel[2].y}) - 2.0;
        const double hi = std::max({t.pixel[0].y, t.pixel[1].y, t.pixel[2].y}) + 2.0;
        const int first = std::clamp(static_cast<int>(std::floor(lo / Film::kBandRows)), 0, bands - 1);
        const int last = std::clamp(static_cast<int>(std::floor(hi / Film::kBandRows)), 0, bands - 1);
        return std::pair{first, last};
    };
    // Each triangle's bands, found once: the passes below read these and not the triangles (168
    // bytes each, and a beam has thousands).
    std::vector<std::pair<int, int>> range(triangles_.size());
    for (size_t n = 0; n < triangles_.size(); ++n) range[n] = bandRange(triangles_[n]);
    // Sorted by first band (stably), then listed in every band they may touch, in that order.
    std::vector<int> counts(bands + 1, 0);
    for (const auto& r : range) ++counts[r.first + 1];
    for (int b = 0; b < bands; ++b) counts[b + 1] += counts[b];
    // (The order first, then the triangles copied in it: a vector of them sized up front would be
    // zeroed first, a tenth of the beam's build.)
    std::vector<int> order(triangles_.size());
    std::vector<std::uint32_t> sortedSeeds(seedIndices_.size());
    bool inOrder = true;
    for (size_t n = 0; n < triangles_.size(); ++n) {
        const int at = counts[range[n].first]++;
        order[at] = static_cast<int>(n);
        inOrder = inOrder && at == static_cast<int>(n);
        if (!seedIndices_.empty()) sortedSeeds[at] = seedIndices_[n];
    }
    // (A beam cut to a band owner's bands arrives in this order already, PassWire.h: its triangles
    // are left where they are, a copy of them all saved.)
    if (!inOrder) {
        std::vector<BeamTriangle> sorted;
        sorted.reserve(triangles_.size());
        std::vector<std::pair<int, int>> sortedRange(triangles_.size());
        for (size_t at = 0; at < order.size(); ++at) {
            sorted.push_back(triangles_[order[at]]);
            sortedRange[at] = range[order[at]];
        }
        triangles_.swap(sorted);
        seedIndices_.swap(sortedSeeds);
        range.swap(sortedRange);
    }
    bandStart_.assign(bands + 1, 0);
    for (const auto& [first, last] : range)
        for (int b = first; b <= last; ++b) ++bandStart_[b + 1];
    for (int b = 0; b < bands; ++b) bandStart_[b + 1] += bandStart_[b];
    bandTriangles_.resize(bandStart_[bands]);
    std::vector<int> next(bandStart_.begin(), bandStart_.end() - 1);
    for (int n = 0; n < static_cast<int>(range.size()); ++n)
        for (int b = range[n].first; b <= range[n].second; ++b) bandTriangles_[next[b]++] = n;
}

void GhostBeam::columnsInBand(int band, int& loPx, int& hiPx) const {
    const int bands = static_cast<int>(bandStart_.size()) - 1;
    if (band < 0 || band >= bands) return;  // (rasterise writes nothing there either)
    double xMin = 1e300, xMax = -1e300;
    for (int k = bandStart_[band]; k < bandStart_[band + 1]; ++k)
        for (const glm::dvec2& p : triangles_[bandTriangles_[k]].pixel) {
            // (A vertex that is not finite: the whole line, whatever rasterise makes of it.)
            xMin = std::isfinite(p.x) ? std::min(xMin, p.x) : -1e300;
            xMax = std::isfinite(p.x) ? std::max(xMax, p.x) : 1e300;
        }
    rim_.widenByBand(band, xMin, xMax);
    if (!(xMin <= xMax)) return;
    // A span or a splat reaches a pixel beyond its image for the jitter (at most one) and one more
    // for the splat's bilinear weights; a third for safety.
    constexpr double kReachPx = 3.0;
    const int width = frame_.widthPx;
    const int lo = static_cast<int>(std::clamp(std::floor(xMin - kReachPx), 0.0, static_cast<double>(width - 1)));
    const int hi = static_cast<int>(std::clamp(std::ceil(xMax + kReachPx), 0.0, static_cast<double>(width - 1)));
    loPx = std::min(loPx, lo);
    hiPx = std::max(hiPx, hi);
}

void GhostBeam::index() const {
    if (triangles_.empty()) return;
    glm::dvec2 lo(1e300), hi(-1e300);
    for (const BeamTriangle& t : triangles_)
        for (const glm::dvec2& p : t.pupilMm) lo = glm::min(lo, p), hi = glm::max(hi, p);
    // About two triangles per bucket.
    const double span = std::max(hi.x - lo.x, hi.y - lo.y);
    const int across = std::clamp(static_cast<int>(std::sqrt(0.5 * static_cast<double>(triangles_.size()))), 1, 512);
    bucketMm_ = std::max(span / across, 1e-9);
    bucketMinMm_ = lo;
    bucketsA_ = std::max(1, static_cast<int>(std::ceil((hi.x - lo.x) / bucketMm_)) + 1);
    bucketsB_ = std::max(1, static_cast<int>(std::ceil((hi.y - lo.y) / bucketMm_)) + 1);
    std::vector<int> counts(static_cast<size_t>(bucketsA_) * bucketsB_ + 1, 0);
    auto range = [&](const BeamTriangle& t, int* i0, int* i1, int* j0, int* j1) {
        const glm::dvec2 a = glm::min(t.pupilMm[0], glm::min(t.pupilMm[1], t.pupilMm[2]));
        const glm::dvec2 b = glm::max(t.pupilMm[0], glm::max(t.pupilMm[1], t.pupilMm[2]));
        *i0 = std::clamp(static_cast<int>((a.x - lo.x) / bucketMm_), 0, bucketsA_ - 1);
        *i1 = std::clamp(static_cast<int>((b.x - lo.x) / bucketMm_), 0, bucketsA_ - 1);
        *j0 = std::clamp(static_cast<int>((a.y - lo.y) / bucketMm_), 0, bucketsB_ - 1);
        *j1 = std::clamp(static_cast<int>((b.y - lo.y) / bucketMm_), 0, bucketsB_ - 1);
    };
    for (const BeamTriangle& t : triangles_) {
        int i0, i1, j0, j1;
        range(t, &i0, &i1, &j0, &j1);
        for (int j = j0; j <= j1; ++j)
            for (int i = i0; i <= i1; ++i) ++counts[static_cast<size_t>(j) * bucketsA_ + i + 1];
    }
    for (size_t k = 1; k < counts.size(); ++k) counts[k] += counts[k - 1];
    bucketStart_ = counts;
    bucketTriangles_.assign(counts.back(), 0);
    for (size_t n = 0; n < triangles_.size(); ++n) {
        int i0, i1, j0, j1;
        range(triangles_[n], &i0, &i1, &j0, &j1);
        for (int j = j0; j <= j1; ++j)
            for (int i = i0; i <= i1; ++i) bucketTriangles_[counts[static_cast<size_t>(j) * bucketsA_ + i]++] = static_cast<int>(n);
    }
}

const BeamTriangle* GhostBeam::locate(const glm::dvec2& u, double* b1, double* b2) const {
    if (triangles_.empty()) return nullptr;
    const double fi = (u.x - bucketMinMm_.x) / bucketMm_, fj = (u.y - bucketMinMm_.y) / bucketMm_;
    if (!(fi >= 0.0 && fj >= 0.0 && fi < bucketsA_ && fj < bucketsB_)) return nullptr;
    const size_t bucket = static_cast<size_t>(fj) * bucketsA_ + static_cast<size_t>(fi);
    for (int k = bucketStart_[bucket]; k < bucketStart_[bucket + 1]; ++k) {
        const BeamTriangle& t = triangles_[bucketTriangles_[k]];
        const glm::dvec2 &a = t.pupilMm[0], &b = t.pupilMm[1], &c = t.pupilMm[2];
        const double d = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
        const double l1 = ((u.x - a.x) * (c.y - a.y) - (c.x - a.x) * (u.y - a.y)) / d;
        const double l2 = ((b.x - a.x) * (u.y - a.y) - (u.x - a.x) * (b.y - a.y)) / d;
        // Triangles share edges exactly; a point on one belongs to the first found, and the
        // piecewise-linear map agrees there anyway.
        if (l1 >= 0.0 && l2 >= 0.0 && l1 + l2 <= 1.0) {
            *b1 = l1;
            *b2 = l2;
            return &t;
        }
    }
    return nullptr;
}

bool GhostBeam::twin(const glm::dvec2& pupilMm, BeamTwin* out) const {
    // The point location grid is built by the first twin: renders without correction photons
    // never need it.
    std::call_once(*indexOnce_, [this] { index(); });
    double l1 = 0.0, l2 = 0.0;
    const BeamTriangle* t = locate(pupilMm, &l1, &l2);
    if (!t) return false;
    const double l0 = 1.0 - l1 - l2;
    out->pixel = l0 * t->pixel[0] + l1 * t->pixel[1] + l2 * t->pixel[2];
    // Twins spread uniformly over the pupil land with density weight × pupil area / image area:
    // weighting them by irradiance × image area / pupil area gives the beam's irradiance. A small
    // triangle's splats carry its throughput, and so do its twins.
    out->throughput = t->small ? l0 * t->throughput[0] + l1 * t->throughput[1] + l2 * t->throughput[2]
                               : (l0 * t->irradiance[0] + l1 * t->irradiance[1] + l2 * t->irradiance[2]) *
                                     t->imageAreaPx2 / t->pupilAreaMm2;
    const double w = frame_.widthPx, h = frame_.heightPx;
    return out->pixel.x >= 0.0 && out->pixel.y >= 0.0 && out->pixel.x < w && out->pixel.y < h;
}

double GhostBeam::powerOnSensor() const {
    const double w = frame_.widthPx, h = frame_.heightPx;
    double total = 0.0;
    for (const BeamTriangle& t : triangles_) {
        const bool inside = std::all_of(std::begin(t.pixel), std::end(t.pixel), [&](const glm::dvec2& p) {
            return p.x >= 0.0 && p.y >= 0.0 && p.x <= w && p.y <= h;
        });
        if (t.small) {
            // Its splats land where its image is: all of it, or (a sliver across the sensor's
            // edge) the share of its area inside.
            const double mean = t.pupilAreaMm2 * (t.throughput[0] + t.throughput[1] + t.throughput[2]) / 3.0;
            if (inside || !(t.imageAreaPx2 > 1e-12)) {
                const glm::dvec2 c = (t.pixel[0] + t.pixel[1] + t.pixel[2]) / 3.0;
                if (inside || (c.x >= 0.0 && c.y >= 0.0 && c.x < w && c.y < h)) total += mean;
                continue;
            }
        }
        // The image (with its irradiance, or throughput for a small one) clipped by the sensor's
        // four sides, integrated exactly (linear over each fan triangle).
        if (inside && !t.small) {
            const glm::dvec3 a(t.pixel[0], t.irradiance[0]), b(t.pixel[1], t.irradiance[1]), c(t.pixel[2], t.irradiance[2]);
            total += std::abs(signedArea(a, b, c)) * (a.z + b.z + c.z) / 3.0;
            continue;
        }
        std::vector<glm::dvec3> polygon;
        for (int k = 0; k < 3; ++k) polygon.emplace_back(t.pixel[k], t.small ? t.throughput[k] : t.irradiance[k]);
        if (!inside) {
            auto cut = [](const std::vector<glm::dvec3>& in, int axis, double bound, bool below) {
                std::vector<glm::dvec3> out;
                for (size_t k = 0; k < in.size(); ++k) {
                    const glm::dvec3& p = in[k];
                    const glm::dvec3& q = in[(k + 1) % in.size()];
                    const double dp = below ? bound - p[axis] : p[axis] - bound;
                    const double dq = below ? bound - q[axis] : q[axis] - bound;
                    if (dp >= 0.0) out.push_back(p);
                    if ((dp >= 0.0) != (dq >= 0.0)) out.push_back(p + (dp / (dp - dq)) * (q - p));
                }
                return out;
            };
            polygon = cut(polygon, 0, 0.0, false);
            polygon = cut(polygon, 0, w, true);
            polygon = cut(polygon, 1, 0.0, false);
            polygon = cut(polygon, 1, h, true);
        }
        double integral = 0.0;
        for (size_t k = 1; k + 1 < polygon.size(); ++k) {
            const glm::dvec3 &a = polygon[0], &b = polygon[k], &c = polygon[k + 1];
            integral += std::abs(signedArea(a, b, c)) * (a.z + b.z + c.z) / 3.0;
        }
        total += t.small ? integral * t.pupilAreaMm2 / t.imageAreaPx2 : integral;
    }
    return total;
}

FLARE_ROUNDING_CLONES
void GhostBeam::rasterise(int band, const glm::dvec2& jitterPx, const glm::dvec3& scale, std::uint64_t seed,
                          double* rows) const {
    const int width = frame_.widthPx, height = frame_.heightPx;
    const int bands = static_cast<int>(bandStart_.size()) - 1;
    // (A beam cut to a band owner's part may hold rim segments reaching a band and no triangle.)
    if (band < 0 || band >= bands) return;
    const int rowBegin = band * Film::kBandRows, rowEnd = std::min(height, rowBegin + Film::kBandRows);
    auto add = [&](int column, int row, double value) {
        double* p = rows + (static_cast<size_t>(row - rowBegin) * width + column) * 3;
        p[0] += value * scale.x;
        p[1] += value * scale.y;
        p[2] += value * scale.z;
    };
    // Pixels whose jittered centre lies on the sensor: centre + jitter in [0, size).
    const int columnLo = std::max(0, static_cast<int>(std::ceil(-0.5 - jitterPx.x)));
    const int columnHi = std::min(width - 1, static_cast<int>(std::ceil(width - 0.5 - jitterPx.x)) - 1);
    const int rowLo = std::max(rowBegin, static_cast<int>(std::ceil(-0.5 - jitterPx.y)));
    const int rowHi = std::min(rowEnd - 1, static_cast<int>(std::ceil(height - 0.5 - jitterPx.y)) - 1);

    const int end = bandStart_[band + 1];
    for (int k = bandStart_[band]; k < end; ++k) {
        const int n = bandTriangles_[k];
        const BeamTriangle& t = triangles_[n];
        // The triangles were written by another task, long before: without a hint, the first read
        // of each (its pixels, about 170 bytes on) waits for memory.
        if (k + kPrefetchAhead < end) {
            const char* next = reinterpret_cast<const char*>(&triangles_[bandTriangles_[k + kPrefetchAhead]]);
            __builtin_prefetch(next + offsetof(BeamTriangle, pixel));
            __builtin_prefetch(next + offsetof(BeamTriangle, irradiance));
            __builtin_prefetch(next + offsetof(BeamTriangle, small));
        }
        if (t.small) {
            // Its power over points spread evenly over its image (a Fibonacci lattice on the unit
            // square, shifted at random, mapped uniformly onto the triangle), as many as its
            // longest side spans pixels twice: the splats then overlap, and their sum varies little
            // from beam to beam.
            const double yLo = std::min({t.pixel[0].y, t.pixel[1].y, t.pixel[2].y});
            const double yHi = std::max({t.pixel[0].y, t.pixel[1].y, t.pixel[2].y});
            if (yHi < rowBegin - 1.0 || yLo > rowEnd + 1.0) continue;
            const double longest = std::max({glm::length(t.pixel[1] - t.pixel[0]), glm::length(t.pixel[2] - t.pixel[1]),
                                              glm::length(t.pixel[0] - t.pixel[2])});
            const int points = std::clamp(static_cast<int>(std::ceil(2.0 * longest)), kSmallPointsMin, kSmallPointsMax);
            Rng rng(seed, static_cast<std::uint64_t>(seedIndex(static_cast<size_t>(n))));
            const double shift1 = rng.uniform(), shift2 = rng.uniform();
            constexpr double kGoldenFraction = 0.6180339887498949;
            for (int point = 0; point < points; ++point) {
                const double u1 = (point + shift1) / points;
                double u2 = point * kGoldenFraction + shift2;
                u2 -= std::floor(u2);
                const double s = std::sqrt(u1);
                const double w0 = 1.0 - s, w1 = s * (1.0 - u2), w2 = s * u2;
                const glm::dvec2 p = w0 * t.pixel[0] + w1 * t.pixel[1] + w2 * t.pixel[2];
                if (!(p.x >= 0.0 && p.y >= 0.0 && p.x < width && p.y < height)) continue;
                const double power = t.pupilAreaMm2 / points *
                                     (w0 * t.throughput[0] + w1 * t.throughput[1] + w2 * t.throughput[2]);
                const double fx = p.x - 0.5, fy = p.y - 0.5;
                const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
                const double tx = fx - x0, ty = fy - y0;
                for (int dy = 0; dy < 2; ++dy)
                    for (int dx = 0; dx < 2; ++dx) {
                        const int x = x0 + dx, y = y0 + dy;
                        if (x < 0 || x >= width || y < rowBegin || y >= rowEnd) continue;
                        add(x, y, power * (dx ? tx : 1.0 - tx) * (dy ? ty : 1.0 - ty));
                    }
            }
            continue;
        }
        // The triangle moved by −jitter, sampled at the pixel centres.
        glm::dvec2 v[3] = {t.pixel[0] - jitterPx, t.pixel[1] - jitterPx, t.pixel[2] - jitterPx};
        const double tp[3] = {t.irradiance[0], t.irradiance[1], t.irradiance[2]};
        const double yLo = std::min({v[0].y, v[1].y, v[2].y}), yHi = std::max({v[0].y, v[1].y, v[2].y});
        const int first = std::max(rowLo, static_cast<int>(std::ceil(yLo - 0.5)));
        const int last = std::min(rowHi, static_cast<int>(std::ceil(yHi - 0.5)) - 1);
        if (first > last) continue;
        // Irradiance as a plane over the image: e = c0 + gx·x + gy·y.
        const double det = (v[1].x - v[0].x) * (v[2].y - v[0].y) - (v[2].x - v[0].x) * (v[1].y - v[0].y);
        const double gx = ((tp[1] - tp[0]) * (v[2].y - v[0].y) - (tp[2] - tp[0]) * (v[1].y - v[0].y)) / det;
        const double gy = ((tp[2] - tp[0]) * (v[1].x - v[0].x) - (tp[1] - tp[0]) * (v[2].x - v[0].x)) / det;
        const double c0 = tp[0] - gx * v[0].x - gy * v[0].y;
        // Sort by y for the spans.
        // (Three compare-and-swaps of strict comparisons: stable, as std::sort's insertion sort of
        // three is, so ties keep their order.)
        int order[3] = {0, 1, 2};
        auto swapIfBelow = [&](int i, int j) {
            if (v[order[j]].y < v[order[i]].y) std::swap(order[i], order[j]);
        };
        swapIfBelow(0, 1);
        swapIfBelow(1, 2);
        swapIfBelow(0, 1);
        const glm::dvec2 top = v[order[0]], mid = v[order[1]], bottom = v[order[2]];
        // The edges' x per unit y (a scanline crosses the upper short edge only if it is not
        // horizontal, and likewise the lower).
        const double longSlope = (bottom.x - top.x) / (bottom.y - top.y);
        const double upperSlope = mid.y > top.y ? (mid.x - top.x) / (mid.y - top.y) : 0.0;
        const double lowerSlope = bottom.y > mid.y ? (bottom.x - mid.x) / (bottom.y - mid.y) : 0.0;
        // The spans' pixels, several values at a time (BeamTriangleRow.h: the same arithmetic), a
        // triangle's rows in one call.
        detail::TriangleRowSpan spans[kSpansPerCall];
        size_t count = 0;
        for (int row = first; row <= last; ++row) {
            const double y = row + 0.5;
            // The long edge top→bottom, and the short edge the scanline crosses.
            const double along = top.x + (y - top.y) * longSlope;
            const double across = y < mid.y ? top.x + (y - top.y) * upperSlope : mid.x + (y - mid.y) * lowerSlope;
            const double xl = std::min(along, across), xr = std::max(along, across);
            const int c1 = std::max(columnLo, static_cast<int>(std::ceil(xl - 0.5)));
            const int c2 = std::min(columnHi, static_cast<int>(std::ceil(xr - 0.5)) - 1);
            if (c1 > c2) continue;
            spans[count++] = {c0 + gy * y, c1, c2, rows + (static_cast<size_t>(row - rowBegin) * width + c1) * 3};
            if (count == kSpansPerCall) detail::addTriangleRows(spans, count, gx, scale), count = 0;
        }
        if (count > 0) detail::addTriangleRows(spans, count, gx, scale);
    }
    rim_.rasterise(band, jitterPx, scale, width, height, rows);
}

}  // namespace flare
