// Sanity checks of a transcribed lens prescription (docs/lens-library.md): the checks every lens of
// the library passes, and that `flare lens check` runs on any lens file. They catch transcription
// errors that still parse: a wrong radius or index moves the focal length; a stop or clear
// aperture too small for the published f-number clips the axial beam.
//
// Per zoom position (or once for a fixed focal length):
//   efl      the paraxial EFL at the d line lies within kEflRelativeTolerance of the focal length
//            the file states (focal_length_mm, or the position's value on the zoom line);
//   stop     the aperture stop opens to the stated f-number (f_number) up to its rounding: the
//            paraxial f-number with the stop row's semi-aperture is at most f_number + kFNumberRounding;
//   ray_fan  real rays from an axial object at infinity, aimed at kFanPupilFractions of the iris
//            opening's radius (in x and in y, both signs) and at its centre, with the iris at the
//            stated f-number (or wide open, if that is slower within the rounding), reach the
//            sensor through every clear aperture with finite coordinates.
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

struct LensCheckFailure {
    std::string check;   // "efl", "stop", "ray_fan", "f_number"
    std::string zoom;    // the zoom position ("" for a fixed focal length)
    std::string detail;  // one line saying what was found
};

struct LensCheckPosition {
    std::string zoom;
    double statedFocalLengthMm = 0.0;
    double eflMm = 0.0;
    double wideOpenFNumber = 0.0;  // paraxial, with the stop row's semi-aperture
};

struct LensCheckReport {
    std::vector<LensCheckPosition> positions;
    std::vector<LensCheckFailure> failures;
    bool ok() const { return failures.empty(); }
};

// Runs the checks on a prescription that has loaded (it throws InputError only where building a
// zoom position throws, which a loaded prescription does not).
LensCheckReport checkLens(const LensPrescription& prescription);

}  // namespace flare
