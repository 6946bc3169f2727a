#include "PreviewCommand.h"

#include "LayersOption.h"
#include "Output.h"
#include "StarburstReport.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

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
    LayersOption layers;
    bool floatLayers = false;
    bool noDiffraction = false;
    bool noGhostRinging = false;
    bool higher = false;
    int passes = PreviewBudget::kDefaultPasses;
    int beamsPerPass = 0;
    double timeS = 0.0;
    long long seed = -1;  // −1: the scene's
    std::optional<double> exposureStops;  // unset: automatic
    bool quiet = false;
    bool pngGiven = false;  // --png given, even as ""
};

// The preview's beams, bands and passes allocate and free buffers of a few hundred kilobytes to a few
// megabytes, thousands of times in a second. glibc maps such blocks afresh (above its mmap
// threshold) or hands a heap's free top back to the system (above its trim threshold), so the next
// one is faulted in page by page again: about 15 % of the preview's CPU was the kernel's, most of it
// page faults. Kept instead, freed memory serves the next allocation. (The output is the same
// bits: nothing depends on where a block lies. Elsewhere than glibc, the allocator's own policy.)
void keepFreedMemory() {
#if defined(__GLIBC__)
    mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's largest; the frame's images stay below it
    mallopt(M_TRIM_THRESHOLD, 1 << 30);
    mallopt(M_TOP_PAD, 16 << 20);
#endif
}

void run(const PreviewCommandOptions& o) {
    const auto start = std::chrono::steady_clock::now();
    keepFreedMemory();
    // Every output is checked before any work and written all or nothing.
    OutputFiles outputs;
    outputs.add(o.exr, "-o");
    if (o.pngGiven) outputs.add(o.png, "--png");
    Scene scene = o.scene.empty() ? defaultScene() : loadScene(o.scene);
    if (o.noDiffraction) scene.render.diffraction = false;
    if (o.noGhostRinging) scene.render.ghostRinging = false;
    const LensSystem lens = buildSceneLens(scene);

    if (!o.quiet) {
        // The analysis comes first and prints nothing of its own.
        std::fprintf(stderr, "preview: analysing the ghosts of %zu light(s)...\n", scene.lights.size());
        std::fflush(stderr);
    }
    PreviewBudget budget;
    budget.passes = o.passes;
    budget.beamsPerPass = o.beamsPerPass;
    // --time counts from the command's start: what loading the scene took is spent already.
    if (o.timeS > 0.0)
        budget.timeS = std::max(1e-3, o.timeS - std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    if (o.seed >= 0) budget.seed = static_cast<std::uint64_t>(o.seed);
    budget.higher = o.higher;
    budget.ghostLayers = o.layers.selection;
    ScenePreview preview = previewScene(scene, lens, o.layers.given, budget);
    // The light's own image is 10⁴–10⁶ times brighter than its ghosts: unless --exposure says
    // otherwise, the PNG is exposed for the ghosts and the light clips (pngExposure, Output.h).
    const double exposure =
        o.pngGiven ? pngExposure(o.exposureStops,
                                 rgbLayerFromXyz("ghost", preview.ghosts, preview.widthPx, preview.heightPx), "preview",
                                 o.quiet)
                   : 0.0;
    const std::vector<ImageLayer> layers = previewLayers(preview, o.layers.given);
    // Per-ghost layers (ghost_...) each as a part of its own over its footprint, at half precision
    // (11 significant bits, what compositing uses), which halves the file: as half floats where the
    // layer's values fit half's range, else as floats rounded to half's precision (a weak ghost can
    // lie below half's range in the lights' units). The main image and the direct and ghost layers
    // stay exact.
    ExrWriteOptions storage;
    // Without layers the file is one float image whose low bits are noise: ZIP would keep 91 % of
    // its bytes and take a sixth of the preview's CPU (ExrCompression).
    if (!o.layers.given) storage.compression = ExrCompression::None;
    for (size_t i = 0; i < layers.size(); ++i) {
        if (!layers[i].name.starts_with("ghost_")) continue;
        storage.ownParts.insert(layers[i].name);
        if (!o.floatLayers)
            storage.storage[layers[i].name] = fitsHalf(layers[i]) ? ExrStorage::Half : ExrStorage::FloatHalfPrecision;
    }
    const std::vector<std::pair<std::string, std::string>> metadata = {
        {"software", "flare preview"},
        {"colorSpace", "linear Rec.709 (sRGB primaries, D65 white)"},
        {"units", "sensor irradiance, W/m2 per the lights' power units"},
        {"scene", scene.sourceFile.empty() ? "embedded default scene" : scene.sourceFile},
        {"lens", lens.name()},
    };
    writeExr(outputs, o.exr, layers, metadata, storage);
    if (o.pngGiven) writePng(outputs, o.png, layers.front(), exposure);
    outputs.commit();

    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!o.quiet) {
        std::fprintf(stderr, "preview: %s, %zu light(s), %d ghosts by beams (%d pruned), %d passes, %lld beams, %ld rays, %.2f s\n",
                     lens.name().c_str(), scene.lights.size(), preview.renderedGhosts, preview.prunedGhosts, preview.passes,
                     static_cast<long long>(preview.beams), preview.tracedRays, seconds);
        if (preview.ghostEstimatedError > 0.0)
            std::fprintf(stderr, "preview: the ghost layer's estimated error %.2g%% (falls as --passes or --time grows)\n",
                         100.0 * preview.ghostEstimatedError);
        std::fprintf(stderr, "preview: left out (flare render has them): %s\n", preview.leftOut.c_str());
    }
    if (!o.quiet && preview.starburst) printStarburst(*preview.starburst);
    std::printf("wrote %s%s%s\n", o.exr.c_str(), o.png.empty() ? "" : " and ", o.png.c_str());
}

}  // namespace

