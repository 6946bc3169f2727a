// Reading lens prescriptions: the native `.lens` format (docs/lens-format.md) and pbrt's
// four-column `.dat` files. Every problem raises InputError naming the file and line.
#pragma once

#include <string>
#include <string_view>

#include "flare/optics/LensPrescription.h"

namespace flare {

// Chooses the reader by extension (`.dat`: pbrt; anything else: native).
LensPrescription loadLensFile(const std::string& path);

// A path, or the name of a shipped lens (e.g. "double-gauss-50mm", with or without ".lens") when no
// file of that name exists: the embedded copy is parsed; else the id of a library lens
// (LensLibrary.h), whose file is read.
LensPrescription loadLens(const std::string& pathOrName);

// Parses text already in memory; `fileName` is used in error messages and as the source file.
LensPrescription parseLensText(std::string_view text, const std::string& fileName);
LensPrescription parsePbrtLensText(std::string_view text, const std::string& fileName);

}  // namespace flare
