#include "flare/scene/SceneStarburst.h"

#include "flare/core/Spectrum.h"
#include "flare/photons/Light.h"

namespace flare {

StarburstImage sceneStarburst(const Scene& scene, const LensSystem& lens, const std::vector<float>& directXyz,
                              int widthPx, int heightPx) {
    std::vector<StarburstLight> lights;
    for (const LightSpec& spec : scene.lights)
        lights.push_back({spec.name, spec.travelDirection(),
                          spectralQuadrature(toSpectrum(spec.spectrum), scene.render.diffractionWavelengths)});
    return renderStarburst(lens, directXyz, widthPx, heightPx, lights);
}

nlohmann::json starburstJson(const StarburstImage& image) {
    nlohmann::json lights = nlohmann::json::array();
    for (const StarburstLightReport& l : image.lights) {
        nlohmann::json j = {{"light", l.name}, {"diffracted", l.diffracted}};
        if (!l.diffracted) {
            j["why"] = l.why;
        } else {
            j["pupil_area_mm2"] = l.pupilAreaMm2;
            j["straight_edges"] = l.spikeEdges;
            j["curved_outline_share"] = l.smoothOutlineShare;
            j["wavelengths"] = l.wavelengths;
            j["crop_radius_px"] = l.cropRadiusPx;
            j["window_radius_px"] = l.windowRadiusPx;
            j["exact_core_radius_px"] = l.coherentRadiusPx;
            j["psf_model_energy_error"] = l.parsevalError;
            j["diffracted_share_of_direct"] = l.diffractedShare;
            j["outside_frame_share"] = l.outsideFrameShare;
            j["seconds"] = l.seconds;
        }
        lights.push_back(j);
    }
    return {{"lights", lights}};
}

}  // namespace flare
