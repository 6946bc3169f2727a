#include "PreviewCommand.h"

#include "StarburstReport.h"

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "flare/core/OutputFiles.h"
#include "flare/film/ImageIO.h"
#include "flare/scene/Scene.h"
#include "flare/scene/ScenePreview.h"

namespace flare::cli {

namespace {

struct PreviewCommandOptions {
    std::string scene;  // "" = the embedded default scene
    std::string exr;
    std::string png;
    bool layers = false;
    bool floatLayers = false;
    bool noDiffraction = false;
    bool quiet = false;
    bool pngGiven = false;  // --png given, even as ""
};

void run(const PreviewCommandOptions& o) {
    const auto start = std::chrono::steady_clock::now();
    // Every output is checked before any work and written all or nothing.
    OutputFiles outputs;
    outputs.add(o.exr, "-o");
    if (o.pngGiven) outputs.add(o.png, "--png");
    Scene scene = o.scene.empty() ? defaultScene() : loadScene(o.scene);
    if (o.noDiffraction) scene.render.diffraction = false;
    const LensSystem lens = buildSceneLens(scene);

    ScenePreview preview = previewScene(scene, lens, o.layers);
    // The light's own image is 10⁴–10⁶ times brighter than its ghosts: the PNG is exposed for the
    // ghosts (two stops under the ghost layer's auto exposure, so that overlapping ghosts keep their
    // colour) and the light clips, as a photograph of a flare does.
    const double pngExposure =
        o.png.empty() ? 0.0
                      : 0.25 * autoExposure(rgbLayerFromXyz("ghost", preview.ghosts, preview.widthPx, preview.heightPx));
    const std::vector<ImageLayer> layers = previewLayers(preview, o.layers);
    // Per-ghost layers (ghost_...) at half precision (11 significant bits, what
    // compositing uses), which halves the file: as half floats where the layer's values fit half's
    // range, else as floats rounded to half's precision (a weak ghost can lie below half's range in
    // the lights' units). The main image and the direct and ghost layers stay exact.
    ExrWriteOptions storage;
    if (!o.floatLayers)
        for (size_t i = 0; i < layers.size(); ++i)
            if (layers[i].name.starts_with("ghost_"))
                storage.storage[layers[i].name] = fitsHalf(layers[i]) ? ExrStorage::Half : ExrStorage::FloatHalfPrecision;
    const std::vector<std::pair<std::string, std::string>> metadata = {
        {"software", "flare preview"},
        {"colorSpace", "linear Rec.709 (sRGB primaries, D65 white)"},
        {"units", "sensor irradiance, W/m2 per the lights' power units"},
        {"scene", scene.sourceFile.empty() ? "embedded default scene" : scene.sourceFile},
        {"lens", lens.name()},
    };
    writeExr(outputs, o.exr, layers, metadata, storage);
    if (o.pngGiven) writePng(outputs, o.png, layers.front(), pngExposure);
    outputs.commit();

    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!o.quiet)
        std::fprintf(stderr, "preview: %s, %zu light(s), %d ghost renders (%d pruned), %ld rays, %.2f s\n",
                     lens.name().c_str(), scene.lights.size(), preview.renderedGhosts, preview.prunedGhosts,
                     preview.tracedRays, seconds);
    if (!o.quiet && preview.starburst) printStarburst(*preview.starburst);
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
                      "add layers: direct, starburst (the direct image diffracted), ghost (32-bit float) and one per ghost (ghost_03_07.R/G/B, half precision)");
    preview->add_flag("--no-diffraction", o->noDiffraction,
                      "leave the light's own image geometric: no starburst (as the scene's render.diffraction: false)");
    preview->add_flag("--float-layers", o->floatLayers, "with --layers: store the per-ghost layers as exact 32-bit float");
    preview->add_flag("--quiet", o->quiet, "no statistics on stderr");
    preview->callback([o, preview] {
        o->pngGiven = preview->count("--png") > 0;
        run(*o);
    });
}

}  // namespace flare::cli
