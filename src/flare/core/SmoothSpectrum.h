// A smooth emission spectrum for a colour given only as RGB or XYZ (a pixel of a plate): D65 times
// a sigmoid of a quadratic in wavelength, S(λ) = D65(λ)·σ(c₀t² + c₁t + c₂), t = (λ − 580 nm)/200 nm,
// σ(z) = ½ + z/(2√(1 + z²)). The form is Jakob and Hanika's (2019) spectral uplifting, used here for
// emission: three coefficients give a smooth, non-negative spectrum for any chromaticity inside the
// spectral locus, a grey is D65 itself (c = 0), and a saturated colour becomes a smooth band rather
// than a spike, as real lamps' colours are. The scale is the light's power (Light.h): only the
// chromaticity is fitted.
#pragma once

#include <glm/vec3.hpp>

namespace flare {

inline constexpr double kSmoothSpectrumCentreNm = 580.0;
inline constexpr double kSmoothSpectrumHalfWidthNm = 200.0;

// σ(c₀t² + c₁t + c₂) at the wavelength, in [0, 1].
double smoothSpectrumShape(const glm::dvec3& coefficients, double wavelengthNm);

struct SmoothSpectrumFit {
    glm::dvec3 coefficients{0.0};
    // Distance in CIE 1931 xy between the target's chromaticity and the fitted spectrum's: ~1e-6
    // inside the Rec.709 gamut; larger only for colours at or beyond the spectral locus, which no
    // smooth spectrum reaches (the fit then gives the nearest it can).
    double chromaticityError = 0.0;
};

// The coefficients whose spectrum has the chromaticity of `xyz` (its scale is ignored). A black or
// non-finite target gives grey (c = 0). Deterministic: damped Gauss–Newton, continued from grey
// towards the target in steps so that saturated colours converge.
SmoothSpectrumFit fitSmoothSpectrum(const glm::dvec3& xyz);

}  // namespace flare
