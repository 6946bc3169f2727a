// The pupil as a directional light sees it, for its diffraction: the outline of the region of a
// plane normal to the light's direction, in front of the lens, whose rays reach the sensor (the
// iris seen through the front elements, cut by every clear aperture that vignettes the beam at
// that field), and how the lens maps a change of the light's direction to pixels.
#pragma once

#include <vector>

#include <glm/mat2x2.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "flare/optics/Iris.h"
#include "flare/optics/LensSystem.h"

namespace flare {

struct PupilOutline {
    bool found = false;                 // false: no ray of this direction reaches the sensor
    std::vector<glm::dvec2> outlineMm;  // counter-clockwise, in the plane's axes (u, v)
    glm::dvec3 axisU{1.0, 0.0, 0.0}, axisV{0.0, 1.0, 0.0};  // the plane's axes (unit, ⟂ direction)
    glm::dvec2 imagePx{0.0};            // where the beam's centroid lands (pixels, camera orientation)
    glm::dmat2 pxPerRad{0.0};           // pixel offset per radian of tilt of the direction along u, v
    long tracedRays = 0;
};

struct PupilOutlineOptions {
    int angles = 720;             // outline vertices (directions from the region's centre)
    int bisections = 24;          // per vertex: places it to 2⁻²⁴ of the search radius
    int seedGrid = 48;            // grid that finds the region and its centre
    double wavelengthNm = 587.56; // the d line; vignetting barely depends on it
    int widthPx = 1536, heightPx = 1024;  // the image the pixels refer to
};

// Traces the outline of the live region for light travelling in `direction` (unit, +z towards the
// sensor). The region is assumed star-shaped about its centroid (an intersection of convex
// apertures' images is).
PupilOutline tracePupilOutline(const LensSystem& lens, const glm::dvec3& direction, const PupilOutlineOptions& options);

// How a deflection of the beam just before surface `surface` (0-based; in the medium in front of
// it, where dust on that face sits) moves its image: pixels per radian about two axes normal to
// the beam there (the beam's centroid, as tracePupilOutline). `found` false when the beam does not
// reach the surface and the sensor.
struct SurfaceDeflection {
    bool found = false;
    glm::dmat2 pxPerRad{0.0};
    double mediumIndex = 1.0;  // in front of the surface, at the options' wavelength
};
SurfaceDeflection traceSurfaceDeflection(const LensSystem& lens, const glm::dvec3& direction, int surface,
                                         const PupilOutlineOptions& options);

// The iris's own outline (at its plane, mm): `samples` directions plus the blades' corners, so
// that the corners are exact.
std::vector<glm::dvec2> irisOutline(const Iris& iris, int samples = 720);

}  // namespace flare
