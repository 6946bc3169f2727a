// The live cells of a path's pupil region (LivePupilRegion, from the ghost analysis), grown by
// one cell on every side: the analysis samples cell centres at one wavelength, and a path stays
// live a little beyond them (other wavelengths, the sun's disk). The mask decides who samples
// what: guided emission draws points uniformly over it, and the unguided tracer leaves to the
// guided strategy exactly the paths that start inside it. Paths outside it are not lost.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include <glm/vec2.hpp>

#include "flare/ghosts/GhostAnalysis.h"

namespace flare {

class GuideMask {
public:
    GuideMask() = default;
    // The region's live cells as they are.
    explicit GuideMask(const LivePupilRegion& region);
    // Re-traces the centre of every cell of the region's grid, extended by `growCells` on each
    // side, through the path (at one wavelength): a cell is live when its ray survives the path
    // and lands within `sensorMarginMm` of the sensor. The analysis's region asks for a landing on
    // the sensor itself; other wavelengths and the light's angular size move landings by a
    // fraction of a millimetre, so a mask that stopped at the sensor's edge would leave the rays
    // just outside it to the unguided tracer, where each is a rare, heavy sample.
    static GuideMask traced(const LensSystem& lens, const SpectralIndices& indices, const PupilGrid& grid,
                            const GhostPath& path, const LivePupilRegion& region, int growCells, double sensorMarginMm);

    bool empty() const { return cells_.empty(); }
    double areaMm2() const { return areaMm2_; }
    int cellCount() const { return static_cast<int>(cells_.size()); }
    double cellMm() const { return cellMm_; }
    // Whether the pupil-plane point lies in a live cell (cells are half-open: [a0, a0 + cell)).
    bool contains(double aMm, double bMm) const {
        if (cells_.empty()) return false;
        const double x = (aMm - aMinMm_) / cellMm_, y = (bMm - bMinMm_) / cellMm_;
        if (!(x >= 0.0 && y >= 0.0 && x < cellsA_ && y < cellsB_)) return false;
        return live_[static_cast<size_t>(y) * cellsA_ + static_cast<size_t>(x)] != 0;
    }
    // The mask's grid of cells: the cell (i, j) spans [aMin + i·cell, aMin + (i + 1)·cell) ×
    // [bMin + j·cell, ...); liveCell is false outside the grid.
    double aMinMm() const { return aMinMm_; }
    double bMinMm() const { return bMinMm_; }
    int cellsA() const { return cellsA_; }
    int cellsB() const { return cellsB_; }
    bool liveCell(int i, int j) const {
        return i >= 0 && j >= 0 && i < cellsA_ && j < cellsB_ && live_[static_cast<size_t>(j) * cellsA_ + i] != 0;
    }
    // A point uniform over the live cells, from three uniform numbers in [0, 1): density
    // 1 / areaMm2() on the mask.
    glm::dvec2 sample(double uCell, double ua, double ub) const {
        const int c = cells_[std::min(cells_.size() - 1, static_cast<size_t>(uCell * cells_.size()))];
        return {aMinMm_ + (c % cellsA_ + ua) * cellMm_, bMinMm_ + (c / cellsA_ + ub) * cellMm_};
    }

private:
    void grow(const std::vector<std::uint8_t>& live, int cellsA, int cellsB, double aMinMm, double bMinMm, double cellMm);

    double aMinMm_ = 0.0, bMinMm_ = 0.0, cellMm_ = 1.0;
    int cellsA_ = 0, cellsB_ = 0;
    std::vector<std::uint8_t> live_;
    std::vector<int> cells_;  // indices of the live cells, for sampling
    double areaMm2_ = 0.0;
};

}  // namespace flare
