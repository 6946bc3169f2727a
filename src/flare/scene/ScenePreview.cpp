#include "flare/scene/ScenePreview.h"

#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>

#include "flare/core/Spectrum.h"
#include "flare/ghosts/GhostAnalysis.h"
#include "flare/scene/SceneStarburst.h"

namespace flare {

namespace {

void add(std::vector<float>& into, const std::vector<float>& from) {
    if (into.empty()) into.assign(from.size(), 0.0f);
    for (size_t i = 0; i < from.size(); ++i) into[i] += from[i];
}

}  // namespace

PreviewLight previewLight(const LightSpec& spec, int wavelengths) {
    PreviewLight light;
    light.direction = spec.travelDirection();
    light.spectrum = spectralQuadrature(toSpectrum(spec.spectrum), wavelengths);
    if (spec.type == LightSpec::Type::Directional) {
        light.irradiance = spec.power;
        light.angularDiameterDeg = spec.angularDiameterDeg;
    } else {
        const double distanceM = glm::length(spec.positionMm) * 1e-3;
        light.irradiance = spec.power / (distanceM * distanceM);
        light.angularDiameterDeg = 2.0 * std::atan(spec.radiusMm / glm::length(spec.positionMm)) * 180.0 / std::numbers::pi;
    }
    return light;
}

ScenePreview previewScene(const Scene& scene, const LensSystem& lens, bool perGhostLayers) {
    GhostAnalysisOptions analysis;
    analysis.order = scene.render.ghostOrder;
    analysis.includeSensor = scene.render.includeSensorGhosts;
    analysis.keepShare = scene.render.pruneKeepShare;
    analysis.relativeThreshold = scene.render.pruneRelativeThreshold;
    PreviewOptions options;
    options.widthPx = scene.sensor.widthPx;
    options.heightPx = scene.sensor.heightPx;
    options.perGhostLayers = perGhostLayers;

    ScenePreview result;
    result.widthPx = options.widthPx;
    result.heightPx = options.heightPx;
    for (const LightSpec& spec : scene.lights) {
        const PreviewLight light = previewLight(spec, scene.render.previewWavelengths);
        GhostReport report = analyseGhosts(lens, light.direction, analysis);
        // The ghosts pruned at 550 nm but strong in this light's spectrum are drawn too.
        keepSpectrallyStrongGhosts(lens, toSpectrum(spec.spectrum), analysis, report);
        const PreviewImage image = renderPreview(lens, light, report, options);
        add(result.direct, image.direct.xyz);
        add(result.ghosts, image.ghosts.xyz);
        for (const XyzLayer& layer : image.perGhost) add(result.perGhost[layer.name], layer.xyz);
        for (long r : image.tracedRays) result.tracedRays += r;
        result.renderedGhosts += static_cast<int>(image.tracedRays.size());
        result.prunedGhosts += report.prunedCount;
    }
    if (scene.render.diffraction)
        result.starburst = sceneStarburst(scene, lens, result.direct, result.widthPx, result.heightPx);
    return result;
}

std::vector<ImageLayer> previewLayers(ScenePreview& preview, bool withLayers) {
    std::vector<float> total = preview.starburst ? preview.starburst->xyz : preview.direct;
    add(total, preview.ghosts);
    const int w = preview.widthPx, h = preview.heightPx;
    std::vector<ImageLayer> layers{rgbLayerFromXyz("", total, w, h)};
    if (withLayers) {
        layers.push_back(rgbLayerFromXyz("direct", preview.direct, w, h));
        if (preview.starburst) layers.push_back(rgbLayerFromXyz("starburst", preview.starburst->xyz, w, h));
        layers.push_back(rgbLayerFromXyz("ghost", preview.ghosts, w, h));
        for (auto& [name, xyz] : preview.perGhost) {
            layers.push_back(rgbLayerFromXyz(name, xyz, w, h));
            std::vector<float>().swap(xyz);
        }
    }
    return layers;
}

}  // namespace flare
