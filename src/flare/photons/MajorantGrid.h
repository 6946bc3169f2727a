// Coarse upper bounds of a VolumeGrid's density, and delta and ratio tracking through them.
//
// Delta tracking proposes collisions at the rate of a majorant σ̄ ≥ σt(x) and rejects the share
// 1 − σt(x)/σ̄ as null collisions. With one majorant for a whole grid (its maximum), a sparse grid
// — a few bubbles in an element, or thin striae — makes almost every proposal a null collision,
// each costing a tree lookup. A MajorantGrid cuts the grid's box into coarse cells (a few voxels
// on a side) holding the largest density any lookup inside them can return, so the majorant
// along a ray is piecewise constant: 0 in empty space, close to the density where there is some.
// The trackers walk the cells with a 3D DDA (Amanatides & Woo 1987) and draw the free flight
// segment by segment against that piecewise-constant rate; since the exponential is memoryless,
// carrying the unused optical depth from one segment to the next is exact, and both estimators
// stay unbiased for any majorant that bounds the density (Novák et al. 2014, "Residual ratio
// tracking", §3).
#pragma once

#include <vector>

#include <glm/vec3.hpp>

#include "flare/core/Random.h"
#include "flare/photons/VolumeGrid.h"

namespace flare {

class MajorantGrid {
public:
    // Cells are kVoxelsPerCell voxels on a side, or larger so that no axis has more than
    // kMaxCellsPerAxis cells (the structure stays below 64³ floats = 1 MB).
    static constexpr int kVoxelsPerCell = 4;
    static constexpr int kMaxCellsPerAxis = 64;

    MajorantGrid() = default;  // no cells: the majorant is 0 everywhere
    // Conservative by construction: each cell holds the maximum over every active voxel and tile
    // whose lookup region (VolumeGrid::forEachActiveBox) meets it, so no densityAt() at a point of
    // the cell exceeds it. The grid covers grid's bounds (outside them the density is 0).
    explicit MajorantGrid(const VolumeGrid& grid);

    bool empty() const { return maxima_.empty(); }
    glm::ivec3 cellCounts() const { return counts_; }
    double cellSizeMm() const { return cellMm_; }
    double maxValue() const { return maxValue_; }  // the largest cell: the grid's maximum
    // The bound holding at pMm: its cell's maximum, 0 outside the covered box (faces included).
    double majorantAt(const glm::dvec3& pMm) const;

    // The ray originMm + t·direction (grid frame, unit direction) for t in [0, tEndMm), cut where
    // it crosses cell faces. Pieces outside the covered box (majorant 0) are skipped.
    struct Segment {
        double t0Mm = 0.0, t1Mm = 0.0;
        double maximum = 0.0;  // the density bound over [t0Mm, t1Mm)
    };
    class Walk {
    public:
        Walk(const MajorantGrid& grid, const glm::dvec3& originMm, const glm::dvec3& direction, double tEndMm);
        // The next piece along the ray; false when the ray has left the box or reached tEndMm.
        bool next(Segment& segment);
        // Length of the ray inside the box: with maxValue() it bounds the walk's optical depth.
        double lengthInBoxMm() const { return tEnd_ - t_; }

    private:
        const MajorantGrid* grid_;
        double t_ = 0.0, tEnd_ = 0.0;
        glm::ivec3 cell_{0}, step_{0};
        glm::dvec3 tNext_{0.0}, tDelta_{0.0};
    };

private:
    double cellMaximum(const glm::ivec3& cell) const {
        return maxima_[(static_cast<std::size_t>(cell.z) * counts_.y + cell.y) * counts_.x + cell.x];
    }

    glm::dvec3 originMm_{0.0};  // corner of cell (0, 0, 0)
    double cellMm_ = 0.0;
    glm::ivec3 counts_{0};
    std::vector<float> maxima_;  // x fastest; the grid's values are floats, so this is exact
    double maxValue_ = 0.0;
};

// Delta tracking along originMm + t·direction, t in [0, tEndMm) (grid frame, unit direction), in a
// medium of extinction sigmaTPerMm × density: the distance to the first real collision, or +inf if
// the ray gets through. Each rejected proposal adds one to nullCollisions.
double sampleFreeFlight(const MajorantGrid& majorants, VolumeGrid::Sampler& density, double sigmaTPerMm,
                        const glm::dvec3& originMm, const glm::dvec3& direction, double tEndMm, Rng& rng,
                        int& nullCollisions);

// Ratio tracking along the same ray: an unbiased estimate of its transmittance
// exp(−∫ sigmaTPerMm × density dt), the product of 1 − σt/σ̄ over proposals at the rate σ̄.
double ratioTrackingTransmittance(const MajorantGrid& majorants, VolumeGrid::Sampler& density, double sigmaTPerMm,
                                  const glm::dvec3& originMm, const glm::dvec3& direction, double tEndMm, Rng& rng);

}  // namespace flare
