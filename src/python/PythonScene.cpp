// flare.Scene: a scene read from a file, JSON text or a dict (docs/scene-format.md), with the
// settings a script changes most (lens and its state, resolution, render settings) settable. A
// value set is checked as the scene parser checks the key (same ranges), so that a scene that
// renders from Python would also load from a file.
#include <cmath>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <pybind11/stl.h>

#include "PythonCommon.h"
#include "flare/optics/LensFile.h"
#include "flare/scene/Scene.h"

namespace flare::python {

namespace {

// The scene parser's limits (Scene.cpp), for values set from Python.
constexpr int kMaxResolutionPx = 16384;
constexpr double kPixelAspectTolerance = 1e-3;

std::string text(double value) { return py::str(py::float_(value)).cast<std::string>(); }

void setResolution(Scene& s, int widthPx, int heightPx) {
    require(widthPx >= 1 && widthPx <= kMaxResolutionPx && heightPx >= 1 && heightPx <= kMaxResolutionPx,
            "resolution: (width_px, height_px), each in [1, " + std::to_string(kMaxResolutionPx) + "], got (" +
                std::to_string(widthPx) + ", " + std::to_string(heightPx) + ")");
    if (s.sensor.widthMm && s.sensor.heightMm) {
        const double pitchX = *s.sensor.widthMm / widthPx, pitchY = *s.sensor.heightMm / heightPx;
        require(std::abs(pitchX - pitchY) <= kPixelAspectTolerance * std::max(pitchX, pitchY),
                "resolution: " + std::to_string(widthPx) + " x " + std::to_string(heightPx) +
                    " px on the scene's " + text(*s.sensor.widthMm) + " x " + text(*s.sensor.heightMm) +
                    " mm sensor gives pixels that are not square; set sensor_size_mm first (or to None: the lens's "
                    "sensor)");
    }
    s.sensor.widthPx = widthPx;
    s.sensor.heightPx = heightPx;
}

void setSensorSize(Scene& s, const std::optional<std::pair<double, double>>& sizeMm) {
    if (!sizeMm) {
        s.sensor.widthMm.reset();
        s.sensor.heightMm.reset();
        return;
    }
    const auto [w, h] = *sizeMm;
    require(w > 0.0 && w <= 1000.0 && h > 0.0 && h <= 1000.0,
            "sensor_size_mm: (width, height), each in (0, 1000] mm, got (" + text(w) + ", " + text(h) + ")");
    s.sensor.widthMm = w;
    s.sensor.heightMm = h;
}

// A lens as a scene names it: an existing file (kept as an absolute path, so that a later change
// of folder does not lose it), a shipped lens name or a library id; checked by loading it.
void setLens(Scene& s, const std::string& lens) {
    require(!lens.empty(), "lens: a lens file, a shipped lens name or a library id");
    std::error_code ec;
    const bool file = std::filesystem::is_regular_file(lens, ec);
    runEngine([&] { (void)loadLens(lens); });
    s.lens = file ? std::filesystem::absolute(lens).string() : lens;
    s.lines.lens = 0;
}

// parse_scene's argument: JSON text, or a dict (any mapping json.dumps takes) written as JSON.
std::string sceneText(const py::object& scene) {
    if (py::isinstance<py::str>(scene)) return scene.cast<std::string>();
    if (py::isinstance<py::dict>(scene))
        return py::module_::import("json").attr("dumps")(scene, py::arg("indent") = 1).cast<std::string>();
    throw py::type_error("parse_scene: JSON text (str) or a dict, got " +
                         py::str(py::type::of(scene).attr("__name__")).cast<std::string>());
}

}  // namespace

py::class_<Scene> registerScene(py::module_& m) {
    py::class_<Scene> scene(m, "Scene",
                      "A scene (docs/scene-format.md): the lens and its zoom/focus/f-stop, the lights, the sensor and "
                      "the render settings. The lens, its state, the resolution, sensor size and render settings can "
                      "be set; each value is checked as the scene file's key is.");
    scene.def_property_readonly("source_file", [](const Scene& s) { return s.sourceFile; },
                               "the file the scene was read from (or the file_name given to parse_scene)")
        .def_property(
            "description", [](const Scene& s) { return s.description; },
            [](Scene& s, const std::string& d) { s.description = d; }, "free text")
        .def_property(
            "lens_name", [](const Scene& s) { return s.lens; }, &setLens,
            "the lens as the scene names it: a resolved path, a shipped lens name or a library id (set: a file, a "
            "shipped name or a library id, checked by loading it)")
        .def_property(
            "zoom", [](const Scene& s) { return s.lensState.zoom; },
            [](Scene& s, const py::object& zoom) {
                s.lensState.zoom = zoomText(zoom);
                s.lines.zoom = 0;
            },
            "the zoom position: a name, or a focal length in mm (a number or its text); '' or None: the first")
        .def_property(
            "focus_distance_mm", [](const Scene& s) { return s.lensState.objectDistanceMm; },
            [](Scene& s, std::optional<double> mm) {
                require(!mm || (*mm > 0.0 && (*mm <= 1e12 || std::isinf(*mm))),
                        "focus_distance_mm: a positive number of mm (math.inf: infinity) or None (the lens's), got " +
                            text(mm.value_or(0.0)));
                s.lensState.objectDistanceMm = mm;
                s.lines.focus = 0;
            },
            "object distance in mm from the first vertex (inf: infinity); None: the lens file's")
        .def_property(
            "f_number", [](const Scene& s) { return s.lensState.fNumber; },
            [](Scene& s, std::optional<double> n) {
                require(!n || (*n >= 0.5 && *n <= 128.0), "f_number: in [0.5, 128] or None (wide open), got " +
                                                              text(n.value_or(0.0)));
                s.lensState.fNumber = n;
                s.lines.fNumber = 0;
            },
            "stop the iris down to this f-number; None: wide open")
        .def_property(
            "resolution", [](const Scene& s) { return std::make_pair(s.sensor.widthPx, s.sensor.heightPx); },
            [](Scene& s, const std::pair<int, int>& r) { setResolution(s, r.first, r.second); },
            "(width_px, height_px), each in [1, 16384]; the pixels must stay square on the sensor")
        .def_property_readonly("width_px", [](const Scene& s) { return s.sensor.widthPx; })
        .def_property_readonly("height_px", [](const Scene& s) { return s.sensor.heightPx; })
        .def_property(
            "sensor_size_mm",
            [](const Scene& s) -> std::optional<std::pair<double, double>> {
                if (s.sensor.widthMm && s.sensor.heightMm) return std::make_pair(*s.sensor.widthMm, *s.sensor.heightMm);
                return std::nullopt;
            },
            &setSensorSize, "(width, height) in mm; None: the lens's sensor")
        .def_property_readonly("light_names",
                               [](const Scene& s) {
                                   std::vector<std::string> names;
                                   for (const LightSpec& light : s.lights) names.push_back(light.name);
                                   return names;
                               })
        .def_property(
            "photons", [](const Scene& s) { return s.render.photons; },
            [](Scene& s, long long photons) {
                require(photons >= 1 && photons <= 10'000'000'000'000LL,
                        "photons: in [1, 10^13], got " + std::to_string(photons));
                s.render.photons = photons;
            },
            "the render's photon budget (render.photons)")
        .def_property(
            "seed", [](const Scene& s) { return s.render.seed; },
            [](Scene& s, const py::object& seed) {
                const std::optional<std::uint64_t> value = checkedSeed(seed);
                require(value.has_value(), "seed: an integer in [0, 2**64), not None");
                s.render.seed = *value;
            },
            "the random seed (render.seed)")
        .def_property(
            "diffraction", [](const Scene& s) { return s.render.diffraction; },
            [](Scene& s, bool on) { s.render.diffraction = on; }, "the starburst (render.diffraction)")
        .def_property(
            "ghost_ringing", [](const Scene& s) { return s.render.ghostRinging; },
            [](Scene& s, bool on) { s.render.ghostRinging = on; },
            "the Fresnel ripples on the ghosts' rims (render.ghost_ringing)")
        .def_property(
            "beams_per_pass", [](const Scene& s) { return s.render.beamsPerPass; },
            [](Scene& s, int beams) {
                require(beams >= 16 && beams <= 65536, "beams_per_pass: in [16, 65536], got " + std::to_string(beams));
                s.render.beamsPerPass = beams;
            },
            "beams per pass and directional light (render.beams_per_pass)")
        .def_property(
            "ghost_order", [](const Scene& s) { return s.render.ghostOrder; },
            [](Scene& s, int order) {
                require(order == 2 || order == 4, "ghost_order: 2 or 4, got " + std::to_string(order));
                s.render.ghostOrder = order;
            },
            "reflections per enumerated ghost path (render.ghost_order): 2 or 4")
        .def("copy", [](const Scene& s) { return Scene(s); }, "an independent copy, to change without changing this one")
        .def("__copy__", [](const Scene& s) { return Scene(s); })
        .def("__deepcopy__", [](const Scene& s, const py::object&) { return Scene(s); }, py::arg("memo"))
        .def("__repr__", [](const Scene& s) {
            return "<flare.Scene " + s.sourceFile + ", lens " + s.lens + ", " + std::to_string(s.sensor.widthPx) +
                   "x" + std::to_string(s.sensor.heightPx) + ">";
        });

    m.def(
        "load_scene", [](const std::string& path) { return runEngine([&] { return loadScene(path); }); },
        py::arg("path"), "A scene file (JSON, docs/scene-format.md); relative paths in it are resolved against its folder.");
    m.def("default_scene", &defaultScene, "The embedded default scene (docs/examples/default.json).");
    m.def(
        "default_scene_text", [] { return std::string(defaultSceneText()); },
        "The default scene's JSON text (json.loads gives the dict parse_scene takes).");
    m.def(
        "parse_scene",
        [](const py::object& scene, const std::string& fileName, const std::string& baseDir) {
            const std::string text = sceneText(scene);
            return runEngine([&] { return parseSceneText(text, fileName, baseDir); });
        },
        py::arg("scene"), py::kw_only(), py::arg("file_name") = "<string>", py::arg("base_dir") = "",
        "A scene from JSON text or a dict with the scene file's keys (docs/scene-format.md). Errors name file_name "
        "and the line (for a dict, of its JSON text as json.dumps(scene, indent=1) writes it) and the key; relative "
        "lens and data paths are resolved against base_dir ('' = the current folder).");
    return scene;
}

}  // namespace flare::python
