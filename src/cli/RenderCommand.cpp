#include "RenderCommand.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "LayersOption.h"
#include "Output.h"
#include "Processes.h"
#include "StarburstReport.h"
#include "flare/core/Error.h"
#include "flare/core/OutputFiles.h"
#include "flare/core/Spectrum.h"
#include "flare/film/ImageIO.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"
#include "flare/scene/SceneRender.h"
#include "flare/scene/SceneStarburst.h"

namespace flare::cli {

namespace {

struct RenderCommandOptions {
    std::string scene;  // "" = the embedded default scene
    std::string exr, png, report, checkpoint;
    ExrCompression compression = ExrCompression::Piz;
    std::string mode = "guided";
    std::string kernel = "fixed";
    std::string higherOrder = "auto";
    double radiusPx = 1.0;
    int smoothNeighbours = 256;
    long long photons = -1;  // −1: the scene's
    double timeS = 0.0;
    double targetError = 0.02;  // 0: none
    double ghostTargetError = 0.0;  // 0: none
    std::string passPlan = "adaptive";
    int maxBounces = -2;     // −2: the scene's
    int beamsPerPass = 0;    // 0: the scene's
    int beamReplicates = 2;
    int beamProbes = -1;  // (unset: RenderOptions' default)
    long long seed = -1;     // −1: the scene's
    int threads = 0;
    double checkpointIntervalS = 60.0;
    std::optional<double> exposureStops;  // unset: automatic
    double interiorAlbedo = -1.0;  // < 0: the scene's finishes
    LayersOption layers;
    bool noDiffraction = false;
    bool noGhostRinging = false;
    bool analogStray = false;
    int scatterSplits = 0;  // 0: the default
    bool quiet = false;
    bool pngGiven = false, reportGiven = false, checkpointGiven = false;  // given, even as ""
};

std::atomic<bool> gInterrupted{false};
extern "C" void onInterrupt(int) { gInterrupted.store(true); }

void printProgress(const Renderer& renderer, double fraction, double targetError, double elapsedS) {
    const RenderStatistics& s = renderer.statistics();
    const double left = fraction > 0.0 ? elapsedS * (1.0 - fraction) / fraction : 0.0;
    const int width = 30, filled = static_cast<int>(fraction * width);
    const double error = renderer.estimatedRelativeError(kGroupFlare);
    char errorText[64] = "";
    if (renderer.hasErrorEstimate()) std::snprintf(errorText, sizeof errorText, "  error %.2g%%", 100.0 * error);
    if (renderer.hasErrorEstimate() && targetError > 0.0)
        std::snprintf(errorText + std::strlen(errorText), sizeof errorText - std::strlen(errorText), " (target %.2g%%)",
                      100.0 * targetError);
    std::fprintf(stderr, "\r[%.*s%*s] %5.1f%%  %d passes%s  %.0f s left   ", filled, "##############################",
                 width - filled, "", 100.0 * fraction, s.passes, errorText, left);
    std::fflush(stderr);
}

// The wall seconds the work after the passes takes (the starburst, reading the layers out, the EXR
// and the other outputs), forecast from the image's size so that a pass that would leave too
// little of --time for them is not started. Measured on the 2-core Zen 4 machine on the street
// lights, 1536 × 1024 (docs/BENCHMARKS.md, "Every light converges, tenth part"): the stage took
// 1.13 s of CPU with six layers written, 1.87 s with the starburst and its layer, and about 1.5 s
// of wall time on two idle cores with them (it runs on about 1.25 threads): per
// megapixel, kFinishSPerMegapixelLayer for each layer written (its read-out, RGB conversion and
// PIZ compression) and kStarburstSPerMegapixel for the diffraction (its far field over every
// pixel), a forecast a little above that wall time, since an early end is better than a late one.
constexpr double kFinishSPerMegapixelLayer = 0.1;
constexpr double kStarburstSPerMegapixel = 0.4;
// A per-ghost layer is read out and written over its footprint, as a part of its own: its cost
// follows the film tiles its ghost reached so far (kFootprintSPerMegapixel per megapixel of
// them), which the forecast counts again before every pass. Measured on the same machine after
// 2 passes: the street lights' 162 ghost layers, over 47 megapixels of tiles, took about 7.6 s of
// wall time, the default scene's over 33 megapixels about 5.2 s (docs/BENCHMARKS.md, "Every
// light converges, tenth part").
constexpr double kFootprintSPerMegapixel = 0.16;
double finishForecastS(const Renderer& renderer, bool diffraction) {
    const FilmSettings& film = renderer.options().film;
    const double megapixels = static_cast<double>(film.widthPx) * film.heightPx * 1e-6;
    // The main image, the variance, the starburst and every film layer of the frame's size.
    double frameLayers = 2.0 + (diffraction ? 1.0 : 0.0), footprintMegapixels = 0.0;
    const std::vector<std::string>& names = renderer.layerNames();
    for (size_t l = 0; l < names.size(); ++l) {
        if (names[l].starts_with("ghost_") || names[l] == kOtherGhostsLayer)
            footprintMegapixels += static_cast<double>(renderer.film().layerTilePixels(static_cast<int>(l))) * 1e-6;
        else
            frameLayers += 1.0;
    }
    return megapixels * (frameLayers * kFinishSPerMegapixelLayer + (diffraction ? kStarburstSPerMegapixel : 0.0)) +
           footprintMegapixels * kFootprintSPerMegapixel;
}

int run(const RenderCommandOptions& o) {
    // --time is wall time from here: loading, the analysis and the passes.
    const auto start = std::chrono::steady_clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
    std::unique_ptr<tbb::global_control> threads;
    if (o.threads > 0)
        threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, o.threads);

