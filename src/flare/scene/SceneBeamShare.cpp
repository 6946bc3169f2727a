#include "flare/scene/SceneBeamShare.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <glm/geometric.hpp>

namespace flare {

std::vector<int> beamsByPowerShare(const std::vector<double>& powers, long totalBeams, int floorBeams) {
    if (floorBeams < 1) throw std::invalid_argument("beamsByPowerShare: the floor must be at least one beam");
    double total = 0.0;
    for (double p : powers) {
        if (!std::isfinite(p) || p < 0.0) throw std::invalid_argument("beamsByPowerShare: a power is negative or not finite");
        total += p;
    }
    std::vector<int> beams(powers.size(), floorBeams);
    if (!(total > 0.0)) return beams;
    for (size_t l = 0; l < powers.size(); ++l) {
        const double share = static_cast<double>(totalBeams) * powers[l] / total;
        beams[l] = std::max(floorBeams, static_cast<int>(std::min(1e9, std::round(share))));
    }
    return beams;
}

std::vector<int> lightBeamsByPower(const std::vector<LightSpec>& lights, int beamsPerPass) {
    std::vector<double> irradiance;
    for (const LightSpec& l : lights) {
        if (l.type == LightSpec::Type::Directional) {
            irradiance.push_back(l.power);
        } else {
            const double distanceM = glm::length(l.positionMm) * 1e-3;
            irradiance.push_back(l.power / (distanceM * distanceM));
        }
    }
    return beamsByPowerShare(irradiance, static_cast<long>(beamsPerPass) * static_cast<long>(lights.size()),
                             std::min(beamsPerPass, kMinLightBeams));
}

}  // namespace flare
