#include "flare/scene/ScenePreview.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>
#include <numbers>

#include <glm/geometric.hpp>
#include <tbb/parallel_invoke.h>
#include <tbb/task_group.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "flare/core/Spectrum.h"
#include "flare/ghosts/GhostAnalysis.h"
#include "flare/render/Render.h"
#include "flare/scene/SceneBeamShare.h"
#include "flare/scene/SceneRender.h"
#include "flare/scene/SceneStarburst.h"

namespace flare {

namespace {

// The film's tiles are small allocations, whose memory the allocator keeps for later small ones when
// they are freed; the footprints taken in their place are large ones, mapped afresh. Without
// handing the freed tiles back to the system, the preview would hold both (glibc's malloc_trim;
// elsewhere the memory is reused as the allocator sees fit).
constexpr size_t kTrimBytes = size_t{64} << 20;
void returnFreedMemory() {
#if defined(__GLIBC__)
    malloc_trim(0);
#endif
}

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
        // A region light's points: a disk of its extent about its centre (the preview's direct image
        // is a mesh of one direction; `flare composite` takes the real one from the plate).
        light.angularDiameterDeg = spec.isRegion() ? 2.0 * spec.apparentRadiusRad() * 180.0 / std::numbers::pi
                                                   : spec.angularDiameterDeg;
    } else {
        const double distanceM = glm::length(spec.positionMm) * 1e-3;
        light.irradiance = spec.power / (distanceM * distanceM);
        light.angularDiameterDeg = 2.0 * std::atan(spec.radiusMm / glm::length(spec.positionMm)) * 180.0 / std::numbers::pi;
    }
    return light;
}

