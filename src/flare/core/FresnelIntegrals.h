// The Fresnel integrals C(u) = ∫₀ᵘ cos(πt²/2) dt and S(u) = ∫₀ᵘ sin(πt²/2) dt, and the intensity
// of a plane wave diffracted by a straight edge (a half-plane), which shapes the rim of every
// defocused image of an aperture: a ghost's ringing (GhostBeam.h).
#pragma once

#include <vector>

namespace flare {

struct FresnelCS {
    double c = 0.0, s = 0.0;
};

// C(u) and S(u) to about 1e-8 absolute for every u: the power series for |u| ≤ 3.5 (its terms
// grow to ~2e7 there, so ~5e-9 of rounding), beyond it the asymptotic expansion of the auxiliary
// functions f and g (Abramowitz & Stegun 7.3.9–10, 7.3.27–28), summed to its smallest term (5e-8
// at u = 3, about 1e-11 from u = 3.5 on).
FresnelCS fresnelIntegrals(double u);

// Intensity behind a straight edge, relative to the unobstructed wave, at u = x / w with x the
// signed distance from the geometric shadow's boundary (u > 0: the lit side) and w = √(λz/2)
// for a plane wave and an edge at distance z: ½[(C(u) + ½)² + (S(u) + ½)²]. It is ¼ on the
// boundary, peaks at 1.370 at u = 1.217, and tends to the step H(u) on both sides as 1/u.
double straightEdgeIntensity(double u);

// The straight edge's excess over the geometric step, I(u) − H(u), tabulated on |u| < kReach and
// zero beyond, with the tails it leaves out returned to it as a constant over the reach so that it
// integrates to zero: the ringing moves power across the edge and creates none. (The tails beyond
// |u| = K hold 1/(π²K) of the power per unit of w and edge length, the 1/(2π²u²) that both sides
// approach; the constant is 1/(2π²K²) = 8e-4 of the wave at K = 8.)
class FresnelEdgeExcess {
public:
    static constexpr double kReach = 8.0;
    static const FresnelEdgeExcess& instance();
    double operator()(double u) const {
        if (!(u > -kReach && u < kReach)) return 0.0;
        const double x = (u + kReach) * kSamplesPerUnit;
        const int i = static_cast<int>(x);
        const double t = x - i;
        return (1.0 - t) * intensity_[i] + t * intensity_[i + 1] - (u > 0.0 ? 1.0 : 0.0) + offset_;
    }
    // The constant added (for tests).
    double offset() const { return offset_; }
    // The table operator() interpolates: straightEdgeIntensity at u = −kReach + i / samplesPerUnit()
    // (for a vector version that repeats its arithmetic, BeamRimRow.h).
    const double* table() const { return intensity_.data(); }
    static constexpr int samplesPerUnit() { return kSamplesPerUnit; }

    // What a light's apparent extent leaves of the ripples. A light of apparent disk radius α
    // moves a rim by G·α (G: the rim's shift per radian, GhostRinging.h) about its mean place, its
    // points uniform over a disk whose projection across the edge is the semicircle law; averaged
    // over them, the excess becomes its convolution with that law. smearedPeak(b) is the largest
    // |value| of that convolution for a disk of radius b (in units of w): max |excess| = 0.745 at
    // b = 0, 0.014 at b = 4, falling as about 0.055 / b beyond a few w.
    double smearedPeak(double radius) const;
    // The smallest radius b (units of w) at which smearedPeak(b) ≤ level, by bisection on [0, 16]
    // (smearedPeak falls monotonically past its first w; the tests check it); infinite if
    // smearedPeak(16) is above the level.
    double smearRadiusFor(double level) const;

private:
    static constexpr int kSamplesPerUnit = 256;
    FresnelEdgeExcess();
    std::vector<double> intensity_;  // straightEdgeIntensity at −kReach + i / kSamplesPerUnit
    double offset_ = 0.0;
};

}  // namespace flare