    // Every output is checked before any work (a long render must not fail at its end) and they
    // are written all or nothing, the final checkpoint with them.
    // Under mpirun, every rank traces its share of each pass and rasterises its share of the film's
    // bands, and rank 0 merges the rest, decides when to stop and writes everything
    // (docs/distributed.md); the other ranks print nothing.
    Processes& processes = Processes::world();
    const bool writer = processes.root();
    const bool quiet = o.quiet || !writer;
    OutputFiles outputs;
    if (writer) {
        outputs.add(o.exr, "-o");
        if (o.pngGiven) outputs.add(o.png, "--png");
        if (o.reportGiven) outputs.add(o.report, "--report");
        if (o.checkpointGiven) outputs.add(o.checkpoint, "--checkpoint");
    }
    // Ctrl-C from here on ends the current pass and writes a checkpoint (before the first pass it
    // simply ends the render: there is nothing to save yet).
    gInterrupted.store(false);
    auto previous = std::signal(SIGINT, onInterrupt);
    Scene scene = o.scene.empty() ? defaultScene() : loadScene(o.scene);
    if (o.noDiffraction) scene.render.diffraction = false;
    if (o.noGhostRinging) scene.render.ghostRinging = false;
    const LensSystem lens = buildSceneLens(scene);

    SceneRenderOverrides overrides;
    overrides.mode = o.mode == "naive"     ? RenderOptions::Mode::Naive
                     : o.mode == "photons" ? RenderOptions::Mode::GuidedPhotons
                                           : RenderOptions::Mode::Guided;
    if (o.seed >= 0) overrides.seed = static_cast<std::uint64_t>(o.seed);
    if (o.maxBounces >= -1) overrides.maxBounces = o.maxBounces;
    if (o.beamsPerPass > 0) overrides.beamsPerPass = o.beamsPerPass;
    overrides.beamReplicates = o.beamReplicates;
    if (o.beamProbes >= 0) overrides.beamVarianceProbes = o.beamProbes;
    overrides.perGhostLayers = o.layers.given;
    overrides.ghostLayers = o.layers.selection;
    overrides.higherOrder = o.higherOrder == "on"    ? RenderOptions::HigherOrder::On
                            : o.higherOrder == "off" ? RenderOptions::HigherOrder::Off
                                                     : RenderOptions::HigherOrder::Auto;
    overrides.kernel = o.kernel == "progressive" ? FilmSettings::Kernel::Progressive
                       : o.kernel == "adaptive"  ? FilmSettings::Kernel::Adaptive
                                                 : FilmSettings::Kernel::Fixed;
    overrides.radiusPx = o.radiusPx;
    overrides.smoothNeighbours = o.smoothNeighbours;
    overrides.strayLightSampling = !o.analogStray;
    if (o.scatterSplits > 0) overrides.scatterSplits = o.scatterSplits;
    if (o.interiorAlbedo >= 0.0) overrides.interiorAlbedo = o.interiorAlbedo;
    RenderOptions options = sceneRenderOptions(scene, lens, overrides);
    const RenderStopRule stop = RenderStopRule::make(scene, options, o.photons > 0 ? o.photons : 0, o.timeS, o.targetError,
                                                     o.ghostTargetError);
    // The adaptive pass plan drives down the errors the render stops on.
    options.passPlan = o.passPlan == "fixed" ? RenderOptions::PassPlan::Fixed : RenderOptions::PassPlan::Adaptive;
    options.errorTargets = stop.errorTargets();

