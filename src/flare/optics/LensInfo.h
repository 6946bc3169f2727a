// What `flare lens info --json` prints and the Python module's Lens.info returns: the lens's
// paraxial data (Paraxial.h), its real field of view, sensor, iris and surface table, at one
// wavelength.
#pragma once

#include <nlohmann/json.hpp>

#include "flare/optics/LensPrescription.h"
#include "flare/optics/LensSystem.h"

namespace flare {

// `lens` is built from `prescription` (at any state).
nlohmann::json lensInfoJson(const LensPrescription& prescription, const LensSystem& lens, double wavelengthNm);

}  // namespace flare
