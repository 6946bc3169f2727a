#pragma once

#include <glm/vec3.hpp>

namespace flare {

// A ray in lens space: millimetres, optical axis +z from object space towards the sensor, the
// first surface's vertex at z = 0. `direction` is a unit vector.
struct Ray {
    glm::dvec3 originMm{0.0};
    glm::dvec3 direction{0.0, 0.0, 1.0};

    glm::dvec3 at(double tMm) const { return originMm + tMm * direction; }
};

}  // namespace flare
