// The live cells of a path's pupil region (LivePupilRegion, from the ghost analysis), grown by
// one cell on every side: the cells whose ray lands on the sensor for some wavelength or point of
// the light (the analysis samples cell centres at one of each), and their neighbours. The mask
// decides who samples what: guided emission draws points uniformly over it, the beams mesh the
// live region inside it, and the unguided tracer leaves to the guided strategy exactly the paths
// that start inside it. Paths outside it are not lost.
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/vec2.hpp>

#include "flare/ghosts/GhostAnalysis.h"
#include "flare/optics/PupilGrid.h"

namespace flare {

class GuideMask {
public:
    GuideMask() = default;
    // The region's live cells as they are.
    explicit GuideMask(const LivePupilRegion& region);
    // Re-traces the centre of every cell of the region's grid, extended by `growCells` on each
    // side, through the path once per probe (a point of the light's extent at a wavelength): a
    // cell is live when the ray of any probe survives the path and lands within `sensorMarginMm`
    // of the sensor. The analysis's region holds the cells whose ray from the light's centre at
    // one wavelength lands on the sensor itself; other wavelengths and other points of the light
    // move landings by a fraction of a millimetre and move the region itself, most where the path
    // crosses the iris more than once (a ghost off the sensor and a front surface: 0.15 mm at
    // 400 nm against 550 nm on a 0.6 mm region). What the mask leaves out goes to the unguided
    // tracer, where each ray is a rare, heavy sample; so the mask also grows outwards from its live
    // cells, `growCells` at a time, as long as any probe finds new live cells, within the square
    // of half-size `maxHalfSizeMm` about the grid's centre (the analysis's window). The window is
    // first traced with the first probe alone, or with the first `seedProbes` (a region light's
    // points: the analysis's region need not be live at its centre).
    struct Probe {
        PupilGrid grid;
        SpectralIndices indices;
    };
    static GuideMask traced(const LensSystem& lens, std::span<const Probe> probes, const GhostPath& path,
                            const LivePupilRegion& region, int growCells, double sensorMarginMm, double maxHalfSizeMm,
                            size_t seedProbes = 1);

    // `lattice` (an analysis's search cells, PupilLattice) with the mask's live cells added where its
    // leaves do not cover them, when the mask's cells are cells of that lattice (a mask traced
    // from the analysis's region): a beam meshed on it (remeshLiveRegion) starts from every cell
    // the mask owns, so it finds the live parts a probe's wavelength or point of the light moved
    // away from the analysis's region. Otherwise `lattice` as it is.
    PupilLattice coveringLattice(const PupilLattice& lattice) const;

    bool empty() const { return cells_.empty(); }
    // What a traced mask cost: the rays it traced, and the distinct cells they started from (a
    // cell costs at most one ray per probe).
    size_t tracedRays() const { return tracedRays_; }
    size_t tracedCells() const { return tracedCells_; }
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
    size_t tracedRays_ = 0, tracedCells_ = 0;
};

}  // namespace flare
