#include "flare/core/Spectrum.h"

#include "flare/core/SmoothSpectrum.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>

#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>

namespace flare {

namespace {

#include "flare/core/Cie1931Data.inc"

// CIE standard illuminant D65, relative spectral power, 300–830 nm at 5 nm, 100 at 560 nm
// (CIE 15:2004 Colorimetry, Table T.1; ISO 11664-2 / CIE S 014-2).
constexpr double kD65FirstNm = 300.0;
constexpr double kD65StepNm = 5.0;
constexpr double kD65[] = {
    0.0341,  1.6643,  3.2945,  11.7652, 20.236,  28.6447, 37.0535, 38.5011, 39.9488, 42.4302,  // 300
    44.9117, 45.775,  46.6383, 49.3637, 52.0891, 51.0323, 49.9755, 52.3118, 54.6482, 68.7015,  // 350
    82.7549, 87.1204, 91.486,  92.4589, 93.4318, 90.057,  86.6823, 95.7736, 104.865, 110.936,  // 400
    117.008, 117.41,  117.812, 116.336, 114.861, 115.392, 115.923, 112.367, 108.811, 109.082,  // 450
    109.354, 108.578, 107.802, 106.296, 104.79,  106.239, 107.689, 106.047, 104.405, 104.225,  // 500
    104.046, 102.023, 100.0,   98.1671, 96.3342, 96.0611, 95.788,  92.2368, 88.6856, 89.3459,  // 550
    90.0062, 89.8026, 89.5991, 88.6489, 87.6987, 85.4936, 83.2886, 83.4939, 83.6992, 81.863,   // 600
    80.0268, 80.1207, 80.2146, 81.2462, 82.2778, 80.281,  78.2842, 74.0027, 69.7213, 70.6652,  // 650
    71.6091, 72.979,  74.349,  67.9765, 61.604,  65.7448, 69.8856, 72.4863, 75.087,  69.3398,  // 700
    63.5927, 55.0054, 46.4182, 56.6118, 66.8054, 65.0941, 63.3828, 63.8434, 64.304,  61.8779,  // 750
    59.4519, 55.7054, 51.959,  54.6998, 57.4406, 58.8765, 60.3125,                             // 800
};
constexpr int kD65Count = sizeof(kD65) / sizeof(kD65[0]);
static_assert(kD65Count == 107, "D65 is tabulated 300-830 nm at 5 nm");

// Exact SI values (CODATA 2018).
constexpr double kPlanckJs = 6.62607015e-34;
constexpr double kLightSpeedMs = 299792458.0;
constexpr double kBoltzmannJk = 1.380649e-23;
// Second radiation constant c2 = hc/k, in nm·K.
constexpr double kC2NmK = kPlanckJs * kLightSpeedMs / kBoltzmannJk * 1e9;

constexpr double kNormalisationNm = 560.0;
constexpr int kSamplerBins = kWavelengthBins;  // 1 nm bins over 360–830 nm
static_assert(kSamplerBins == kCieCount - 1);

double interpolate(const double* table, int count, double position) {
    if (position < 0.0 || position > count - 1) return 0.0;
    const int i = std::min(static_cast<int>(position), count - 2);
    const double t = position - i;
    return table[i] + t * (table[i + 1] - table[i]);
}

// Blackbody radiance relative to its value at 560 nm, written so that neither exponential can
// overflow: (560/λ)⁵·(eᵃ − 1)/(eᵇ − 1) = (560/λ)⁵·e^(a−b)·(1 − e⁻ᵃ)/(1 − e⁻ᵇ).
double relativeBlackbody(double wavelengthNm, double temperatureK) {
    const double a = kC2NmK / (kNormalisationNm * temperatureK);
    const double b = kC2NmK / (wavelengthNm * temperatureK);
    return std::pow(kNormalisationNm / wavelengthNm, 5) * std::exp(a - b) * std::expm1(-a) /
           std::expm1(-b);
}

struct Rec709Matrices {
    glm::dmat3 toXyz, fromXyz;
};

// RGB → XYZ has the primaries' XYZ (at Y = 1) as columns, each scaled so that RGB (1, 1, 1) is
// the white point's XYZ at Y = 1.
Rec709Matrices buildRec709() {
    auto column = [](const double* xy) {
        return glm::dvec3(xy[0] / xy[1], 1.0, (1.0 - xy[0] - xy[1]) / xy[1]);
    };
    const glm::dmat3 primaries(column(kRec709RedXy), column(kRec709GreenXy), column(kRec709BlueXy));
    const glm::dvec3 scale = glm::inverse(primaries) * column(kD65WhiteXy);
    Rec709Matrices m;
    m.toXyz = glm::dmat3(primaries[0] * scale.x, primaries[1] * scale.y, primaries[2] * scale.z);
    m.fromXyz = glm::inverse(m.toXyz);
    return m;
}

const Rec709Matrices& rec709() {
    static const Rec709Matrices matrices = buildRec709();
    return matrices;
}

}  // namespace

glm::dvec3 cieXyzBar(double wavelengthNm) {
    const double position = wavelengthNm - kCieFirstNm;
    return {interpolate(kCieX, kCieCount, position), interpolate(kCieY, kCieCount, position),
            interpolate(kCieZ, kCieCount, position)};
}

double planckRadiance(double wavelengthNm, double temperatureK) {
    assert(wavelengthNm > 0.0 && temperatureK > 0.0);
    const double lambdaM = wavelengthNm * 1e-9;
    const double perMetre = 2.0 * kPlanckJs * kLightSpeedMs * kLightSpeedMs /
                            (std::pow(lambdaM, 5) * std::expm1(kC2NmK / (wavelengthNm * temperatureK)));
    return perMetre * 1e-9;
}

Spectrum Spectrum::blackbody(double temperatureK) {
    assert(std::isfinite(temperatureK) && temperatureK > 0.0);
    Spectrum s;
    s.kind_ = Kind::Blackbody;
    s.temperatureK_ = temperatureK;
    return s;
}

Spectrum Spectrum::equalEnergy() { return Spectrum{}; }

Spectrum Spectrum::d65() {
    Spectrum s;
    s.kind_ = Kind::D65;
    return s;
}

Spectrum Spectrum::smooth(const glm::dvec3& coefficients) {
    Spectrum s;
    s.kind_ = Kind::Smooth;
    s.coefficients_ = coefficients;
    return s;
}

double Spectrum::value(double wavelengthNm) const {
    switch (kind_) {
        case Kind::EqualEnergy: return 1.0;
        case Kind::Blackbody:
            return wavelengthNm > 0.0 ? relativeBlackbody(wavelengthNm, temperatureK_) : 0.0;
        case Kind::D65:
            return 0.01 * interpolate(kD65, kD65Count, (wavelengthNm - kD65FirstNm) / kD65StepNm);
        case Kind::Smooth:
            return 0.01 * interpolate(kD65, kD65Count, (wavelengthNm - kD65FirstNm) / kD65StepNm) *
                   smoothSpectrumShape(coefficients_, wavelengthNm);
    }
    return 0.0;
}

std::string Spectrum::describe() const {
    switch (kind_) {
        case Kind::EqualEnergy: return "equal energy (CIE E)";
        case Kind::D65: return "CIE D65";
        case Kind::Smooth: {
            char buffer[96];
            std::snprintf(buffer, sizeof buffer, "smooth (D65 x sigmoid %.4g, %.4g, %.4g)", coefficients_.x,
                          coefficients_.y, coefficients_.z);
            return buffer;
        }
        case Kind::Blackbody: {
            char buffer[48];
            std::snprintf(buffer, sizeof buffer, "blackbody %g K", temperatureK_);
            return buffer;
        }
    }
    return "";
}

glm::dvec3 spectrumXyz(const Spectrum& spectrum, double fromNm, double toNm) {
    const double lo = std::max(fromNm, kCieMinNm), hi = std::min(toNm, kCieMaxNm);
    auto integrand = [&](double l) { return spectrum.value(l) * cieXyzBar(l); };
    glm::dvec3 sum(0.0);
    // Split at the table's 1 nm knots (D65's 5 nm knots are among them), where the integrand is a
    // product of two linear pieces: Simpson's rule is exact there.
    for (double a = lo; a < hi;) {
        const double b = std::min(hi, std::floor(a) + 1.0);
        sum += (b - a) / 6.0 * (integrand(a) + 4.0 * integrand(0.5 * (a + b)) + integrand(b));
        a = b;
    }
    return sum;
}

glm::dvec2 xyChromaticity(const glm::dvec3& xyz) {
    const double total = xyz.x + xyz.y + xyz.z;
    if (total == 0.0) return {0.0, 0.0};
    return {xyz.x / total, xyz.y / total};
}

glm::dvec3 xyzToLinearSrgb(const glm::dvec3& xyz) { return rec709().fromXyz * xyz; }

const glm::dmat3& xyzToLinearSrgbMatrix() { return rec709().fromXyz; }

glm::dvec3 linearSrgbToXyz(const glm::dvec3& rgb) { return rec709().toXyz * rgb; }

std::vector<SpectralSample> spectralQuadrature(const Spectrum& spectrum, int count) {
    assert(count >= 1);
    const double width = (kVisibleMaxNm - kVisibleMinNm) / count;
    std::vector<SpectralSample> samples;
    samples.reserve(count);
    double luminance = 0.0;
    for (int i = 0; i < count; ++i) {
        const double lo = kVisibleMinNm + i * width;
        const double hi = i + 1 == count ? kVisibleMaxNm : lo + width;
        samples.push_back({0.5 * (lo + hi), spectrumXyz(spectrum, lo, hi)});
        luminance += samples.back().xyzWeight.y;
    }
    assert(luminance > 0.0);
    for (SpectralSample& s : samples) s.xyzWeight /= luminance;
    return samples;
}

WavelengthSampler::WavelengthSampler(const Spectrum& spectrum) : WavelengthSampler(spectrum, {}) {}

WavelengthSampler::WavelengthSampler(const Spectrum& spectrum, std::span<const double> importancePerNm)
    : spectrum_(spectrum) {
    assert(importancePerNm.empty() || importancePerNm.size() == static_cast<size_t>(kSamplerBins));
    cdf_.assign(kSamplerBins + 1, 0.0);
    for (int i = 0; i < kSamplerBins; ++i) {
        const double lo = kCieMinNm + i;
        const glm::dvec3 xyz = spectrumXyz(spectrum, lo, lo + 1.0);
        const double importance = importancePerNm.empty() ? 1.0 : std::max(0.0, importancePerNm[i]);
        cdf_[i + 1] = cdf_[i] + std::max(0.0, xyz.x + xyz.y + xyz.z) * importance;
    }
    if (!(cdf_.back() > 0.0) && !importancePerNm.empty()) {
        *this = WavelengthSampler(spectrum);
        return;
    }
    const double total = cdf_.back();
    assert(total > 0.0);
    for (double& c : cdf_) c /= total;
    cdf_.back() = 1.0;
    inverseLuminance_ = 1.0 / spectrumXyz(spectrum).y;
    guide_.resize(kGuideCells);
    for (int k = 0; k < kGuideCells; ++k) {
        const double u = static_cast<double>(k) / kGuideCells;
        guide_[k] = static_cast<int>(std::upper_bound(cdf_.begin(), cdf_.end(), u) - cdf_.begin()) - 1;
    }
}

double WavelengthSampler::sample(double u, double* pdfPerNm) const {
    u = std::clamp(u, 0.0, 1.0);
    // The bin with cdf_[i] ≤ u < cdf_[i + 1]: never an empty bin, since those have equal ends.
    // (As upper_bound(cdf_, u) − 1, walked from the guide's start: cdf_[guide] ≤ k / cells ≤ u.)
    int i = guide_[std::min(static_cast<int>(u * kGuideCells), kGuideCells - 1)];
    while (i + 1 < static_cast<int>(cdf_.size()) && cdf_[i + 1] <= u) ++i;
    if (i >= kSamplerBins) {  // u = 1: the last bin with any probability
        i = kSamplerBins - 1;
        while (i > 0 && cdf_[i + 1] == cdf_[i]) --i;
    }
    const double mass = cdf_[i + 1] - cdf_[i];
    const double t = mass > 0.0 ? std::min(1.0, (u - cdf_[i]) / mass) : 0.5;
    if (pdfPerNm) *pdfPerNm = mass;  // bins are 1 nm wide
    // Stay inside bin i even where i + t rounds up to the next edge, so that pdf(λ) = *pdfPerNm.
    const double upperEdge = kCieMinNm + i + 1;
    return std::min(kCieMinNm + i + t, std::nextafter(upperEdge, 0.0));
}

double WavelengthSampler::pdf(double wavelengthNm) const {
    if (!(wavelengthNm >= kCieMinNm && wavelengthNm <= kCieMaxNm)) return 0.0;
    const int i = std::min(static_cast<int>(wavelengthNm - kCieMinNm), kSamplerBins - 1);
    return cdf_[i + 1] - cdf_[i];
}

glm::dvec3 WavelengthSampler::xyzWeight(double wavelengthNm, double pdfPerNm) const {
    if (pdfPerNm <= 0.0) return glm::dvec3(0.0);
    return spectrum_.value(wavelengthNm) * cieXyzBar(wavelengthNm) *
           (inverseLuminance_ / pdfPerNm);
}

}  // namespace flare
