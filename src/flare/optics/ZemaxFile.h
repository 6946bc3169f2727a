// Zemax OpticStudio lens files (`.zmx`, sequential mode): read into the same LensPrescription the
// `.lens` reader produces, and written from one (docs/lens-format.md, "Zemax files").
//
// A .zmx file is a list of keyword lines: system lines (UNIT, NAME, GCAT, WAVM, ...), one `SURF n`
// block per surface from the object (surface 0) to the image (the last one), and after them the
// multi-configuration editor (MNUM, then one operand line per operand and configuration, e.g.
// `THIC surface configuration value ...`). The reader keeps what flare models: standard, even (and
// odd, when its odd terms are zero) aspheric surfaces, catalogue and model glasses, the stop,
// semi-diameters, the AR coating, and thicknesses that vary between configurations (a zoom). What
// would change the optics and cannot be kept (tilts, decentres, mirrors, other surface types,
// non-sequential mode, ...) raises InputError naming the file, the line, the surface and the
// keyword; what can be left out with a stated fallback (an unknown coating, an unknown keyword) is
// a warning naming the file and line. Coatings: AR and MGF2 (a quarter wave of MgF2 at the primary
// wavelength), NONE, and those flare's notes define. Glasses are looked up in the file's GCAT
// catalogues, then in every catalogue, the private ones given (useGlassCatalog, AgfCatalog.h) first.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "flare/optics/LensPrescription.h"

namespace flare {

// `bytes` in either encoding Zemax writes (UTF-16 LE with a byte-order mark, or 8-bit text).
// Warnings ("file:line: ...") go to `warnings`, or to flare::warn (core/Warnings.h: stderr unless
// captured) when it is null.
LensPrescription parseZemaxText(std::string_view bytes, const std::string& fileName,
                                std::vector<std::string>* warnings = nullptr);
LensPrescription loadZemaxFile(const std::string& path, std::vector<std::string>* warnings = nullptr);

// The prescription as .zmx text (UTF-8, CRLF line ends; encodeUtf16Le gives Zemax's own encoding),
// in millimetres at the first zoom position, every other position a configuration whose varying
// thicknesses are THIC operands. An `auto` last thickness is written as the distance the focus
// solve finds at each position. What a .zmx file cannot say is written as notes Zemax keeps and
// ignores (`NOTE 0 flare: ...`, lines of the native format) and parseZemaxText reads back: the iris
// (blades, rotation, curvature), the zoom positions' names and published focal lengths, and each
// coating's layers (mgf2 is written as Zemax's AR). The sensor, finishes and dirt are not written.
// Expects a prescription that builds (one the readers returned).
std::string writeZemax(const LensPrescription& prescription);

}  // namespace flare
