// flare.preview, flare.render (with its report, progress callback and checkpoints) and
// flare.write_exr: the engine functions `flare preview` and `flare render` call, so that the
// images equal the CLI's bit for bit and the report equals `flare render --report`'s.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <pybind11/stl.h>

#include "PythonCommon.h"
#include "flare/film/ImageIO.h"
#include "flare/render/Render.h"
#include "flare/scene/ScenePreview.h"
#include "flare/scene/SceneRender.h"
#include "flare/scene/SceneStarburst.h"

namespace flare::python {

namespace {

// The scene with its render.diffraction overridden when `diffraction` is given (the CLI's
// --no-diffraction).
Scene withDiffraction(const Scene& scene, std::optional<bool> diffraction) {
    Scene copy = scene;
    if (diffraction) copy.render.diffraction = *diffraction;
    return copy;
}

py::dict preview(const Scene& sceneIn, const py::object& layersArgument, int threads, std::optional<bool> diffraction,
                 int passes, double timeS, const py::object& seed, bool higher) {
    const Scene scene = withDiffraction(sceneIn, diffraction);
    // Checked as the CLI checks them.
    require(passes >= 1, "passes: at least 1, got " + std::to_string(passes));
    require(timeS >= 0.0, "time: 0 (use passes) or a positive number of seconds");
    PreviewBudget budget;
    budget.passes = passes;
    budget.timeS = timeS;
    budget.seed = checkedSeed(seed);
    budget.higher = higher;
    const std::optional<LayerSelection> selection = layerSelection(layersArgument);
    const bool layers = selection.has_value();
    if (selection) budget.ghostLayers = *selection;
    const auto limit = limitThreads(threads);
    std::vector<ImageLayer> images = runEngine([&] {
        const LensSystem lens = buildSceneLens(scene);
        ScenePreview result = previewScene(scene, lens, layers, budget);
        return previewLayers(result, layers);
    });
    return toDict(std::move(images));
}

RenderOptions::Mode renderMode(const std::string& mode) {
    if (mode == "guided") return RenderOptions::Mode::Guided;
    if (mode == "photons") return RenderOptions::Mode::GuidedPhotons;
    if (mode == "naive") return RenderOptions::Mode::Naive;
    throw py::value_error("mode: guided, photons or naive, not \"" + mode + "\"");
}

RenderOptions::HigherOrder higherOrder(const std::string& choice) {
    if (choice == "auto") return RenderOptions::HigherOrder::Auto;
    if (choice == "on") return RenderOptions::HigherOrder::On;
    if (choice == "off") return RenderOptions::HigherOrder::Off;
    throw py::value_error("higher_order: auto, on or off, not \"" + choice + "\"");
}

FilmSettings::Kernel kernel(const std::string& choice) {
    if (choice == "fixed") return FilmSettings::Kernel::Fixed;
    if (choice == "progressive") return FilmSettings::Kernel::Progressive;
    if (choice == "adaptive") return FilmSettings::Kernel::Adaptive;
    throw py::value_error("kernel: fixed, progressive or adaptive, not \"" + choice + "\"");
}

struct RenderArguments {
    std::optional<std::int64_t> photons;
    std::optional<double> timeS;
    double targetError = 0.02;
    int threads = 0;
    py::object progress;                 // None, or called after every pass
    std::optional<std::string> checkpoint;
    double checkpointIntervalS = 60.0;
};

// A render's images (a read-only mapping from EXR layer name to array, as the dict render
// returned before) and its report.
struct RenderResult {
    py::dict images;
    py::object report;
};

// What the progress callback is given after each pass.
py::dict progressDict(const Renderer& renderer, const RenderStopRule& stop, double elapsedS) {
    const RenderStatistics& s = renderer.statistics();
    py::dict d;
    d["passes"] = s.passes;
    d["photons"] = s.photons;
    d["beams"] = s.beams;
    d["elapsed_s"] = elapsedS;
    d["estimated_error"] =
        renderer.hasErrorEstimate() ? py::object(py::float_(renderer.estimatedRelativeError(kGroupFlare))) : py::none();
    d["target_error"] = stop.targetError;
    d["fraction"] = stop.progress(renderer, elapsedS);
    return d;
}

// As `flare render`, with the same defaults, the same stopping rule and the same checkpoints: a
// checkpoint file that exists is resumed from; it is written every checkpointIntervalS, when the
// render is interrupted (Ctrl-C, or an exception from the progress callback, which then goes on
// its way) and at the end.
RenderResult render(const Scene& scene, const RenderArguments& arguments, const SceneRenderOverrides& overrides) {
    require(!arguments.photons || *arguments.photons > 0, "photons must be positive");
    require(!arguments.timeS || *arguments.timeS > 0.0, "time_s must be positive");
    require(arguments.targetError >= 0.0 && arguments.targetError <= 1.0, "target_error: in [0, 1]");
    require(!overrides.maxBounces || (*overrides.maxBounces >= -1 && *overrides.maxBounces <= 1000),
            "max_bounces: in [-1, 1000]");
    require(overrides.radiusPx > 0.0, "radius_px must be positive");
    require(overrides.smoothNeighbours >= 0 && overrides.smoothNeighbours <= 1000000,
            "smooth_neighbours: in [0, 1000000]");
    require(!overrides.interiorAlbedo || (*overrides.interiorAlbedo >= 0.0 && *overrides.interiorAlbedo <= 1.0),
            "interior_albedo: in [0, 1]");
    require(arguments.checkpointIntervalS > 0.0, "checkpoint_interval_s must be positive");
    require(arguments.progress.is_none() || PyCallable_Check(arguments.progress.ptr()),
            "progress: a callable taking one dict, or None");
    require(!arguments.checkpoint || !arguments.checkpoint->empty(), "checkpoint: a file path, or None");

    const auto limit = limitThreads(arguments.threads);
    std::optional<LensSystem> lens;
    std::optional<RenderOptions> options;
    std::unique_ptr<Renderer> renderer;
    runEngine([&] {
        lens.emplace(buildSceneLens(scene));
        options.emplace(sceneRenderOptions(scene, *lens, overrides));
        // The adaptive pass plan drives down the error the render stops on, as the CLI's.
        options->errorTargets = RenderStopRule::make(scene, *options, 0, 0.0, arguments.targetError).errorTargets();
        renderer = std::make_unique<Renderer>(*lens, scene.lights, *options);
        std::error_code ec;
        if (arguments.checkpoint && std::filesystem::is_regular_file(*arguments.checkpoint, ec))
            renderer->loadCheckpoint(*arguments.checkpoint);
    });
    for (const LightPlan& l : renderer->lights())
        if (l.skipped) issueWarnings({"skipped light " + l.name + ": " + l.skipReason});

    const RenderStopRule stop = RenderStopRule::make(scene, *options, arguments.photons.value_or(0),
                                                     arguments.timeS.value_or(0.0), arguments.targetError);
    auto saveCheckpoint = [&] {
        py::gil_scoped_release release;
        renderer->saveCheckpoint(*arguments.checkpoint);
    };
    const auto start = std::chrono::steady_clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
    auto lastCheckpoint = std::chrono::steady_clock::now();
    try {
        for (;;) {
            if (stop.reached(*renderer, elapsed())) break;
            {
                py::gil_scoped_release release;
                renderer->runPass();
            }
            if (PyErr_CheckSignals() != 0) throw py::error_already_set();
            if (!arguments.progress.is_none()) {
                const py::object answer = arguments.progress(progressDict(*renderer, stop, elapsed()));
                // False (not merely falsy: a callback that returns nothing goes on) ends the render here.
                if (answer.is(py::bool_(false))) break;
            }
            if (arguments.checkpoint && std::chrono::duration<double>(std::chrono::steady_clock::now() - lastCheckpoint)
                                                .count() >= arguments.checkpointIntervalS) {
                saveCheckpoint();
                lastCheckpoint = std::chrono::steady_clock::now();
            }
        }
    } catch (const py::error_already_set&) {
        // Keep the work done for a resume, then let the interruption go on its way.
        if (arguments.checkpoint && renderer->statistics().passes > 0) saveCheckpoint();
        throw;
    }

    RenderResult result;
    std::vector<ImageLayer> images;
    nlohmann::json report;
    runEngine([&] {
        // As `flare render`: the starburst in place of the direct image when the scene asks for it.
        std::optional<StarburstImage> starburst;
        if (scene.render.diffraction)
            starburst = sceneStarburst(scene, *lens, renderer->layerXyz(kLayerDirect), options->film.widthPx,
                                       options->film.heightPx);
        images = renderLayers(*renderer, starburst ? &*starburst : nullptr);
        report = sceneRenderReportJson(*renderer, scene, *lens, arguments.targetError, starburst ? &*starburst : nullptr);
        if (arguments.checkpoint) renderer->saveCheckpoint(*arguments.checkpoint);
    });
    result.images = toDict(std::move(images));
    result.report = toPython(report);
    return result;
}

ExrCompression compression(const std::string& name) {
    if (name == "zip") return ExrCompression::Zip;
    if (name == "piz") return ExrCompression::Piz;
    if (name == "none") return ExrCompression::None;
    throw py::value_error("compression: zip, piz or none, not \"" + name + "\"");
}

// flare.write_exr: the images (a mapping from layer name to array; "" the main image) in the
// order given, the main image first, as the CLI writes its EXRs.
void writeExrFile(const std::string& path, const py::object& images, const std::map<std::string, std::string>& metadata,
                  const std::vector<std::string>& halfLayers, const std::string& compressionName) {
    require(py::hasattr(images, "items"), "images: a mapping from layer name to an array (height, width, 3)");
    std::vector<ImageLayer> layers;
    for (const py::handle item : images.attr("items")()) {
        const py::tuple pair = item.cast<py::tuple>();
        const std::string name = pair[0].cast<std::string>();
        const std::string label = "images['" + name + "']";
        ImageLayer layer = fromArray(pair[1].cast<FloatArray>(), name, label);
        for (float v : layer.rgb) require(std::isfinite(v), label + ": holds NaN or infinity");
        if (!layers.empty())
            require(layer.width == layers.front().width && layer.height == layers.front().height,
                    label + ": " + std::to_string(layer.width) + " x " + std::to_string(layer.height) +
                        " px, but images['" + layers.front().name + "'] is " + std::to_string(layers.front().width) +
                        " x " + std::to_string(layers.front().height) + " (every layer of an EXR has one size)");
        for (const ImageLayer& other : layers) require(other.name != name, label + ": the layer name repeats");
        layers.push_back(std::move(layer));
    }
    require(!layers.empty(), "images: at least one layer");
    std::stable_partition(layers.begin(), layers.end(), [](const ImageLayer& l) { return l.name.empty(); });
    ExrWriteOptions options;
    options.compression = compression(compressionName);
    for (const std::string& name : halfLayers) {
        const auto layer = std::find_if(layers.begin(), layers.end(), [&](const ImageLayer& l) { return l.name == name; });
        require(layer != layers.end(), "half_layers: no layer '" + name + "' among the images");
        require(fitsHalf(*layer), "half_layers: layer '" + name +
                                      "' has values beyond half precision's range (|x| > 65504, or small values "
                                      "below 6.1e-5 that half would lose); write it as float");
        options.storage[name] = ExrStorage::Half;
    }
    std::vector<std::pair<std::string, std::string>> attributes(metadata.begin(), metadata.end());
    runEngine([&] { writeExr(path, layers, attributes, options); });
}

}  // namespace

void registerRender(py::module_& m) {
    py::class_<RenderResult>(m, "RenderResult",
                             "What flare.render returns: a read-only mapping from EXR layer name to float32 array "
                             "(height, width, 3), as the dict of images it returned before (result[''] is the main "
                             "image), with the render's report.")
        .def_readonly("images", &RenderResult::images, "the images: a dict from EXR layer name to array")
        .def_readonly("report", &RenderResult::report,
                      "the report, as `flare render --report` writes it: passes, photons, wall time, per-layer "
                      "power, standard error and estimated error, per-ghost power and strategy, the photons' fates")
        .def(
            "__getitem__",
            [](const RenderResult& r, const std::string& name) -> py::object {
                if (!r.images.contains(name)) throw py::key_error(name);
                return r.images[py::str(name)];
            },
            py::arg("name"))
        .def(
            "__contains__", [](const RenderResult& r, const py::object& name) { return r.images.contains(name); },
            py::arg("name"))
        .def("__len__", [](const RenderResult& r) { return r.images.size(); })
        .def("__iter__", [](const RenderResult& r) { return py::iter(r.images); })
        .def("keys", [](const RenderResult& r) { return r.images.attr("keys")(); }, "the layer names")
        .def("values", [](const RenderResult& r) { return r.images.attr("values")(); }, "the images")
        .def("items", [](const RenderResult& r) { return r.images.attr("items")(); }, "(layer name, image) pairs")
        .def(
            "get",
            [](const RenderResult& r, const std::string& name, const py::object& fallback) {
                return r.images.contains(name) ? py::object(r.images[py::str(name)]) : fallback;
            },
            py::arg("name"), py::arg("default") = py::none(), "the layer's image, or default")
        .def("__repr__", [](const RenderResult& r) {
            return "<flare.RenderResult " + std::to_string(r.images.size()) + " layers, " +
                   py::str(r.report["passes"]).cast<std::string>() + " passes>";
        });
    // A Mapping for isinstance checks and for code that takes any mapping.
    py::module_::import("collections.abc").attr("Mapping").attr("register")(m.attr("RenderResult"));

    m.def("preview", &preview, py::arg("scene"), py::kw_only(), py::arg("layers") = false, py::arg("threads") = 0,
          py::arg("diffraction") = py::none(), py::arg("passes") = PreviewBudget::kDefaultPasses, py::arg("time") = 0.0,
          py::arg("seed") = py::none(), py::arg("higher") = false,
          "The ghost preview, as `flare preview`: the final render's first `passes` passes of beams without photons "
          "(or as many as fit in `time` seconds; the same seed and passes give the same image; `higher` adds the "
          "order-4 chains). Returns a dict of float32 arrays (height, width, 3), linear Rec.709 RGB in W/m2, keyed "
          "by EXR layer name: '' (the main image, with the starburst in place of the direct image when diffraction "
          "is on), then with layers=True 'direct', 'starburst', 'ghost' and one per kept ghost ('ghost_03_07', ..., each "
          "a Footprint over the pixels it reaches; layers='top:N' or 'share:F' keeps the strongest and sums the rest "
          "in 'ghost_other', as --layers does) "
          "in float precision (the CLI's --float-layers). diffraction: None takes the scene's render.diffraction, "
          "False is --no-diffraction. threads: 0 for all cores. seed: None for the scene's.");
    m.def(
        "render",
        [](const Scene& scene, std::optional<std::int64_t> photons, std::optional<double> timeS, double targetError,
           const py::object& seed, int threads, const std::string& mode, const py::object& layers, std::optional<int> maxBounces,
           const std::string& higherOrderChoice, const std::string& kernelChoice, double radiusPx, int smoothNeighbours,
           std::optional<double> interiorAlbedo, std::optional<bool> diffraction, bool analogStray, int beamReplicates,
           int beamProbes, int scatterSplits, const py::object& progress, std::optional<std::string> checkpoint, double checkpointIntervalS) {
            require(beamReplicates >= 2 && beamReplicates <= kMaxReplicates,
                    "beam_replicates: in [2, " + std::to_string(kMaxReplicates) + "], got " + std::to_string(beamReplicates));
            // As --beam-probes: one probe has no spread to measure.
            require(beamProbes == 0 || (beamProbes >= 2 && beamProbes <= 64),
                    "beam_probes: 0, or 2 to 64, got " + std::to_string(beamProbes));
            require(scatterSplits >= 1 && scatterSplits <= kMaxStrayBranches + 1,
                    "scatter_splits: in [1, " + std::to_string(kMaxStrayBranches + 1) + "], got " +
                        std::to_string(scatterSplits));
            SceneRenderOverrides overrides;
            overrides.mode = renderMode(mode);
            overrides.seed = checkedSeed(seed);
            overrides.maxBounces = maxBounces;
            const std::optional<LayerSelection> selection = layerSelection(layers);
            overrides.perGhostLayers = selection.has_value();
            if (selection) overrides.ghostLayers = *selection;
            overrides.higherOrder = higherOrder(higherOrderChoice);
            overrides.kernel = kernel(kernelChoice);
            overrides.radiusPx = radiusPx;
            overrides.smoothNeighbours = smoothNeighbours;
            overrides.interiorAlbedo = interiorAlbedo;
            overrides.strayLightSampling = !analogStray;
            overrides.beamReplicates = beamReplicates;
            overrides.beamVarianceProbes = beamProbes;
            overrides.scatterSplits = scatterSplits;
            return render(withDiffraction(scene, diffraction),
                          RenderArguments{photons, timeS, targetError, threads, progress, checkpoint, checkpointIntervalS},
                          overrides);
        },
        py::arg("scene"), py::kw_only(), py::arg("photons") = py::none(), py::arg("time_s") = py::none(),
        py::arg("target_error") = 0.02, py::arg("seed") = py::none(), py::arg("threads") = 0,
        py::arg("mode") = "guided", py::arg("layers") = false, py::arg("max_bounces") = py::none(),
        py::arg("higher_order") = "auto", py::arg("kernel") = "fixed", py::arg("radius_px") = 1.0,
        py::arg("smooth_neighbours") = 256, py::arg("interior_albedo") = py::none(), py::arg("diffraction") = py::none(),
        py::arg("analog_stray") = false, py::arg("beam_replicates") = 2,
        py::arg("beam_probes") = RenderOptions{}.beamVarianceProbes,
        py::arg("scatter_splits") = kDefaultScatterSplits, py::arg("progress") = py::none(), py::arg("checkpoint") = py::none(), py::arg("checkpoint_interval_s") = 60.0,
        "The physically based render, as `flare render` with the same options and defaults: it stops at the target "
        "error, time_s or photons, whichever comes first, after at least two passes (without time_s or photons at the "
        "scene's photon count). Returns a RenderResult: a mapping from EXR layer name to float32 array (height, "
        "width, 3): '' (the sum, the starburst in place of the direct layer when diffraction is on), 'direct', "
        "'ghost', 'higher', 'scatter', per-ghost (each a Footprint; 'top:N' or 'share:F' as --layers) and "
        "per-scatter-source layers with layers=True, 'starburst' with "
        "diffraction, then 'variance'; and .report, the dict `flare render --report` writes. progress: called after "
        "every pass with a dict (passes, photons, beams, elapsed_s, estimated_error (None before the estimate "
        "exists), target_error, fraction of the work done); returning False ends the render there, an exception "
        "ends it and goes on its way. checkpoint: a file resumed from when it exists, written every "
        "checkpoint_interval_s seconds, on Ctrl-C (KeyboardInterrupt) and at the end, as --checkpoint. The image "
        "depends on the seed, never on the thread count (threads: 0 for all cores).");
    m.def("write_exr", &writeExrFile, py::arg("path"), py::arg("images"), py::kw_only(),
          py::arg("metadata") = std::map<std::string, std::string>{}, py::arg("half_layers") = std::vector<std::string>{},
          py::arg("compression") = "zip",
          "Writes images (a mapping from layer name to float32 array (height, width, 3), linear Rec.709 RGB; '' the "
          "main image, written first; other names become EXR layers name.R/G/B) as the CLI writes its EXRs: "
          "losslessly compressed ('zip' or 'piz') or not at all ('none'), 32-bit float except the layers named in half_layers (half "
          "precision, refused for values half cannot keep), the Rec.709 chromaticities and each metadata pair as a "
          "string attribute; all or nothing (a partial file never stands under the name). read_exr reads it back.");
}

}  // namespace flare::python
