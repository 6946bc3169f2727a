#include "flare/optics/Fresnel.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

namespace flare {

FresnelTerms fresnelDielectric(double cosThetaI, double n1, double n2) {
    FresnelTerms terms;
    cosThetaI = std::clamp(cosThetaI, 0.0, 1.0);
    const double eta = n1 / n2;
    const double sin2ThetaT = eta * eta * std::max(0.0, 1.0 - cosThetaI * cosThetaI);
    if (sin2ThetaT >= 1.0) {
        terms.rs = terms.rp = 1.0;
        terms.ts = terms.tp = 0.0;
        terms.cosThetaT = 0.0;
        terms.totalInternalReflection = true;
        return terms;
    }
    const double cosThetaT = std::sqrt(1.0 - sin2ThetaT);
    const double a = n1 * cosThetaI, b = n2 * cosThetaT;  // s
    const double c = n2 * cosThetaI, d = n1 * cosThetaT;  // p
    if (a + b <= 0.0) {  // grazing from both sides: nothing enters
        terms.rs = terms.rp = 1.0;
        terms.ts = terms.tp = 0.0;
        terms.cosThetaT = cosThetaT;
        return terms;
    }
    const double rsAmp = (a - b) / (a + b);
    const double rpAmp = (c - d) / (c + d);
    const double tsAmp = 2.0 * a / (a + b);
    const double tpAmp = 2.0 * a / (c + d);
    // Power transmittance carries the ratio of beam cross-sections and of the media's impedance.
    const double beam = (n2 * cosThetaT) / (n1 * cosThetaI);
    terms.rs = rsAmp * rsAmp;
    terms.rp = rpAmp * rpAmp;
    terms.ts = cosThetaI > 0.0 ? beam * tsAmp * tsAmp : 0.0;
    terms.tp = cosThetaI > 0.0 ? beam * tpAmp * tpAmp : 0.0;
    terms.cosThetaT = cosThetaT;
    return terms;
}

glm::dvec3 reflect(const glm::dvec3& direction, const glm::dvec3& normal) {
    return direction - 2.0 * glm::dot(direction, normal) * normal;
}

}  // namespace flare
