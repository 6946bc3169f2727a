#include "flare/scene/SceneJson.h"

#include <stdexcept>

namespace flare {

namespace {

nlohmann::json spectrumJson(const SpectrumSpec& s) {
    switch (s.kind) {
        case SpectrumSpec::Kind::D65: return "d65";
        case SpectrumSpec::Kind::EqualEnergy: return "equal_energy";
        case SpectrumSpec::Kind::Blackbody: return {{"blackbody_k", s.temperatureK}};
        case SpectrumSpec::Kind::Rgb: return {{"rgb", {s.rgb.x, s.rgb.y, s.rgb.z}}};
    }
    throw std::logic_error("sceneToJson: unknown spectrum kind");
}

nlohmann::json lightJson(const LightSpec& l) {
    nlohmann::json j;
    switch (l.type) {
        case LightSpec::Type::Directional:
            j["type"] = "directional";
            break;
        case LightSpec::Type::Point: j["type"] = "point"; break;
        case LightSpec::Type::Disk: j["type"] = "disk"; break;
    }
    j["name"] = l.name;
    if (l.isRegion()) {
        // Centred on its points when read (LightSpec::centreOnRegion): no field_deg.
        j["type"] = "region";
        j["points"] = nlohmann::json::array();
        for (const RegionPoint& p : l.region) {
            nlohmann::json point = {p.fieldXDeg, p.fieldYDeg, p.share};
            if (!l.regionColours.empty()) point.push_back(p.colour);
            j["points"].push_back(point);
        }
        if (!l.regionColours.empty()) {
            j["colours"] = nlohmann::json::array();
            for (const glm::dvec3& c : l.regionColours) j["colours"].push_back({c.x, c.y, c.z});
        }
    } else if (l.type == LightSpec::Type::Directional) {
        j["field_deg"] = {l.fieldXDeg, l.fieldYDeg};
        if (l.angularDiameterDeg > 0.0) j["angular_diameter_deg"] = l.angularDiameterDeg;
    } else {
        j["position_mm"] = {l.positionMm.x, l.positionMm.y, l.positionMm.z};
        if (l.type == LightSpec::Type::Disk) j["radius_mm"] = l.radiusMm;
    }
    j["spectrum"] = spectrumJson(l.spectrum);
    j["power"] = l.power;
    return j;
}

}  // namespace

nlohmann::json sceneToJson(const Scene& scene) {
    nlohmann::json j;
    if (!scene.description.empty()) j["description"] = scene.description;
    j["lens"] = scene.lens;
    if (!scene.lensState.zoom.empty()) j["zoom"] = scene.lensState.zoom;
    if (scene.lensState.objectDistanceMm) j["focus_distance_mm"] = *scene.lensState.objectDistanceMm;
    if (scene.lensState.fNumber) j["f_number"] = *scene.lensState.fNumber;
    nlohmann::json sensor;
    if (scene.sensor.widthMm) sensor["width_mm"] = *scene.sensor.widthMm;
    if (scene.sensor.heightMm) sensor["height_mm"] = *scene.sensor.heightMm;
    sensor["resolution"] = {scene.sensor.widthPx, scene.sensor.heightPx};
    j["sensor"] = sensor;
    j["lights"] = nlohmann::json::array();
    for (const LightSpec& l : scene.lights) j["lights"].push_back(lightJson(l));
    const RenderSettings& r = scene.render;
    j["render"] = {{"preview_wavelengths", r.previewWavelengths},
                   {"ghost_order", r.ghostOrder},
                   {"prune_keep_share", r.pruneKeepShare},
                   {"prune_relative_threshold", r.pruneRelativeThreshold},
                   {"photons", r.photons},
                   {"seed", r.seed},
                   {"max_bounces", r.maxBounces},
                   {"sensor_ghosts", r.includeSensorGhosts},
                   {"diffraction", r.diffraction},
                   {"diffraction_wavelengths", r.diffractionWavelengths},
                   {"beams_per_pass", r.beamsPerPass}};
    if (r.beamsByPower) j["render"]["beams_by_power"] = true;
    return j;
}

}  // namespace flare
