#include "PythonCommon.h"

#include <charconv>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace flare::python {

PyObject* gFlareWarning = nullptr;

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

py::array_t<float> Footprint::full() const {
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

void registerFootprint(py::module_& m) {
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
}

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

py::dict toDict(std::vector<ImageLayer> layers) {
    const int width = layers.empty() ? 0 : layers.front().width, height = layers.empty() ? 0 : layers.front().height;
    std::set<std::string> perGhost;
    for (const ImageLayer& layer : layers)
        if (layer.name.starts_with("ghost_")) perGhost.insert(layer.name);
    return toDict(std::move(layers), width, height, perGhost);
}

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

ImageLayer fromArray(const FloatArray& array, const std::string& name, const std::string& label) {
    if (array.ndim() != 3 || array.shape(2) != 3)
        throw py::value_error(label + ": expected an array of shape (height, width, 3)");
    require(array.shape(0) > 0 && array.shape(1) > 0, label + ": the image is empty");
    ImageLayer layer{name, static_cast<int>(array.shape(1)), static_cast<int>(array.shape(0)), {}};
    layer.rgb.assign(array.data(), array.data() + array.size());
    return layer;
}

std::unique_ptr<tbb::global_control> limitThreads(int threads) {
    require(threads >= 0, "threads: 0 (all cores) or a positive number of worker threads, got " +
                              std::to_string(threads));
    if (threads == 0) return nullptr;
    return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
}

std::optional<std::uint64_t> checkedSeed(const py::object& seed, const char* name) {
    if (seed.is_none()) return std::nullopt;
    if (!py::isinstance<py::int_>(seed) || py::isinstance<py::bool_>(seed))
        throw py::type_error(std::string(name) + ": an integer in [0, 2**64) or None, got " +
                             py::str(py::type::of(seed).attr("__name__")).cast<std::string>());
    const py::int_ value = seed.cast<py::int_>();
    if (value < py::int_(0) || value >= py::int_(1).attr("__lshift__")(64))
        throw py::value_error(std::string(name) + ": an integer in [0, 2**64), got " + py::str(seed).cast<std::string>());
    return PyLong_AsUnsignedLongLong(value.ptr());
}

double checkedWavelengthNm(double wavelengthNm, const char* name) {
    require(wavelengthNm >= 300.0 && wavelengthNm <= 2000.0,
            std::string(name) + ": in [300, 2000] nm (the glasses' data range), got " + py::str(py::float_(wavelengthNm)).cast<std::string>());
    return wavelengthNm;
}

std::string zoomText(const py::object& zoom) {
    if (zoom.is_none()) return "";
    if (py::isinstance<py::str>(zoom)) return zoom.cast<std::string>();
    if (py::isinstance<py::bool_>(zoom) || !(py::isinstance<py::int_>(zoom) || py::isinstance<py::float_>(zoom)))
        throw py::type_error("zoom: a position name or a focal length in mm, got " +
                             py::str(py::type::of(zoom).attr("__name__")).cast<std::string>());
    const double mm = zoom.cast<double>();
    require(std::isfinite(mm) && mm > 0.0 && mm <= 100000.0,
            "zoom: a focal length in (0, 100000] mm, got " + py::str(zoom).cast<std::string>());
    // The shortest text that reads back as the same number (135 -> "135", 70.5 -> "70.5").
    char text[32];
    const auto [end, ec] = std::to_chars(text, text + sizeof text, mm);
    return std::string(text, ec == std::errc() ? end : text);
}

void issueWarnings(const std::vector<std::string>& warnings, bool whileUnwinding) {
    for (const std::string& text : warnings) {
        if (PyErr_WarnEx(gFlareWarning, text.c_str(), 1) == 0) continue;
        if (whileUnwinding) {
            PyErr_Clear();
            continue;
        }
        throw py::error_already_set();
    }
}

}  // namespace flare::python
