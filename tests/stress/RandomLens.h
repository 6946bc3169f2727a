// Random valid lenses for the numerical-stability stress tests, written as `.lens` text so that
// they go through the real parser and validator (parseLensText). The generator aims at the corners
// of the valid domain: nearly flat and nearly hemispherical surfaces, strong conics and aspheres,
// indices from 1.4 to 2.0, elements and air spaces that touch at their rims, irises of any blade
// count. Thicknesses are derived from the sampled sags so that surfaces never cross, but the
// engine stays the judge: a lens its builder rejects (a failed focus solve, an asphere that
// bends back) is counted and skipped by the caller.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>

#include "flare/core/Random.h"

namespace flare::stress {

struct GeneratedLens {
    std::string text;     // the `.lens` file
    int rows = 0;         // surface rows, counting the stop
    bool zoom = false;    // written with two zoom positions and a variable gap
    bool aspheric = false;
};

// A lens drawn from `rng`. Deterministic: the same generator state gives the same text.
GeneratedLens randomLens(Rng& rng);

// Uniform helpers shared with the ray generators.
inline double uniform(Rng& rng, double lo, double hi) { return lo + (hi - lo) * rng.uniform(); }
inline double logUniform(Rng& rng, double log10Lo, double log10Hi) {
    return std::pow(10.0, uniform(rng, log10Lo, log10Hi));
}
inline int uniformInt(Rng& rng, int lo, int hi) {  // inclusive
    return lo + static_cast<int>(rng.uniform() * (hi - lo + 1));
}
inline bool chance(Rng& rng, double p) { return rng.uniform() < p; }

// Shortest text that reads back as exactly `value` (%.17g).
std::string exact(double value);

}  // namespace flare::stress
