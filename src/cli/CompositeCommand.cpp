#include "CompositeCommand.h"

#include "LayersOption.h"
#include "Output.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <numbers>
#include <optional>
#include <set>
#include <string>

#include "flare/core/Error.h"
#include "flare/core/OutputFiles.h"
#include "flare/film/ImageIO.h"
#include "flare/optics/LensFile.h"
#include "flare/scene/Plate.h"
#include "flare/scene/PlateDisplay.h"
#include "flare/scene/PlateLights.h"
#include "flare/scene/PlateRegions.h"
#include "flare/scene/PlateSources.h"
#include "flare/scene/Scene.h"
#include "flare/scene/SceneJson.h"
#include "flare/scene/ScenePreview.h"
#include "flare/scene/SceneStarburst.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_group.h>

namespace flare::cli {

namespace {

// Regions whose diffraction PSFs differ by at most this share one (StarburstOptions::
// psfGroupTolerance, PsfGroups.h; docs/composite.md says what it costs in accuracy).
constexpr double kDefaultPsfTolerance = 0.05;
// Regions sharing a PSF whose crops lie within this share of their near windows' half-width of
// their cluster's centroid share one far field (StarburstOptions::clusterFarFields; docs/
// composite.md says what it costs in accuracy).
constexpr double kDefaultFarCluster = 0.5;
// Beams per pass and region light on average, shared by power: on the night plate the estimated
// ghost error of 256 equal beams (12 %) is reached by power with about 160 (docs/BENCHMARKS.md).
constexpr int kDefaultRegionBeams = 160;

struct CompositeOptions {
    std::string plate;
    std::string lens;
    std::string zoom;
    std::optional<double> focusMm, fNumber, sensorWidthMm;
    std::string exr, png, lightsJson, extraLights;
    ExrCompression compression = ExrCompression::Piz;
    std::string colourSpace;
    DisplayView displayView;  // --display, --view: the PNG through an OpenColorIO view
    std::string frames;  // "FIRST-LAST": a sequence
    std::optional<double> threshold;
    int maxLights = 64;
    int cellPx = 16;
    bool cells = false;  // --cell-px given: merge into cells (else region lights)
    double regionDeg = kDefaultRegionRadiusDeg;
    double cullShare = 1e-3;
    double psfTolerance = kDefaultPsfTolerance;
    double farCluster = kDefaultFarCluster;
    LayersOption layers;
    int passes = PreviewBudget::kDefaultPasses;
    int beamsPerPass = 0;  // 0: 160 per region light, 64 per cell (--cell-px gives many more lights)
    double timeS = 0.0;
    double targetError = 0.0;
    long long seed = -1;
    std::optional<double> exposureStops;
    bool noDiffraction = false;
    bool equalBeams = false;  // every light --beams-per-pass (else shared by power)
    bool quiet = false;
    bool pngGiven = false;
};

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// A layer in the plate's space from interleaved XYZ (pixel by pixel: the same bits on any
// number of threads).
ImageLayer plateLayer(const std::string& name, const std::vector<float>& xyz, int w, int h, const PlateColourSpace& space) {
    ImageLayer layer{name, w, h, std::vector<float>(xyz.size())};
    tbb::parallel_for(tbb::blocked_range<size_t>(0, xyz.size() / 3, 1 << 14), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t p = r.begin(); p < r.end(); ++p) {
            const size_t i = 3 * p;
            const glm::dvec3 rgb = space.fromXyz * glm::dvec3(xyz[i], xyz[i + 1], xyz[i + 2]);
            for (int k = 0; k < 3; ++k) layer.rgb[i + k] = static_cast<float>(rgb[k]);
        }
    });
    return layer;
}

void addInto(std::vector<float>& into, const std::vector<float>& from, float sign = 1.0f) {
    if (from.empty()) return;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, into.size(), 1 << 16), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i < r.end(); ++i) into[i] += sign * from[i];
    });
}

