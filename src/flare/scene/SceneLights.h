// The "lights" of a scene file: directional, point and disk lights with their spectra, read from
// the scene's JSON tree into LightSpec (photons/Light.h), every value checked.
#pragma once

#include <cstddef>
#include <string>

#include "flare/photons/Light.h"
#include "flare/scene/SceneChecker.h"

namespace flare::scenefile {

// A spectrum: "d65", "equal_energy" or { "blackbody_k": T }.
SpectrumSpec parseSpectrum(const Checker& c, const Node& node, const std::string& path);
// The light at `path` (lights[i]); its name defaults to "light<i>".
LightSpec parseLight(const Checker& c, const Node& node, const std::string& path, std::size_t i);

}  // namespace flare::scenefile
