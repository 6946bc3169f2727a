// The forward diffraction of dust: the glow around a light seen through a dusty element.
//
// An opaque particle of diameter d diffracts, by Babinet's principle, as a hole of its size: an
// Airy pattern of angular radius 1.22 λ/d carrying as much power as the particle intercepts (the
// "extinction paradox": a particle removes twice its cross-section from a beam, half by absorbing
// or scattering it, half by this narrow forward lobe). The photon tracer models the first half
// (dust blocks `coverage` of the light and scatters `albedo` of that into its lobe); this is the
// second, which it does not: `coverage` of the light that crosses a dusty surface, spread by the
// particles' Airy pattern averaged over their sizes (log-normal, weighted by cross-section) and
// the light's spectrum. The particles lie at random, so their patterns add incoherently.
#pragma once

#include <vector>

#include <glm/vec3.hpp>

#include "flare/core/Spectrum.h"

namespace flare {

class DustGlow {
public:
    // medianDiameterUm and sigma of ln(diameter), as the scene's dust; mediumIndex: the index of
    // the medium the dust sits in (its wavelength is λ/n).
    DustGlow(double medianDiameterUm, double diameterSigma, const std::vector<SpectralSample>& spectrum,
             double mediumIndex = 1.0);

    // Per channel, normalised so that ∫ perSteradian dΩ = 1 (each channel over the plane of small
    // angles), at deflection angle θ (radians).
    glm::dvec3 perSteradian(double thetaRad) const;

private:
    std::vector<double> logTheta_;      // table abscissae: ln θ
    std::vector<glm::dvec3> values_;    // per steradian
    glm::dvec3 tailCoefficient_{0.0};   // beyond the table: c/θ³ (the Airy envelope)
};

}  // namespace flare
