// Sanity checks of a transcribed lens prescription (docs/lens-library.md): the checks every lens of
// the library passes, and that `flare lens check` runs on any lens file. They catch transcription
// errors that still parse: a wrong radius or index moves the focal length; a stop or clear
// aperture too small for the published f-number clips the axial beam.
//
// Per zoom position (or once for a fixed focal length):
//   efl      the paraxial EFL at the d line lies within kEflRelativeTolerance of the focal length
//            the file states (focal_length_mm, or the position's value on the zoom line);
//   stop     the aperture stop opens to the stated f-number (f_number, or the position's own for a
//            variable-aperture zoom) up to its rounding: the
//            paraxial f-number with the stop row's semi-aperture is at most f_number + kFNumberRounding;
//   ray_fan  real rays from an axial object at infinity, aimed at kFanPupilFractions of the round
//            opening of the stated f-number (or of the wide-open stop, if that is slower within the
//            rounding) in x and in y, both signs, and at its centre, reach the sensor through every
//            clear aperture with finite coordinates.
// A check needs what it compares with: a file that states no focal length (pbrt .dat, Zemax .zmx
// without configurations) gets no efl check, one that states no f-number no stop check and its fan
// at the stop's own wide-open f-number. Each such omission is a note, not a failure: the lens is not
// wrong for lacking what its format cannot say. A bladed iris's corners reach beyond the round
// opening of the same area (the f-number is the area's): whether light through them is clipped by
// another clear aperture is reported as a note too, since clear apertures are sized for the round beam.
// Loading itself (parse, no intersecting elements, positive edge thicknesses, the focus solve) is
// the parser's and LensSystem::build's job: a lens that does not load has failed before these run.
#pragma once

#include <string>
#include <vector>

#include "flare/optics/LensPrescription.h"

namespace flare {

// Published focal lengths are printed to 3–5 significant figures and computed by the designer,
// sometimes at the e line (546 nm) where the EFL is ~0.3–0.5 % shorter than at the d line for
// common glasses: 1 % covers both. A wrong radius, thickness or index (the transcription errors
// this check is for) moves the EFL by more.
inline constexpr double kEflRelativeTolerance = 0.01;
// Published f-numbers are rounded to one decimal (f/2 for f/2.03, the patent's "FNo. 2.9" for
// 2.88): a stop that opens to within half a unit of the last digit of the stated value is found.
inline constexpr double kFNumberRounding = 0.05;
// Fan rays are aimed at these fractions of the iris opening's radius in their direction. The outermost stays 2 % inside the rim
// so that a ray aimed exactly at the iris edge is not stopped by rounding.
inline constexpr double kFanPupilFractions[] = {0.0, 0.35, 0.7, 0.98};

// A failed check, or a note (information that does not fail the lens).
struct LensCheckFailure {
    std::string check;   // "efl", "stop", "ray_fan"
    std::string zoom;    // the zoom position ("" for a fixed focal length)
    std::string detail;  // one line saying what was found
};
using LensCheckNote = LensCheckFailure;

struct LensCheckPosition {
    std::string zoom;
    double statedFocalLengthMm = 0.0;  // 0: the file states none
    double eflMm = 0.0;
    double wideOpenFNumber = 0.0;  // paraxial, with the stop row's semi-aperture
    double fanFNumber = 0.0;       // the f-number the ray fan ran at (0: it did not run)
};

struct LensCheckReport {
    std::vector<LensCheckPosition> positions;
    std::vector<LensCheckFailure> failures;
    std::vector<LensCheckNote> notes;
    bool ok() const { return failures.empty(); }
};

// Runs the checks on a prescription that has loaded (it throws InputError only where building a
// zoom position throws, which a loaded prescription does not).
LensCheckReport checkLens(const LensPrescription& prescription);

}  // namespace flare
