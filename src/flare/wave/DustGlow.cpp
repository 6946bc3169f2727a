#include "flare/wave/DustGlow.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace flare {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kTablePoints = 2048;
constexpr double kThetaMin = 1e-6, kThetaMax = 1.0;
// Sizes at equal steps of ln d over ±3σ: fine enough that the rings of neighbouring sizes (their
// radii differ by the step) wash out instead of beating.
constexpr int kSizeSamples = 61;

// [2 J1(x)/x]²: the Airy pattern's shape, 1 at x = 0. A table of J1 up to kAiryTableEnd (step
// 1/256, interpolated linearly: error below 1e-5), Hankel's asymptote J1(x) ≈ √(2/πx) cos(x − 3π/4)
// (relative error about 3/(8x) of the envelope) beyond.
constexpr double kAiryTableEnd = 64.0;
constexpr int kAiryStepsPerUnit = 256;

double besselJ1(double x) {
    static const std::vector<double> table = [] {
        std::vector<double> t(static_cast<size_t>(kAiryTableEnd * kAiryStepsPerUnit) + 2);
        for (size_t i = 0; i < t.size(); ++i) t[i] = std::cyl_bessel_j(1.0, double(i) / kAiryStepsPerUnit);
        return t;
    }();
    if (x >= kAiryTableEnd) return std::sqrt(2.0 / (kPi * x)) * std::cos(x - 0.75 * kPi);
    const double u = x * kAiryStepsPerUnit;
    const size_t i = static_cast<size_t>(u);
    return table[i] + (u - i) * (table[i + 1] - table[i]);
}

double airyShape(double x) {
    if (x < 1e-6) return 1.0;
    const double j = 2.0 * besselJ1(x) / x;
    return j * j;
}

}  // namespace

DustGlow::DustGlow(double medianDiameterUm, double diameterSigma, const std::vector<SpectralSample>& spectrum,
                   double mediumIndex) {
    if (!(medianDiameterUm > 0.0) || !(diameterSigma >= 0.0) || !(mediumIndex >= 1.0) || spectrum.empty())
        throw std::invalid_argument("dust glow: needs a positive diameter, a sigma ≥ 0, an index ≥ 1 and a spectrum");
    // Sizes: ln d at equal steps over ±3σ, weighted by the log-normal density times the particle's
    // cross-section (its diffracted power).
    std::vector<double> diametersMm, weights;
    const int sizes = diameterSigma > 0.0 ? kSizeSamples : 1;
    double weightSum = 0.0;
    for (int i = 0; i < sizes; ++i) {
        const double z = sizes == 1 ? 0.0 : -3.0 + 6.0 * i / (sizes - 1);
        const double d = medianDiameterUm * 1e-3 * std::exp(diameterSigma * z);
        diametersMm.push_back(d);
        weights.push_back(std::exp(-0.5 * z * z) * d * d);
        weightSum += weights.back();
    }
    for (double& w : weights) w /= weightSum;
    glm::dvec3 channelWeight{0.0};
    for (const SpectralSample& s : spectrum) channelWeight += s.xyzWeight;
    for (int c = 0; c < 3; ++c)
        if (channelWeight[c] <= 0.0) channelWeight[c] = 1.0;

    // I(θ) = (π d²/4)/λ² · [2J1(x)/x]², x = π d θ/λ: integrates to 1 over the plane of angles.
    logTheta_.resize(kTablePoints);
    values_.assign(kTablePoints, glm::dvec3(0.0));
    for (int t = 0; t < kTablePoints; ++t) {
        logTheta_[t] = std::log(kThetaMin) + (std::log(kThetaMax) - std::log(kThetaMin)) * t / (kTablePoints - 1);
        const double theta = std::exp(logTheta_[t]);
        for (const SpectralSample& s : spectrum) {
            const double lambdaMm = s.wavelengthNm * 1e-6 / mediumIndex;
            double value = 0.0;
            for (size_t i = 0; i < diametersMm.size(); ++i) {
                const double d = diametersMm[i];
                value += weights[i] * (kPi * d * d / 4.0) / (lambdaMm * lambdaMm) * airyShape(kPi * d * theta / lambdaMm);
            }
            values_[t] += value * s.xyzWeight;
        }
        values_[t] /= channelWeight;
    }
    // [2J1(x)/x]² averages 4/(π x³) over its rings (J1² averages 1/(πx)): (π d²/4)/λ² times that
    // is λ/(π³ d θ³).
    for (const SpectralSample& s : spectrum) {
        const double lambdaMm = s.wavelengthNm * 1e-6 / mediumIndex;
        double c = 0.0;
        for (size_t i = 0; i < diametersMm.size(); ++i) c += weights[i] * lambdaMm / (kPi * kPi * kPi * diametersMm[i]);
        tailCoefficient_ += c * s.xyzWeight;
    }
    tailCoefficient_ /= channelWeight;
}

glm::dvec3 DustGlow::perSteradian(double theta) const {
    if (theta <= kThetaMin) return values_.front();
    if (theta >= kThetaMax) return tailCoefficient_ / (theta * theta * theta);
    const double x = (std::log(theta) - logTheta_.front()) / (logTheta_[1] - logTheta_[0]);
    const int i = std::min(static_cast<int>(x), kTablePoints - 2);
    const double f = x - i;
    return (1.0 - f) * values_[i] + f * values_[i + 1];
}

}  // namespace flare
