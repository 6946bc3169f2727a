#include "flare/optics/Coating.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numbers>
#include <utility>

namespace flare {

Coating Coating::quarterWave(std::string name, double index, double designWavelengthNm) {
    return Coating{std::move(name), {{index, designWavelengthNm / (4.0 * index)}}, {}};
}

Coating Coating::magnesiumFluoride() { return quarterWave("mgf2", 1.38, 550.0); }

Coating Coating::idealFlat(std::string name, double reflectance) {
    return Coating{std::move(name), {}, IdealReflectance{{550.0}, {reflectance}}};
}

double IdealReflectance::at(double wavelengthNm) const {
    assert(!wavelengthsNm.empty() && wavelengthsNm.size() == reflectances.size());
    if (wavelengthNm <= wavelengthsNm.front()) return reflectances.front();
    if (wavelengthNm >= wavelengthsNm.back()) return reflectances.back();
    const size_t i = static_cast<size_t>(
        std::upper_bound(wavelengthsNm.begin(), wavelengthsNm.end(), wavelengthNm) - wavelengthsNm.begin());
    const double t = (wavelengthNm - wavelengthsNm[i - 1]) / (wavelengthsNm[i] - wavelengthsNm[i - 1]);
    return reflectances[i - 1] + t * (reflectances[i] - reflectances[i - 1]);
}

namespace {

// A characteristic matrix of lossless, propagating layers has the form [[a, i b], [i c, d]] with
// real a, b, c, d, and products keep that form, so the stack needs only real arithmetic.
struct LayerMatrix {
    double a = 1.0, b = 0.0, c = 0.0, d = 1.0;