    if (!quiet) {
        // The analysis prints nothing of its own and can take seconds: say what is happening.
        std::fprintf(stderr, "render: analysing the ghosts of %zu light(s)...", scene.lights.size());
        std::fflush(stderr);
    }
    Renderer renderer(lens, scene.lights, options);
    if (processes.size() > 1) renderer.setExchange(&processes);
    if (!quiet) std::fprintf(stderr, " %.1f s\n", elapsed());
    // Without --checkpoint, one beside the image while the render runs (none when the image goes
    // to a device or a pipe: no folder to put it in).
    const std::string checkpoint = !writer            ? std::string()
                                   : o.checkpointGiven ? o.checkpoint
                                   : outputs.writesThrough(o.exr) ? std::string()
                                   : o.exr + ".checkpoint";
    std::error_code ec;
    // Every rank resumes from the checkpoint (the others only for where the passes' random
    // numbers go on), so it must be on a file system they all see; whether it exists is rank 0's.
    const bool resume =
        processes.broadcastFromRoot(o.checkpointGiven && std::filesystem::is_regular_file(o.checkpoint, ec) ? 1 : 0) != 0;
    if (resume) {
        renderer.loadCheckpoint(o.checkpoint);
        if (!quiet)
            std::fprintf(stderr, "resumed from %s: %lld photons already traced\n", o.checkpoint.c_str(),
                         static_cast<long long>(renderer.statistics().photons));
    }

    // (The ranks trace a pass ahead while rank 0 ends the last: none beyond the last pass.)
    if (stop.passesWanted > 0) renderer.setPassLimit(static_cast<int>(std::min<std::int64_t>(stop.passesWanted, std::numeric_limits<int>::max())));

    auto lastCheckpoint = std::chrono::steady_clock::now();
    bool interrupted = false;
    double lastPrintS = -1.0, passS = 0.0;
    // Rank 0 decides, for every rank, whether to run another pass (its film holds the error
    // estimate; its clock and Ctrl-C count).
    enum Next { kPass = 0, kStop = 1, kInterruptedBeforeFirstPass = 2 };
    for (;;) {
        // A pass that would end past --time, with the work after the passes, is not started (each
        // pass costs about what the last did).
        int next = kPass;
        if (writer) {
            // (The ghosts' layers grow as their ghosts reach more tiles: forecast again each time.)
            const double finishS = finishForecastS(renderer, scene.render.diffraction);
            if (stop.reached(renderer, elapsed() + passS + finishS)) next = kStop;
            else if (gInterrupted.load() && renderer.statistics().passes == 0) next = kInterruptedBeforeFirstPass;
        }
        next = processes.broadcastFromRoot(next);
        if (next == kStop) break;
        if (next == kInterruptedBeforeFirstPass) {
            std::signal(SIGINT, previous);
            if (writer) std::fprintf(stderr, "interrupted before the first pass: nothing written\n");
            return 130;
        }
        const double passStartS = elapsed();
        renderer.runPass();
        passS = elapsed() - passStartS;
        // The progress line (whose error estimate scans the film) at most four times a second.
        if (!quiet && elapsed() - lastPrintS >= 0.25) {
            printProgress(renderer, stop.progress(renderer, elapsed()), o.targetError, elapsed());
            lastPrintS = elapsed();
        }
        if (processes.broadcastFromRoot(gInterrupted.load() ? 1 : 0) != 0) {
            interrupted = true;
            break;
        }
        if (!checkpoint.empty() &&
            std::chrono::duration<double>(std::chrono::steady_clock::now() - lastCheckpoint).count() >= o.checkpointIntervalS) {
            renderer.saveCheckpoint(checkpoint);
            lastCheckpoint = std::chrono::steady_clock::now();
        }
    }
    std::signal(SIGINT, previous);
    // The other ranks' work is in rank 0's film now: rank 0 alone writes.
    if (!writer) return interrupted ? 130 : 0;
    if (!o.quiet && renderer.statistics().passes > 0)
        printProgress(renderer, stop.progress(renderer, elapsed()), o.targetError, elapsed());
    if (!o.quiet) std::fprintf(stderr, "\n");
    if (interrupted && checkpoint.empty()) {
        std::fprintf(stderr, "interrupted: nothing written (-o is not a regular file; --checkpoint keeps the work)\n");
        return 130;
    }
    if (interrupted) {
        renderer.saveCheckpoint(checkpoint);
        std::fprintf(stderr, "interrupted: checkpoint written to %s (resume with --checkpoint %s)\n", checkpoint.c_str(),
                     checkpoint.c_str());
        return 130;
    }