void addPreviewCommand(CLI::App& app) {
    auto o = std::make_shared<PreviewCommandOptions>();
    CLI::App* preview =
        app.add_subcommand("preview", "ghost preview of a scene: the final render's first passes without photons (EXR, optional PNG)");
    preview->add_option("SCENE", o->scene, "scene file (JSON); default: the embedded default scene");
    preview->add_option("-o,--output", o->exr, "EXR file to write")->required();
    preview->add_option("--png", o->png, "also write a tone-mapped PNG");
    addExposureOption(preview, o->exposureStops);
    addLayersOption(preview, o->layers,
                    "add layers: direct, starburst (the direct image diffracted), ghost (32-bit float) and one per ghost "
                    "(ghost_03_07.R/G/B, half precision)");
    preview->add_flag("--no-ghost-ringing", o->noGhostRinging,
                      "leave the ghosts' rims geometric: no Fresnel ripples (as the scene's render.ghost_ringing: false)");
    preview->add_flag("--no-diffraction", o->noDiffraction,
                      "leave the light's own image geometric: no starburst (as the scene's render.diffraction: false)");
    preview->add_flag("--float-layers", o->floatLayers, "with --layers: store the per-ghost layers as exact 32-bit float");
    preview->add_option("--passes", o->passes,
                        "passes of the final render's beams (default " + std::to_string(PreviewBudget::kDefaultPasses) +
                            "; the same seed and passes give the same image)")
        ->check(CLI::Range(1, 1 << 20));
    preview->add_option("--beams-per-pass", o->beamsPerPass,
                        "beams per pass and light (default: half the scene's render.beams_per_pass, so that the "
                        "default passes cost one pass of the render; the render's own value makes the preview the "
                        "first passes of flare render --beam-probes 0)")
        ->check(CLI::Range(16, 65536));
    preview->add_option("--time", o->timeS,
                        "instead of --passes: as many passes as fit in this many seconds of wall time, analysis included")
        ->check(CLI::PositiveNumber);
    preview->add_option("--seed", o->seed, "random seed of the beams (default: the scene's render.seed)")
        ->check(CLI::Range(0LL, (1LL << 62)));
    preview->add_flag("--higher", o->higher, "add the order-4 chains the final render guides (the `higher` layer)");
    preview->add_flag("--quiet", o->quiet, "no statistics on stderr");
    preview->callback([o, preview] {
        o->pngGiven = preview->count("--png") > 0;
        resolveLayersOption(preview, o->layers, o->scene);
        run(*o);
    });
}

}  // namespace flare::cli
