// The Python module `flare` (docs/python.md): the engine driven as the CLI drives it, through the
// same engine functions, so that a ghost table, preview or render from Python equals the CLI's
// JSON and EXR value for value (tests/python/test_flare_module.py checks it). Images are NumPy
// float32 arrays (height × width × 3, linear Rec.709 RGB) keyed by their EXR layer names; reports
// are dicts with the keys of the CLI's JSON. The GIL is released while the engine works, and its
// input errors (InputError: "file:line: problem") become ValueError.
#include <chrono>
#include <cstdint>
#include <cstring>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <tbb/global_control.h>

#include <nlohmann/json.hpp>

#include "flare/core/Error.h"
#include "flare/film/ImageCompare.h"
#include "flare/film/ImageIO.h"
#include "flare/film/LayerSelection.h"
#include "flare/ghosts/GhostAnalysis.h"
#include "flare/ghosts/GhostTable.h"
#include "flare/optics/EmbeddedLenses.h"
#include "flare/optics/Glass.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/LensInfo.h"
#include "flare/optics/LensLibrary.h"
#include "flare/optics/Paraxial.h"
#include "flare/optics/PupilGrid.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"
#include "flare/scene/ScenePreview.h"
#include "flare/scene/SceneRender.h"
#include "flare/scene/SceneStarburst.h"

namespace py = pybind11;

namespace flare::python {

namespace {

py::object toPython(const nlohmann::json& j) {
    switch (j.type()) {
        case nlohmann::json::value_t::null: return py::none();
        case nlohmann::json::value_t::boolean: return py::bool_(j.get<bool>());
        case nlohmann::json::value_t::number_integer: return py::int_(j.get<std::int64_t>());
        case nlohmann::json::value_t::number_unsigned: return py::int_(j.get<std::uint64_t>());
        case nlohmann::json::value_t::number_float: return py::float_(j.get<double>());
        case nlohmann::json::value_t::string: return py::str(j.get_ref<const std::string&>());
        case nlohmann::json::value_t::array: {
            py::list list;
            for (const nlohmann::json& item : j) list.append(toPython(item));
            return list;
        }
        case nlohmann::json::value_t::object: {
            py::dict dict;
            for (const auto& [key, value] : j.items()) dict[py::str(key)] = toPython(value);
            return dict;
        }
        default: throw std::logic_error("toPython: a JSON value of a kind the engine's reports never hold");
    }
}

py::array_t<float> toArray(const ImageLayer& layer) {
    py::array_t<float> array({layer.height, layer.width, 3});
    std::memcpy(array.mutable_data(), layer.rgb.data(), layer.rgb.size() * sizeof(float));
    return array;
}

// A layer over a window of its frame (a ghost's footprint): its pixels, where they lie, and the
// whole frame on request.
struct Footprint {
    std::string name;
    int x = 0, y = 0, frameWidth = 0, frameHeight = 0;
    py::array_t<float> rgb;

