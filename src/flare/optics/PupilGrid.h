// The rays of one light named by where they cross a plane normal to the light's central direction:
// the common parametrisation of the ghost analysis, the preview, the beams and photon emission. The
// plane passes through the first vertex; (a, b) are millimetres along e1, e2. A directional light's
// rays are parallel; a point source's (a point light, or one point of a disk light) fan out from
// it, each through its own point of the plane. Everything that traces a grid's rays (the ghost
// analysis, the meshes, the guide masks) works the same on both.
#pragma once

#include <vector>

#include <glm/geometric.hpp>
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
    double backOffMm = 0.0;   // parallel rays start this far before the plane, in front of the lens
    double halfSizeMm = 0.0;  // [−half, half]² covers every ray that can enter the front aperture
    // Rays from a point: each from sourceMm through its plane point (direction is then the central
    // ray's, from the source through the first vertex).
    bool fromPoint = false;
    glm::dvec3 sourceMm{0.0};
    double startZMm = 0.0;    // a point's rays start at this z (in front of the lens) or at the point

    static PupilGrid forDirection(const LensSystem& lens, const glm::dvec3& direction);
    // The rays from a point in front of the lens (inFront; else std::invalid_argument).
    static PupilGrid forPoint(const LensSystem& lens, const glm::dvec3& sourceMm);
    // Whether rays from the point can be named on a plane through the first vertex: it lies
    // ahead of the vertex, farther than the front surface reaches towards it.
    static bool inFront(const LensSystem& lens, const glm::dvec3& sourceMm);
    // The same plane and window with the rays from another point (a disk light's sampled point):
    // the (a, b) of a mask or a lattice name the same plane points.
    PupilGrid withSource(const glm::dvec3& pointMm) const {
        PupilGrid moved = *this;
        moved.sourceMm = pointMm;
        return moved;
    }
    Ray ray(double aMm, double bMm) const {
        if (fromPoint) return rayFrom(sourceMm, aMm, bMm);
        return {centreMm + aMm * e1 + bMm * e2 - backOffMm * direction, direction};
    }
    // The ray from pointMm (in front of the lens) through the plane point (a, b). It starts where
    // it crosses z = startZMm, just in front of the lens whatever its inclination, or at the point
    // when that is nearer; measured back from the plane point, so that a far light's rays start
    // near the lens with a directional light's precision (from 10⁹ mm away, a sphere's
    // intersection would lose 9 digits).
    Ray rayFrom(const glm::dvec3& pointMm, double aMm, double bMm) const {
        const glm::dvec3 onPlane = centreMm + aMm * e1 + bMm * e2;
        const glm::dvec3 toPlane = onPlane - pointMm;
        const double distanceMm = glm::length(toPlane);
        const glm::dvec3 d = toPlane / distanceMm;
        const double backMm = (onPlane.z - startZMm) / d.z;
        return {d.z > 0.0 && distanceMm > backMm ? onPlane - backMm * d : pointMm, d};
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
