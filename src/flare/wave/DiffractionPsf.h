// The lens's diffraction point-spread function on the sensor's pixels, per CIE channel.
//
// For a wavelength λ the Fraunhofer pattern of the pupil, per steradian of direction change α
// (radians, in the pupil plane's axes), is I_λ(α) = |F(2πα/λ)|² / (λ² A), which integrates to 1
// (Parseval). The pixel offset of a direction change is `pxPerRad`·α (the light's image moves so
// on the sensor: the local Jacobian of the lens's mapping, traced, so the λ·distance law holds for
// any focus and field). The CIE channel c's PSF is Σ_λ w_c(λ) I_λ / Σ_λ w_c(λ) over the light's
// spectral quadrature, so convolving a channel of the direct image with it conserves its energy.
//
// Near the centre (|k| up to `coherentFringes` fringes of the aperture, 2π/D each) the exact
// transform is used, from a table of F on a grid of eight samples per fringe (bicubic), each
// pixel integrated over sub-cells of a quarter fringe by the 2 × 2 Gauss–Legendre rule (box
// pixels; at most maxSubsamples a side, and where that leaves them wider than a fringe, those that
// reach the core are split again to half a fringe); further out, the fringe-averaged asymptote
// (ApertureTransform::incoherentIntensity):
// the spikes integrated across each pixel exactly (the cumulative of sinc²), the corners'
// interference (its profile across a spike likewise), the halo; the two are blended over the
// last 30 % of the coherent range. The model's total energy is computed (the pixels of the window plus the
// asymptote's analytic integral outside it) and the PSF is divided by it, so that it integrates
// to 1 whatever the small mismatch between the two regimes (reported as parsevalError()).
#pragma once

#include <array>
#include <vector>

#include <glm/mat2x2.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "flare/core/Spectrum.h"
#include "flare/wave/ApertureTransform.h"

namespace flare {

struct DiffractionPsfOptions {
    double coherentFringes = 10.0;  // extent of the exact (coherent) core, in fringes 2π/D
    int maxSubsamples = 24;         // per pixel side near the core (see cellEnergy: wider than a fringe, split)
};

// ∫_{−∞}^{z} sinc²(πx) dx (from 0 to 1): the share of a straight edge's spike, across it, that
// lies on one side of z transverse widths λ/L; beyond four widths, of its fringe average.
double sincSquaredCumulative(double z);

class DiffractionPsf {
public:
    // `spectrum`: the light's quadrature (wavelengths and XYZ weights); `pxPerRad`: pixel offset
    // per radian of direction change along the pupil plane's two axes (columns).
    DiffractionPsf(const ApertureTransform& aperture, std::vector<SpectralSample> spectrum, const glm::dmat2& pxPerRad,
                   const DiffractionPsfOptions& options = {});

    // Share of each channel's energy landing in the square cell of half-size `halfPx` centred
    // `offsetPx` from the point image (a pixel: halfPx = 0.5), before normalisation.
    glm::dvec3 cellEnergy(const glm::dvec2& offsetPx, double halfPx) const;

    // The normalised PSF on the pixels of a square window of half-size `halfPx` around the point
    // image (which sits at the centre of the centre pixel): (2h+1)² pixels × XYZ, row-major from
    // offset (−h, −h), energy per pixel. The first call fixes the normalisation (window plus the
    // analytic energy outside it); later calls reuse it.
    std::vector<float> window(int halfPx);
    // Normalisation: the model's total energy per channel before it (1 for an exact model).
    glm::dvec3 parsevalTotal() const { return parsevalTotal_; }
    double parsevalError() const;

    // The fringe-averaged far field, for the starburst's projection (Starburst.h): per spike edge,
    // its direction in pixels and its energy per pixel of length at pixel distance r (per channel,
    // normalised) is lineDensity / r²; its transverse profile is sinc² of the given width.
    struct Spike {
        glm::dvec2 directionPx{0.0};   // unit, along the spike (both ways)
        glm::dvec2 transversePx{0.0};  // unit, across it
        glm::dvec3 lineDensity{0.0};   // energy per pixel of length × r² (px²), per channel
        glm::dvec3 transverseWidthPx{0.0};  // λ/L in pixels across the spike (first zero of sinc²)
        // The fan (ApertureEdge): the spike spreads uniformly over the directions turned from
        // directionPx towards transversePx by angles in [fanFromRad, fanToRad].
        double fanFromRad = 0.0, fanToRad = 0.0;
    };
    const std::vector<Spike>& spikes() const { return spikes_; }
    // The smooth halo's energy per pixel at offset (px), per channel, normalised.
    glm::dvec3 smoothPerPixel(const glm::dvec2& offsetPx) const;
    // The corners' interference (ApertureTransform::corners) in the pixel at offset (px), per
    // channel, normalised; it is negative near the spikes of some corners, and the pixel's total
    // is not.
    glm::dvec3 cornerPerPixel(const glm::dvec2& offsetPx) const;

    const std::vector<SpectralSample>& spectrum() const { return spectrum_; }
    // Radius (px) within which the coherent core is used (at the longest wavelength).
    double coherentRadiusPx() const { return coherentRadiusPx_; }

private:
    double coherentIntensity(const glm::dvec2& kPerMm) const;  // |F|² from the table
    void addSubcellEnergy(const glm::dvec2& centrePx, double halfPx, glm::dvec3& energy) const;
    double spikeCellEnergy(const glm::dvec2& alpha, const glm::dvec2& cellAxisA, const glm::dvec2& cellAxisB,
                           double lambdaMm) const;
    double outsideWindowEnergy(int halfPx, int channel) const;

    const ApertureTransform* aperture_;
    std::vector<SpectralSample> spectrum_;
    std::vector<SpectralSample> farSpectrum_;  // spectrum_ merged in bands of four, for the asymptote
    double lambdaMaxMm_ = 0.0;
    glm::dvec3 channelWeight_{0.0};  // Σ_λ w_c(λ)
    glm::dvec3 lambdaMeanMm_{0.0};   // Σ_λ w_c(λ) λ / Σ_λ w_c(λ)
    glm::dvec3 lambdaRmsMm_{0.0};    // (Σ_λ w_c(λ) λ² / Σ_λ w_c(λ))^½
    glm::dmat2 pxPerRad_, radPerPx_;
    double pixelSolidAngle_ = 0.0;   // rad² per px²
    DiffractionPsfOptions options_;
    double coherentK_ = 0.0;         // rad/mm
    double tableStep_ = 0.0;
    int tableHalf_ = 0;
    std::vector<std::complex<double>> table_;
    double coherentRadiusPx_ = 0.0;
    double fringePx_ = 0.0;          // smallest fringe spacing, px
    std::vector<Spike> spikes_;
    glm::dvec3 parsevalTotal_{0.0};
    glm::dvec3 normalisation_{0.0};  // 1/parsevalTotal once fixed
};

}  // namespace flare
