// A light as a scene describes it: directional (the sun, a distant lamp), a point at a finite
// distance, or a Lambertian disk; where it is, how large it looks, its spectral shape and power.
// Plain data, read from scenes (scene/Scene.h) and used by the samplers of the preview and the
// photon tracer.
#pragma once

#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "flare/core/Spectrum.h"

namespace flare {

// The spectral shape of a light. Only the shape: the light's `power` sets the amount.
struct SpectrumSpec {
    enum class Kind { Blackbody, D65, EqualEnergy, Rgb };
    Kind kind = Kind::Blackbody;
    double temperatureK = 5778.0;  // Blackbody only (5778 K: the sun's effective temperature)
    // Rgb only: a colour in linear Rec.709 (its scale does not matter), given the smooth spectrum
    // of that chromaticity (SmoothSpectrum.h): what `flare composite` gives a plate's sources.
    glm::dvec3 rgb{1.0};
};

// The spectral shape a SpectrumSpec names.
Spectrum toSpectrum(const SpectrumSpec& spec);

// One direction of a region light (LightSpec::region): where it appears in the picture, its share
// of the light's power and its colour (an index into LightSpec::regionColours).
struct RegionPoint {
    double fieldXDeg = 0.0, fieldYDeg = 0.0;
    double share = 0.0;  // of the light's power; the shares sum to 1
    int colour = 0;
};

// The widest a region light may be (its farthest point from its centre): its points share one
// ghost analysis, one plan and one pupil grid, widened to hold every point's rays (LightSampler).
// Tested against the same points as separate lights (test_plate_regions.cpp): at 4.35° a ghost of
// the outer points of the test's region was nearly lost. `flare composite` makes regions of at
// most 3° by default (PlateRegions.h).
inline constexpr double kMaxRegionRadiusDeg = 3.0;

struct LightSpec {
    enum class Type { Directional, Point, Disk };
    Type type = Type::Directional;
    std::string name;  // unique within the scene; default "light<index>"

    // Directional: where the light appears in the picture, as field angles (x to the right, y up,
    // as the photographer sees the scene). Each in [-89.9, 89.9]; outside the frame is allowed
    // (light from outside the frame still flares). angularDiameterDeg: full apparent diameter
    // (the sun: 0.53°), 0 for a perfectly collimated source.
    double fieldXDeg = 0.0, fieldYDeg = 0.0, angularDiameterDeg = 0.0;

    // Directional only, optional: a region light (a plate's extended source, `flare composite`).
    // Its rays come from a discrete set of directions, each with its share of the power and its
    // colour, as a sun's come from its disk: one ghost analysis and plan for all of them, each
    // beam and photon drawing one direction by its share (LightSampler). fieldXDeg/fieldYDeg are
    // then the points' centre (centreOnRegion), angularDiameterDeg is unused, and `spectrum`
    // is the shape the wavelengths are drawn from (each point's own colour reweights them).
    std::vector<RegionPoint> region;
    std::vector<glm::dvec3> regionColours;  // linear Rec.709; only the chromaticity matters
    bool isRegion() const { return type == Type::Directional && !region.empty(); }
    // Sets fieldXDeg/fieldYDeg to the share-weighted mean of the points' directions.
    void centreOnRegion();

    // Point and Disk: position in lens space (mm; z < 0 is in front of the first vertex).
    // Disk: a Lambertian disk of radius radiusMm whose normal points at the first vertex.
    glm::dvec3 positionMm{0.0, 0.0, -1000.0};
    double radiusMm = 0.0;

    SpectrumSpec spectrum;
    // Directional: irradiance on a plane normal to the rays, W/m². Point: radiant intensity,
    // W/sr. Disk: radiant intensity along its normal (towards the lens), W/sr. Integrated over
    // the spectrum; 1 is a convenient relative unit, since every output scales linearly with it.
    double power = 1.0;

    // Unit direction in which the light's rays travel (z > 0: towards the sensor). Directional:
    // normalize(−tan fieldX, −tan fieldY, 1) — a light seen up and to the right sends its rays
    // down and to the left. Point and Disk: from the position towards the first vertex (0, 0, 0).
    glm::dvec3 travelDirection() const;
    // The radius of the light's apparent disk as the lens sees it, in radians: a directional
    // light's half angular diameter, a disk's radius over its distance from the first vertex
    // (atan), 0 for a point; a region's largest angle between its centre and a point.
    double apparentRadiusRad() const;
    // Disk: the unit normal of the emitting face (equal to travelDirection(): it faces the lens).
    glm::dvec3 diskNormal() const { return travelDirection(); }
};

}  // namespace flare