    // The light's own image, diffracted: in the main image in place of the direct layer.
    std::optional<StarburstImage> starburst;
    if (!o.quiet)
        std::fprintf(stderr, "render: %s (forecast %.1f s)...\n",
                     scene.render.diffraction ? "diffraction and writing" : "writing",
                     finishForecastS(renderer, scene.render.diffraction));
    if (scene.render.diffraction)
        starburst = sceneStarburst(scene, lens, renderer.layerXyz(kLayerDirect), options.film.widthPx,
                                   options.film.heightPx);
    const std::vector<ImageLayer> layers = renderLayers(renderer, starburst ? &*starburst : nullptr);

    const RenderStatistics& s = renderer.statistics();
    const std::vector<std::pair<std::string, std::string>> metadata = {
        {"software", "flare render"},
        {"colorSpace", "linear Rec.709 (sRGB primaries, D65 white)"},
        {"units", "sensor irradiance, W/m2 per the lights' power units; variance layer in (W/m2)^2"},
        {"scene", scene.sourceFile.empty() ? "embedded default scene" : scene.sourceFile},
        {"lens", lens.name()},
        {"mode", o.mode},
        {"photons", std::to_string(s.photons)},
        {"seed", std::to_string(options.seed)},
    };
    // PIZ by default: a render's layers are grainy, where it beats ZIP in size and time (ImageIO.h).
    // Each per-ghost layer is a part of its own, over its footprint.
    ExrWriteOptions exrOptions{.storage = {}, .compression = o.compression, .ownParts = {}, .chromaticities = {}};
    for (const ImageLayer& layer : layers)
        if (layer.name.starts_with("ghost_")) exrOptions.ownParts.insert(layer.name);
    writeExr(outputs, o.exr, layers, metadata, exrOptions);
    if (o.pngGiven) {
        const ImageLayer& ghost = layers[1 + kLayerGhost];
        writePng(outputs, o.png, layers.front(), pngExposure(o.exposureStops, ghost, "render", o.quiet));
    }
    if (o.reportGiven) {
        const nlohmann::json report =
            sceneRenderReportJson(renderer, scene, lens, o.targetError, starburst ? &*starburst : nullptr);
        outputs.write(o.report, jsonText(report) + "\n");
    }
    if (o.checkpointGiven) renderer.saveCheckpoint(outputs, o.checkpoint);
    outputs.commit();
    if (!o.checkpointGiven && !checkpoint.empty()) std::filesystem::remove(checkpoint, ec);

