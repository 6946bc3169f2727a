#include "flare/core/FresnelIntegrals.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace flare {

FresnelCS fresnelIntegrals(double u) {
    const double a = std::abs(u);
    const double sign = u < 0.0 ? -1.0 : 1.0;
    constexpr double pi = std::numbers::pi;
    FresnelCS out;
    if (a <= 3.5) {
        // C = u Σ (−1)ⁿ x²ⁿ / ((2n)! (4n + 1)), S = u Σ (−1)ⁿ x²ⁿ⁺¹ / ((2n + 1)! (4n + 3)), x = πu²/2:
        // the k-th term of exp(x)'s series, x^k / k!, over 2k + 1, into C for even k and S for odd.
        const double x = 0.5 * pi * a * a;
        double term = 1.0;  // x^k / k!
        for (int k = 0; k < 200; ++k) {
            if (k > 0) term *= x / k;
            const double value = ((k / 2) % 2 == 0 ? term : -term) / (2 * k + 1);
            (k % 2 == 0 ? out.c : out.s) += value;
            if (k > x && term < 1e-18) break;
        }
        out.c *= sign * a;
        out.s *= sign * a;
        return out;
    }
    // f = (1/(πu)) Σ (−1)ᵐ (1·3···(4m − 1)) / (πu²)²ᵐ, g = (1/(π²u³)) Σ (−1)ᵐ (1·3···(4m + 1)) / (πu²)²ᵐ,
    // both summed until their terms stop falling.
    const double y = pi * a * a, inverseY2 = 1.0 / (y * y);
    double f = 0.0, g = 0.0, tf = 1.0, tg = 1.0;
    for (int m = 0; m < 60; ++m) {
        f += tf;
        g += tg;
        const double nextF = -tf * (4 * m + 1) * (4 * m + 3) * inverseY2;
        const double nextG = -tg * (4 * m + 3) * (4 * m + 5) * inverseY2;
        if (std::abs(nextF) >= std::abs(tf) || std::abs(nextF) < 1e-18) break;
        tf = nextF;
        tg = nextG;
    }
    f /= pi * a;
    g /= pi * pi * a * a * a;
    const double phase = 0.5 * y;
    const double sn = std::sin(phase), cs = std::cos(phase);
    out.c = sign * (0.5 + f * sn - g * cs);
    out.s = sign * (0.5 - f * cs - g * sn);
    return out;
}

double straightEdgeIntensity(double u) {
    const FresnelCS cs = fresnelIntegrals(u);
    return 0.5 * ((cs.c + 0.5) * (cs.c + 0.5) + (cs.s + 0.5) * (cs.s + 0.5));
}

const FresnelEdgeExcess& FresnelEdgeExcess::instance() {
    static const FresnelEdgeExcess table;
    return table;
}

FresnelEdgeExcess::FresnelEdgeExcess() {
    const int samples = static_cast<int>(2.0 * kReach * kSamplesPerUnit) + 2;
    intensity_.resize(samples);
    for (int i = 0; i < samples; ++i) intensity_[i] = straightEdgeIntensity(-kReach + static_cast<double>(i) / kSamplesPerUnit);
    // The table's integral of I − H over (−K, K) (trapezoids of the interpolant; the step's jump
    // sits on a sample, u = 0), spread back as a constant.
    const double h = 1.0 / kSamplesPerUnit;
    const int zero = static_cast<int>(kReach * kSamplesPerUnit);
    const int last = static_cast<int>(2.0 * kReach * kSamplesPerUnit);
    double integral = 0.0;
    for (int i = 0; i < last; ++i) integral += 0.5 * h * (intensity_[i] + intensity_[i + 1]) - (i >= zero ? h : 0.0);
    offset_ = -integral / (2.0 * kReach);
}

double FresnelEdgeExcess::smearedPeak(double radius) const {
    // Quadrature at h = 1/32 of w: the excess's fastest ripple within the reach has a period of
    // 2/K = 1/4, sampled 8 times; the samples sit half a step off the table's, so that the step
    // (u = 0) falls between two; the semicircle's weights are normalised to sum to one.
    constexpr double h = 1.0 / 32.0;
    const int halfWidth = static_cast<int>(std::floor(std::max(radius, 0.0) / h));
    std::vector<double> weight(2 * halfWidth + 1);
    double sum = 0.0;
    for (int j = -halfWidth; j <= halfWidth; ++j) {
        const double t = halfWidth > 0 ? j * h / radius : 0.0;
        sum += weight[j + halfWidth] = std::sqrt(std::max(0.0, 1.0 - t * t));
    }
    for (double& w : weight) w /= sum;
    // The excess at (k + ½)·h for k over the reach, zero-padded by the kernel's half width.
    const int reachSteps = static_cast<int>(std::ceil(kReach / h));
    std::vector<double> excess(2 * (reachSteps + 2 * halfWidth), 0.0);
    const int origin = reachSteps + 2 * halfWidth;  // index of k = 0
    for (int k = -reachSteps; k < reachSteps; ++k) excess[k + origin] = (*this)((k + 0.5) * h);
    double peak = 0.0;
    for (int i = -reachSteps - halfWidth; i < reachSteps + halfWidth; ++i) {
        double value = 0.0;
        const double* e = excess.data() + (i + origin + halfWidth);
        for (int j = 0; j <= 2 * halfWidth; ++j) value += weight[j] * e[-j];
        peak = std::max(peak, std::abs(value));
    }
    return peak;
}

double FresnelEdgeExcess::smearRadiusFor(double level) const {
    constexpr double kLargest = 16.0;  // smearedPeak(16) ≈ 0.003
    double below = 0.0, above = kLargest;
    if (smearedPeak(above) > level) return INFINITY;
    while (above - below > 1.0 / 64.0) {
        const double middle = 0.5 * (below + above);
        (smearedPeak(middle) <= level ? above : below) = middle;
    }
    return above;
}

}  // namespace flare
