// The Python module `flare` (docs/python.md): the engine driven as the CLI drives it, through the
// same engine functions, so that a ghost table, preview or render from Python equals the CLI's
// JSON and EXR value for value (tests/python/test_flare_module.py checks it). Images are NumPy
// float32 arrays (height × width × 3, linear Rec.709 RGB) keyed by their EXR layer names; reports
// are dicts with the keys of the CLI's JSON. The GIL is released while the engine works, its
// input errors (InputError: "file:line: problem") become ValueError and its warnings Python
// warnings (flare.FlareWarning). This file: the module, lenses, the library, images; scenes are in
// PythonScene.cpp, the preview, render and EXR writer in PythonRender.cpp. flare.pyi, copied
// beside the module, gives editors its signatures.
#include <optional>
#include <string>
#include <vector>

#include <pybind11/stl.h>

#include "PythonCommon.h"
#include "flare/core/Error.h"
#include "flare/film/ImageCompare.h"
#include "flare/ghosts/GhostAnalysis.h"
#include "flare/ghosts/GhostTable.h"
#include "flare/optics/AgfCatalog.h"
#include "flare/optics/EmbeddedLenses.h"
#include "flare/optics/Glass.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/LensInfo.h"
#include "flare/optics/LensLibrary.h"
#include "flare/optics/Paraxial.h"
#include "flare/optics/PupilGrid.h"
#include "flare/scene/Scene.h"

#ifndef FLARE_VERSION
#error "FLARE_VERSION (the project's version) comes from CMake"
#endif

