// The colour space of a plate (`flare composite`): a linear RGB space known by its matrix to CIE
// 1931 XYZ. It comes from the EXR's `chromaticities` attribute, or by name: ACEScg, ACES2065-1 and
// linear Rec.709/sRGB are known without a config; any other name is looked up in the OpenColorIO
// config that $OCIO names, related to XYZ through the config's `cie_xyz_d65_interchange` role (or
// its `aces_interchange` role, ACES2065-1). Compositing adds light, which is only right in a linear
// space: a name whose transform to XYZ is not a matrix (a log or display space) is refused.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <glm/mat3x3.hpp>

namespace flare {

struct PlateColourSpace {
    std::string name;          // as reported ("ACEScg", "linear Rec.709", a config's name, ...)
    std::string source;        // how it was found: "the file's chromaticities", "--colorspace", ...
    glm::dmat3 toXyz{1.0};     // plate RGB → XYZ (RGB (1, 1, 1) is the white at Y = 1)
    glm::dmat3 fromXyz{1.0};
    // CIE xy of red, green, blue and white (the EXR attribute's order), from the matrix.
    std::array<double, 8> chromaticities{};
};

// The space of primaries and white given as CIE xy (red, green, blue, white).
PlateColourSpace colourSpaceFromChromaticities(const std::array<double, 8>& xy, const std::string& name,
                                               const std::string& source);
// The space of a matrix to XYZ (its chromaticities derived from it).
PlateColourSpace colourSpaceFromMatrix(const glm::dmat3& toXyz, const std::string& name, const std::string& source);

// The names known without a config (case, spaces, '-', '_' and '.' ignored when matching).
std::vector<std::string> builtinColourSpaceNames();

// `name` resolved: first in the $OCIO config when one is set and names it, then among the
// built-in names. An unknown name, a config that cannot be read or relate the space to XYZ, or a
// space that is not linear raises InputError(optionName, 0, ...) listing the names there are.
PlateColourSpace resolveColourSpace(const std::string& name, const std::string& optionName = "--colorspace");

// A known name for these chromaticities (within 2e-4 in xy), or "".
std::string knownColourSpaceName(const std::array<double, 8>& xy);

}  // namespace flare
