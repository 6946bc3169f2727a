#include "flare/ghosts/GuideMask.h"

#include <cmath>

#include "flare/optics/SequentialTracer.h"

namespace flare {

GuideMask::GuideMask(const LivePupilRegion& region) {
    if (region.empty() || region.liveCount() == 0) return;
    grow(region.live, region.cellsA, region.cellsB, region.aMinMm, region.bMinMm, region.cellMm);
}

GuideMask GuideMask::traced(const LensSystem& lens, const SpectralIndices& indices, const PupilGrid& grid,
                            const GhostPath& path, const LivePupilRegion& region, int growCells, double sensorMarginMm) {
    GuideMask mask;
    if (region.empty() || region.liveCount() == 0) return mask;
    const int cellsA = region.cellsA + 2 * growCells, cellsB = region.cellsB + 2 * growCells;
    const double aMin = region.aMinMm - growCells * region.cellMm, bMin = region.bMinMm - growCells * region.cellMm;
    const double halfW = 0.5 * lens.sensor().widthMm + sensorMarginMm;
    const double halfH = 0.5 * lens.sensor().heightMm + sensorMarginMm;
    SequentialPath sequence;
    sequence.reflections = path.reflections;
    std::vector<std::uint8_t> live(static_cast<size_t>(cellsA) * cellsB, 0);
    bool any = false;
    for (int j = 0; j < cellsB; ++j)
        for (int i = 0; i < cellsA; ++i) {
            const TraceResult r = tracePath(lens, indices, grid.ray(aMin + (i + 0.5) * region.cellMm,
                                                                     bMin + (j + 0.5) * region.cellMm),
                                            sequence);
            if (!r.ok() || std::abs(r.ray.originMm.x) > halfW || std::abs(r.ray.originMm.y) > halfH) continue;
            live[static_cast<size_t>(j) * cellsA + i] = 1;
            any = true;
        }
    if (any) mask.grow(live, cellsA, cellsB, aMin, bMin, region.cellMm);
    return mask;
}

// Live cells and their eight neighbours.
void GuideMask::grow(const std::vector<std::uint8_t>& live, int cellsA, int cellsB, double aMinMm, double bMinMm,
                     double cellMm) {
    cellMm_ = cellMm;
    cellsA_ = cellsA + 2;
    cellsB_ = cellsB + 2;
    aMinMm_ = aMinMm - cellMm_;
    bMinMm_ = bMinMm - cellMm_;
    live_.assign(static_cast<size_t>(cellsA_) * cellsB_, 0);
    for (int j = 0; j < cellsB; ++j)
        for (int i = 0; i < cellsA; ++i) {
            if (!live[static_cast<size_t>(j) * cellsA + i]) continue;
            for (int dj = 0; dj <= 2; ++dj)
                for (int di = 0; di <= 2; ++di) live_[static_cast<size_t>(j + dj) * cellsA_ + i + di] = 1;
        }
    cells_.clear();
    for (size_t c = 0; c < live_.size(); ++c)
        if (live_[c]) cells_.push_back(static_cast<int>(c));
    areaMm2_ = static_cast<double>(cells_.size()) * cellMm_ * cellMm_;
}

}  // namespace flare
