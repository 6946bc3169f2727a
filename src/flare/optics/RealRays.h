// Real-ray analysis on top of the sequential tracer: aiming rays at a point of the stop (chief
// and marginal rays of a field), real image heights and the real field of view (which differs
// from the paraxial one for wide angles and fisheyes).
#pragma once

#include <optional>

#include "flare/core/Ray.h"
#include "flare/optics/LensSystem.h"

namespace flare {

// Axial position of a plane in front of every point of the first surface (and 1 mm clear of it),
// where object-space rays for real-ray analysis start.
double objectSpaceStartZMm(const LensSystem& lens);

// The ray from an object at infinity, at field angle fieldRad (in the x–z plane), that crosses the
// stop plane at (stopXMm, stopYMm). Solved by damped Newton on the entry point, ignoring apertures.
// `guess` (an earlier solution at a nearby field) helps at wide fields. nullopt if it fails.
std::optional<Ray> aimAtStop(const LensSystem& lens, const SpectralIndices& indices, double fieldRad,
                             double stopXMm, double stopYMm, const Ray* guess = nullptr);

// Real image height (x on the sensor) of the chief ray at field angle fieldRad, or nullopt.
std::optional<double> chiefRayImageHeightMm(const LensSystem& lens, const SpectralIndices& indices,
                                            double fieldRad, const Ray* guess = nullptr);

struct RealFieldOfView {
    enum class Kind { Reached, Beyond180, Failed };
    Kind kind = Kind::Failed;
    double fullAngleDeg = 0.0;   // Reached: the diagonal field of view
    double maxFieldImageHeightMm = 0.0;  // Beyond180: chief-ray height at the 89.9° field
};

// Diagonal field of view whose real chief rays reach the sensor corners. Fisheyes whose chief ray
// at a 89.9° field still lands inside the corner report Beyond180; Failed if aiming fails first.
RealFieldOfView realFieldOfView(const LensSystem& lens, double wavelengthNm);

}  // namespace flare
