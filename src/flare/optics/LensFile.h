// Reading lens prescriptions: the native `.lens` format (docs/lens-format.md), pbrt's four-column
// `.dat` files (PbrtLensFile.h) and Zemax OpticStudio `.zmx` files (ZemaxFile.h). Every problem
// raises InputError naming the file and line.
#pragma once

#include <string>
#include <string_view>

#include "flare/optics/LensPrescription.h"

namespace flare {

// Chooses the reader by extension, in any case (`.dat`: pbrt; `.zmx`: Zemax; anything else: native).
LensPrescription loadLensFile(const std::string& path);

// A path, or the name of a shipped lens (e.g. "double-gauss-50mm", with or without ".lens") when no
// file of that name exists: the embedded copy is parsed; else the id of a library lens
// (LensLibrary.h), whose file is read.
LensPrescription loadLens(const std::string& pathOrName);

// Why `name` (no file here) names no lens: the shipped names, the library searched and the ids
// nearest to it (or the id it was renamed to).
std::string unknownLensProblem(const std::string& name);

// Parses text already in memory; `fileName` is used in error messages and as the source file.
// (pbrt's and Zemax's text: parsePbrtLensText in PbrtLensFile.h, parseZemaxText in ZemaxFile.h.)
LensPrescription parseLensText(std::string_view text, const std::string& fileName);

// One header line of the native format (e.g. "iris blades=7 rotation_deg=10", "coating ar1 single
// n=1.38 quarter_wave_nm=550") applied to `p`, checked as in a .lens file; errors name `fileName`
// and `line`. The Zemax reader takes flare's own lines from the notes it writes (ZemaxFile.h).
void parseLensHeaderLine(LensPrescription& p, std::string_view text, const std::string& fileName, int line);

// The checks every reader makes once its rows are read: each row's semi-aperture within its
// surface, one stop that does not change the medium, known gaps and coatings, dirt where it can
// settle, air after the last row, and every zoom position builds (no crossing surfaces). Raises
// InputError naming p.sourceFile and the row's line (`lastLine` where no row is to blame).
void validatePrescription(const LensPrescription& p, int lastLine);

}  // namespace flare
