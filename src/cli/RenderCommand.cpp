#include "RenderCommand.h"

#include <atomic>
#include <chrono>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "LayersOption.h"
#include "Output.h"
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
    std::string mode = "guided";
    std::string kernel = "fixed";
    std::string higherOrder = "auto";
    double radiusPx = 1.0;
    int smoothNeighbours = 256;
    long long photons = -1;  // −1: the scene's
    double timeS = 0.0;
    double targetError = 0.02;  // 0: none
    int maxBounces = -2;     // −2: the scene's
    int beamsPerPass = 0;    // 0: the scene's
    int beamReplicates = 2;
    long long seed = -1;     // −1: the scene's
    int threads = 0;
    double checkpointIntervalS = 60.0;
    double interiorAlbedo = -1.0;  // < 0: the scene's finishes
    LayersOption layers;
    bool noDiffraction = false;
    bool analogStray = false;
    bool quiet = false;
    bool pngGiven = false, reportGiven = false, checkpointGiven = false;  // given, even as ""
};

std::atomic<bool> gInterrupted{false};
extern "C" void onInterrupt(int) { gInterrupted.store(true); }

const char* kindName(PathTally::Kind kind) {
    switch (kind) {
        case PathTally::Kind::Direct: return "direct";
        case PathTally::Kind::Ghost: return "ghost";
        case PathTally::Kind::Higher: return "higher";
        case PathTally::Kind::Scatter: return "scatter";
    }
    return "?";
}

