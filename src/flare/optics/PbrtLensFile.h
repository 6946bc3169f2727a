// pbrt's four-column lens files (`*.NNmm.dat`, docs/lens-format.md, "pbrt lens files"): one row
// per surface, `radius thickness index aperture-diameter`, read into the LensPrescription the
// `.lens` reader produces. loadLensFile (LensFile.h) chooses this reader for a `.dat` file.
#pragma once

#include <string>
#include <string_view>

#include "flare/optics/LensPrescription.h"

namespace flare {

// Parses text already in memory; `fileName` is used in error messages, as the source file and,
// without its directory and ".dat", as the lens's name. A radius of 0 is the stop, an index of 0
// or 1 is air, and the last thickness is replaced by the focus solve's (pbrt's is no sensor
// distance). Every problem raises InputError naming the file and line.
LensPrescription parsePbrtLensText(std::string_view text, const std::string& fileName);

}  // namespace flare
