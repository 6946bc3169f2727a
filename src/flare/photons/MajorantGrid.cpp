#include "flare/photons/MajorantGrid.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/common.hpp>

namespace flare {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// An exponential variate of rate 1: an optical depth to the next proposal.
double sampleOpticalDepth(Rng& rng) { return -std::log(1.0 - rng.uniform()); }

}  // namespace

MajorantGrid::MajorantGrid(const VolumeGrid& grid) {
    if (grid.empty()) return;
    originMm_ = grid.boundsMinMm();
    const glm::dvec3 extentMm = grid.boundsMaxMm() - originMm_;
    const double longestMm = std::max({extentMm.x, extentMm.y, extentMm.z});
    cellMm_ = std::max(kVoxelsPerCell * grid.voxelSizeMm(), longestMm / kMaxCellsPerAxis);
    if (!(cellMm_ > 0.0)) cellMm_ = 1.0;  // a flat box (one plane of a constant grid): one cell
    for (int a = 0; a < 3; ++a)
        counts_[a] = std::clamp(static_cast<int>(std::ceil(extentMm[a] / cellMm_)), 1, kMaxCellsPerAxis);
    maxima_.assign(static_cast<std::size_t>(counts_.x) * counts_.y * counts_.z, 0.0f);

    grid.forEachActiveBox([&](const glm::dvec3& loMm, const glm::dvec3& hiMm, double value) {
        glm::ivec3 first, last;
        for (int a = 0; a < 3; ++a) {
            // Cells the closed box [lo, hi] meets: a box face on a cell face marks both cells.
            const double lo = std::floor((loMm[a] - originMm_[a]) / cellMm_);
            const double hi = std::floor((hiMm[a] - originMm_[a]) / cellMm_);
            if (hi < 0.0 || lo > counts_[a] - 1) return;  // wholly outside the bounds: never looked up
            first[a] = static_cast<int>(std::max(lo, 0.0));
            last[a] = static_cast<int>(std::min(hi, counts_[a] - 1.0));
        }
        const auto v = static_cast<float>(value);
        for (int z = first.z; z <= last.z; ++z)
            for (int y = first.y; y <= last.y; ++y)
                for (int x = first.x; x <= last.x; ++x) {
                    float& m = maxima_[(static_cast<std::size_t>(z) * counts_.y + y) * counts_.x + x];
                    m = std::max(m, v);
                }
    });
    maxValue_ = *std::max_element(maxima_.begin(), maxima_.end());
}

double MajorantGrid::majorantAt(const glm::dvec3& pMm) const {
    if (empty()) return 0.0;
    glm::ivec3 cell;
    for (int a = 0; a < 3; ++a) {
        // A point on the far face of the box (which lookups include) belongs to the last cell.
        const double c = std::floor((pMm[a] - originMm_[a]) / cellMm_);
        if (!(c >= 0.0 && c <= counts_[a])) return 0.0;  // also NaN
        cell[a] = std::min(static_cast<int>(c), counts_[a] - 1);
    }
    return cellMaximum(cell);
}

MajorantGrid::Walk::Walk(const MajorantGrid& grid, const glm::dvec3& originMm, const glm::dvec3& direction,
                         double tEndMm)
    : grid_(&grid) {
    if (grid.empty()) return;  // t_ = tEnd_ = 0: no segments
    // Clip the ray to the box [0, counts·cell] (slab method) in coordinates relative to its corner.
    const glm::dvec3 o = originMm - grid.originMm_;
    double tIn = 0.0, tOut = tEndMm;
    for (int a = 0; a < 3; ++a) {
        const double size = grid.counts_[a] * grid.cellMm_;
        if (direction[a] == 0.0) {
            if (!(o[a] >= 0.0 && o[a] <= size)) return;
            continue;
        }
        double t0 = -o[a] / direction[a], t1 = (size - o[a]) / direction[a];
        if (t0 > t1) std::swap(t0, t1);
        tIn = std::max(tIn, t0);
        tOut = std::min(tOut, t1);
    }
    if (!(tIn < tOut)) return;
    t_ = tIn;
    tEnd_ = tOut;
    const glm::dvec3 p = o + tIn * direction;
    for (int a = 0; a < 3; ++a) {
        cell_[a] = std::clamp(static_cast<int>(std::floor(p[a] / grid.cellMm_)), 0, grid.counts_[a] - 1);
        if (direction[a] == 0.0) {
            step_[a] = 0, tNext_[a] = kInf, tDelta_[a] = kInf;
            continue;
        }
        step_[a] = direction[a] > 0.0 ? 1 : -1;
        const double face = (cell_[a] + (step_[a] > 0 ? 1 : 0)) * grid.cellMm_;
        tNext_[a] = (face - o[a]) / direction[a];
        tDelta_[a] = grid.cellMm_ / std::abs(direction[a]);
    }
}

