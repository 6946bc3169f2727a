// Light as spectra and how the engine turns spectra into colour: the CIE 1931 observer, Planck's
// law, relative spectral power distributions of the lights, XYZ ↔ linear Rec.709, a deterministic
// wavelength quadrature for the preview and importance-sampled photon wavelengths for the
// stochastic tracer. All colour is CIE 1931 XYZ until the final conversion to Rec.709.
#pragma once

#include <string>
#include <span>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

namespace flare {

// Range of the CIE tables (nm): outside it the colour-matching functions are zero.
inline constexpr double kCieMinNm = 360.0;
inline constexpr double kCieMaxNm = 830.0;
// The visible band covered by the preview's wavelength quadrature (nm).
inline constexpr double kVisibleMinNm = 380.0;
inline constexpr double kVisibleMaxNm = 780.0;

// Rec.709 / sRGB primaries and D65 white point, CIE 1931 xy (ITU-R BT.709-6, IEC 61966-2-1).
inline constexpr double kRec709RedXy[2] = {0.64, 0.33};
inline constexpr double kRec709GreenXy[2] = {0.30, 0.60};
inline constexpr double kRec709BlueXy[2] = {0.15, 0.06};
inline constexpr double kD65WhiteXy[2] = {0.3127, 0.3290};

// CIE 1931 2° colour-matching functions (x̄, ȳ, z̄): the CIE's official 1 nm table (360–830 nm,
// src/flare/core/Cie1931Data.inc), linearly interpolated between the 1 nm samples; zero outside.
glm::dvec3 cieXyzBar(double wavelengthNm);

// Spectral radiance of a black body from Planck's law, W·sr⁻¹·m⁻²·nm⁻¹ (per nanometre of
// wavelength), with the exact SI (CODATA 2018) values of h, c and k.
double planckRadiance(double wavelengthNm, double temperatureK);

// A relative spectral power distribution, normalised to 1 at 560 nm (the CIE's convention, which
// prints these tables as 100 at 560 nm). The amount of light is set elsewhere (a light's power);
// a Spectrum only carries the shape. Cheap to copy.
class Spectrum {
public:
    enum class Kind { EqualEnergy, Blackbody, D65, Smooth };

    static Spectrum blackbody(double temperatureK);
    // CIE illuminant E: equal power per unit wavelength everywhere.
    static Spectrum equalEnergy();
    // CIE standard illuminant D65 (CIE 15:2004 Table T.1, 300–830 nm at 5 nm), linearly
    // interpolated; zero outside the table.
    static Spectrum d65();
    // D65 times a smooth sigmoid (SmoothSpectrum.h) with these coefficients: the spectrum a
    // plate's colour is given (fitSmoothSpectrum). Not normalised at 560 nm (a saturated blue has
    // nothing there); like every shape here, the light's power sets the amount.
    static Spectrum smooth(const glm::dvec3& coefficients);

    double value(double wavelengthNm) const;
    Kind kind() const { return kind_; }
    double temperatureK() const { return temperatureK_; }  // Blackbody only, else 0
    const glm::dvec3& coefficients() const { return coefficients_; }  // Smooth only, else 0
    // "blackbody 5778 K", "CIE D65", "equal energy (CIE E)".
    std::string describe() const;

private:
    Kind kind_ = Kind::EqualEnergy;
    double temperatureK_ = 0.0;
    glm::dvec3 coefficients_{0.0};
};

// ∫ S(λ)·(x̄, ȳ, z̄)(λ) dλ over [fromNm, toNm] (clipped to the CIE range), in units of S·nm.
// Integrated exactly for table-based spectra (Simpson's rule on every 1 nm interval of the CIE
// table, where the integrand is a product of linear pieces) and to ~1e-10 for a black body.
glm::dvec3 spectrumXyz(const Spectrum& spectrum, double fromNm = kCieMinNm,
                       double toNm = kCieMaxNm);

// CIE 1931 chromaticity (x, y) of an XYZ tristimulus; (0, 0) for black.
glm::dvec2 xyChromaticity(const glm::dvec3& xyz);

// XYZ ↔ linear Rec.709 RGB with D65 white (the sRGB colour space, IEC 61966-2-1). The matrix is
// derived from the primaries and white above, so XYZ of the D65 white with Y = 1 maps to exactly
// (1, 1, 1) up to rounding; its entries round to the standard's printed 4-decimal matrix.
glm::dvec3 xyzToLinearSrgb(const glm::dvec3& xyz);
// The matrix xyzToLinearSrgb multiplies by (matrix · xyz, the same bits), for loops over pixels.
const glm::dmat3& xyzToLinearSrgbMatrix();
glm::dvec3 linearSrgbToXyz(const glm::dvec3& rgb);

// Deterministic spectral quadrature for the preview: `count` equal-width bands over 380–780 nm,
// each represented by its midpoint wavelength and weighted by the band's ∫ S·cmf dλ (integrated
// finely, not the midpoint value). Weights are normalised so that Σ xyzWeight.y = 1: a lens that
// transmits everything at every wavelength returns the light's XYZ with unit luminance.
struct SpectralSample {
    double wavelengthNm;
    glm::dvec3 xyzWeight;
};
std::vector<SpectralSample> spectralQuadrature(const Spectrum& spectrum, int count);

// Photon wavelengths for the stochastic tracer, importance-sampled in proportion to
// S(λ)·(x̄ + ȳ + z̄)(λ) over 360–830 nm: the density is piecewise constant on 1 nm bins (each
// bin's exact integral), sampled by inverting its piecewise-linear CDF. A pure function of u.
// The wavelength sampler's bins: 1 nm wide from kCieMinNm to 830 nm.
inline constexpr int kWavelengthBins = 470;

class WavelengthSampler {
public:
    explicit WavelengthSampler(const Spectrum& spectrum);
    // Draws from S·(x̄ + ȳ + z̄) times an importance per 1 nm bin (kWavelengthBins values from
    // kCieMinNm; non-negative; all zero counts as none), e.g. a ghost path's throughput over the spectrum, so that samples
    // go where the path's light is. xyzWeight stays unbiased: it divides by this density.
    WavelengthSampler(const Spectrum& spectrum, std::span<const double> importancePerNm);

    // Wavelength for a uniform u in [0, 1), with its probability density (per nm) if asked.
    double sample(double u, double* pdfPerNm = nullptr) const;
    // The density sample() draws from, per nm (0 outside 360–830 nm).
    double pdf(double wavelengthNm) const;
    // The photon's XYZ weight S·cmf/pdf, normalised so that E[weight.y] = 1 (unit luminance,
    // matching spectralQuadrature). 0 where pdf is 0.
    glm::dvec3 xyzWeight(double wavelengthNm, double pdfPerNm) const;

    const Spectrum& spectrum() const { return spectrum_; }

private:
    Spectrum spectrum_;
    std::vector<double> cdf_;  // cdf_[i] = P(λ < 360 nm + i·1 nm); 471 entries
    // A guide to the search: guide_[k] is the last i with cdf_[i] ≤ k / kGuideCells, where the
    // bin of any u in [k, k + 1) / kGuideCells starts (a few steps instead of a binary search).
    static constexpr int kGuideCells = 512;
    std::vector<int> guide_;
    double inverseLuminance_ = 0.0;  // 1 / ∫ S·ȳ dλ over 360–830 nm
};

}  // namespace flare
