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

py::dict toDict(const std::vector<ImageLayer>& layers) {
    py::dict dict;
    for (const ImageLayer& layer : layers) dict[py::str(layer.name)] = toArray(layer);
    return dict;
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