namespace flare::python {

namespace {

// glass_catalog: None, one .agf path or a list of them (`--glass-catalog`).
std::vector<std::string> glassCatalogPaths(const py::object& catalogs) {
    if (catalogs.is_none()) return {};
    if (py::isinstance<py::str>(catalogs)) return {catalogs.cast<std::string>()};
    if (py::isinstance<py::sequence>(catalogs)) return catalogs.cast<std::vector<std::string>>();
    throw py::type_error("glass_catalog: a .agf file's path, a list of them, or None");
}

Lens loadLensAtState(const std::string& lens, const py::object& zoom, std::optional<double> focusMm,
                     std::optional<double> fNumber, const py::object& glassCatalog) {
    // Checked as `--focus` and `--f-number` are.
    require(!focusMm || *focusMm > 0.0, "focus_mm must be positive");
    require(!fNumber || *fNumber > 0.0, "f_number must be positive");
    const LensState state{zoomText(zoom), focusMm, fNumber};
    const std::vector<std::string> catalogs = glassCatalogPaths(glassCatalog);
    return runEngine([&] {
        for (const std::string& catalog : catalogs) useGlassCatalog(catalog);
        LensPrescription prescription = loadLens(lens);
        LensSystem system = LensSystem::build(prescription, state);
        return Lens{std::move(prescription), std::move(system)};
    });
}

std::optional<glm::dvec3> fieldDirection(const std::optional<std::vector<double>>& fieldDeg) {
    if (!fieldDeg) return std::nullopt;
    require(!fieldDeg->empty() && fieldDeg->size() <= 2, "field_deg: one or two angles (X[, Y]) in degrees");
    for (double angle : *fieldDeg) require(angle >= -89.0 && angle <= 89.0, "field_deg: each angle in [-89, 89]");
    return directionFromFieldDeg((*fieldDeg)[0], fieldDeg->size() > 1 ? (*fieldDeg)[1] : 0.0);
}

GhostAnalysisOptions ghostOptions(int order, double wavelengthNm, bool sensorGhosts) {
    require(order == 2 || order == 4, "order: 2 or 4");
    GhostAnalysisOptions options;
    options.order = order;
    options.wavelengthNm = checkedWavelengthNm(wavelengthNm);
    options.includeSensor = sensorGhosts;
    return options;
}

py::object ghostTable(const LensSystem& lens, const glm::dvec3& direction, const GhostAnalysisOptions& options,
                      bool all) {
    return toPython(runEngine(
        [&] { return ghostTableJson(lens, direction, options, analyseGhosts(lens, direction, options), all); }));
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
    const LensSystem lens = runEngine([&] { return buildSceneLens(scene); });
    return ghostTable(lens, direction, options, all);
}

// An EXR path (its layer `layer`) or an array of shape (height, width, 3).
ImageLayer comparedImage(const py::object& image, const std::string& layer, const std::string& label) {
    if (py::isinstance<py::str>(image)) {
        const std::string path = image.cast<std::string>();
        return runEngine([&] { return readExrLayer(path, layer); });
    }
    return fromArray(image.cast<FloatArray>(), "", label);
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

// One library lens as `flare lens list --json` prints it (the test checks that they agree).
py::dict libraryLensDict(const LibraryLens& lens) {
    py::dict d;
    d["id"] = lens.id;
    d["maker"] = lens.maker;
    d["model"] = lens.model;
    d["name"] = lens.name;
    d["kind"] = lens.kind;
    d["tags"] = lens.tags;
    d["focal_length_mm"] = lens.focalLengthMm;
    d["focal_range_mm"] = std::vector<double>{lens.focalMinMm, lens.focalMaxMm};
    d["f_number"] = lens.fNumber;
    d["patent"] = lens.patent;
    d["example"] = lens.example;
    d["collection"] = lens.collection;
    d["file"] = lens.path;
    if (!lens.zoomPositions.empty()) {
        d["zoom_positions"] = lens.zoomPositions;
        d["zoom_focal_lengths_mm"] = lens.zoomFocalLengthsMm;
    }
    if (lens.zoomRangeMm) d["zoom_range_mm"] = std::vector<double>{lens.zoomRangeMm->first, lens.zoomRangeMm->second};
    if (!lens.renamedFrom.empty()) d["renamed_from"] = lens.renamedFrom;
    return d;
}

py::list libraryLensList(const std::vector<const LibraryLens*>& lenses) {
    py::list list;
    for (const LibraryLens* lens : lenses) list.append(libraryLensDict(*lens));
    return list;
}

// As `flare lens list [--maker M] [--focal MIN-MAX] [--f-number N]`; focal_mm: one focal length or
// (min, max), either end None for open.
py::list lensList(const std::string& maker, const py::object& focalMm, std::optional<double> fNumber) {
    LibraryFilter filter;
    filter.maker = maker;
    if (fNumber) {
        require(*fNumber > 0.0, "f_number must be positive");
        filter.maxFNumber = fNumber;
    }
    auto focal = [](const py::handle value) -> std::optional<double> {
        if (value.is_none()) return std::nullopt;
        const double mm = value.cast<double>();
        require(mm > 0.0, "focal_mm: focal lengths in mm must be positive");
        return mm;
    };
    if (!focalMm.is_none()) {
        if (py::isinstance<py::tuple>(focalMm) || py::isinstance<py::list>(focalMm)) {
            const py::sequence range = focalMm.cast<py::sequence>();
            require(range.size() == 2, "focal_mm: one focal length or (min, max) in mm");
            filter.focalMinMm = focal(range[0]);
            filter.focalMaxMm = focal(range[1]);
            require(!filter.focalMinMm || !filter.focalMaxMm || *filter.focalMinMm <= *filter.focalMaxMm,
                    "focal_mm: (min, max) with min <= max");
        } else {
            filter.focalMinMm = filter.focalMaxMm = focal(focalMm);
        }
    }
    const LensLibrary& library = *runEngine([] { return &LensLibrary::shared(); });
    return libraryLensList(library.filter(filter));
}

}  // namespace

}  // namespace flare::python

PYBIND11_MODULE(flare, m) {
    using namespace flare;
    using namespace flare::python;

    m.doc() = "Physically based lens flare: lenses, ghost tables, previews and renders (docs/python.md)";
    m.attr("__version__") = FLARE_VERSION;

    // Registered translators are tried before pybind11's own, so InputError (a std::runtime_error)
    // becomes ValueError, while other engine exceptions keep pybind11's mapping.
    py::register_exception_translator([](std::exception_ptr error) {
        try {
            if (error) std::rethrow_exception(error);
        } catch (const InputError& e) {
            PyErr_SetString(PyExc_ValueError, e.what());
        }
    });
    gFlareWarning = PyErr_NewExceptionWithDoc(
        "flare.FlareWarning",
        "A problem the engine worked around with a stated fallback (an unknown Zemax keyword or coating, a light "
        "the render skipped, ...), issued through Python's warnings module.",
        PyExc_UserWarning, nullptr);
    m.attr("FlareWarning") = py::handle(gFlareWarning);

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

    py::class_<Lens>(m, "Lens", "A lens at one zoom/focus/f-stop state")
        .def_property_readonly("name", [](const Lens& l) { return l.system.name(); })
        .def_property_readonly("source_file", [](const Lens& l) { return l.system.sourceFile(); })
        .def_property_readonly("surface_count", [](const Lens& l) { return l.system.surfaceCount(); },
                               "surfaces in file order, counting the stop; the sensor is surface_count + 1")
        .def(
            "paraxial",
            [](const Lens& l, double wavelengthNm) { return analyseParaxial(l.system, checkedWavelengthNm(wavelengthNm)); },
            py::arg("wavelength_nm") = kLineDNm,
            "Paraxial data at a wavelength in [300, 2000] nm (default: the d line, 587.56 nm), as `flare lens info`")
        .def(
            "info",
            [](const Lens& l, double wavelengthNm) {
                return toPython(lensInfoJson(l.prescription, l.system, checkedWavelengthNm(wavelengthNm)));
            },
            py::arg("wavelength_nm") = kLineDNm,
            "The dict `flare lens info --json` prints (wavelength_nm in [300, 2000], as --wavelength)")
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
          py::arg("focus_mm") = py::none(), py::arg("f_number") = py::none(), py::arg("glass_catalog") = py::none(),
          "A lens file (.lens, pbrt .dat, Zemax .zmx), a shipped lens name or a library id, at a zoom position (a "
          "name, or a focal length in mm: zoom=135 or '135'), focus (object distance in mm from the first vertex) "
          "and f-number, as LENS --zoom --focus --f-number. glass_catalog: a Zemax glass catalogue (.agf) of your "
          "own, or a list of them, as --glass-catalog: searched first by this and every later lens read. Warnings of "
          "the reader (a .zmx keyword left out) are issued as flare.FlareWarning.");
    m.def("lens_names", &lensNames, "The shipped lens names, then the library's ids.");
    m.def("lens_list", &lensList, py::kw_only(), py::arg("maker") = "", py::arg("focal_mm") = py::none(),
          py::arg("f_number") = py::none(),
          "The library's lenses as `flare lens list --json` lists them (a dict per lens: id, maker, model, name, kind, "
          "tags, focal_length_mm, focal_range_mm, f_number, patent, example, collection, file, zoom_positions and "
          "zoom_focal_lengths_mm for a zoom with positions, zoom_range_mm for a file holding one state of a zoom, "
          "renamed_from for a renamed id), filtered as --maker (exact, case-insensitive), --focal (focal_mm: one focal "
          "length, or (min, max) with None for an open end; a file matches a focal length it can be set to) and "
          "--f-number (at least this fast).");
    m.def(
        "lens_search", [](const std::string& text) { return libraryLensList(LensLibrary::shared().search(text)); },
        py::arg("text"),
        "Library lenses whose id, maker, model, name, patent or tags contain every word of text (case-insensitive), "
        "as `flare lens search TEXT --json`: a dict per lens as lens_list gives.");