// Renders `scene`'s preview with the budget: --passes, --time, or --target-error (the passes
// continue, those made kept, until the ghosts' estimated error is below it).
ScenePreview renderFlare(const Scene& scene, const LensSystem& lens, const CompositeOptions& o, bool perGhost,
                         Clock::time_point start, bool plate) {
    PreviewBudget budget;
    budget.passes = o.passes;
    budget.beamsPerPass = o.beamsPerPass;
    if (o.seed >= 0) budget.seed = static_cast<std::uint64_t>(o.seed);
    budget.ghostLayers = o.layers.selection;
    budget.direct = !plate;  // the plate holds its sources' own image
    if (o.timeS > 0.0) budget.timeS = std::max(1e-3, o.timeS - secondsSince(start));
    budget.targetError = o.targetError;
    return previewScene(scene, lens, perGhost, budget);
}

// A frame's lights as the next frame matches them: where each is on the plate, and its spec.
struct FrameLight {
    glm::dvec2 centroidPx;
    LightSpec spec;
};

// Orders this frame's lights as the previous frame's: each previous light takes the nearest
// unmatched light within `radiusPx` (and its name), at its own index, so that its beams draw the
// same random sequences (the render keys them by the light's index) and a static or slowly moving
// source does not flicker; the unmatched follow, strongest first.
void matchPrevious(std::vector<PlateLight>& lights, const std::vector<FrameLight>& previous, double radiusPx) {
    std::vector<PlateLight> ordered;
    std::vector<bool> taken(lights.size(), false);
    for (const FrameLight& p : previous) {
        int best = -1;
        double bestPx = radiusPx;
        for (size_t i = 0; i < lights.size(); ++i) {
            const double d = glm::length(lights[i].cell.centroidPx - p.centroidPx);
            if (!taken[i] && d <= bestPx) {
                best = static_cast<int>(i);
                bestPx = d;
            }
        }
        if (best < 0) continue;
        taken[static_cast<size_t>(best)] = true;
        ordered.push_back(lights[static_cast<size_t>(best)]);
        ordered.back().spec.name = p.spec.name;
    }
    for (size_t i = 0; i < lights.size(); ++i)
        if (!taken[i]) ordered.push_back(lights[i]);
    // Names stay unique: a new light whose name a matched one took gets a suffix.
    std::set<std::string> names;
    for (PlateLight& l : ordered) {
        while (!names.insert(l.spec.name).second) l.spec.name += "'";
    }
    lights = std::move(ordered);
}

