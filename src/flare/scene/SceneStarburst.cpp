#include "flare/scene/SceneStarburst.h"

#include "flare/core/Spectrum.h"
#include "flare/photons/Light.h"
#include "flare/render/Render.h"
#include "flare/scene/SceneScattering.h"

namespace flare {

StarburstImage sceneStarburst(const Scene& scene, const LensSystem& lens, const std::vector<float>& directXyz,
                              int widthPx, int heightPx, StarburstOptions options) {
    std::vector<StarburstLight> lights;
    for (const LightSpec& spec : scene.lights)
        lights.push_back({spec.name, spec.travelDirection(),
                          spectralQuadrature(toSpectrum(spec.spectrum), scene.render.diffractionWavelengths)});
    // The dust of the scene and of the lens file, as the render resolves it.
    RenderOptions scattering;
    applySceneScattering(scene, lens, scattering);
    std::vector<StarburstDust> dust;
    for (size_t s = 0; s < scattering.contamination.size(); ++s) {
        const SurfaceContamination& c = scattering.contamination[s];
        if (!(c.dustCoverage > 0.0)) continue;
        // A mask's mean over the clear aperture.
        double coverage = c.dustCoverage;
        if (c.dustMask) {
            const double r = lens.surface(static_cast<int>(s)).semiApertureMm;
            double sum = 0.0;
            int n = 0;
            for (int j = 0; j < 64; ++j)
                for (int i = 0; i < 64; ++i) {
                    const double x = r * ((i + 0.5) / 32.0 - 1.0), y = r * ((j + 0.5) / 32.0 - 1.0);
                    if (x * x + y * y > r * r) continue;
                    sum += c.dustCoverageAt(x, y);
                    ++n;
                }
            coverage = n > 0 ? sum / n : 0.0;
        }
        dust.push_back({static_cast<int>(s), coverage, c.dustDiameterUm, c.dustDiameterSigma});
    }
    return renderStarburst(lens, directXyz, widthPx, heightPx, lights, options, dust);
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
            j["dust_surfaces"] = l.dustSurfaces;
            j["dust_glow_share"] = l.dustGlowShare;
            j["dust_glow_in_frame_share"] = l.dustGlowInFrameShare;
            j["seconds"] = l.seconds;
        }
        lights.push_back(j);
    }
    return {{"lights", lights}};
}

}  // namespace flare
