// Parallel rays of a directional light named by where they cross a plane normal to their
// direction: the common parametrisation of the ghost analysis, the preview and (later) guided
// photon emission. The plane passes through the first vertex; (a, b) are millimetres along e1, e2.
#pragma once

#include <glm/vec3.hpp>

#include "flare/LensSystem.h"
#include "flare/Ray.h"

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

}  // namespace flare
