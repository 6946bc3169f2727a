// Thin-film anti-reflection coatings on an air–glass interface. Reflectance and transmittance come
// from the characteristic-matrix (Abelès) calculation for s and p polarisation, for lossless layers,
// at any wavelength and angle; incidence from either side of the interface.
#pragma once

#include <string>
#include <vector>

#include "flare/optics/Fresnel.h"

namespace flare {

struct ThinFilmLayer {
    double index = 1.38;
    double thicknessNm = 0.0;
};

struct Coating {
    std::string name;
    std::vector<ThinFilmLayer> layers;  // from the air side towards the glass

    // Single quarter-wave layer of `index` at `designWavelengthNm` (normal incidence).
    static Coating quarterWave(std::string name, double index, double designWavelengthNm);
    // The built-in default: MgF2 (n = 1.38), quarter-wave at 550 nm.
    static Coating magnesiumFluoride();
};

// Response of an interface between an ambient medium nAir and a glass nGlass carrying `coating`,
// for light arriving from the air side (fromAirSide = true) or from the glass side, at an incidence
// angle whose cosine in the incident medium is cosThetaI. With no layers this equals
// fresnelDielectric. Total internal reflection gives R = 1, T = 0.
FresnelTerms thinFilmResponse(const Coating& coating, double cosThetaI, double nAir, double nGlass,
                              bool fromAirSide, double wavelengthNm);

}  // namespace flare
