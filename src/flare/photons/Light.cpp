#include "flare/photons/Light.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>

#include "flare/core/SmoothSpectrum.h"
#include "flare/optics/PupilGrid.h"

namespace flare {

Spectrum toSpectrum(const SpectrumSpec& spec) {
    switch (spec.kind) {
        case SpectrumSpec::Kind::Blackbody: return Spectrum::blackbody(spec.temperatureK);
        case SpectrumSpec::Kind::D65: return Spectrum::d65();
        case SpectrumSpec::Kind::EqualEnergy: return Spectrum::equalEnergy();
        case SpectrumSpec::Kind::Rgb: return Spectrum::smooth(fitSmoothSpectrum(linearSrgbToXyz(spec.rgb)).coefficients);
    }
    return Spectrum::equalEnergy();
}

glm::dvec3 LightSpec::travelDirection() const {
    if (type == Type::Directional) return directionFromFieldDeg(fieldXDeg, fieldYDeg);
    return glm::normalize(-positionMm);
}

void LightSpec::centreOnRegion() {
    glm::dvec3 sum{0.0};
    for (const RegionPoint& p : region) sum += p.share * directionFromFieldDeg(p.fieldXDeg, p.fieldYDeg);
    if (!(glm::length(sum) > 0.0)) return;
    const glm::dvec3 d = glm::normalize(sum);
    fieldXDeg = std::atan(-d.x / d.z) * 180.0 / std::numbers::pi;
    fieldYDeg = std::atan(-d.y / d.z) * 180.0 / std::numbers::pi;
}

double LightSpec::apparentRadiusRad() const {
    if (isRegion()) {
        const glm::dvec3 centre = travelDirection();
        double widest = 0.0;
        for (const RegionPoint& p : region) {
            const glm::dvec3 d = directionFromFieldDeg(p.fieldXDeg, p.fieldYDeg);
            // atan2 of |cross| and dot: accurate for the small angles a region holds.
            widest = std::max(widest, std::atan2(glm::length(glm::cross(centre, d)), glm::dot(centre, d)));
        }
        return widest;
    }
    switch (type) {
        case Type::Directional: return 0.5 * angularDiameterDeg * std::numbers::pi / 180.0;
        case Type::Disk: return glm::length(positionMm) > 0.0 ? std::atan(radiusMm / glm::length(positionMm)) : 0.0;
        case Type::Point: return 0.0;
    }
    return 0.0;
}

}  // namespace flare
