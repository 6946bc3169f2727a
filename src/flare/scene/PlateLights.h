// From a plate's sources to lights through a lens (`flare composite`). A pixel of the plate is a
// direction in the scene: the field angle whose real chief ray lands there, found by inverting the
// lens's real chief-ray image height against field angle (RealRays.h), so distortion is the lens's
// own. Each source cell (PlateSources.h) becomes a directional light at its centroid's field, with
// the power whose direct image through the lens puts the cell's energy on the sensor (the plate's
// values are sensor irradiance: the flare comes out in the plate's units), a smooth spectrum of its
// colour (SmoothSpectrum.h) and its angular extent (a disk of the cell's solid angle).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <glm/vec2.hpp>

#include "flare/optics/LensSystem.h"
#include "flare/photons/Light.h"
#include "flare/scene/PlateSources.h"

namespace flare {

// The mapping between the plate's pixels and field angles through `lens`, whose sensor is the
// plate's (sensor().widthMm across widthPx; square pixels). Picture coordinates: the camera's view
// (x to the right, y up; the sensor image turned by 180°), as LightSpec's field angles.
class PlateFieldMap {
public:
    PlateFieldMap(const LensSystem& lens, int widthPx, int heightPx, double wavelengthNm = 550.0);

    double pixelMm() const { return pixelMm_; }
    // Millimetres from the picture's centre of a pixel coordinate (column, row from the top left;
    // a pixel's centre at +0.5).
    glm::dvec2 pictureMm(const glm::dvec2& px) const;
    glm::dvec2 pixelOf(const glm::dvec2& pictureMm) const;
    // |real chief-ray image height| at field angle thetaRad; nullopt where the chief ray fails.
    std::optional<double> imageHeightMm(double thetaRad) const;
    // The field angle (rad) whose chief ray lands at image height heightMm (≥ 0): to 1e-9 mm.
    // Throws InputError (the lens, line 0) when the plate reaches beyond the lens's field.
    double fieldAngleRad(double heightMm) const;
    // The field angles (deg, LightSpec's x and y) whose chief ray lands at pixel coordinate px.
    glm::dvec2 fieldDeg(const glm::dvec2& px) const;
    // The solid angle (sr) one pixel subtends at field angle thetaRad: radial × tangential extents.
    double pixelSolidAngleSr(double thetaRad) const;

private:
    const LensSystem& lens_;
    int widthPx_, heightPx_;
    double pixelMm_;
    double wavelengthNm_;
    std::vector<double> tableRad_, tableMm_;  // the chief-ray height on a grid of fields, to bracket
};

struct PlateLight {
    LightSpec spec;
    PlateSource cell;
    double directThroughputMm2 = 0.0;  // power on the sensor per unit irradiance (direct path)
};

struct PlateLightSet {
    std::vector<PlateLight> lights;  // strongest first
    int culled = 0;                  // dim cells left out...
    double culledPowerShare = 0.0;   // ...holding this share of the sources' power
};

// One light per cell, named "<prefix><group>-<k>". Cells are culled, dimmest first, while
// together they hold at most `cullShare` of the total power (their ghosts hold about that share
// of the flare: ghost fractions vary slowly across the frame).
PlateLightSet plateLights(const LensSystem& lens, const PlateFieldMap& map, const PlateSources& sources,
                          double cullShare = 1e-3, const std::string& prefix = "source");

// Sorts the lights strongest first and leaves out the dimmest while together they hold at most
// `cullShare` of the total power.
PlateLightSet cullDimmestLights(std::vector<PlateLight> lights, double cullShare);

}  // namespace flare
