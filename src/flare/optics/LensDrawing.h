// A cutaway drawing of a lens (the meridional x–z section) as SVG: elements with their edges and
// bevels, the iris, the barrel, the sensor, and traced ray paths.
#pragma once

#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "flare/optics/LensSystem.h"

namespace flare {

struct DrawnRay {
    std::vector<glm::dvec3> pointsMm;  // polyline in lens space
    std::string colour;                // SVG colour
};

struct LensDrawingOptions {
    int raysPerField = 9;
    std::vector<double> fieldsDeg = {0.0};
    double wavelengthNm = 587.5618;
    std::string title;  // default: the lens name
};

// Meridional ray fans: for each field, rays aimed across the stop diameter, traced to the sensor
// (or to where they are blocked).
std::vector<DrawnRay> traceRayFans(const LensSystem& lens, const LensDrawingOptions& options);

// Where the drawing begins in front of the lens (z, mm): rays are drawn from there.
double drawingStartZMm(const LensSystem& lens);

std::string drawLensSvg(const LensSystem& lens, const std::vector<DrawnRay>& rays,
                        const LensDrawingOptions& options);

}  // namespace flare