bool MajorantGrid::Walk::next(Segment& segment) {
    if (!(t_ < tEnd_)) return false;
    const int axis = tNext_.x <= tNext_.y ? (tNext_.x <= tNext_.z ? 0 : 2) : (tNext_.y <= tNext_.z ? 1 : 2);
    const double t1 = std::min(std::max(tNext_[axis], t_), tEnd_);
    segment = {t_, t1, grid_->cellMaximum(cell_)};
    t_ = t1;
    if (t1 < tEnd_) {
        // Rounding can put the last face crossing a hair before tEnd_: stay in the last cell then,
        // so that the rest of the ray keeps a bound instead of getting none.
        const int nextCell = cell_[axis] + step_[axis];
        if (nextCell >= 0 && nextCell < grid_->counts_[axis]) {
            cell_[axis] = nextCell;
            tNext_[axis] += tDelta_[axis];
        } else {
            tNext_[axis] = kInf;
        }
    }
    return true;
}

double sampleFreeFlight(const MajorantGrid& majorants, VolumeGrid::Sampler& density, double sigmaTPerMm,
                        const glm::dvec3& originMm, const glm::dvec3& direction, double tEndMm, Rng& rng,
                        int& nullCollisions) {
    if (!(sigmaTPerMm > 0.0)) return kInf;
    // The walk's optical depth is at most σt · max · (length in the box) ≤ σt · max · tEnd: a
    // larger draw gets through whatever the cells hold, so the walk is skipped with exactly the
    // outcome it would have had. In thin media most rays cross without a single proposal; the
    // cheaper bound first keeps even the walk's setup off that common path.
    double tau = sampleOpticalDepth(rng);
    const double bound = sigmaTPerMm * majorants.maxValue();
    if (tau >= bound * tEndMm) return kInf;
    MajorantGrid::Walk walk(majorants, originMm, direction, tEndMm);
    if (tau >= bound * walk.lengthInBoxMm()) return kInf;
    MajorantGrid::Segment s;
    while (walk.next(s)) {
        const double rate = sigmaTPerMm * s.maximum;
        if (rate <= 0.0) continue;
        for (double t = s.t0Mm;;) {
            const double step = tau / rate;
            if (step >= s.t1Mm - t) {  // no proposal left in this segment: carry the rest on
                tau = std::max(0.0, tau - (s.t1Mm - t) * rate);
                break;
            }
            t += step;
            if (rng.uniform() * rate < sigmaTPerMm * density.densityAt(originMm + t * direction)) return t;
            ++nullCollisions;
            tau = sampleOpticalDepth(rng);
        }
    }
    return kInf;
}

double ratioTrackingTransmittance(const MajorantGrid& majorants, VolumeGrid::Sampler& density, double sigmaTPerMm,
                                  const glm::dvec3& originMm, const glm::dvec3& direction, double tEndMm, Rng& rng) {
    if (!(sigmaTPerMm > 0.0)) return 1.0;
    double tau = sampleOpticalDepth(rng);  // no proposal at all past these bounds (as above)
    const double bound = sigmaTPerMm * majorants.maxValue();
    if (tau >= bound * tEndMm) return 1.0;
    MajorantGrid::Walk walk(majorants, originMm, direction, tEndMm);
    if (tau >= bound * walk.lengthInBoxMm()) return 1.0;
    double transmittance = 1.0;
    MajorantGrid::Segment s;
    while (walk.next(s)) {
        const double rate = sigmaTPerMm * s.maximum;
        if (rate <= 0.0) continue;
        for (double t = s.t0Mm;;) {
            const double step = tau / rate;
            if (step >= s.t1Mm - t) {
                tau = std::max(0.0, tau - (s.t1Mm - t) * rate);
                break;
            }
            t += step;
            transmittance *= 1.0 - sigmaTPerMm * density.densityAt(originMm + t * direction) / rate;
            tau = sampleOpticalDepth(rng);
        }
    }
    return transmittance;
}

}  // namespace flare