    if (!o.quiet) {
        std::fprintf(stderr,
                     "render: %s, %s mode, %d passes (%lld photons, %lld beams) in %.2f s, estimated error of the flare "
                     "%.2g%%\n",
                     lens.name().c_str(), o.mode.c_str(), s.passes, static_cast<long long>(s.photons),
                     static_cast<long long>(s.beams), s.seconds, 100.0 * renderer.estimatedRelativeError(kGroupFlare));
        if (processes.size() > 1) {
            const ExchangeCosts& c = renderer.exchangeCosts();
            const double perPass = c.passes > 0 ? 1.0 / c.passes : 0.0;
            std::fprintf(stderr,
                         "  %d ranks, per pass (wall s / CPU s): rank 0 traced %.0f%% of the jobs in %.3g / %.3g, each "
                         "other rank traced and encoded its share in %.3g / %.3g; rank 0 received %.3g MB, waited at "
                         "the exchange %.3g, decoded the others' jobs, rasterised %.0f%% of the bands, splatted every hit "
                         "and ended its bands' pass in %.3g / %.3g (%.3g besides its bands), each other rank decoded, rasterised and encoded its bands in %.3g / %.3g; rank 0 added their bands and "
                         "ended the pass in %.3g / %.3g, after waiting %.3g for their bands\n",
                         processes.size(), 100.0 * c.rootShare * perPass, c.traceS * perPass, c.traceCpuS * perPass,
                         c.othersTraceS * perPass, c.othersTraceCpuS * perPass, c.bytesReceived * perPass / 1e6,
                         c.gatherS * perPass, 100.0 * c.rootBands * perPass, c.bandsS * perPass,
                         c.bandsCpuS * perPass, c.besidesBandsS * perPass, c.othersBandsS * perPass, c.othersBandsCpuS * perPass, c.mergeS * perPass, c.mergeCpuS * perPass, c.bandsWaitS * perPass);
        }
        for (const LightPlan& l : renderer.lights())
            if (l.skipped) std::fprintf(stderr, "  skipped light %s: %s\n", l.name.c_str(), l.skipReason.c_str());
        if (starburst) printStarburst(*starburst);
    }
    std::printf("wrote %s%s%s%s%s\n", o.exr.c_str(), o.pngGiven ? " and " : "", o.png.c_str(),
                o.reportGiven ? " and " : "", o.report.c_str());
    return 0;
}

}  // namespace