std::vector<FrameLight> runFrame(const CompositeOptions& o, const std::vector<FrameLight>* previous) {
    const Clock::time_point start = Clock::now();
    if (o.plate.empty()) throw InputError("flare composite", 0, "no plate given (flare composite PLATE.exr --lens LENS -o OUT.exr)");
    OutputFiles outputs;
    outputs.add(o.exr, "-o");
    if (o.pngGiven) outputs.add(o.png, "--png");
    if (!o.lightsJson.empty()) outputs.add(o.lightsJson, "--lights-json");

    const Plate plate = readPlate(o.plate, o.colourSpace);
    const int w = plate.width, h = plate.height;

    // The scene: the lens at its state, the plate's frame as the sensor (the lens's sensor width,
    // or --sensor-width-mm, across the plate's width; square pixels).
    Scene scene;
    scene.sourceFile = o.lightsJson.empty() ? o.plate : o.lightsJson;
    scene.description = "lights found in the plate " + o.plate + " by flare composite";
    scene.lens = std::filesystem::exists(o.lens) ? std::filesystem::absolute(o.lens).string() : o.lens;
    scene.lensState = LensState{o.zoom, o.focusMm, o.fNumber};
    const double widthMm = o.sensorWidthMm ? *o.sensorWidthMm : loadLens(scene.lens).sensor.widthMm;
    scene.sensor.widthMm = widthMm;
    scene.sensor.heightMm = widthMm * h / w;
    scene.sensor.widthPx = w;
    scene.sensor.heightPx = h;
    if (o.noDiffraction) scene.render.diffraction = false;
    if (o.seed >= 0) scene.render.seed = static_cast<std::uint64_t>(o.seed);
    // `flare preview` of the written scene draws half its beams_per_pass per pass: the same beams.
    scene.render.beamsPerPass = 2 * o.beamsPerPass;
    // The pass's beams (--beams-per-pass per light on average) shared by the lights' power
    // (SceneBeamShare.h): a dim region's ghosts matter in proportion to its power.
    scene.render.beamsByPower = !o.equalBeams;
    std::vector<LightSpec> extra;
    if (!o.extraLights.empty()) extra = loadScene(o.extraLights).lights;
    // A lens without lights: only the optics, for the field mapping.
    const LensSystem lens = buildSceneLens(scene);
    const PlateFieldMap map(lens, w, h);

    // Sources: region lights of at most --region-deg, grown until at most --max-lights remain;
    // or with --cell-px, cells grown likewise, each merged into one light.
    int cellPx = o.cells ? o.cellPx : 1;
    PlateSources sources = findPlateSources(plate, o.threshold, cellPx);
    const std::string thresholdRule = sources.thresholdRule;
    const long sourcePixels = sources.sourcePixels;
    double regionDeg = o.regionDeg;
    // Where the time goes (wall seconds, printed at the end): the sources and their lights, the
    // ghosts, the starburst, the rest (reading, writing).
    double lightsS = 0.0, ghostsS = 0.0, starburstS = 0.0;
    Clock::time_point phase = Clock::now();
    PlateLightSet found;
    double matchRadiusPx = 0.0;
    if (o.cells) {
        while (static_cast<int>(sources.cells.size()) > o.maxLights && cellPx < std::max(w, h)) {
            cellPx *= 2;
            sources = findPlateSources(plate, sources.threshold, cellPx);
        }
        found = plateLights(lens, map, sources, o.cullShare);
        matchRadiusPx = cellPx;
    } else {
        std::vector<PlateRegion> regions = plateRegions(map, sources, regionDeg);
        while (static_cast<int>(regions.size()) > o.maxLights && regionDeg < kDefaultRegionRadiusDeg) {
            regionDeg = std::min(kDefaultRegionRadiusDeg, 1.5 * regionDeg);
            regions = plateRegions(map, sources, regionDeg);
        }
        found = plateRegionLights(lens, map, regions, o.cullShare);
        // A region's own radius in pixels on the axis (a pixel's angle there: √ of its solid angle).
        matchRadiusPx = regionDeg * std::numbers::pi / 180.0 / std::sqrt(map.pixelSolidAngleSr(0.0));
    }
    sources.thresholdRule = thresholdRule;
    lightsS = secondsSince(phase);
    if (previous) matchPrevious(found.lights, *previous, matchRadiusPx);
    std::vector<FrameLight> frameLights;
    for (const PlateLight& l : found.lights) frameLights.push_back({l.cell.centroidPx, l.spec});
    for (const PlateLight& l : found.lights) scene.lights.push_back(l.spec);
    for (LightSpec l : extra) {
        for (const LightSpec& other : scene.lights)
            if (other.name == l.name)
                throw InputError(o.extraLights, 0, "the light name '" + l.name + "' is also a plate source's; rename it");
        scene.lights.push_back(l);
    }
    if (!o.quiet) {
        std::fprintf(stderr, "composite: plate %d x %d, colour space %s (%s)\n", w, h, plate.space.name.c_str(),
                     plate.space.source.c_str());
        if (o.cells)
            std::fprintf(stderr, "composite: threshold Y > %.6g (%s); %ld source pixels in %d sources, %zu cells of up to %d px\n",
                         sources.threshold, sources.thresholdRule.c_str(), sourcePixels, sources.groups,
                         sources.cells.size(), cellPx);
        else
            std::fprintf(stderr, "composite: threshold Y > %.6g (%s); %ld source pixels in %d sources, %zu region lights of up to %.3g deg\n",
                         sources.threshold, sources.thresholdRule.c_str(), sourcePixels, sources.groups,
                         found.lights.size() + static_cast<size_t>(found.culled), regionDeg);
        if (found.culled)
            std::fprintf(stderr, "composite: culled the %d dimmest %s (%.3g%% of the sources' power)\n", found.culled,
                         o.cells ? "cells" : "regions", 100.0 * found.culledPowerShare);
    }

    // The starburst of the plate's own source pixels (each diffracted by the PSF of the light
    // nearest it), less those pixels: the light the iris moves from the sources' cores into their
    // spikes. The plate holds the sources, so the composite stays non-negative. It needs only the
    // plate and the lights, so it is computed beside the ghosts (each deterministic on its own:
    // the same bits whatever runs beside it).
    const size_t n = 3 * static_cast<size_t>(w) * h;
    std::vector<float> sourceXyz;
    std::optional<StarburstImage> starburst;
    tbb::task_group beside;
    if (!found.lights.empty() && scene.render.diffraction)
        beside.run([&] {
            const Clock::time_point begin = Clock::now();
            sourceXyz.assign(n, 0.0f);
            for (size_t p = 0; p < n / 3; ++p) {
                const glm::dvec3 xyz = plate.space.toXyz * plate.pixel(static_cast<int>(p % w), static_cast<int>(p / w));
                if (!(xyz.y > sources.threshold)) continue;
                for (int k = 0; k < 3; ++k) sourceXyz[3 * p + k] = static_cast<float>(xyz[k]);
            }
            Scene plateScene = scene;
            plateScene.lights.resize(found.lights.size());
            // A region's pixels all go into its crop (a region reaches its radius from its centre
            // and the centre lies within it: twice the radius from the centroid at most).
            StarburstOptions crops;
            if (!o.cells) crops.maxCropRadiusPx = std::max(crops.maxCropRadiusPx, static_cast<int>(std::ceil(2.0 * matchRadiusPx)) + 2);
            crops.psfGroupTolerance = o.psfTolerance;
            crops.clusterFarFields = o.farCluster;
            starburst = sceneStarburst(plateScene, lens, sourceXyz, w, h, crops);
            starburstS = secondsSince(begin);
        });
    ScenePreview plateFlare;
    std::optional<ScenePreview> extraFlare;
    try {
        if (!found.lights.empty()) {
            Scene plateScene = scene;
            plateScene.lights.resize(found.lights.size());
            if (!o.quiet) {
                std::fprintf(stderr, "composite: rendering the flare of %zu light(s)...\n", plateScene.lights.size());
                std::fflush(stderr);
            }
            // The preview's own starburst diffracts the lights' modelled direct image; the plate's
            // sources are diffracted below instead.
            plateScene.render.diffraction = false;
            phase = Clock::now();
            plateFlare = renderFlare(plateScene, lens, o, o.layers.given, start, true);
            ghostsS = secondsSince(phase);
        }
        if (!extra.empty()) {
            Scene extraScene = scene;
            extraScene.lights.assign(scene.lights.end() - static_cast<long>(extra.size()), scene.lights.end());
            extraFlare = renderFlare(extraScene, lens, o, false, start, false);
        }
    } catch (...) {
        beside.wait();
        throw;
    }
    beside.wait();
    if (starburst && !o.quiet) {
        std::set<int> psfs, farFields;
        double largest = 0.0;
        for (size_t l = 0; l < starburst->lights.size(); ++l) {
            const StarburstLightReport& r = starburst->lights[l];
            if (!r.diffracted) continue;
            psfs.insert(r.psfLight), largest = std::max(largest, r.psfDifference);
            farFields.insert(r.farCluster >= 0 ? r.farCluster : static_cast<int>(l));
        }
        std::fprintf(stderr, "composite: starburst of %zu light(s) with %zu PSF(s) (pupils within %.2g of their PSF's), %zu far field(s)\n",
                     starburst->lights.size(), psfs.size(), largest, farFields.size());
    }
    if (found.lights.empty()) {
        std::fprintf(stderr, "composite: warning: no pixel of %s has Y above the threshold %.6g (brightest %.6g): %s\n",
                     o.plate.c_str(), sources.threshold, sources.maxLuminance,
                     extra.empty() ? "the composite is the plate" : "only the --extra-lights flare");
    }

    // The flare in XYZ: the ghosts, and the light's diffraction without its own image (the plate
    // holds that): starburst − direct, which moves light from the core into the spikes. Lights
    // from --extra-lights are not in the plate: their whole image is added.
    std::vector<float> ghost(n, 0.0f), starburstDelta(n, 0.0f), higher, extraLayer;
    if (!found.lights.empty()) {
        addInto(ghost, plateFlare.ghosts);
        if (starburst) {
            addInto(starburstDelta, starburst->xyz);
            addInto(starburstDelta, sourceXyz, -1.0f);
        }
        if (!plateFlare.higher.empty()) higher = plateFlare.higher;
    }
    if (extraFlare) {
        extraLayer.assign(n, 0.0f);
        addInto(extraLayer, extraFlare->starburst ? extraFlare->starburst->xyz : extraFlare->direct);
        addInto(extraLayer, extraFlare->ghosts);
    }
    std::vector<float> flareXyz = ghost;
    addInto(flareXyz, starburstDelta);
    addInto(flareXyz, higher);
    addInto(flareXyz, extraLayer);

    phase = Clock::now();
    std::vector<ImageLayer> layers;
    ImageLayer flare = plateLayer("flare", flareXyz, w, h, plate.space);
    ImageLayer composite{"", w, h, plate.rgb};
    addInto(composite.rgb, flare.rgb);
    layers.push_back(composite);
    layers.push_back(ImageLayer{"plate", w, h, plate.rgb});
    layers.push_back(std::move(flare));
    layers.push_back(plateLayer("ghost", ghost, w, h, plate.space));
    if (scene.render.diffraction) layers.push_back(plateLayer("starburst", starburstDelta, w, h, plate.space));
    if (!higher.empty()) layers.push_back(plateLayer("higher", higher, w, h, plate.space));
    if (!extraLayer.empty()) layers.push_back(plateLayer("extra", extraLayer, w, h, plate.space));
    ExrWriteOptions storage;
    // PIZ by default (lossless): the layers are float images whose low bits are noise (the beams'
    // ghosts, the plate's grain), where ZIP's deflate took a tenth of the default run's CPU
    // (ExrCompression).
    storage.compression = o.compression;
    storage.chromaticities = plate.space.chromaticities;
    if (o.layers.given && !found.lights.empty()) {
        // Per-ghost layers as `flare preview` writes them: parts of their own over their footprints.
        for (auto& [name, window] : plateFlare.perGhost) {
            ImageLayer layer = plateLayer(name, window.xyz, window.width, window.height, plate.space);
            layer.x = window.x;
            layer.y = window.y;
            storage.ownParts.insert(name);
            storage.storage[name] = fitsHalf(layer) ? ExrStorage::Half : ExrStorage::FloatHalfPrecision;
            layers.push_back(std::move(layer));
        }
    }
    char threshold[64];
    std::snprintf(threshold, sizeof threshold, "%.9g", sources.threshold);
    const std::vector<std::pair<std::string, std::string>> metadata = {
        {"software", "flare composite"},
        {"colorSpace", plate.space.name},
        {"plate", o.plate},
        {"lens", lens.name()},
        {"sourceThreshold", threshold},
        {"lights", std::to_string(found.lights.size())},
        {"flareLayers", "composite = plate + flare; flare = ghost + starburst (+ higher, extra)"},
    };
    writeExr(outputs, o.exr, layers, metadata, storage);
    if (o.pngGiven) {
        // The PNG in linear Rec.709 (displayEncode's input); the plate's own exposure unless --exposure.
        ImageLayer rec709 = composite;
        const glm::dmat3 toRec709 = xyzToLinearSrgbMatrix() * plate.space.toXyz;
        for (size_t i = 0; i < n; i += 3) {
            const glm::dvec3 v = toRec709 * glm::dvec3(composite.rgb[i], composite.rgb[i + 1], composite.rgb[i + 2]);
            for (int k = 0; k < 3; ++k) rec709.rgb[i + k] = static_cast<float>(v[k]);
        }
        const double exposure = std::exp2(o.exposureStops.value_or(0.0));
        if (o.displayView.display.empty())
            writePng(outputs, o.png, rec709, exposure);
        else  // the config's view is the tone curve: the plate's exposure times --exposure, no curve of ours
            writeDisplayPng(outputs, o.png, applyDisplayView(composite, plate.space, o.displayView, exposure));
    }
    if (!o.lightsJson.empty()) outputs.write(o.lightsJson, jsonText(sceneToJson(scene)) + "\n");
    outputs.commit();
    const double writeS = secondsSince(phase);

    if (!o.quiet) {
        if (!found.lights.empty())
            std::fprintf(stderr, "composite: %d ghosts by beams, %d passes, estimated ghost error %.2g%%\n",
                         plateFlare.renderedGhosts, plateFlare.passes, 100.0 * plateFlare.ghostEstimatedError);
        std::fprintf(stderr, "composite: %zu light(s), %.2f s (lights %.2f s, ghosts %.2f s, starburst %.2f s, layers and writing %.2f s)\n",
                     scene.lights.size(), secondsSince(start), lightsS, ghostsS, starburstS, writeS);
        if (starburst)
            std::fprintf(stderr, "composite: starburst stages: outlines %.2f s, PSFs %.2f s, near windows %.2f s, %d far field(s) %.2f s\n",
                         starburst->stages.outlines, starburst->stages.psfs, starburst->stages.near, starburst->farFields,
                         starburst->stages.far);
    }
    std::printf("wrote %s%s%s%s%s\n", o.exr.c_str(), o.pngGiven ? " and " : "", o.pngGiven ? o.png.c_str() : "",
                o.lightsJson.empty() ? "" : " and ", o.lightsJson.c_str());
    return frameLights;
}

