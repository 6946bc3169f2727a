#include "flare/scene/PlateColourSpace.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <optional>

#include <OpenColorIO/OpenColorIO.h>
#include <glm/matrix.hpp>

#include "flare/core/Error.h"
#include "flare/core/NearestNames.h"
#include "flare/core/Spectrum.h"

namespace OCIO = OCIO_NAMESPACE;

namespace flare {

namespace {

// Published primaries and white (CIE xy): ACES AP1 (ACEScg) and AP0 (ACES2065-1), SMPTE ST
// 2065-1 and Academy S-2014-004, white the ACES white (≈ D60); Rec.709 from Spectrum.h.
constexpr std::array<double, 8> kAp1 = {0.713, 0.293, 0.165, 0.830, 0.128, 0.044, 0.32168, 0.33767};
constexpr std::array<double, 8> kAp0 = {0.7347, 0.2653, 0.0, 1.0, 0.0001, -0.0770, 0.32168, 0.33767};
constexpr std::array<double, 8> kRec709 = {kRec709RedXy[0],  kRec709RedXy[1],  kRec709GreenXy[0], kRec709GreenXy[1],
                                           kRec709BlueXy[0], kRec709BlueXy[1], kD65WhiteXy[0],    kD65WhiteXy[1]};

struct Builtin {
    const char* name;
    std::array<double, 8> xy;
    std::vector<const char*> aliases;  // compared as key()s
};
const std::vector<Builtin>& builtins() {
    static const std::vector<Builtin> list = {
        {"ACEScg", kAp1, {"acescg", "linap1", "acesacescg", "linearap1"}},
        {"ACES2065-1", kAp0, {"aces20651", "linap0", "acesaces20651", "linearap0"}},
        {"linear Rec.709", kRec709,
         {"linearrec709", "linrec709", "linsrgb", "linearsrgb", "srgblinear", "rec709linear", "linearrec709srgb",
          "scenelinearrec709srgb", "lin709"}},
    };
    return list;
}

// Lower case, letters and digits only: "ACES - ACEScg" and "acescg" match.
std::string key(const std::string& name) {
    std::string k;
    for (char c : name)
        if (std::isalnum(static_cast<unsigned char>(c))) k += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return k;
}

glm::dvec3 xyToXyz(double x, double y) { return {x / y, 1.0, (1.0 - x - y) / y}; }

// Applies a CPU processor to one RGB triple.
glm::dvec3 applyProcessor(const OCIO::ConstCPUProcessorRcPtr& cpu, const glm::dvec3& rgb) {
    float p[3] = {static_cast<float>(rgb.x), static_cast<float>(rgb.y), static_cast<float>(rgb.z)};
    cpu->applyRGB(p);
    return {p[0], p[1], p[2]};
}

// The config's space `name` as a matrix to XYZ, or nothing when the config does not name it.
std::optional<PlateColourSpace> fromConfig(const std::string& name, const std::string& optionName,
                                           std::vector<std::string>* configNames) {
    const char* env = std::getenv("OCIO");
    if (!env || !*env) return std::nullopt;
    OCIO::ConstConfigRcPtr config;
    try {
        config = OCIO::Config::CreateFromEnv();
    } catch (const OCIO::Exception& e) {
        throw InputError(env, 0, std::string("the OpenColorIO config ($OCIO) cannot be read: ") + e.what());
    }
    for (int i = 0; i < config->getNumColorSpaces(); ++i) configNames->push_back(config->getColorSpaceNameByIndex(i));
    if (!config->getColorSpace(name.c_str())) return std::nullopt;
    // XYZ through the config's interchange roles (OCIO 2.1 configs define one or both).
    const bool xyzRole = config->hasRole("cie_xyz_d65_interchange");
    const bool acesRole = config->hasRole("aces_interchange");
    if (!xyzRole && !acesRole)
        throw InputError(optionName, 0,
                         "the OpenColorIO config " + std::string(env) + " has neither a cie_xyz_d65_interchange nor an "
                         "aces_interchange role, so its space '" + name + "' cannot be related to CIE XYZ");
    OCIO::ConstCPUProcessorRcPtr cpu;
    try {
        cpu = config->getProcessor(name.c_str(), xyzRole ? "cie_xyz_d65_interchange" : "aces_interchange")
                  ->getDefaultCPUProcessor();
    } catch (const OCIO::Exception& e) {
        throw InputError(optionName, 0, "OpenColorIO cannot convert '" + name + "' to CIE XYZ: " + e.what());
    }
    glm::dmat3 m;
    const glm::dvec3 zero = applyProcessor(cpu, glm::dvec3(0.0));
    for (int k = 0; k < 3; ++k) {
        glm::dvec3 unit(0.0);
        unit[k] = 1.0;
        m[k] = applyProcessor(cpu, unit) - zero;
    }
    // Linear (a matrix) within float rounding, over HDR values too; else adding light is wrong.
    const glm::dvec3 probes[] = {{0.25, 2.5, 7.0}, {120.0, 0.5, 40.0}, {0.01, 0.02, 0.005}};
    for (const glm::dvec3& probe : probes) {
        const glm::dvec3 got = applyProcessor(cpu, probe);
        const glm::dvec3 want = m * probe;
        const double scale = std::max({std::abs(want.x), std::abs(want.y), std::abs(want.z), 1e-6});
        if (glm::length(zero) > 1e-6 || glm::length(got - want) > 1e-4 * scale)
            throw InputError(optionName, 0,
                             "the colour space '" + name + "' of the OpenColorIO config is not scene-linear (its transform "
                             "to CIE XYZ is not a matrix): light adds up only in a linear space");
    }
    if (!xyzRole) m = colourSpaceFromChromaticities(kAp0, "", "").toXyz * m;
    return colourSpaceFromMatrix(m, name, std::string("the OpenColorIO config ") + env);
}

}  // namespace

PlateColourSpace colourSpaceFromMatrix(const glm::dmat3& toXyz, const std::string& name, const std::string& source) {
    PlateColourSpace s;
    s.name = name;
    s.source = source;
    s.toXyz = toXyz;
    s.fromXyz = glm::inverse(toXyz);
    const glm::dvec3 columns[4] = {toXyz[0], toXyz[1], toXyz[2], toXyz * glm::dvec3(1.0)};
    for (int i = 0; i < 4; ++i) {
        const double sum = columns[i].x + columns[i].y + columns[i].z;
        s.chromaticities[2 * i] = columns[i].x / sum;
        s.chromaticities[2 * i + 1] = columns[i].y / sum;
    }
    return s;
}

PlateColourSpace colourSpaceFromChromaticities(const std::array<double, 8>& xy, const std::string& name,
                                               const std::string& source) {
    // Columns: the primaries' XYZ at Y = 1, scaled so that RGB (1, 1, 1) is the white at Y = 1.
    const glm::dmat3 primaries(xyToXyz(xy[0], xy[1]), xyToXyz(xy[2], xy[3]), xyToXyz(xy[4], xy[5]));
    if (glm::determinant(primaries) == 0.0 || xy[7] == 0.0)
        throw InputError(source, 0, "the chromaticities do not span a colour space (degenerate primaries)");
    const glm::dvec3 scale = glm::inverse(primaries) * xyToXyz(xy[6], xy[7]);
    PlateColourSpace s = colourSpaceFromMatrix(
        glm::dmat3(primaries[0] * scale.x, primaries[1] * scale.y, primaries[2] * scale.z), name, source);
    s.chromaticities = xy;  // exactly as given
    return s;
}

std::vector<std::string> builtinColourSpaceNames() {
    std::vector<std::string> names;
    for (const Builtin& b : builtins()) names.push_back(b.name);
    return names;
}

std::string knownColourSpaceName(const std::array<double, 8>& xy) {
    for (const Builtin& b : builtins()) {
        bool same = true;
        for (int i = 0; i < 8; ++i) same = same && std::abs(xy[i] - b.xy[i]) < 2e-4;
        if (same) return b.name;
    }
    return "";
}

PlateColourSpace resolveColourSpace(const std::string& name, const std::string& optionName) {
    std::vector<std::string> configNames;
    if (std::optional<PlateColourSpace> s = fromConfig(name, optionName, &configNames)) return *s;
    const std::string k = key(name);
    for (const Builtin& b : builtins()) {
        bool match = key(b.name) == k;
        for (const char* alias : b.aliases) match = match || k == alias;
        if (match) return colourSpaceFromChromaticities(b.xy, b.name, optionName);
    }
    std::vector<std::string> all = builtinColourSpaceNames();
    all.insert(all.end(), configNames.begin(), configNames.end());
    std::string message = "unknown colour space '" + name + "'";
    const std::vector<std::string> near = nearestNames(name, all, 3);
    if (!near.empty()) {
        message += " (did you mean";
        for (size_t i = 0; i < near.size(); ++i) message += (i ? ", '" : " '") + near[i] + "'";
        message += "?)";
    }
    message += "; known without a config: ";
    for (size_t i = 0; i < builtins().size(); ++i) message += (i ? ", " : "") + std::string(builtins()[i].name);
    message += configNames.empty() ? "; set $OCIO to an OpenColorIO config for others"
                                   : "; and the " + std::to_string(configNames.size()) + " spaces of the $OCIO config";
    throw InputError(optionName, 0, message);
}

}  // namespace flare