    registerFootprint(m);
    py::class_<Scene> scene = registerScene(m);
    scene.def(
            "lens",
            [](const Scene& s) {
                return runEngine([&] {
                    for (const std::string& catalog : s.glassCatalogs) useGlassCatalog(catalog);
                    return Lens{loadLens(s.lens), buildSceneLens(s)};
                });
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
            "the ghost table: ghost_report(...)['ghosts'], strongest first");

    registerRender(m);
    m.def(
        "compare",
        [](const py::object& a, const py::object& b, const std::string& layer) {
            const ImageLayer imageA = comparedImage(a, layer, "a");
            const ImageLayer imageB = comparedImage(b, layer, "b");
            return toPython(imageComparisonJson(compareImages(imageA, imageB, imageLabel(a, "A"), imageLabel(b, "B"))));
        },
        py::arg("a"), py::arg("b"), py::kw_only(), py::arg("layer") = "",
        "Error metrics of image a against the reference b, as `flare compare --json` (without the file names): each "
        "an EXR path (its layer `layer`, '' = the main image) or a float array (height, width, 3).");
    m.def(
        "read_exr",
        [](const std::string& path) {
            ExrImage image = runEngine([&] { return readExrImage(path); });
            return toDict(std::move(image.layers), image.width, image.height, image.ownParts);
        },
        py::arg("path"),
        "Every RGB layer of an EXR keyed by layer name: a float32 array (height, width, 3) for a layer over the whole "
        "frame, a Footprint for one over a window of it (the per-ghost parts of --layers).");
}
