#include "flare/Coating.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>

namespace flare {

using Complex = std::complex<double>;

Coating Coating::quarterWave(std::string name, double index, double designWavelengthNm) {
    return Coating{std::move(name), {{index, designWavelengthNm / (4.0 * index)}}};
}

Coating Coating::magnesiumFluoride() { return quarterWave("mgf2", 1.38, 550.0); }

namespace {

// cosθ in a medium of index n given the invariant n0·sinθ0 (complex beyond the critical angle,
// on the branch whose wave decays into the medium).
Complex cosineIn(double n, double invariant) {
    const double sin2 = (invariant / n) * (invariant / n);
    return std::sqrt(Complex(1.0 - sin2, 0.0));
}

struct Polarised {
    double r, t;
};

// Characteristic matrix product for one polarisation; `tilted` maps (n, cosθ) to the tilted
// optical admittance (n cosθ for s, n / cosθ for p).
template <typename Admittance>
Polarised stackResponse(const std::vector<ThinFilmLayer>& layers, bool reversed, double n0,
                        double nSub, double invariant, double wavelengthNm, Admittance tilted) {
    Complex m00(1.0), m01(0.0), m10(0.0), m11(1.0);
    const size_t count = layers.size();
    for (size_t i = 0; i < count; ++i) {
        const ThinFilmLayer& layer = layers[reversed ? count - 1 - i : i];
        const Complex cosT = cosineIn(layer.index, invariant);
        const Complex eta = tilted(layer.index, cosT);
        const Complex delta = 2.0 * std::numbers::pi * layer.index * layer.thicknessNm * cosT /
                              wavelengthNm;
        const Complex c = std::cos(delta), s = std::sin(delta);
        const Complex j(0.0, 1.0);
        const Complex a00 = c, a01 = j * s / eta, a10 = j * eta * s, a11 = c;
        const Complex n00 = m00 * a00 + m01 * a10, n01 = m00 * a01 + m01 * a11;
        const Complex n10 = m10 * a00 + m11 * a10, n11 = m10 * a01 + m11 * a11;
        m00 = n00; m01 = n01; m10 = n10; m11 = n11;
    }
    const Complex eta0 = tilted(n0, cosineIn(n0, invariant));
    const Complex etaSub = tilted(nSub, cosineIn(nSub, invariant));
    const Complex b = m00 + m01 * etaSub;
    const Complex c = m10 + m11 * etaSub;
    const Complex denom = eta0 * b + c;
    const Complex r = (eta0 * b - c) / denom;
    const double t = 4.0 * eta0.real() * etaSub.real() / std::norm(denom);
    return {std::norm(r), std::max(0.0, t)};
}

}  // namespace

FresnelTerms thinFilmResponse(const Coating& coating, double cosThetaI, double nAir, double nGlass,
                              bool fromAirSide, double wavelengthNm) {
    if (coating.layers.empty()) {
        return fromAirSide ? fresnelDielectric(cosThetaI, nAir, nGlass)
                           : fresnelDielectric(cosThetaI, nGlass, nAir);
    }
    const double n0 = fromAirSide ? nAir : nGlass;
    const double nSub = fromAirSide ? nGlass : nAir;
    cosThetaI = std::clamp(cosThetaI, 0.0, 1.0);
    const double invariant = n0 * std::sqrt(std::max(0.0, 1.0 - cosThetaI * cosThetaI));

    FresnelTerms terms;
    if (invariant >= nSub) {  // total internal reflection at the stack's far side
        terms.rs = terms.rp = 1.0;
        terms.ts = terms.tp = 0.0;
        terms.cosThetaT = 0.0;
        terms.totalInternalReflection = true;
        return terms;
    }
    const bool reversed = !fromAirSide;
    const Polarised s = stackResponse(coating.layers, reversed, n0, nSub, invariant, wavelengthNm,
                                      [](double n, Complex cosT) { return n * cosT; });
    const Polarised p = stackResponse(coating.layers, reversed, n0, nSub, invariant, wavelengthNm,
                                      [](double n, Complex cosT) { return n / cosT; });
    terms.rs = s.r;
    terms.ts = s.t;
    terms.rp = p.r;
    terms.tp = p.t;
    terms.cosThetaT = std::sqrt(std::max(0.0, 1.0 - (invariant / nSub) * (invariant / nSub)));
    return terms;
}

}  // namespace flare
