#include "flare/ghosts/GhostTable.h"

#include <cmath>
#include <numbers>
#include <optional>

namespace flare {

namespace {

nlohmann::json optionalNumber(const std::optional<double>& v) {
    return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

nlohmann::json ghostJson(const GhostEstimate& g) {
    nlohmann::json j;
    j["surfaces"] = g.path.surfaceNumbers();
    j["label"] = g.path.label();
    j["ghost_efl_mm"] = optionalNumber(g.paraxial.eflMm);
    j["ghost_focus_mm"] = optionalNumber(g.paraxial.focusFromSensorMm);
    j["internal_focus"] = g.paraxial.internalFocus;
    j["marginal_heights_mm"] = g.paraxial.marginalHeightsMm;
    j["power_fraction"] = g.powerFraction;
    j["footprint_mm"] = {{"x_min", g.footprintMinMm.x}, {"y_min", g.footprintMinMm.y},
                         {"x_max", g.footprintMaxMm.x}, {"y_max", g.footprintMaxMm.y}};
    j["peak_irradiance_ratio"] = g.peakIrradianceRatio;
    j["live_pupil_cells"] = g.pupil.liveCount();
    j["pruned"] = g.pruned;
    // false: the analysis ran out of its ray budget on this path and the estimate is from the
    // part of the region it found (only on lenses far from the shipped ones).
    j["resolved"] = g.resolved;
    j["traced_rays"] = g.tracedRays;
    return j;
}

}  // namespace

glm::dvec2 fieldDegFromDirection(const glm::dvec3& direction) {
    return {std::atan(-direction.x / direction.z) * 180.0 / std::numbers::pi,
            std::atan(-direction.y / direction.z) * 180.0 / std::numbers::pi};
}

nlohmann::json ghostTableJson(const LensSystem& lens, const glm::dvec3& lightDirection,
                              const GhostAnalysisOptions& options, const GhostReport& report, bool includePruned) {
    const glm::dvec2 fieldDeg = fieldDegFromDirection(lightDirection);
    nlohmann::json j;
    j["lens"] = lens.name();
    j["field_deg"] = {fieldDeg.x, fieldDeg.y};
    j["wavelength_nm"] = options.wavelengthNm;
    j["order"] = options.order;
    j["surfaces"] = lens.surfaceCount();
    j["sensor_surface_number"] = lens.surfaceCount() + 1;
    j["enumerated"] = report.ghosts.size();
    j["direct_power_fraction"] = report.direct.powerFraction;
    j["total_ghost_power_fraction"] = report.totalGhostPowerFraction;
    j["pruned_count"] = report.prunedCount;
    j["pruned_power_fraction"] = report.prunedPowerFraction;
    j["ghosts"] = nlohmann::json::array();
    for (const GhostEstimate& g : report.ghosts)
        if (includePruned || !g.pruned) j["ghosts"].push_back(ghostJson(g));
    return j;
}

}  // namespace flare