nlohmann::json reportJson(const Renderer& renderer, const Scene& scene, const LensSystem& lens, const RenderCommandOptions& o) {
    const RenderStatistics& s = renderer.statistics();
    nlohmann::json j;
    j["scene"] = scene.sourceFile.empty() ? "embedded default scene" : scene.sourceFile;
    j["lens"] = lens.name();
    j["mode"] = o.mode;
    j["seed"] = renderer.options().seed;
    j["photons"] = s.photons;
    j["guided_photons"] = s.guidedPhotons;
    j["unguided_photons"] = s.unguidedPhotons;
    j["passes"] = s.passes;
    j["wall_time_s"] = s.seconds;
    j["photons_per_second"] = s.seconds > 0.0 ? s.photons / s.seconds : 0.0;
    j["units"] = "power in W for the lights' power units; irradiance layers in W/m2";

    nlohmann::json lights = nlohmann::json::array();
    nlohmann::json skipped = nlohmann::json::array();
    for (const LightPlan& l : renderer.lights()) {
        lights.push_back({{"name", l.name}, {"entering_power_w", l.enteringPowerW}, {"kept_ghosts", l.keptGhosts},
                          {"beam_ghosts", l.beamGhosts}, {"pruned_ghosts", l.prunedGhosts},
                          {"spectrally_kept_ghosts", l.spectrallyKeptGhosts}, {"skipped", l.skipped},
                          {"higher_order",
                           {{"share_estimate", l.higherOrderShareEstimate},
                            {"guided", l.higherOrderGuided},
                            {"chains", l.higherOrderChains},
                            {"analysed", l.higherOrderAnalysed},
                            {"paths", l.higherOrderPaths},
                            {"why", l.higherOrderWhy}}}});
        if (l.skipped) skipped.push_back({{"light", l.name}, {"reason", l.skipReason}});
    }
    j["lights"] = lights;
    j["skipped"] = skipped;

    // Per layer: the power with its standard error, the estimated relative L2 error of the image
    // (as `flare compare` measures it against a reference), and the largest share of the layer's
    // power one photon carried (a firefly shows as a share far above 1 / photons).
    nlohmann::json layers;
    // No estimate yet (fewer than two passes, or a replicate without a pass): null, not 0.
    auto estimate = [&](int group) -> nlohmann::json {
        return renderer.hasErrorEstimate() ? nlohmann::json(renderer.estimatedRelativeError(group)) : nlohmann::json();
    };
    const double drawn = static_cast<double>(s.passes) * renderer.options().photonsPerPass();
    for (int l = 0; l < kFixedLayerCount; ++l) {
        const PathTally& t = renderer.layerTallies()[l];
        const double power = renderer.tallyPowerW(t);
        layers[kindName(t.kind)] = {
            {"power_w", power},
            {"standard_error_w", renderer.tallyStandardErrorW(t)},
            {"estimated_relative_error", estimate(kGroupDirect + l)},
            {"largest_photon_share", power > 0.0 && drawn > 0.0 ? s.largestPhotonY[l] / (drawn * power) : 0.0}};
    }
    j["layers"] = layers;
    j["flare_estimated_relative_error"] = estimate(kGroupFlare);
    j["target_error"] = o.targetError;
    j["beams"] = {{"beams", s.beams},
                  {"traced_rays", s.beamRays},
                  {"correction_photons", s.correctionPhotons},
                  {"replicates", renderer.film().replicates()}};
    nlohmann::json sources;
    for (size_t i = 0; i < renderer.scatterSourceTallies().size(); ++i) {
        const PathTally& t = renderer.scatterSourceTallies()[i];
        sources[toString(static_cast<ScatterSource>(i + 1))] = {{"power_w", renderer.tallyPowerW(t)},
                                                                {"standard_error_w", renderer.tallyStandardErrorW(t)}};
    }
    j["scatter_sources"] = sources;
    const double collisions = static_cast<double>(s.nullCollisions + s.realCollisions);
    j["delta_tracking"] = {{"real_collisions", s.realCollisions},
                           {"null_collisions", s.nullCollisions},
                           {"null_collision_ratio", collisions > 0.0 ? s.nullCollisions / collisions : 0.0}};

    std::vector<const PathTally*> ghosts;
    for (const PathTally& t : renderer.tallies())
        if (t.kind == PathTally::Kind::Ghost && (t.sumMeans != 0.0 || t.guided))
            ghosts.push_back(&t);
    std::stable_sort(ghosts.begin(), ghosts.end(), [&](const PathTally* a, const PathTally* b) {
        return renderer.tallyPowerW(*a) > renderer.tallyPowerW(*b);
    });
    nlohmann::json ghostArray = nlohmann::json::array();
    for (const PathTally* t : ghosts) {
        const double entering = renderer.lights()[t->light].enteringPowerW;
        const double power = renderer.tallyPowerW(*t);
        ghostArray.push_back({{"light", renderer.lights()[t->light].name},
                              {"label", t->path.label()},
                              {"surfaces", t->path.surfaceNumbers()},
                              {"power_w", power},
                              {"standard_error_w", renderer.tallyStandardErrorW(*t)},
                              {"power_fraction", entering > 0.0 ? power / entering : 0.0},
                              {"analysed_power_fraction", t->analysedPowerFraction},
                              {"guided", t->guided},
                              {"strategy", toString(t->strategy)}});
    }
    j["ghosts"] = ghostArray;

    // Photon weights are powers per photon drawn: their sum over all photons (both strategies)
    // divided by the photon count estimates a power.
    const double perPhoton = s.photons > 0 ? 1.0 / static_cast<double>(s.photons) : 0.0;
    nlohmann::json fates;
    for (int f = 0; f < static_cast<int>(PhotonFate::Count); ++f)
        fates[toString(static_cast<PhotonFate>(f))] = {{"photons", s.fates[f].photons},
                                                       {"power_w", s.fates[f].powerW * perPhoton}};
    j["unguided_energy"] = {{"emitted_power_w", s.unguidedEmittedPowerW * perPhoton},
                            {"entered_power_w", s.unguidedEnteredPowerW * perPhoton},
                            {"fates", fates}};
    return j;
}

