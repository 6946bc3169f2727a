// What a lens's name promises: the focal length (or zoom range) and the f-number (or range) that a
// library id such as "nikon-ai-nikkor-180mm-f-2.8-ed" or "schneider-variogon-2.8-10-40" states.
// The library keeps every lens's name true to its prescription (docs/lens-library.md): a name is
// checked against the paraxial EFL and the f-number with the tolerances below.
#pragma once

#include <optional>
#include <string_view>

namespace flare {

// ISO 517 lets a camera lens's marked focal length differ from the real one by up to 5 %.
inline constexpr double kNamedFocalLengthTolerance = 0.05;
// Marked f-numbers are the nearest third stop: a factor 2^(1/6) in f-number either way.
inline constexpr double kNamedFNumberFactor = 1.122462048309373;  // 2^(1/6)

struct NamedRange {
    double lo = 0.0, hi = 0.0;  // equal for one value
};

struct LensNameValues {
    std::optional<NamedRange> focalLengthMm;
    std::optional<NamedRange> fNumber;  // a T-stop ("t1.3") counts as its f-number
};

// Reads a library id (lower case, words joined by '-'). The focal length is the first of "NNmm"
// or "NN-MMmm" (a zoom range), "N.Ncm", "NN-f2.8" (a number before the f-number), "xfNN"; or, in
// the "F-NUMBER FOCAL" order of Schneider, Hasselblad and Zeiss ("xcd-3.5-45", "variogon-2.8-10-40"),
// the pair of numbers that follows a name. The f-number is "fN", "f-N" or "tN" (with a range
// "f3.5-4.5", letters after it as in "f2.8g"), preferably after the focal length; a number after
// an f-number that is smaller than it ("f2.8-2x") is not a range.
LensNameValues parseLensName(std::string_view id);

}  // namespace flare
