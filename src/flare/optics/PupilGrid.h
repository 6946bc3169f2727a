// Parallel rays of a directional light named by where they cross a plane normal to their
// direction: the common parametrisation of the ghost analysis, the preview and (later) guided
// photon emission. The plane passes through the first vertex; (a, b) are millimetres along e1, e2.
#pragma once

#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "flare/core/Ray.h"
#include "flare/optics/LensSystem.h"

namespace flare {

// Unit direction of travel of light from a source seen at field angles (fieldXDeg, fieldYDeg):
// a source to the right (+x) and above (+y) sends light travelling towards −x, −y and +z.
glm::dvec3 directionFromFieldDeg(double fieldXDeg, double fieldYDeg);

struct PupilGrid {
    glm::dvec3 direction{0.0, 0.0, 1.0};
    glm::dvec3 e1{1.0, 0.0, 0.0};
    glm::dvec3 e2{0.0, 1.0, 0.0};
    glm::dvec3 centreMm{0.0};
    double backOffMm = 0.0;   // rays start this far before the plane, in front of the lens
    double halfSizeMm = 0.0;  // [−half, half]² covers every ray that can enter the front aperture

    static PupilGrid forDirection(const LensSystem& lens, const glm::dvec3& direction);
    Ray ray(double aMm, double bMm) const {
        return {centreMm + aMm * e1 + bMm * e2 - backOffMm * direction, direction};
    }
    // Area of the front clear aperture projected on the plane (mm²): the cross-section of the
    // beam that enters the lens. Counted on a cells × cells grid.
    double enteringAreaMm2(const LensSystem& lens, int cells) const;
};

// Cells of a quadtree lattice over a square window of the pupil plane: level 0 has baseCells ×
// baseCells cells; a cell (level, i, j) spans [i, i + 1) × [j, j + 1) cells of size
// windowSizeMm / (baseCells · 2^level) from windowMinMm. The leaves of an adaptive search
// (PupilMesh), kept so that other wavelengths can be traced on the same cells.
struct PupilLattice {
    struct Leaf {
        int level = 0;
        long i = 0, j = 0;
    };
    glm::dvec2 windowMinMm{0.0};
    double windowSizeMm = 0.0;
    int baseCells = 1;
    std::vector<Leaf> leaves;

    double cellMm(int level) const { return windowSizeMm / static_cast<double>(static_cast<long>(baseCells) << level); }
    bool empty() const { return leaves.empty(); }
};

}  // namespace flare
