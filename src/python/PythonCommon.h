// What the parts of the Python module share (docs/python.md): conversions between the engine's
// values and Python's, argument checks that refuse what the CLI refuses with a ValueError naming
// the argument, and running engine work without the GIL with its warnings turned into Python
// warnings (flare.FlareWarning) instead of lines on stderr.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <tbb/global_control.h>

#include <nlohmann/json.hpp>

#include "flare/core/Warnings.h"
#include "flare/film/ImageIO.h"
#include "flare/film/LayerSelection.h"
#include "flare/optics/LensPrescription.h"
#include "flare/optics/LensSystem.h"
#include "flare/scene/Scene.h"

namespace flare::python {

namespace py = pybind11;

py::object toPython(const nlohmann::json& j);
py::array_t<float> toArray(const ImageLayer& layer);

// A layer over a window of its frame (a ghost's footprint): its pixels, where they lie, and the
// whole frame on request (flare.Footprint).
struct Footprint {
    std::string name;
    int x = 0, y = 0, frameWidth = 0, frameHeight = 0;
    py::array_t<float> rgb;

    py::array_t<float> full() const;
};
void registerFootprint(py::module_& m);

// The layers as Python values, each layer's memory released once copied (one copy at a time): a
// Footprint for a layer over a window of the frame or named in `footprints` (the per-ghost layers,
// which an EXR holds in parts of their own, even where one covers the frame), else an array.
py::dict toDict(std::vector<ImageLayer> layers, int frameWidth, int frameHeight, const std::set<std::string>& footprints);
// An engine's images (the first the whole frame): the per-ghost layers (ghost_...) as Footprints.
py::dict toDict(std::vector<ImageLayer> layers);

// `layers=` of preview and render: False, True (every ghost), or "all", "top:N", "share:F".
std::optional<LayerSelection> layerSelection(const py::object& layers);

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;
// An array of shape (height, width, 3) as a layer named `name`; `label` names it in errors.
ImageLayer fromArray(const FloatArray& array, const std::string& name, const std::string& label);

inline void require(bool condition, const std::string& message) {
    if (!condition) throw py::value_error(message);
}

// `threads`: 0 for all cores, else a positive count of TBB workers, limited for the lifetime of the
// returned object; a negative count is refused (as `--threads` refuses it).
std::unique_ptr<tbb::global_control> limitThreads(int threads);

// A seed: None (the scene's) or an integer in [0, 2^64) (as `--seed`); anything else is refused
// with a ValueError or TypeError naming `name`.
std::optional<std::uint64_t> checkedSeed(const py::object& seed, const char* name = "seed");

// A wavelength in [300, 2000] nm, the range `flare lens info --wavelength` and `flare ghosts
// --wavelength` take (the glass data do not reach further).
double checkedWavelengthNm(double wavelengthNm, const char* name = "wavelength_nm");

// A zoom position: a name, or a focal length in mm given as a number or as text (the scene's
// "zoom" and `--zoom` alike); "" or None: the first position.
std::string zoomText(const py::object& zoom);

// The category of the engine's warnings in Python (a UserWarning).
extern PyObject* gFlareWarning;

// Issues each warning through Python's `warnings` (category flare.FlareWarning). When a filter
// turns it into an error, throws error_already_set, unless `whileUnwinding` (another exception is
// already on its way; the warning's error is then dropped).
void issueWarnings(const std::vector<std::string>& warnings, bool whileUnwinding = false);

// Runs `work` without the GIL, capturing the engine's warnings on this thread and issuing them as
// Python warnings afterwards (also when `work` throws).
template <class Work>
auto runEngine(Work&& work) -> std::invoke_result_t<Work&> {
    WarningCapture capture;
    try {
        if constexpr (std::is_void_v<std::invoke_result_t<Work&>>) {
            {
                py::gil_scoped_release release;
                work();
            }
            issueWarnings(capture.take());
        } else {
            auto result = [&] {
                py::gil_scoped_release release;
                return work();
            }();
            issueWarnings(capture.take());
            return result;
        }
    } catch (const py::error_already_set&) {
        throw;
    } catch (...) {
        issueWarnings(capture.take(), /*whileUnwinding=*/true);
        throw;
    }
}

// A lens at one zoom/focus/f-stop state, with the prescription it was built from (the lens
// information reports the file's nominal values).
struct Lens {
    LensPrescription prescription;
    LensSystem system;
};

py::class_<Scene> registerScene(py::module_& m);
void registerRender(py::module_& m);

}  // namespace flare::python