// `name` with its run of '#' replaced by the frame number, zero-padded to the run's length.
std::string frameName(const std::string& name, int frame) {
    const size_t first = name.find('#');
    if (first == std::string::npos) return name;
    const size_t last = name.find_first_not_of('#', first);
    const size_t width = (last == std::string::npos ? name.size() : last) - first;
    std::string number = std::to_string(frame);
    if (number.size() < width) number.insert(0, width - number.size(), '0');
    return name.substr(0, first) + number + name.substr(first + width);
}

void run(CompositeOptions& o) {
    if (o.frames.empty()) {
        runFrame(o, nullptr);
        return;
    }
    // A sequence: every named output must carry the frame number, the frames run in order, and
    // each frame's sources are matched to the previous frame's (matchPrevious).
    const size_t dash = o.frames.find('-', 1);
    int first = 0, last = 0;
    try {
        size_t used = 0;
        first = std::stoi(o.frames, &used);
        last = dash == std::string::npos ? first : std::stoi(o.frames.substr(dash + 1), &used);
    } catch (const std::exception&) {
        throw InputError("--frames", 0, "must be a frame range FIRST-LAST (e.g. 1-48), got '" + o.frames + "'");
    }
    if (last < first) throw InputError("--frames", 0, "the range " + o.frames + " is empty (LAST < FIRST)");
    for (const auto& [value, option] : {std::pair{o.plate, "PLATE"}, std::pair{o.exr, "-o"}, std::pair{o.png, "--png"},
                                        std::pair{o.lightsJson, "--lights-json"}})
        if (!value.empty() && value.find('#') == std::string::npos)
            throw InputError(option, 0, std::string("with --frames, ") + option + " must hold the frame number as a run of '#' (plate.####.exr), got '" + value + "'");
    std::vector<FrameLight> previous;
    for (int frame = first; frame <= last; ++frame) {
        CompositeOptions f = o;
        f.plate = frameName(o.plate, frame);
        f.exr = frameName(o.exr, frame);
        f.png = frameName(o.png, frame);
        f.lightsJson = frameName(o.lightsJson, frame);
        previous = runFrame(f, frame == first ? nullptr : &previous);
    }
}

}  // namespace