void addRenderCommand(CLI::App& app) {
    auto o = std::make_shared<RenderCommandOptions>();
    CLI::App* render = app.add_subcommand("render", "physically based render by photon tracing (EXR with layers)");
    render->add_option("SCENE", o->scene, "scene file (JSON); default: the embedded default scene");
    render->add_option("-o,--output", o->exr, "EXR file to write")->required();
    render->add_option("--mode", o->mode,
                       "guided (default: beams and photons), photons (guided photons only) or naive (the unguided "
                       "tracer alone)")
        ->check(CLI::IsMember({"naive", "guided", "photons"}));
    render->add_option("--photons", o->photons, "stop after this many photons at the latest")->check(CLI::PositiveNumber);
    render->add_option("--time", o->timeS, "stop after this many seconds at the latest")->check(CLI::PositiveNumber);
    render->add_option("--target-error", o->targetError,
                       "stop when the estimated relative L2 error of the flare without the direct image (ghost + higher "
                       "+ scatter) falls below this (default 0.02; 0: none); --time, --photons or else the scene's "
                       "photon count limit the render")
        ->check(CLI::Range(0.0, 1.0));
    render->add_option("--ghost-target-error", o->ghostTargetError,
                       "also wait for the ghost layer's estimated relative L2 error to fall below this (default 0: "
                       "no target of its own)")
        ->check(CLI::Range(0.0, 1.0));
    render->add_option("--pass-plan", o->passPlan,
                       "adaptive (default: each pass's beams and photons chosen from the passes before, at the same "
                       "cost, so that the targeted errors fall fastest) or fixed (every pass the same)")
        ->check(CLI::IsMember({"adaptive", "fixed"}));
    render->add_option("--max-bounces", o->maxBounces, "stop photons after K reflections (-1: unbounded)")
        ->check(CLI::Range(-1, 1000));
    render->add_option("--beams-per-pass", o->beamsPerPass,
                       "beams per pass and directional light (default: the scene's render.beams_per_pass, 1024)")
        ->check(CLI::Range(16, 65536));
    render->add_option("--beam-replicates", o->beamReplicates,
                       "independent replicates of the beams' Sobol' sequences, whose spread gives the error estimate "
                       "(default 2): more give steadier estimates and per-ghost standard errors, fewer a cleaner image")
        ->check(CLI::Range(2, kMaxReplicates));
    render->add_option("--beam-probes", o->beamProbes,
                       "probe beams per ghost path at independent samples, whose spread predicts its variance per "
                       "beam: the beams of all lights are shared by it (default 4; 0: each light's own beams shared "
                       "by one central probe's image, as before)")
        ->check(CLI::Range(0, 64))
        ->check([](const std::string& value) {
            return value == "1" ? std::string("one probe has no spread: 0, or 2 to 64") : std::string();
        });
    render->add_option("--seed", o->seed, "random seed (default: the scene's)")->check(CLI::NonNegativeNumber);
    render->add_option("--threads", o->threads, "worker threads (default: all cores)")->check(CLI::PositiveNumber);
    addLayersOption(render, o->layers,
                    "add one layer per kept ghost (ghost_03_07.R/G/B) and per scatter source the scene has "
                    "(scatter_housing, scatter_dust, scatter_grease, scatter_bulk)");
    render->add_flag("--no-ghost-ringing", o->noGhostRinging,
                     "leave the ghosts' rims geometric: no Fresnel ripples (as the scene's render.ghost_ringing: false)");
    render->add_flag("--no-diffraction", o->noDiffraction,
                     "leave the light's own image geometric: no starburst layer (as the scene's render.diffraction: false)");
    render->add_flag("--analog-stray", o->analogStray,
                     "trace the unguided photons' stray light analog (absorption by roulette, no connections to the "
                     "sensor), as the naive mode does: slower to converge, for comparison");
    render->add_option("--scatter-splits", o->scatterSplits,
                       "split each weighted bounce off the lens's interior (barrel, edges, rings, iris) into K directions "
                       "of 1/K the weight (default " + std::to_string(kDefaultScatterSplits) + "; 1: no splitting)")
        ->check(CLI::Range(1, kMaxStrayBranches + 1));
    render->add_option("--png", o->png, "also write a tone-mapped PNG");
    addCompressionOption(render, o->compression);
    addExposureOption(render, o->exposureStops);
    render->add_option("--report", o->report, "write a JSON report (per-ghost power with standard errors, layers, energy)");
    render->add_option("--checkpoint", o->checkpoint,
                       "checkpoint file: resumed from if it exists, written periodically, on Ctrl-C and at the end");
    render->add_option("--checkpoint-interval", o->checkpointIntervalS, "seconds between checkpoints (default 60)")
        ->check(CLI::PositiveNumber);
    render->add_option("--higher-order", o->higherOrder,
                       "guide the strongest order-4 chains too: auto (default: when the lens's reflectances make "
                       "them matter), on or off")
        ->check(CLI::IsMember({"auto", "on", "off"}));
    render->add_option("--kernel", o->kernel, "density estimation: fixed (default), progressive or adaptive")
        ->check(CLI::IsMember({"fixed", "progressive", "adaptive"}));
    render->add_option("--radius", o->radiusPx, "kernel radius in pixels (fixed; first pass for progressive)")
        ->check(CLI::PositiveNumber);
    render->add_option("--smooth-neighbours", o->smoothNeighbours,
                       "the scatter layer's and the higher layer's photons are splatted by an adaptive kernel holding "
                       "about this many times the photon's power of the earlier ones, growing as passes^(2/3) "
                       "(default 256; 0: the film's kernel; only with --kernel fixed)")
        ->check(CLI::Range(0, 1000000));
    render->add_option("--interior-albedo", o->interiorAlbedo,
                       "diffuse albedo of the barrel, element edges and iris blades, overriding the scene's finishes")
        ->check(CLI::Range(0.0, 1.0));
    render->add_flag("--quiet", o->quiet, "no progress or statistics on stderr");
    render->callback([o, render] {
        o->pngGiven = render->count("--png") > 0;
        o->reportGiven = render->count("--report") > 0;
        o->checkpointGiven = render->count("--checkpoint") > 0;
        resolveLayersOption(render, o->layers, o->scene);
        const int code = runOnEveryRank("render", [&] { return run(*o); });
        if (code != 0) throw CLI::RuntimeError(code);
    });
}

}  // namespace flare::cli
