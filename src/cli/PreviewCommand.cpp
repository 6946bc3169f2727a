#include "PreviewCommand.h"

#include "Output.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <memory>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "flare/core/Spectrum.h"
#include "flare/film/ImageIO.h"
#include "flare/ghosts/GhostAnalysis.h"
#include "flare/ghosts/Preview.h"
#include "flare/scene/Scene.h"

namespace flare::cli {

namespace {

struct PreviewCommandOptions {
    std::string scene;  // "" = the embedded default scene
    std::string exr;
    std::string png;
    bool layers = false;
    bool floatLayers = false;
    bool quiet = false;
};

// The preview traces parallel rays. A point or disk light at distance d is rendered as a distant
// source in its direction with irradiance I/d² at the lens (exact in the far field, d ≫ the
// aperture) and, for a disk, the angular diameter it subtends.
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

void add(std::vector<float>& into, const std::vector<float>& from) {
    if (into.empty()) into.assign(from.size(), 0.0f);
    for (size_t i = 0; i < from.size(); ++i) into[i] += from[i];
}

void run(const PreviewCommandOptions& o) {
    const auto start = std::chrono::steady_clock::now();
    checkWritable(o.exr);
    if (!o.png.empty()) checkWritable(o.png);
    const Scene scene = o.scene.empty() ? defaultScene() : loadScene(o.scene);
    const LensSystem lens = buildSceneLens(scene);

    GhostAnalysisOptions analysis;
    analysis.order = scene.render.ghostOrder;
    analysis.includeSensor = scene.render.includeSensorGhosts;
    analysis.keepShare = scene.render.pruneKeepShare;
    analysis.relativeThreshold = scene.render.pruneRelativeThreshold;
    PreviewOptions options;
    options.widthPx = scene.sensor.widthPx;
    options.heightPx = scene.sensor.heightPx;
    options.perGhostLayers = o.layers;

    std::vector<float> direct, ghosts;
    std::map<std::string, std::vector<float>> perGhost;  // summed over lights, by path label
    long rays = 0;
    int rendered = 0, pruned = 0;
    for (const LightSpec& spec : scene.lights) {
        const PreviewLight light = previewLight(spec, scene.render.previewWavelengths);
        const GhostReport report = analyseGhosts(lens, light.direction, analysis);
        const PreviewImage image = renderPreview(lens, light, report, options);
        add(direct, image.direct.xyz);
        add(ghosts, image.ghosts.xyz);
        for (const XyzLayer& layer : image.perGhost) add(perGhost[layer.name], layer.xyz);
        for (long r : image.tracedRays) rays += r;
        rendered += static_cast<int>(image.tracedRays.size());
        pruned += report.prunedCount;
    }

    std::vector<float> total = direct;
    add(total, ghosts);
    const int w = options.widthPx, h = options.heightPx;
    std::vector<ImageLayer> layers{rgbLayerFromXyz("", total, w, h)};
    ExrWriteOptions storage;
    if (o.layers) {
        layers.push_back(rgbLayerFromXyz("direct", direct, w, h));
        layers.push_back(rgbLayerFromXyz("ghost", ghosts, w, h));
        // Per-ghost layers at half precision (11 significant bits, what compositing uses), which
        // halves the file: as half floats where the layer's values fit half's range, else as
        // floats rounded to half's precision (a weak ghost can lie below half's range in the
        // lights' units). The main image and the direct and ghost layers stay exact.
        for (auto& [name, xyz] : perGhost) {
            layers.push_back(rgbLayerFromXyz(name, xyz, w, h));
            std::vector<float>().swap(xyz);  // one copy at a time
            if (!o.floatLayers)
                storage.storage[name] = fitsHalf(layers.back()) ? ExrStorage::Half : ExrStorage::FloatHalfPrecision;
        }
    }
    const std::vector<std::pair<std::string, std::string>> metadata = {
        {"software", "flare preview"},
        {"colorSpace", "linear Rec.709 (sRGB primaries, D65 white)"},
        {"units", "sensor irradiance, W/m2 per the lights' power units"},
        {"scene", scene.sourceFile.empty() ? "embedded default scene" : scene.sourceFile},
        {"lens", lens.name()},
    };
    writeExr(o.exr, layers, metadata, storage);
    // The light's own image is 10⁴–10⁶ times brighter than its ghosts: expose for the ghosts (two
    // stops under the ghost layer's auto exposure, so that overlapping ghosts keep their colour) and
    // let the light clip, as a photograph of a flare does.
    if (!o.png.empty()) writePng(o.png, layers.front(), 0.25 * autoExposure(rgbLayerFromXyz("ghost", ghosts, w, h)));

    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!o.quiet)
        std::fprintf(stderr, "preview: %s, %zu light(s), %d ghost renders (%d pruned), %ld rays, %.2f s\n",
                     lens.name().c_str(), scene.lights.size(), rendered, pruned, rays, seconds);
    std::printf("wrote %s%s%s\n", o.exr.c_str(), o.png.empty() ? "" : " and ", o.png.c_str());
}

}  // namespace

void addPreviewCommand(CLI::App& app) {
    auto o = std::make_shared<PreviewCommandOptions>();
    CLI::App* preview = app.add_subcommand("preview", "noise-free ghost preview of a scene (EXR, optional PNG)");
    preview->add_option("SCENE", o->scene, "scene file (JSON); default: the embedded default scene");
    preview->add_option("-o,--output", o->exr, "EXR file to write")->required();
    preview->add_option("--png", o->png, "also write a tone-mapped PNG");
    preview->add_flag("--layers", o->layers,
                      "add layers: direct, ghost (32-bit float) and one per ghost (ghost_03_07.R/G/B, half precision)");
    preview->add_flag("--float-layers", o->floatLayers, "with --layers: store the per-ghost layers as exact 32-bit float");
    preview->add_flag("--quiet", o->quiet, "no statistics on stderr");
    preview->callback([o] { run(*o); });
}

}  // namespace flare::cli
