#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "flare/wave/DustGlow.h"

using namespace flare;

namespace {
constexpr double kPi = std::numbers::pi;

// ∫ perSteradian 2πθ dθ per channel, on a log grid out to 1 rad plus the analytic 1/θ³ tail.
glm::dvec3 totalEnergy(const DustGlow& glow) {
    glm::dvec3 sum{0.0};
    const int steps = 200000;
    const double lo = std::log(1e-7), hi = std::log(1.0);
    for (int i = 0; i < steps; ++i) {
        const double t = std::exp(lo + (hi - lo) * (i + 0.5) / steps);
        sum += glow.perSteradian(t) * (2.0 * kPi * t * t * (hi - lo) / steps);
    }
    // ∫_1^∞ c/θ³ 2πθ dθ = 2πc, c the tail's coefficient (the rings' mean envelope beyond the table).
    return sum + glow.perSteradian(1.0 + 1e-12) * 2.0 * kPi;
}
}  // namespace

// A single particle size at one wavelength: the Airy pattern of the particle, first zero at
// 1.22 λ/d, 83.8 % of the energy inside it, and all of it over the plane.
TEST(DustGlow, OneSizeIsTheParticlesAiryPattern) {
    const double dUm = 20.0, lambdaNm = 550.0;
    const DustGlow glow(dUm, 0.0, {{lambdaNm, glm::dvec3(1.0)}});
    const double zero = 1.2197 * lambdaNm * 1e-6 / (dUm * 1e-3);
    EXPECT_LT(glow.perSteradian(zero).y, 1e-4 * glow.perSteradian(0.0).y);  // a zero, to the table's interpolation
    EXPECT_GT(glow.perSteradian(0.9 * zero).y, 1e-3 * glow.perSteradian(0.0).y);
    EXPECT_NEAR(totalEnergy(glow).y, 1.0, 2e-3);
    double inside = 0.0;
    const int steps = 20000;
    for (int i = 0; i < steps; ++i) {
        const double t = zero * (i + 0.5) / steps;
        inside += glow.perSteradian(t).y * 2.0 * kPi * t * zero / steps;
    }
    EXPECT_NEAR(inside, 0.838, 0.002);
}

// A spread of sizes over a broad spectrum: still unit energy per channel, and larger dust makes a
// narrower glow (the half-energy angle scales as 1/d).
TEST(DustGlow, SizeSpreadAndSpectrumKeepUnitEnergyAndScaleAsOneOverD) {
    std::vector<SpectralSample> spectrum;
    for (int i = 0; i < 16; ++i) spectrum.push_back({400.0 + 20.0 * i, glm::dvec3(0.2 + 0.05 * i, 1.0, 1.0 - 0.05 * i)});
    const DustGlow small(10.0, 0.5, spectrum), large(40.0, 0.5, spectrum);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(totalEnergy(small)[c], 1.0, 3e-3) << c;
        EXPECT_NEAR(totalEnergy(large)[c], 1.0, 3e-3) << c;
    }
    auto halfEnergyAngle = [](const DustGlow& g) {
        double sum = 0.0;
        for (int i = 0; i < 400000; ++i) {
            const double t = 1e-6 * (i + 0.5);
            sum += g.perSteradian(t).y * 2.0 * kPi * t * 1e-6;
            if (sum >= 0.5) return t;
        }
        return -1.0;
    };
    EXPECT_NEAR(halfEnergyAngle(small) / halfEnergyAngle(large), 4.0, 0.1);
}