ScenePreview previewScene(const Scene& scene, const LensSystem& lens, bool perGhostLayers, const PreviewBudget& budget) {
    const auto start = std::chrono::steady_clock::now();
    auto elapsedS = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
    // The final render's plan and beams, as `flare render` makes them with the same seed.
    SceneRenderOverrides overrides;
    overrides.perGhostLayers = perGhostLayers;
    overrides.ghostLayers = budget.ghostLayers;
    if (budget.seed) overrides.seed = *budget.seed;
    RenderOptions options = sceneRenderOptions(scene, lens, overrides);
    options.tracePhotons = false;
    options.ghostGroupsOnly = true;  // (the preview reads the layers and the ghost group's estimate)
    // Each light's beams shared by its paths' central probes: the render's probes by sampled beams
    // (BeamVariance.h) cost about half the preview's second again on the default scene.
    options.beamVarianceProbes = 0;
    options.beamsPerPass = budget.beamsPerPass > 0 ? budget.beamsPerPass : std::max(16, options.beamsPerPass / 2);
    if (scene.render.beamsByPower) options.lightBeamsPerPass = lightBeamsByPower(scene.lights, options.beamsPerPass);
    Renderer renderer(lens, scene.lights, options);

    // Each light's own image (the mesh preview of its direct path alone) and its diffraction need
    // only the analysis: they are computed beside the beams' passes, not after them. Two cores then
    // stay busy through the passes' serial stretches (the merge's last bands, the film's end of
    // pass) and the mesh preview's serial part, which otherwise delayed the writing. Each is
    // deterministic on its own, so the image is the same bits whatever runs beside it.
    std::vector<GhostReport> directReports;
    for (size_t l = 0; budget.direct && l < scene.lights.size(); ++l) {
        directReports.push_back(renderer.ghostReport(static_cast<int>(l)));
        for (GhostEstimate& g : directReports.back().ghosts) g.pruned = true;
    }
    std::vector<float> directXyz;
    std::optional<StarburstImage> starburst;
    tbb::task_group beside;
    beside.run([&] {
        if (!budget.direct) {  // the caller has the lights' own image (flare composite: the plate)
            directXyz.assign(3 * static_cast<size_t>(options.film.widthPx) * options.film.heightPx, 0.0f);
            return;
        }
        PreviewOptions direct;
        direct.widthPx = options.film.widthPx;
        direct.heightPx = options.film.heightPx;
        for (size_t l = 0; l < scene.lights.size(); ++l) {
            const PreviewImage image =
                renderPreview(lens, previewLight(scene.lights[l], scene.render.previewWavelengths), directReports[l], direct);
            add(directXyz, image.direct.xyz);
        }
        if (scene.render.diffraction)
            starburst = sceneStarburst(scene, lens, directXyz, options.film.widthPx, options.film.heightPx);
    });
    // The passes (their own exceptions are rethrown after the side work has stopped: it reads the
    // lens and the scene, which outlive neither).
    const int replicates = std::max(1, renderer.film().replicates());
    double passS = 0.0;
    // With a target error: the passes to reach before the error is estimated again.
    int until = std::max(budget.passes, 1);
    try {
        for (int pass = 0;; ++pass) {
            if (budget.timeS > 0.0) {
                // Whole passes that end within the budget, and one per replicate at least (the
                // error estimate); each pass costs about what the last one did.
                if (pass >= replicates && elapsedS() + passS > budget.timeS) break;
            } else if (pass >= until) {
                if (!(budget.targetError > 0.0) || pass % replicates != 0 || pass >= budget.maxPasses) break;
                // Continue from here (the passes made are kept): the error falls at least as one
                // over the square root of the passes, so the forecast is pass·(error/target)²,
                // a little more (a forecast just short costs a whole extra round), in whole rounds.
                const double error = renderer.hasErrorEstimate() ? renderer.estimatedRelativeError(kGroupGhost) : 0.0;
                if (error <= budget.targetError) break;
                const double ratio = error / budget.targetError;
                double forecast = std::min<double>(budget.maxPasses, std::ceil(pass * ratio * ratio * 1.1));
                // A forecast more than twice the passes made is made again halfway there: the
                // first passes' estimate (two replicates) is itself noisy, and the passes met a
                // 5 % target at 3.7 % when forecast in one step (docs/BENCHMARKS.md).
                if (forecast > 2.0 * pass) forecast = pass + std::ceil(0.5 * (forecast - pass));
                const int rounds = static_cast<int>(std::ceil(forecast / replicates));
                until = std::min(budget.maxPasses, std::max(pass + replicates, rounds * replicates));
            }
            const double before = elapsedS();
            renderer.runPass();
            passS = elapsedS() - before;
        }
    } catch (...) {
        beside.wait();
        throw;
    }

    ScenePreview result;
    result.widthPx = options.film.widthPx;
    result.heightPx = options.film.heightPx;
    // The layers read out (one thread: Film::irradianceXyz) beside the error estimate (its own
    // parallel loop); both only read the film.
    tbb::parallel_invoke(
        [&] {
            result.ghosts = renderer.layerXyz(kLayerGhost);
            if (budget.higher) result.higher = renderer.layerXyz(kLayerHigher);
        },
        [&] {
            result.ghostEstimatedError =
                renderer.hasErrorEstimate() ? renderer.estimatedRelativeError(kGroupGhost) : 0.0;
        });
    result.passes = renderer.statistics().passes;
    result.beams = renderer.statistics().beams;
    if (perGhostLayers) {
        // The kept ghosts' own layers (the order-4 chains' only with `higher`).
        std::set<std::string> chains;
        for (const PathTally& t : renderer.tallies())
            if (t.kind == PathTally::Kind::Ghost && t.path.reflections.size() > 2) chains.insert(t.path.label());
        // Each taken over its footprint and freed in turn: one copy of each at a time.
        const std::vector<std::string>& names = renderer.layerNames();
        size_t freedBytes = 0;
        for (int l = kFixedLayerCount; l < static_cast<int>(names.size()); ++l) {
            if (!names[l].starts_with("ghost_") || (!budget.higher && chains.contains(names[l]))) continue;
            freedBytes += renderer.film().layerBytes(l);
            FilmWindow footprint = renderer.takeLayerXyzFootprint(l);
            if (!footprint.empty()) result.perGhost[names[l]] = std::move(footprint);
            if (freedBytes > kTrimBytes) {
                returnFreedMemory();
                freedBytes = 0;
            }
        }
    }
    for (const LightPlan& plan : renderer.lights()) {
        result.renderedGhosts += plan.beamGhosts;
        result.prunedGhosts += plan.prunedGhosts;
    }
    // The direct image and the starburst, when they are done.
    beside.wait();
    result.direct = std::move(directXyz);
    result.starburst = std::move(starburst);
    result.tracedRays = renderer.statistics().beamRays;
    result.leftOut = "scattering, the ghosts' parts the final render leaves to photons (pruned ghosts, rays outside the "
                     "guide masks)";
    if (!budget.higher) result.leftOut += ", the order-4 chains (`higher`)";
    return result;
}

std::vector<ImageLayer> previewLayers(ScenePreview& preview, bool withLayers) {
    std::vector<float> total = preview.starburst ? preview.starburst->xyz : preview.direct;
    add(total, preview.ghosts);
    if (!preview.higher.empty()) add(total, preview.higher);
    const int w = preview.widthPx, h = preview.heightPx;
    std::vector<ImageLayer> layers{rgbLayerFromXyz("", total, w, h)};
    if (withLayers) {
        layers.push_back(rgbLayerFromXyz("direct", preview.direct, w, h));
        if (preview.starburst) layers.push_back(rgbLayerFromXyz("starburst", preview.starburst->xyz, w, h));
        layers.push_back(rgbLayerFromXyz("ghost", preview.ghosts, w, h));
        if (!preview.higher.empty()) layers.push_back(rgbLayerFromXyz("higher", preview.higher, w, h));
        // By label, the layer of the ghosts left out last.
        for (int other = 0; other < 2; ++other)
            for (auto& [name, window] : preview.perGhost) {
                if ((name == kOtherGhostsLayer) != (other == 1)) continue;
                layers.push_back(rgbLayerFromXyz(name, std::move(window.xyz), window.width, window.height, window.x, window.y));
            }
    }
    return layers;
}

}  // namespace flare