// The share of the work done, whichever limit comes first: the photon count, the time, or the
// target error (whose square falls as one over the passes for photons, faster for beams: the time
// left is then an upper bound).
double progressFraction(const Renderer& renderer, std::int64_t photonLimit, double timeLimitS, double targetError,
                        double elapsedS) {
    const RenderStatistics& s = renderer.statistics();
    double fraction = photonLimit > 0 ? static_cast<double>(s.photons) / photonLimit : 0.0;
    if (timeLimitS > 0.0) fraction = std::max(fraction, elapsedS / timeLimitS);
    const double error = renderer.estimatedRelativeError(kGroupFlare);
    if (targetError > 0.0 && error > 0.0 && renderer.hasErrorEstimate())
        fraction = std::max(fraction, std::min(1.0, (targetError * targetError) / (error * error)) *
                                          std::min(1.0, s.passes / static_cast<double>(kMinPassesToStop)));
    return std::min(fraction, 1.0);
}

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

int run(const RenderCommandOptions& o) {
    // --time is wall time from here: loading, the analysis and the passes.
    const auto start = std::chrono::steady_clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
    std::unique_ptr<tbb::global_control> threads;
    if (o.threads > 0)
        threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, o.threads);

    // Every output is checked before any work (a long render must not fail at its end) and they
    // are written all or nothing, the final checkpoint with them.
    OutputFiles outputs;
    outputs.add(o.exr, "-o");
    if (o.pngGiven) outputs.add(o.png, "--png");
    if (o.reportGiven) outputs.add(o.report, "--report");
    if (o.checkpointGiven) outputs.add(o.checkpoint, "--checkpoint");
    // Ctrl-C from here on ends the current pass and writes a checkpoint (before the first pass it
    // simply ends the render: there is nothing to save yet).
    gInterrupted.store(false);
    auto previous = std::signal(SIGINT, onInterrupt);
    Scene scene = o.scene.empty() ? defaultScene() : loadScene(o.scene);
    if (o.noDiffraction) scene.render.diffraction = false;
    const LensSystem lens = buildSceneLens(scene);

    SceneRenderOverrides overrides;
    overrides.mode = o.mode == "naive"     ? RenderOptions::Mode::Naive
                     : o.mode == "photons" ? RenderOptions::Mode::GuidedPhotons
                                           : RenderOptions::Mode::Guided;
    if (o.seed >= 0) overrides.seed = static_cast<std::uint64_t>(o.seed);
    if (o.maxBounces >= -1) overrides.maxBounces = o.maxBounces;
    if (o.beamsPerPass > 0) overrides.beamsPerPass = o.beamsPerPass;
    overrides.beamReplicates = o.beamReplicates;
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
    if (o.interiorAlbedo >= 0.0) overrides.interiorAlbedo = o.interiorAlbedo;
    const RenderOptions options = sceneRenderOptions(scene, lens, overrides);

    if (!o.quiet) {
        // The analysis prints nothing of its own and can take seconds: say what is happening.
        std::fprintf(stderr, "render: analysing the ghosts of %zu light(s)...", scene.lights.size());
        std::fflush(stderr);
    }
    Renderer renderer(lens, scene.lights, options);
    if (!o.quiet) std::fprintf(stderr, " %.1f s\n", elapsed());
    // Without --checkpoint, one beside the image while the render runs (none when the image goes
    // to a device or a pipe: no folder to put it in).
    const std::string checkpoint = o.checkpointGiven ? o.checkpoint
                                   : outputs.writesThrough(o.exr) ? std::string()
                                   : o.exr + ".checkpoint";
    std::error_code ec;
    if (o.checkpointGiven && std::filesystem::is_regular_file(o.checkpoint, ec)) {
        renderer.loadCheckpoint(o.checkpoint);
        if (!o.quiet)
            std::fprintf(stderr, "resumed from %s: %lld photons already traced\n", o.checkpoint.c_str(),
                         static_cast<long long>(renderer.statistics().photons));
    }

    const RenderStopRule stop = RenderStopRule::make(scene, options, o.photons > 0 ? o.photons : 0, o.timeS, o.targetError);
    const std::int64_t perPass = options.photonsPerPass();

    auto lastCheckpoint = std::chrono::steady_clock::now();
    bool interrupted = false;
    double lastPrintS = -1.0, passS = 0.0;
    for (;;) {
        // A pass that would end past --time is not started (each costs about what the last did).
        if (stop.reached(renderer, elapsed() + passS)) break;
        if (gInterrupted.load() && renderer.statistics().passes == 0) {
            std::signal(SIGINT, previous);
            std::fprintf(stderr, "interrupted before the first pass: nothing written\n");
            return 130;
        }
        const double passStartS = elapsed();
        renderer.runPass();
        passS = elapsed() - passStartS;
        // The progress line (whose error estimate scans the film) at most four times a second.
        if (!o.quiet && elapsed() - lastPrintS >= 0.25) {
            printProgress(renderer, progressFraction(renderer, stop.passesWanted * perPass, o.timeS, o.targetError, elapsed()),
                          o.targetError, elapsed());
            lastPrintS = elapsed();
        }
        if (gInterrupted.load()) {
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
    if (!o.quiet && renderer.statistics().passes > 0)
        printProgress(renderer, progressFraction(renderer, stop.passesWanted * perPass, o.timeS, o.targetError, elapsed()),
                      o.targetError, elapsed());
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
    if (!o.quiet) std::fprintf(stderr, "render: %s...\n", scene.render.diffraction ? "diffraction and writing" : "writing");
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
    // PIZ: a render's layers are grainy, where it beats ZIP in size and time (ImageIO.h). Each
    // per-ghost layer is a part of its own, over its footprint.
    ExrWriteOptions exrOptions{.storage = {}, .compression = ExrCompression::Piz, .ownParts = {}};
    for (const ImageLayer& layer : layers)
        if (layer.name.starts_with("ghost_")) exrOptions.ownParts.insert(layer.name);
    writeExr(outputs, o.exr, layers, metadata, exrOptions);
    if (o.pngGiven) {
        const ImageLayer& ghost = layers[1 + kLayerGhost];
        writePng(outputs, o.png, layers.front(), 0.25 * autoExposure(ghost));
    }
    if (o.reportGiven) {
        nlohmann::json report = reportJson(renderer, scene, lens, o);
        if (starburst) report["diffraction"] = starburstJson(*starburst);
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
    render->add_option("--max-bounces", o->maxBounces, "stop photons after K reflections (-1: unbounded)")
        ->check(CLI::Range(-1, 1000));
    render->add_option("--beams-per-pass", o->beamsPerPass,
                       "beams per pass and directional light (default: the scene's render.beams_per_pass, 1024)")
        ->check(CLI::Range(16, 65536));
    render->add_option("--beam-replicates", o->beamReplicates,
                       "independent replicates of the beams' Sobol' sequences, whose spread gives the error estimate "
                       "(default 2): more give steadier estimates and per-ghost standard errors, fewer a cleaner image")
        ->check(CLI::Range(2, kMaxReplicates));
    render->add_option("--seed", o->seed, "random seed (default: the scene's)")->check(CLI::NonNegativeNumber);
    render->add_option("--threads", o->threads, "worker threads (default: all cores)")->check(CLI::PositiveNumber);
    addLayersOption(render, o->layers,
                    "add one layer per kept ghost (ghost_03_07.R/G/B) and per scatter source the scene has "
                    "(scatter_housing, scatter_dust, scatter_grease, scatter_bulk)");
    render->add_flag("--no-diffraction", o->noDiffraction,
                     "leave the light's own image geometric: no starburst layer (as the scene's render.diffraction: false)");
    render->add_flag("--analog-stray", o->analogStray,
                     "trace the unguided photons' stray light analog (absorption by roulette, no connections to the "
                     "sensor), as the naive mode does: slower to converge, for comparison");
    render->add_option("--png", o->png, "also write a tone-mapped PNG");
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
        const int code = run(*o);
        if (code != 0) throw CLI::RuntimeError(code);
    });
}

}  // namespace flare::cli
