#include "flare/scene/SceneRender.h"

#include <algorithm>
#include <utility>

#include "flare/render/RenderReport.h"
#include "flare/scene/SceneBeamShare.h"
#include "flare/scene/SceneScattering.h"
#include "flare/scene/SceneStarburst.h"

namespace flare {

RenderOptions sceneRenderOptions(const Scene& scene, const LensSystem& lens, const SceneRenderOverrides& overrides) {
    RenderOptions options;
    options.mode = overrides.mode;
    options.seed = overrides.seed.value_or(scene.render.seed);
    options.maxBounces = overrides.maxBounces.value_or(scene.render.maxBounces);
    options.beamsPerPass = overrides.beamsPerPass.value_or(scene.render.beamsPerPass);
    if (scene.render.beamsByPower) options.lightBeamsPerPass = lightBeamsByPower(scene.lights, options.beamsPerPass);
    // A guided pass's beams cost far more than its photons, and the layers left to photons
    // (scatter, higher) are what a target waits for: guided passes trace four times the photons.
    if (options.mode == RenderOptions::Mode::Guided) options.batchesPerPass = kGuidedBatchesPerPass;
    options.ghostRinging = scene.render.ghostRinging;
    options.beamReplicates = overrides.beamReplicates;
    if (overrides.beamVarianceProbes) options.beamVarianceProbes = *overrides.beamVarianceProbes;
    options.perGhostLayers = overrides.perGhostLayers;
    options.ghostLayers = overrides.ghostLayers;
    // The ghosts are the order-2 paths; a scene's ghost_order 4 asks for the order-4 chains to be
    // guided as well (in the `higher` layer).
    options.analysis.order = 2;
    options.higherOrder = overrides.higherOrder == RenderOptions::HigherOrder::Auto && scene.render.ghostOrder == 4
                              ? RenderOptions::HigherOrder::On
                              : overrides.higherOrder;
    options.analysis.includeSensor = scene.render.includeSensorGhosts;
    options.analysis.keepShare = scene.render.pruneKeepShare;
    options.analysis.relativeThreshold = scene.render.pruneRelativeThreshold;
    applySceneScattering(scene, lens, options);
    if (overrides.interiorAlbedo) {
        const double albedo = *overrides.interiorAlbedo;
        options.materials.housingAlbedo = options.materials.edgeAlbedo = options.materials.irisAlbedo = albedo;
        options.materials.housingGlossy = options.materials.edgeGlossy = options.materials.irisGlossy = 0.0;
    }
    options.film.widthPx = scene.sensor.widthPx;
    options.film.heightPx = scene.sensor.heightPx;
    options.film.widthMm = lens.sensor().widthMm;
    options.film.heightMm = lens.sensor().heightMm;
    options.film.kernel = overrides.kernel;
    options.film.radiusPx = overrides.radiusPx;
    options.smoothNeighbours = overrides.smoothNeighbours;
    options.strayLightSampling = overrides.strayLightSampling;
    if (overrides.scatterSplits) options.scatterSplits = *overrides.scatterSplits;
    if (overrides.kernel == FilmSettings::Kernel::Progressive && overrides.radiusPx == 1.0) options.film.radiusPx = 4.0;
    return options;
}

RenderStopRule RenderStopRule::make(const Scene& scene, const RenderOptions& options, std::int64_t photons,
                                    double timeS, double targetError, double ghostTargetError) {
    RenderStopRule rule;
    rule.timeS = timeS;
    rule.targetError = targetError;
    rule.ghostTargetError = ghostTargetError;
    const std::int64_t photonLimit = photons > 0 ? photons : (timeS > 0.0 ? 0 : scene.render.photons);
    const std::int64_t perPass = options.photonsPerPass();
    if (photonLimit > 0) rule.passesWanted = std::max<std::int64_t>(2, (photonLimit + perPass - 1) / perPass);
    return rule;
}

bool RenderStopRule::reached(const Renderer& renderer, double elapsedS) const {
    const int done = renderer.statistics().passes;
    if (done < 2) return false;
    if (passesWanted > 0 && done >= passesWanted) return true;
    if (timeS > 0.0 && elapsedS >= timeS) return true;
    const int minimum = std::max(kMinPassesToStop, kMinPassesPerReplicateToStop * renderer.film().replicates());
    if (!(targetError > 0.0 || ghostTargetError > 0.0) || done < minimum || !renderer.hasErrorEstimate()) return false;
    // The estimate scans the whole film: after the first passes it is checked every sixteenth of
    // the passes done (an overshoot of at most 1/16 of the work; a rule of the pass count, so the
    // same seed stops after the same pass).
    if (done >= 2 * kMinPassesToStop && done % std::max(1, done / 16) != 0) return false;
    return (!(targetError > 0.0) || renderer.estimatedRelativeError(kGroupFlare) <= targetError) &&
           (!(ghostTargetError > 0.0) || renderer.estimatedRelativeError(kGroupGhost) <= ghostTargetError);
}

std::vector<RenderOptions::ErrorTarget> RenderStopRule::errorTargets() const {
    std::vector<RenderOptions::ErrorTarget> targets;
    if (targetError > 0.0) targets.push_back({kGroupFlare, targetError});
    if (ghostTargetError > 0.0) targets.push_back({kGroupGhost, ghostTargetError});
    return targets;
}

double RenderStopRule::progress(const Renderer& renderer, double elapsedS) const {
    const RenderStatistics& s = renderer.statistics();
    // (The photon limit is a number of nominal passes: the adaptive plan sizes each pass's photons.)
    double fraction = passesWanted > 0 ? static_cast<double>(s.passes) / static_cast<double>(passesWanted) : 0.0;
    if (timeS > 0.0) fraction = std::max(fraction, elapsedS / timeS);
    const double error = renderer.estimatedRelativeError(kGroupFlare);
    if (targetError > 0.0 && error > 0.0 && renderer.hasErrorEstimate())
        fraction = std::max(fraction, std::min(1.0, (targetError * targetError) / (error * error)) *
                                          std::min(1.0, s.passes / static_cast<double>(kMinPassesToStop)));
    return std::min(fraction, 1.0);
}

nlohmann::json sceneRenderReportJson(const Renderer& renderer, const Scene& scene, const LensSystem& lens,
                                     double targetError, const StarburstImage* starburst) {
    nlohmann::json report = renderReportJson(
        renderer, scene.sourceFile.empty() ? "embedded default scene" : scene.sourceFile, lens.name(), targetError);
    if (starburst) report["diffraction"] = starburstJson(*starburst);
    return report;
}

std::vector<ImageLayer> renderLayers(const Renderer& renderer, const StarburstImage* starburst) {
    const int w = renderer.options().film.widthPx, h = renderer.options().film.heightPx;
    std::vector<float> total(static_cast<size_t>(w) * h * 3, 0.0f);
    std::vector<ImageLayer> layers{ImageLayer{}};
    for (int l = 0; l < static_cast<int>(renderer.layerNames().size()); ++l) {
        const std::string& name = renderer.layerNames()[l];
        if (l >= kFixedLayerCount && name.starts_with("ghost_")) {
            // Per-ghost layers over their footprints.
            const FilmWindow window = renderer.layerXyzFootprint(l);
            if (!window.empty())
                layers.push_back(rgbLayerFromXyz(name, window.xyz, window.width, window.height, window.x, window.y));
            continue;
        }
        const std::vector<float> xyz = renderer.layerXyz(l);
        const std::vector<float>& summed = l == kLayerDirect && starburst ? starburst->xyz : xyz;
        if (l < kFixedLayerCount)
            for (size_t i = 0; i < summed.size(); ++i) total[i] += summed[i];
        layers.push_back(rgbLayerFromXyz(renderer.layerNames()[l], xyz, w, h));
    }
    layers.front() = rgbLayerFromXyz("", total, w, h);
    if (starburst) layers.push_back(rgbLayerFromXyz("starburst", starburst->xyz, w, h));
    std::vector<float> variance = renderer.film().varianceRgb();
    if (!variance.empty()) layers.push_back(ImageLayer{"variance", w, h, std::move(variance)});
    return layers;
}

}  // namespace flare