    py::array_t<float> full() const {
        py::array_t<float> whole({frameHeight, frameWidth, 3});
        float* out = whole.mutable_data();
        std::memset(out, 0, static_cast<size_t>(whole.size()) * sizeof(float));
        const auto pixels = rgb.unchecked<3>();
        for (py::ssize_t r = 0; r < pixels.shape(0); ++r)
            for (py::ssize_t c = 0; c < pixels.shape(1); ++c)
                for (int k = 0; k < 3; ++k)
                    out[((static_cast<size_t>(y) + r) * frameWidth + x + c) * 3 + k] = pixels(r, c, k);
        return whole;
    }
};

// The layers as Python values, each layer's memory released once copied (one copy at a time): a
// Footprint for a layer over a window of the frame or named in `footprints` (the per-ghost layers,
// which an EXR holds in parts of their own, even where one covers the frame), else an array.
py::dict toDict(std::vector<ImageLayer> layers, int frameWidth, int frameHeight, const std::set<std::string>& footprints) {
    py::dict dict;
    for (ImageLayer& layer : layers) {
        const bool whole = layer.x == 0 && layer.y == 0 && layer.width == frameWidth && layer.height == frameHeight;
        if (whole && !footprints.count(layer.name)) dict[py::str(layer.name)] = toArray(layer);
        else dict[py::str(layer.name)] = Footprint{layer.name, layer.x, layer.y, frameWidth, frameHeight, toArray(layer)};
        std::vector<float>().swap(layer.rgb);
    }
    return dict;
}
// An engine's images (the first the whole frame): the per-ghost layers (ghost_...) as Footprints.
py::dict toDict(std::vector<ImageLayer> layers) {
    const int width = layers.empty() ? 0 : layers.front().width, height = layers.empty() ? 0 : layers.front().height;
    std::set<std::string> perGhost;
    for (const ImageLayer& layer : layers)
        if (layer.name.starts_with("ghost_")) perGhost.insert(layer.name);
    return toDict(std::move(layers), width, height, perGhost);
}

// `layers=` of preview and render: False, True (every ghost), or "all", "top:N", "share:F".
std::optional<LayerSelection> layerSelection(const py::object& layers) {
    if (py::isinstance<py::bool_>(layers))
        return layers.cast<bool>() ? std::optional<LayerSelection>(LayerSelection{}) : std::nullopt;
    if (py::isinstance<py::str>(layers)) {
        try {
            return LayerSelection::parse(layers.cast<std::string>());
        } catch (const std::invalid_argument& e) {
            throw py::value_error(e.what());
        }
    }
    throw py::type_error("layers: False, True, \"all\", \"top:N\" or \"share:F\"");
}

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

ImageLayer fromArray(const FloatArray& array, const std::string& label) {
    if (array.ndim() != 3 || array.shape(2) != 3)
        throw py::value_error(label + ": expected an array of shape (height, width, 3)");
    ImageLayer layer{"", static_cast<int>(array.shape(1)), static_cast<int>(array.shape(0)), {}};
    layer.rgb.assign(array.data(), array.data() + array.size());
    return layer;
}

void require(bool condition, const std::string& message) {
    if (!condition) throw py::value_error(message);
}

// Limits TBB's worker threads for the lifetime of the object (threads ≤ 0: all cores).
std::unique_ptr<tbb::global_control> limitThreads(int threads) {
    if (threads <= 0) return nullptr;
    return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
}

// A lens at one zoom/focus/f-stop state, with the prescription it was built from (the lens
// information reports the file's nominal values).
struct Lens {
    LensPrescription prescription;
    LensSystem system;
};

Lens loadLensAtState(const std::string& lens, const std::string& zoom, std::optional<double> focusMm,
                     std::optional<double> fNumber) {
    require(!focusMm || *focusMm > 0.0, "focus_mm must be positive");
    require(!fNumber || *fNumber > 0.0, "f_number must be positive");
    py::gil_scoped_release release;
    LensPrescription prescription = loadLens(lens);
    LensSystem system = LensSystem::build(prescription, LensState{zoom, focusMm, fNumber});
    return Lens{std::move(prescription), std::move(system)};
}

std::optional<glm::dvec3> fieldDirection(const std::optional<std::vector<double>>& fieldDeg) {
    if (!fieldDeg) return std::nullopt;
    require(!fieldDeg->empty() && fieldDeg->size() <= 2, "field_deg: one or two angles (X[, Y]) in degrees");
    for (double angle : *fieldDeg) require(angle >= -89.0 && angle <= 89.0, "field_deg: each angle in [-89, 89]");
    return directionFromFieldDeg((*fieldDeg)[0], fieldDeg->size() > 1 ? (*fieldDeg)[1] : 0.0);
}

GhostAnalysisOptions ghostOptions(int order, double wavelengthNm, bool sensorGhosts) {
    require(order == 2 || order == 4, "order: 2 or 4");
    require(wavelengthNm >= 300.0 && wavelengthNm <= 2000.0, "wavelength_nm: in [300, 2000]");
    GhostAnalysisOptions options;
    options.order = order;
    options.wavelengthNm = wavelengthNm;
    options.includeSensor = sensorGhosts;
    return options;
}

py::object ghostTable(const LensSystem& lens, const glm::dvec3& direction, const GhostAnalysisOptions& options,
                      bool all) {
    nlohmann::json table;
    {
        py::gil_scoped_release release;
        table = ghostTableJson(lens, direction, options, analyseGhosts(lens, direction, options), all);
    }
    return toPython(table);
}

// As `flare ghosts LENS --json`: the light on the axis unless field_deg says otherwise.
py::object lensGhostReport(const Lens& lens, const std::optional<std::vector<double>>& fieldDeg, int order,
                           double wavelengthNm, bool all, bool sensorGhosts) {
    const GhostAnalysisOptions options = ghostOptions(order, wavelengthNm, sensorGhosts);
    const glm::dvec3 direction = fieldDirection(fieldDeg).value_or(directionFromFieldDeg(0.0, 0.0));
    return ghostTable(lens.system, direction, options, all);
}

// As `flare ghosts SCENE.json --json`: the scene supplies the lens state, the light and the
// pruning settings; field_deg overrides the light's direction.
py::object sceneGhostReport(const Scene& scene, int light, const std::optional<std::vector<double>>& fieldDeg,
                            int order, double wavelengthNm, bool all, bool sensorGhosts) {
    GhostAnalysisOptions options = ghostOptions(order, wavelengthNm, sensorGhosts);
    if (light < 0 || light >= static_cast<int>(scene.lights.size()))
        throw py::index_error("light " + std::to_string(light) + ": the scene has " +
                              std::to_string(scene.lights.size()) + " light(s)");
    options.includeSensor = scene.render.includeSensorGhosts && sensorGhosts;
    options.keepShare = scene.render.pruneKeepShare;
    options.relativeThreshold = scene.render.pruneRelativeThreshold;
    const glm::dvec3 direction = fieldDirection(fieldDeg).value_or(scene.lights[light].travelDirection());
    std::optional<LensSystem> lens;
    {
        py::gil_scoped_release release;
        lens.emplace(buildSceneLens(scene));
    }
    return ghostTable(*lens, direction, options, all);
}

// The scene with its render.diffraction overridden when `diffraction` is given (the CLI's
// --no-diffraction).
Scene withDiffraction(const Scene& scene, std::optional<bool> diffraction) {
    Scene copy = scene;
    if (diffraction) copy.render.diffraction = *diffraction;
    return copy;
}

py::dict preview(const Scene& sceneIn, const py::object& layersArgument, int threads, std::optional<bool> diffraction, int passes,
                 double timeS, std::optional<long long> seed, bool higher) {
    const Scene scene = withDiffraction(sceneIn, diffraction);
    // Checked as the CLI checks them.
    if (passes < 1) throw py::value_error("passes: at least 1, got " + std::to_string(passes));
    if (!(timeS >= 0.0)) throw py::value_error("time: 0 (use passes) or a positive number of seconds");
    if (seed && *seed < 0) throw py::value_error("seed: a non-negative integer");
    PreviewBudget budget;
    budget.passes = passes;
    budget.timeS = timeS;
    if (seed) budget.seed = static_cast<std::uint64_t>(*seed);
    budget.higher = higher;
    const std::optional<LayerSelection> selection = layerSelection(layersArgument);
    const bool layers = selection.has_value();
    if (selection) budget.ghostLayers = *selection;
    std::vector<ImageLayer> images;
    {
        py::gil_scoped_release release;
        const auto limit = limitThreads(threads);
        const LensSystem lens = buildSceneLens(scene);
        ScenePreview result = previewScene(scene, lens, layers, budget);
        images = previewLayers(result, layers);
    }
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
};

// As `flare render`, with the same defaults and the same stopping rule; passes stop early with
// KeyboardInterrupt on Ctrl-C (checked between passes).
py::dict render(const Scene& scene, const RenderArguments& arguments, const SceneRenderOverrides& overrides) {
    require(!arguments.photons || *arguments.photons > 0, "photons must be positive");
    require(!arguments.timeS || *arguments.timeS > 0.0, "time_s must be positive");
    require(arguments.targetError >= 0.0 && arguments.targetError <= 1.0, "target_error: in [0, 1]");
    require(!overrides.maxBounces || (*overrides.maxBounces >= -1 && *overrides.maxBounces <= 1000),
            "max_bounces: in [-1, 1000]");
    require(overrides.radiusPx > 0.0, "radius_px must be positive");
    require(overrides.smoothNeighbours >= 0 && overrides.smoothNeighbours <= 1000000, "smooth_neighbours: in [0, 1000000]");
    require(!overrides.interiorAlbedo || (*overrides.interiorAlbedo >= 0.0 && *overrides.interiorAlbedo <= 1.0),
            "interior_albedo: in [0, 1]");

    const auto limit = limitThreads(arguments.threads);
    std::optional<LensSystem> lens;
    std::optional<RenderOptions> options;
    std::unique_ptr<Renderer> renderer;
    {
        py::gil_scoped_release release;
        lens.emplace(buildSceneLens(scene));
        options.emplace(sceneRenderOptions(scene, *lens, overrides));
        renderer = std::make_unique<Renderer>(*lens, scene.lights, *options);
    }
    const RenderStopRule stop = RenderStopRule::make(scene, *options, arguments.photons.value_or(0),
                                                     arguments.timeS.value_or(0.0), arguments.targetError);
    const auto start = std::chrono::steady_clock::now();
    for (;;) {
        if (stop.reached(*renderer, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()))
            break;
        {
            py::gil_scoped_release release;
            renderer->runPass();
        }
        if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    }
    std::vector<ImageLayer> images;
    {
        py::gil_scoped_release release;
        // As `flare render`: the starburst in place of the direct image when the scene asks for it.
        std::optional<StarburstImage> starburst;
        if (scene.render.diffraction)
            starburst = sceneStarburst(scene, *lens, renderer->layerXyz(kLayerDirect), options->film.widthPx,
                                       options->film.heightPx);
        images = renderLayers(*renderer, starburst ? &*starburst : nullptr);
    }
    return toDict(std::move(images));
}

// An EXR path (its layer `layer`) or an array of shape (height, width, 3).
ImageLayer comparedImage(const py::object& image, const std::string& layer, const std::string& label) {
    if (py::isinstance<py::str>(image)) {
        const std::string path = image.cast<std::string>();
        py::gil_scoped_release release;
        return readExrLayer(path, layer);
    }
    return fromArray(image.cast<FloatArray>(), label);
}

std::string imageLabel(const py::object& image, const std::string& fallback) {
    return py::isinstance<py::str>(image) ? image.cast<std::string>() : fallback;
}

std::vector<std::string> lensNames() {
    std::vector<std::string> names;
    for (const EmbeddedLens& lens : embeddedLenses()) names.push_back(lens.name);
    for (const LibraryLens& lens : LensLibrary::shared().lenses()) names.push_back(lens.id);
    return names;
}

}  // namespace

}  // namespace flare::python

