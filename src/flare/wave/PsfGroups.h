// Lights whose diffraction PSFs agree share one (the starburst of many nearby lights: the region
// lights of `flare composite`).
//
// A light's PSF on the sensor is fixed by its pupil as seen in pixel-frequency space: the pattern
// at pixel offset Δ is |F(2π radPerPx·Δ/λ)|² over the pupil P, and radPerPx·Δ·x = Δ·(radPerPxᵀ x),
// so the PSF is the Fraunhofer pattern of Q = radPerPxᵀ P / λ (PupilOutline's pxPerRad inverted).
// Two lights with the same Q up to a translation have the same PSF. The difference used here is
// |Q_a Δ Q_b| / |Q_b|, the area of the two pupils' symmetric difference (both centred on their
// centroids, the pattern being blind to a shift) relative to the area, the largest over the three
// CIE channels, each at the light's mean wavelength in it. It bounds the PSF's change: with
// a = ||1_Qa − 1_Qb||₂² = |Qa Δ Qb|, Parseval gives ||Fa − Fb||₂ = √a, so the intensities differ
// in L1 by at most ||Fa − Fb||₂ (||Fa||₂ + ||Fb||₂), 2 √difference of the PSF's energy (per
// wavelength, for two pupils of nearly equal area): a difference of 10⁻⁴ moves at most 2 % of
// the light, and in practice far less (the bound is reached only by a pupil whose change is
// spread as noise over its whole area; a smooth change of shape moves about the difference
// itself).
#pragma once

#include <vector>

#include <glm/vec3.hpp>

#include "flare/core/Spectrum.h"
#include "flare/wave/PupilOutline.h"

namespace flare {

// The pupil in pixel-frequency space (before the division by λ): its radius about its centroid
// at kPsfShapeAngles equally spaced directions, and the light's mean wavelength per channel.
struct PsfShape {
    static constexpr int kAngles = 1440;
    bool found = false;  // false: the outline was not found (no PSF; such a light is a group alone)
    std::vector<double> radius;
    glm::dvec3 meanWavelengthNm{0.0};
};

PsfShape psfShape(const PupilOutline& outline, const std::vector<SpectralSample>& spectrum);

// |Q_a Δ Q_b| / |Q_b| (see above), the largest over the channels; infinity when either is not
// found.
double psfShapeDifference(const PsfShape& a, const PsfShape& b);

// Groups the lights, in the order given, greedily: each joins the first group whose founder's
// shape differs from its own by at most `tolerance`, else founds a group. Returns each light's
// group (0, 1, ... in the order of founding) and, through `founders`, each group's founder, whose
// PSF the group shares. A tolerance of 0 puts every light in its own group (unless two are the
// same to the bit).
std::vector<int> groupByPsf(const std::vector<PsfShape>& shapes, double tolerance, std::vector<int>* founders = nullptr);

}  // namespace flare
