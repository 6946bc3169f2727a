// Shared helpers for the unit tests: paths into the source tree and lens loading.
#pragma once

#include <string>

#include "flare/LensFile.h"
#include "flare/LensSystem.h"

namespace flare::test {

inline std::string sourcePath(const std::string& relative) {
    return std::string(FLARE_SOURCE_DIR) + "/" + relative;
}

inline LensSystem loadLens(const std::string& relative, const LensState& state = {}) {
    return LensSystem::build(loadLensFile(sourcePath(relative)), state);
}

// Every lens shipped in lenses/.
inline const char* const kShippedLenses[] = {
    "lenses/double-gauss-50mm.lens", "lenses/wide-angle-28mm.lens", "lenses/telephoto-180mm.lens",
    "lenses/fisheye-16mm.lens",      "lenses/zoom-24-70mm.lens",
};

}  // namespace flare::test
