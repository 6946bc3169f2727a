// Interface optics for a smooth dielectric boundary: Snell refraction, mirror reflection and the
// Fresnel coefficients for s and p polarisation. Directions are unit vectors; a normal may face
// either side (the functions orient it against the incident direction).
#pragma once

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace flare {

struct FresnelTerms {
    double rs = 0.0;  // reflectance, s (TE) polarisation
    double rp = 0.0;  // reflectance, p (TM) polarisation
    double ts = 1.0;  // transmittance (power), s
    double tp = 1.0;  // transmittance (power), p
    double cosThetaT = 1.0;  // cosine of the refraction angle (0 under total internal reflection)
    bool totalInternalReflection = false;

    double reflectance() const { return 0.5 * (rs + rp); }    // unpolarised
    double transmittance() const { return 0.5 * (ts + tp); }  // unpolarised
};

// Fresnel terms for light in a medium of index n1 meeting a medium of index n2 at an incidence
// angle whose cosine is cosThetaI (in [0, 1]). Transmittances come from the transmission
// amplitudes (with the n2·cosθt / n1·cosθi beam factor), not from 1 − R, so R + T = 1 is a check.
FresnelTerms fresnelDielectric(double cosThetaI, double n1, double n2);

// Mirror reflection of `direction` about a surface with normal `normal` (either orientation).
glm::dvec3 reflect(const glm::dvec3& direction, const glm::dvec3& normal);

// Snell refraction from index n1 into n2. Returns false under total internal reflection. Inline
// so that batch tracers compile it into their loops with the same results to the last bit.
inline bool refract(const glm::dvec3& direction, const glm::dvec3& normal, double n1, double n2,
                    glm::dvec3* refracted) {
    glm::dvec3 n = normal;
    double cosThetaI = -glm::dot(direction, n);
    if (cosThetaI < 0.0) {
        n = -n;
        cosThetaI = -cosThetaI;
    }
    const double eta = n1 / n2;
    const double sin2ThetaT = eta * eta * std::max(0.0, 1.0 - cosThetaI * cosThetaI);
    if (sin2ThetaT >= 1.0) return false;
    const double cosThetaT = std::sqrt(1.0 - sin2ThetaT);
    *refracted = glm::normalize(eta * direction + (eta * cosThetaI - cosThetaT) * n);
    return true;
}

}  // namespace flare
