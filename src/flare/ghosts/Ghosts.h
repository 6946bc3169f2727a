// Ghost paths: the reflection sequences light can follow through a lens, their enumeration and
// their first-order (paraxial) analysis, with the meaning of the Ghost Focus Generator of
// sequential optical-design programs.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "flare/optics/LensSystem.h"

namespace flare {

// A path through the lens described by where it reflects: 0-based surface indices in the order the
// light meets them; lens.surfaceCount() denotes the sensor. Between reflections the light
// refracts through every surface it crosses. Two reflections {j, i} with i < j: the light passes
// forward to j, reflects back to i, reflects forward again and reaches the sensor.
struct GhostPath {
    std::vector<int> reflections;

    // "ghost_03_07": the reflecting surfaces as 1-based numbers in file order (the sensor is
    // surfaceCount + 1), in the order the light meets them, two digits each.
    std::string label() const;
    // 1-based surface numbers, for reports.
    std::vector<int> surfaceNumbers() const;
    bool operator==(const GhostPath&) const = default;
};

// Interfaces where light can reflect, in file order (0-based), plus the sensor when asked.
std::vector<int> reflectingSurfaces(const LensSystem& lens, bool includeSensor);

// Every reflection sequence of the given even order (2 or 4) that ends on the sensor:
// order 2 gives n(n−1)/2 paths for n reflecting surfaces.
std::vector<GhostPath> enumerateGhosts(const LensSystem& lens, int order, bool includeSensor);

// The product of the reflecting surfaces' reflectances at normal incidence along a path (the
// sensor's own reflectance for a sensor reflection): a cheap proxy of its strength, for ranking
// paths before a real-ray analysis.
double normalIncidenceReflectance(const LensSystem& lens, const SpectralIndices& indices, const GhostPath& path);

// A cheap estimate of the power of the order-4 paths relative to the order-2 ones: Σ_{i<j} RᵢRⱼ
// over the reflecting surfaces at normal incidence (the extra two reflections a chain of four
// needs), divided by 4, which the measured ratios of the shipped double Gauss (coated: 2.5e-4) and
// pbrt's uncoated one (3.9e-2) bracket within a factor of 1.3. Coated lenses come out near R², so
// their longer chains can be left to the photon tracer.
double higherOrderShareEstimate(const LensSystem& lens, const SpectralIndices& indices, bool includeSensor);

struct GhostParaxial {
    // Focal length of the ghost's equivalent system (nullopt: afocal ghost).
    std::optional<double> eflMm;
    // Distance from the sensor plane to the paraxial ghost focus of an object at infinity,
    // negative when the focus lies in front of the sensor (towards the lens); nullopt if afocal.
    std::optional<double> focusFromSensorMm;
    // Height of the marginal ray (an axial ray at infinity filling the entrance pupil) at each
    // surface event along the path, in order; the last entry is at the sensor.
    std::vector<double> marginalHeightsMm;
    // The marginal ray crosses the axis between two events inside the lens: the ghost comes to a
    // focus inside the lens (a concentrated, bright ghost on nearby surfaces).
    bool internalFocus = false;
};

// Paraxial trace along the path at the given indices (mirrors have power 2c; a reflection turns
// the direction of travel, so the curvature seen by the light changes sign).
GhostParaxial analyseGhostParaxial(const LensSystem& lens, const SpectralIndices& indices,
                                   const GhostPath& path);

}  // namespace flare
