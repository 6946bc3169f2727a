// Anti-reflection coatings on an air–glass interface. Thin-film stacks: reflectance and
// transmittance from the characteristic-matrix (Abelès) calculation for s and p polarisation, for
// lossless layers, at any wavelength and angle; incidence from either side of the interface. Ideal
// coatings (as optical-design tools offer for ghost studies): a reflectance given directly, flat or
// per wavelength, the same at every angle and for both polarisations, the rest transmitted.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "flare/optics/Fresnel.h"

namespace flare {

struct ThinFilmLayer {
    double index = 1.38;
    double thicknessNm = 0.0;
};

// A reflectance per wavelength, linear between the points and constant beyond the end points; one
// point is a flat reflectance.
struct IdealReflectance {
    std::vector<double> wavelengthsNm;  // increasing
    std::vector<double> reflectances;   // each in [0, 1]

    double at(double wavelengthNm) const;
};

struct Coating {
    std::string name;
    std::vector<ThinFilmLayer> layers;  // from the air side towards the glass
    std::optional<IdealReflectance> ideal;  // set: an ideal coating (no layers)

    // False for an uncoated interface (no layers and not ideal).
    bool changesInterface() const { return !layers.empty() || ideal.has_value(); }

    // Single quarter-wave layer of `index` at `designWavelengthNm` (normal incidence).
    static Coating quarterWave(std::string name, double index, double designWavelengthNm);
    // The built-in default: MgF2 (n = 1.38), quarter-wave at 550 nm.
    static Coating magnesiumFluoride();
    // An ideal coating of flat reflectance R.
    static Coating idealFlat(std::string name, double reflectance);
};

// Response of an interface between an ambient medium nAir and a glass nGlass carrying `coating`,
// for light arriving from the air side (fromAirSide = true) or from the glass side, at an incidence
// angle whose cosine in the incident medium is cosThetaI. With no layers this equals
// fresnelDielectric. Total internal reflection gives R = 1, T = 0 (also for an ideal coating: the
// critical angle belongs to the two media, not to the coating).
FresnelTerms thinFilmResponse(const Coating& coating, double cosThetaI, double nAir, double nGlass,
                              bool fromAirSide, double wavelengthNm);

// An upper bound on thinFilmResponse(...).reflectance() for a single-layer coating, whatever the
// layer's phase, so without its sincos: each polarisation's reflectance is largest where the
// film's two reflections add in phase, ((|r01| + |r12|) / (1 + |r01 r12|))² (the Airy formula is
// monotone in the cosine of twice the phase), and at every dielectric interface |rp| ≤ |rs|, so
// the s bound holds for the unpolarised mean. Returns 1 (no bound) for any other coating, under
// total internal reflection and at grazing incidence. A photon whose uniform draw lies above the
// bound refracts, and the exact response is needed only below it (PhotonTracer).
double thinFilmReflectanceBound(const Coating& coating, double cosThetaI, double nAir, double nGlass, bool fromAirSide);

}  // namespace flare