PYBIND11_MODULE(flare, m) {
    using namespace flare;
    using namespace flare::python;

    m.doc() = "Physically based lens flare: lenses, ghost tables, previews and renders (docs/python.md)";

    // Registered translators are tried before pybind11's own, so InputError (a std::runtime_error)
    // becomes ValueError, while other engine exceptions keep pybind11's mapping.
    py::register_exception_translator([](std::exception_ptr error) {
        try {
            if (error) std::rethrow_exception(error);
        } catch (const InputError& e) {
            PyErr_SetString(PyExc_ValueError, e.what());
        }
    });

    py::class_<ParaxialData>(m, "Paraxial", "First-order data of a lens at one wavelength (lengths in mm)")
        .def_readonly("wavelength_nm", &ParaxialData::wavelengthNm)
        .def_readonly("efl_mm", &ParaxialData::eflMm, "effective focal length")
        .def_readonly("bfl_mm", &ParaxialData::bflMm, "last vertex to the rear focal point")
        .def_readonly("front_focal_distance_mm", &ParaxialData::frontFocalDistanceMm,
                      "front focal point to the first vertex (> 0: in front)")
        .def_readonly("image_distance_mm", &ParaxialData::imageDistanceMm,
                      "last vertex to the paraxial image of the object in focus")
        .def_readonly("entrance_pupil_z_mm", &ParaxialData::entrancePupilZMm,
                      "from the first vertex, + towards the sensor")
        .def_readonly("entrance_pupil_diameter_mm", &ParaxialData::entrancePupilDiameterMm)
        .def_readonly("exit_pupil_z_mm", &ParaxialData::exitPupilZMm)
        .def_readonly("exit_pupil_diameter_mm", &ParaxialData::exitPupilDiameterMm)
        .def_readonly("f_number", &ParaxialData::fNumber, "EFL / entrance-pupil diameter")
        .def_readonly("working_f_number", &ParaxialData::workingFNumber, "1 / (2 n' |u'|) for the object in focus")
        .def_readonly("field_of_view_deg", &ParaxialData::paraxialFieldOfViewDeg,
                      "full diagonal angle, 2 atan(half diagonal / EFL)")
        .def_readonly("total_track_mm", &ParaxialData::totalTrackMm, "first vertex to the sensor")
        .def("__repr__", [](const ParaxialData& p) {
            return "<flare.Paraxial EFL " + std::to_string(p.eflMm) + " mm, f/" + std::to_string(p.fNumber) + " at " +
                   std::to_string(p.wavelengthNm) + " nm>";
        });

    py::class_<Footprint>(m, "Footprint",
                          "A layer over a window of its frame (a ghost's footprint: the bounding box of the pixels it "
                          "reaches; every pixel outside is zero). np.asarray(footprint) is the whole frame.")
        .def_readonly("name", &Footprint::name)
        .def_readonly("x", &Footprint::x, "the window's first column in the frame")
        .def_readonly("y", &Footprint::y, "the window's first row in the frame (0 = top)")
        .def_property_readonly("width", [](const Footprint& f) { return static_cast<int>(f.rgb.shape(1)); })
        .def_property_readonly("height", [](const Footprint& f) { return static_cast<int>(f.rgb.shape(0)); })
        .def_property_readonly("frame_size", [](const Footprint& f) { return py::make_tuple(f.frameWidth, f.frameHeight); },
                               "(width, height) of the whole frame")
        .def_readonly("rgb", &Footprint::rgb, "the window's pixels: float32 (height, width, 3), linear Rec.709 RGB")
        .def("full", &Footprint::full, "the layer over the whole frame: float32 (frame height, frame width, 3)")
        .def(
            "__array__",
            [](const Footprint& f, const py::object& dtype, const py::object&) {
                py::array whole = f.full();
                return dtype.is_none() ? whole : py::array(whole.attr("astype")(dtype));
            },
            py::arg("dtype") = py::none(), py::arg("copy") = py::none())
        .def("__repr__", [](const Footprint& f) {
            return "<flare.Footprint '" + f.name + "' " + std::to_string(f.rgb.shape(1)) + "x" +
                   std::to_string(f.rgb.shape(0)) + " at (" + std::to_string(f.x) + ", " + std::to_string(f.y) +
                   ") of " + std::to_string(f.frameWidth) + "x" + std::to_string(f.frameHeight) + ">";
        });

    py::class_<Lens>(m, "Lens", "A lens at one zoom/focus/f-stop state")
        .def_property_readonly("name", [](const Lens& l) { return l.system.name(); })
        .def_property_readonly("source_file", [](const Lens& l) { return l.system.sourceFile(); })
        .def_property_readonly("surface_count", [](const Lens& l) { return l.system.surfaceCount(); },
                               "surfaces in file order, counting the stop; the sensor is surface_count + 1")
        .def(
            "paraxial", [](const Lens& l, double wavelengthNm) { return analyseParaxial(l.system, wavelengthNm); },
            py::arg("wavelength_nm") = kLineDNm, "paraxial data (default: the d line, 587.56 nm)")
        .def(
            "info",
            [](const Lens& l, double wavelengthNm) {
                return toPython(lensInfoJson(l.prescription, l.system, wavelengthNm));
            },
            py::arg("wavelength_nm") = kLineDNm, "the dict `flare lens info --json` prints")
        .def(
            "ghost_report",
            [](const Lens& l, const std::optional<std::vector<double>>& fieldDeg, int order, double wavelengthNm,
               bool all, bool sensorGhosts) { return lensGhostReport(l, fieldDeg, order, wavelengthNm, all, sensorGhosts); },
            py::kw_only(), py::arg("field_deg") = py::none(), py::arg("order") = 2, py::arg("wavelength_nm") = 550.0,
            py::arg("all") = false, py::arg("sensor_ghosts") = true,
            "the dict `flare ghosts LENS --json` prints (field_deg: [X] or [X, Y], default on the axis)")
        .def(
            "ghosts",
            [](const Lens& l, const std::optional<std::vector<double>>& fieldDeg, int order, double wavelengthNm,
               bool all, bool sensorGhosts) {
                return py::object(lensGhostReport(l, fieldDeg, order, wavelengthNm, all, sensorGhosts)["ghosts"]);
            },
            py::kw_only(), py::arg("field_deg") = py::none(), py::arg("order") = 2, py::arg("wavelength_nm") = 550.0,
            py::arg("all") = false, py::arg("sensor_ghosts") = true,
            "the ghost table: ghost_report(...)['ghosts'], strongest first")
        .def("__repr__", [](const Lens& l) { return "<flare.Lens " + l.system.name() + ">"; });

    m.def("load_lens", &loadLensAtState, py::arg("lens"), py::kw_only(), py::arg("zoom") = "",
          py::arg("focus_mm") = py::none(), py::arg("f_number") = py::none(),
          "A lens file (.lens, pbrt .dat), a shipped lens name or a library id, at a zoom position (name or focal "
          "length in mm), focus (object distance in mm from the first vertex) and f-number");
    m.def("lens_names", &lensNames, "the shipped lens names, then the library's ids");

    py::class_<Scene>(m, "Scene", "A scene: lens and state, lights, sensor and render settings")
        .def_property_readonly("source_file", [](const Scene& s) { return s.sourceFile; })
        .def_property_readonly("description", [](const Scene& s) { return s.description; })
        .def_property_readonly("lens_name", [](const Scene& s) { return s.lens; },
                               "the lens as the scene names it (a resolved path or a shipped or library name)")
        .def_property_readonly("width_px", [](const Scene& s) { return s.sensor.widthPx; })
        .def_property_readonly("height_px", [](const Scene& s) { return s.sensor.heightPx; })
        .def_property_readonly("light_names",
                               [](const Scene& s) {
                                   std::vector<std::string> names;
                                   for (const LightSpec& light : s.lights) names.push_back(light.name);
                                   return names;
                               })
        .def_property_readonly("photons", [](const Scene& s) { return s.render.photons; })
        .def_property_readonly("seed", [](const Scene& s) { return s.render.seed; })
        .def(
            "lens",
            [](const Scene& s) {
                py::gil_scoped_release release;
                return Lens{loadLens(s.lens), buildSceneLens(s)};
            },
            "the scene's lens at the scene's state and sensor")
        .def(
            "ghost_report",
            [](const Scene& s, int light, const std::optional<std::vector<double>>& fieldDeg, int order,
               double wavelengthNm, bool all, bool sensorGhosts) {
                return sceneGhostReport(s, light, fieldDeg, order, wavelengthNm, all, sensorGhosts);
            },
            py::kw_only(), py::arg("light") = 0, py::arg("field_deg") = py::none(), py::arg("order") = 2,
            py::arg("wavelength_nm") = 550.0, py::arg("all") = false, py::arg("sensor_ghosts") = true,
            "the dict `flare ghosts SCENE.json --json` prints, for one light (0-based)")
        .def(
            "ghosts",
            [](const Scene& s, int light, const std::optional<std::vector<double>>& fieldDeg, int order,
               double wavelengthNm, bool all, bool sensorGhosts) {
                return py::object(sceneGhostReport(s, light, fieldDeg, order, wavelengthNm, all, sensorGhosts)["ghosts"]);
            },
            py::kw_only(), py::arg("light") = 0, py::arg("field_deg") = py::none(), py::arg("order") = 2,
            py::arg("wavelength_nm") = 550.0, py::arg("all") = false, py::arg("sensor_ghosts") = true,
            "the ghost table: ghost_report(...)['ghosts'], strongest first")
        .def("__repr__", [](const Scene& s) {
            return "<flare.Scene " + s.sourceFile + ", lens " +
                   s.lens + ", " + std::to_string(s.sensor.widthPx) + "x" + std::to_string(s.sensor.heightPx) + ">";
        });

    m.def(
        "load_scene",
        [](const std::string& path) {
            py::gil_scoped_release release;
            return loadScene(path);
        },
        py::arg("path"), "a scene file (JSON, docs/scene-format.md)");
    m.def("default_scene", &defaultScene, "the embedded default scene (docs/examples/default.json)");
    m.def("default_scene_text", [] { return std::string(defaultSceneText()); }, "the default scene's JSON text");
    m.def(
        "parse_scene",
        [](const std::string& text, const std::string& fileName, const std::string& baseDir) {
            return parseSceneText(text, fileName, baseDir);
        },
        py::arg("text"), py::kw_only(), py::arg("file_name") = "<string>", py::arg("base_dir") = "",
        "a scene from JSON text; relative lens and data paths are resolved against base_dir");

    m.def("preview", &preview, py::arg("scene"), py::kw_only(), py::arg("layers") = false, py::arg("threads") = 0,
          py::arg("diffraction") = py::none(), py::arg("passes") = PreviewBudget::kDefaultPasses, py::arg("time") = 0.0,
          py::arg("seed") = py::none(), py::arg("higher") = false,
          "The ghost preview, as `flare preview`: the final render's first `passes` passes of beams without photons "
          "(or as many as fit in `time` seconds; the same seed and passes give the same image; `higher` adds the "
          "order-4 chains). Its per-ghost layers as with --float-layers: a dict "
          "of float32 arrays (height, width, 3), linear Rec.709 RGB in W/m2, keyed by EXR layer name: '' (the main "
          "image, with the starburst in place of the direct image when diffraction is on), then with layers=True "
          "'direct', 'starburst', 'ghost' and one per kept ghost ('ghost_03_07', ...) as a Footprint (its pixels over the "
          "bounding box of the pixels it reaches); layers='top:N' or 'share:F' keeps the N strongest ghosts, or the "
          "strongest until they hold F of the ghosts' power, and sums the others in 'ghost_other', as --layers does. "
          "diffraction: None takes the scene's render.diffraction, False is --no-diffraction");
    m.def(
        "render",
        [](const Scene& scene, std::optional<std::int64_t> photons, std::optional<double> timeS, double targetError,
           std::optional<std::uint64_t> seed, int threads, const std::string& mode, const py::object& layers,
           std::optional<int> maxBounces, const std::string& higherOrderChoice, const std::string& kernelChoice,
           double radiusPx, int smoothNeighbours, std::optional<double> interiorAlbedo, std::optional<bool> diffraction,
           bool analogStray, int beamReplicates) {
            if (beamReplicates < 2 || beamReplicates > kMaxReplicates)
                throw py::value_error("beam_replicates must be in [2, " + std::to_string(kMaxReplicates) + "]");
            SceneRenderOverrides overrides;
            overrides.mode = renderMode(mode);
            overrides.seed = seed;
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
            return render(withDiffraction(scene, diffraction), RenderArguments{photons, timeS, targetError, threads},
                          overrides);
        },
        py::arg("scene"), py::kw_only(), py::arg("photons") = py::none(), py::arg("time_s") = py::none(),
        py::arg("target_error") = 0.02, py::arg("seed") = py::none(), py::arg("threads") = 0,
        py::arg("mode") = "guided", py::arg("layers") = false, py::arg("max_bounces") = py::none(),
        py::arg("higher_order") = "auto", py::arg("kernel") = "fixed", py::arg("radius_px") = 1.0,
        py::arg("smooth_neighbours") = 256, py::arg("interior_albedo") = py::none(), py::arg("diffraction") = py::none(),
        py::arg("analog_stray") = false, py::arg("beam_replicates") = 2,
        "The physically based render, as `flare render` with the same options and defaults (it stops at the target "
        "error, time_s or photons, whichever comes first; without either limit at the scene's photon count): a dict "
        "of float32 arrays (height, width, 3) keyed by EXR layer name: '' (the sum, the starburst in place of the "
        "direct layer when diffraction is on), 'direct', 'ghost', 'higher', 'scatter', per-ghost (each a Footprint) and "
        "per-scatter-source layers with layers=True ('top:N' or 'share:F' as --layers), 'starburst' with diffraction, "
        "then 'variance' when estimated. "
        "diffraction: None takes the scene's render.diffraction, False is --no-diffraction. The "
        "image depends on the seed, never on the thread count.");
    m.def(
        "compare",
        [](const py::object& a, const py::object& b, const std::string& layer) {
            const ImageLayer imageA = comparedImage(a, layer, "a");
            const ImageLayer imageB = comparedImage(b, layer, "b");
            return toPython(imageComparisonJson(compareImages(imageA, imageB, imageLabel(a, "A"), imageLabel(b, "B"))));
        },
        py::arg("a"), py::arg("b"), py::kw_only(), py::arg("layer") = "",
        "Error metrics of image a against the reference b, as `flare compare --json` (without the file names): each "
        "an EXR path (its layer `layer`, '' = the main image) or a float array (height, width, 3)");
    m.def(
        "read_exr",
        [](const std::string& path) {
            ExrImage image;
            {
                py::gil_scoped_release release;
                image = readExrImage(path);
            }
            return toDict(std::move(image.layers), image.width, image.height, image.ownParts);
        },
        py::arg("path"),
        "every RGB layer of an EXR keyed by layer name: a float32 array (height, width, 3) for a layer over the "
        "whole frame, a Footprint for one over a window of it (the per-ghost parts of --layers)");
}