void addCompositeCommand(CLI::App& app) {
    auto o = std::make_shared<CompositeOptions>();
    CLI::App* c = app.add_subcommand(
        "composite", "the flare of a plate's bright sources through a lens, added over the plate (EXR with layers, PNG)");
    c->add_option("PLATE", o->plate, "linear HDR EXR (a photograph or a rendering)");
    c->add_option("--lens", o->lens, "lens file, shipped lens name or library id")->required();
    c->add_option("--zoom", o->zoom, "zoom position name, or a focal length in mm");
    c->add_option("--focus", o->focusMm, "object distance in mm from the first vertex (default: the lens file's)")
        ->check(CLI::PositiveNumber);
    c->add_option("--f-number", o->fNumber, "stop the iris down to this f-number")->check(CLI::PositiveNumber);
    c->add_option("--sensor-width-mm", o->sensorWidthMm,
                  "the plate's width on the sensor (default: the lens's sensor width); sets the field of view")
        ->check(CLI::Range(1e-3, 1000.0));
    c->add_option("-o,--output", o->exr, "EXR to write: composite, plate, flare and its layers")->required();
    c->add_option("--png", o->png, "also write the composite as a tone-mapped PNG");
    addCompressionOption(c, o->compression);
    addExposureOption(c, o->exposureStops);
    auto* display = c->add_option("--display", o->displayView.display,
                                  "show the PNG through this display of the $OCIO config (its view's tone curve in place of "
                                  "flare's)");
    c->add_option("--view", o->displayView.view, "the display's view (default: the config's default view of the display)")
        ->needs(display);
    c->add_option("--colorspace", o->colourSpace,
                  "the plate's colour space: ACEScg, ACES2065-1, linear Rec.709, or a name in the $OCIO config "
                  "(default: the file's chromaticities)");
    c->add_option("--threshold", o->threshold, "luminance above which a pixel is a source (default: from the image)")
        ->check(CLI::NonNegativeNumber);
    c->add_option("--region-deg", o->regionDeg,
                  "largest angular radius of a region light, whose rays come from its own source pixels (default and "
                  "largest 2.5)")
        ->check(CLI::Range(1e-3, kDefaultRegionRadiusDeg));
    c->add_option("--cell-px", o->cellPx,
                  "merge the source pixels into the cells of a grid of this side instead, one light at each cell's "
                  "centroid")
        ->check(CLI::Range(1, 4096))
        ->excludes("--region-deg");
    c->add_option("--max-lights", o->maxLights,
                  "at most this many lights: cells (with --cell-px) or regions (up to 2.5 deg) grow until they fit (default 64)")
        ->check(CLI::Range(1, 65536));
    c->add_option("--cull-share", o->cullShare,
                  "leave out the dimmest cells while together they hold at most this share of the power (default 1e-3)")
        ->check(CLI::Range(0.0, 0.5));
    c->add_option("--psf-tolerance", o->psfTolerance,
                  "regions whose diffraction PSFs differ by at most this (relative area of their pupils' difference) "
                  "share one (default 0.05; 0: one per region)")
        ->check(CLI::Range(0.0, 1.0));
    c->add_option("--far-cluster", o->farCluster,
                  "regions sharing a PSF whose crops lie within this share of their near window's half-width of their "
                  "cluster's centre share one far field (default 0.5; 0: one per region)")
        ->check(CLI::Range(0.0, 4.0));
    c->add_option("--extra-lights", o->extraLights, "scene file whose lights are added (sources the plate cannot show)");
    c->add_option("--lights-json", o->lightsJson, "write the scene of the lights found (edit it, render it)");
    addLayersOption(c, o->layers, "add the per-ghost layers (ghost_03_07.R/G/B, half precision, parts of their own)");
    c->add_flag("--no-diffraction", o->noDiffraction, "no starburst layer");
    auto* passes = c->add_option("--passes", o->passes, "passes of the preview's beams (default 2)")->check(CLI::Range(1, 1 << 16));
    auto* time = c->add_option("--time", o->timeS, "as many passes as fit in this many seconds")->check(CLI::PositiveNumber);
    auto* error = c->add_option("--target-error", o->targetError,
                                "passes until the flare's estimated relative error is below this (e.g. 0.05)")
                      ->check(CLI::Range(1e-4, 1.0));
    time->excludes(passes)->excludes(error);
    error->excludes(passes);
    c->add_option("--beams-per-pass", o->beamsPerPass,
                  "beams per pass and light, on average: the pass's beams are shared among the lights by their power "
                  "(default 160 per region light, 64 per cell with --cell-px)")
        ->check(CLI::Range(8, 32768));
    c->add_flag("--equal-beams", o->equalBeams,
                "every light --beams-per-pass beams a pass (by default the pass's beams are shared among the lights "
                "by their power)");
    c->add_option("--frames", o->frames,
                  "a sequence FIRST-LAST: PLATE, -o (and --png, --lights-json) hold the frame number as '####'; "
                  "sources are matched frame to frame so that their flare does not flicker");
    c->add_option("--seed", o->seed, "random seed of the beams (default 1)")->check(CLI::Range(0LL, (1LL << 62)));
    c->add_flag("--quiet", o->quiet, "no statistics on stderr");
    c->callback([o, c] {
        o->pngGiven = c->count("--png") > 0;
        o->cells = c->count("--cell-px") > 0;
        if (o->beamsPerPass == 0) o->beamsPerPass = o->cells ? 64 : kDefaultRegionBeams;
        if (!o->displayView.display.empty() && !o->pngGiven)
            throw InputError("--display", 0, "a display and view shape the PNG: give --png too");
        resolveLayersOption(c, o->layers, o->plate);
        run(*o);
    });
}

}  // namespace flare::cli