    LayerMatrix then(const LayerMatrix& l) const {
        return {a * l.a - b * l.c, a * l.b + b * l.d, c * l.a + d * l.c, -c * l.b + d * l.d};
    }
};

// Reflectance and transmittance of the stack for one polarisation, with tilted admittances η0 of
// the incident medium and ηs of the substrate: B = a + i b ηs, C = i c + d ηs,
// r = (η0 B − C)/(η0 B + C), T = 4 η0 ηs / |η0 B + C|².
void respond(const LayerMatrix& m, double eta0, double etaSub, double* r, double* t) {
    const double numRe = eta0 * m.a - m.d * etaSub, numIm = eta0 * m.b * etaSub - m.c;
    const double denRe = eta0 * m.a + m.d * etaSub, denIm = eta0 * m.b * etaSub + m.c;
    const double inverse = 1.0 / (denRe * denRe + denIm * denIm);
    *r = (numRe * numRe + numIm * numIm) * inverse;
    *t = 4.0 * eta0 * etaSub * inverse;
}

}  // namespace

// Every ghost ray evaluates this at most surfaces it meets, so it is written with few divisions
// and square roots: the invariant n·sinθ is kept squared, the incident cosine is the one given,
// and each reciprocal is taken once.
FresnelTerms thinFilmResponse(const Coating& coating, double cosThetaI, double nAir, double nGlass,
                              bool fromAirSide, double wavelengthNm) {
    if (!coating.changesInterface()) {
        return fromAirSide ? fresnelDielectric(cosThetaI, nAir, nGlass)
                           : fresnelDielectric(cosThetaI, nGlass, nAir);
    }
    const double n0 = fromAirSide ? nAir : nGlass;
    const double nSub = fromAirSide ? nGlass : nAir;
    cosThetaI = std::clamp(cosThetaI, 0.0, 1.0);
    const double invariant2 = n0 * n0 * std::max(0.0, 1.0 - cosThetaI * cosThetaI);  // (n·sinθ)²

    FresnelTerms terms;
    if (invariant2 >= nSub * nSub) {  // total internal reflection at the stack's far side
        terms.rs = terms.rp = 1.0;
        terms.ts = terms.tp = 0.0;
        terms.cosThetaT = 0.0;
        terms.totalInternalReflection = true;
        return terms;
    }
    if (coating.ideal) {
        terms.rs = terms.rp = coating.ideal->at(wavelengthNm);
        terms.ts = terms.tp = 1.0 - terms.rs;
        terms.cosThetaT = std::sqrt(1.0 - invariant2 / (nSub * nSub));
        return terms;
    }
    if (cosThetaI == 0.0) {  // grazing: the limit (the p admittance n0/cosθ would be infinite)
        terms.rs = terms.rp = 1.0;
        terms.ts = terms.tp = 0.0;
        terms.cosThetaT = std::sqrt(1.0 - invariant2 / (nSub * nSub));
        return terms;
    }
    // Below the outer critical angle every layer propagates: from air the invariant is below 1 and
    // layer indices are at least 1 (the parser enforces it); from glass anything above nAir = 1 has
    // already been reflected totally. So each layer has a real angle and phase δ, and δ is shared
    // by s and p: one sincos per layer.
    LayerMatrix s, p;
    const double wavenumber = 2.0 * std::numbers::pi / wavelengthNm;
    const size_t count = coating.layers.size();
    for (size_t i = 0; i < count; ++i) {
        const ThinFilmLayer& layer = coating.layers[fromAirSide ? i : count - 1 - i];
        const double inverseIndex = 1.0 / layer.index;
        const double sin2 = invariant2 * inverseIndex * inverseIndex;
        assert(sin2 < 1.0 && "coating layers have indices of at least 1");
        const double cosT = std::sqrt(std::max(0.0, 1.0 - sin2));
        const double inverseCosT = 1.0 / cosT;
        const double delta = wavenumber * layer.index * layer.thicknessNm * cosT;
        const double cosDelta = std::cos(delta), sinDelta = std::sin(delta);
        // s: η = n·cosθ; p: η = n/cosθ.
        const double etaS = layer.index * cosT, etaP = layer.index * inverseCosT;
        s = s.then({cosDelta, sinDelta * inverseIndex * inverseCosT, etaS * sinDelta, cosDelta});
        p = p.then({cosDelta, sinDelta * cosT * inverseIndex, etaP * sinDelta, cosDelta});
    }
    const double cosSub = std::sqrt(1.0 - invariant2 / (nSub * nSub));
    respond(s, n0 * cosThetaI, nSub * cosSub, &terms.rs, &terms.ts);
    respond(p, n0 / cosThetaI, nSub / cosSub, &terms.rp, &terms.tp);
    terms.cosThetaT = cosSub;
    return terms;
}

double thinFilmReflectanceBound(const Coating& coating, double cosThetaI, double nAir, double nGlass, bool fromAirSide) {
    if (coating.layers.size() != 1 || coating.ideal) return 1.0;
    const double n0 = fromAirSide ? nAir : nGlass;
    const double nSub = fromAirSide ? nGlass : nAir;
    const double nFilm = coating.layers.front().index;
    const double c = std::clamp(cosThetaI, 0.0, 1.0);
    if (c == 0.0) return 1.0;
    const double sin2 = std::max(0.0, 1.0 - c * c);
    // sin² of the angles in the film and the substrate, from the invariant n·sinθ.
    const double film = n0 / nFilm, sub = n0 / nSub;
    const double sin2Sub = sub * sub * sin2;
    if (sin2Sub >= 1.0) return 1.0;  // total internal reflection: thinFilmResponse says so exactly
    const double cosFilm = std::sqrt(std::max(0.0, 1.0 - film * film * sin2)), cosSub = std::sqrt(1.0 - sin2Sub);
    // s admittances η = n cosθ; |r01| = a1 / a2, |r12| = b1 / b2, and the bound's ratio with one
    // division: (|r01| + |r12|) / (1 + |r01 r12|) = (a1 b2 + b1 a2) / (a2 b2 + a1 b1).
    const double eta0 = n0 * c, eta1 = nFilm * cosFilm, eta2 = nSub * cosSub;
    const double a1 = std::abs(eta0 - eta1), a2 = eta0 + eta1, b1 = std::abs(eta1 - eta2), b2 = eta1 + eta2;
    const double g = (a1 * b2 + b1 * a2) / (a2 * b2 + a1 * b1);
    return g * g;
}

}  // namespace flare
