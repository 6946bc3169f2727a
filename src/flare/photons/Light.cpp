#include "flare/photons/Light.h"

#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>

#include "flare/core/SmoothSpectrum.h"

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
    if (type == Type::Directional) {
        constexpr double kDegToRad = std::numbers::pi / 180.0;
        return glm::normalize(glm::dvec3(-std::tan(fieldXDeg * kDegToRad), -std::tan(fieldYDeg * kDegToRad), 1.0));
    }
    return glm::normalize(-positionMm);
}

double LightSpec::apparentRadiusRad() const {
    switch (type) {
        case Type::Directional: return 0.5 * angularDiameterDeg * std::numbers::pi / 180.0;
        case Type::Disk: return glm::length(positionMm) > 0.0 ? std::atan(radiusMm / glm::length(positionMm)) : 0.0;
        case Type::Point: return 0.0;
    }
    return 0.0;
}

}  // namespace flare
