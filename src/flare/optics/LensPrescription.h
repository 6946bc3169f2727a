// A lens prescription as read from a file: rows like a patent table, with variable gaps still
// named and zoom positions unresolved. LensSystem::build turns it into surfaces at a zoom/focus
// state.
#pragma once

#include <array>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "flare/optics/Coating.h"
#include "flare/optics/Glass.h"
#include "flare/optics/Surface.h"

namespace flare {

// Surfaces (rows, counting the stop) a lens may have. Keeps per-wavelength index tables on the
// stack in the tracers.
inline constexpr int kMaxSurfaces = 96;

struct ThicknessSpec {
    enum class Kind { Value, Gap, Auto };
    Kind kind = Kind::Value;
    double valueMm = 0.0;
    std::string gapName;  // Kind::Gap
};

// Scattering a lens file can state (docs/lens-format.md, "Scattering"); a scene's `scattering`
// block overrides it. How one of the lens's inner parts reflects: a Lambertian albedo and a share
// reflected into a Phong lobe about the mirror direction (the rest is absorbed).
struct FinishSpec {
    double diffuse = 0.03;  // default: dark matte black paint, ~3 %
    double glossy = 0.0;
};
// Dust and grease a row's surface carries (the scene's dust and grease entries without a mask).
struct RowDust {
    double coverage = 0.0, albedo = 0.5, diameterUm = 20.0, diameterSigma = 0.5;
};
struct RowGrease {
    double coverage = 0.0, roughness = 0.1;
};

struct PrescriptionRow {
    double radiusMm = 0.0;  // 0: plane
    bool isStop = false;
    ThicknessSpec thickness;
    Medium mediumAfter;
    std::string materialText;  // as written in the file
    // The clear radius; on a stop row with `semiApertureName` the largest of the aperture's values
    // (the iris mount holds the widest opening; LensSystem::build takes the position's value).
    double semiApertureMm = 0.0;
    std::string semiApertureName;  // the stop row's semi-aperture column naming an `aperture` line
    double conic = 0.0;
    std::array<double, kAsphereTerms> asphere{};
    std::optional<double> mechSemiDiameterMm;
    std::optional<std::string> coatingName;  // per-row override of the default coating
    std::optional<RowDust> dust;             // `dust=` options (air on at least one side)
    std::optional<RowGrease> grease;         // `grease=` options
    int line = 0;
};

struct ZoomPosition {
    std::string name;
    double focalLengthMm = 0.0;  // published focal length of this position
    // Published f-number of this position: a variable-aperture zoom's `f_number wide=3.5 tele=5.6`
    // (LensPrescription::fNumber is then the first position's); unset: fNumber holds everywhere.
    std::optional<double> fNumber;
};

// A value that changes with the zoom position and runs linearly between positions: a `gap` line
// (a thickness), or an `aperture` line (the stop's semi-aperture: a zoom's iris opens as the
// zoom moves, so that a constant-aperture zoom keeps its f-number).
struct VariableGap {
    std::string name;
    std::vector<double> valuesMm;  // one per zoom position, in ZoomPosition order
    int line = 0;
};
using VariableAperture = VariableGap;

struct IrisSpec {
    int blades = 0;  // 0: circular
    double rotationDeg = 0.0;
    double curvature = 0.0;
};

struct SensorSpec {
    double widthMm = 36.0;
    double heightMm = 24.0;
    double reflectance = 0.02;
};

struct LensPrescription {
    std::string name;
    std::string source;
    std::string sourceFile;  // path the prescription was read from
    std::optional<double> focalLengthMm;
    std::optional<double> fNumber;
    IrisSpec iris;
    SensorSpec sensor;
    double objectDistanceMm = std::numeric_limits<double>::infinity();
    double housingMarginMm = 1.0;
    std::vector<ZoomPosition> zoomPositions;
    std::vector<VariableGap> gaps;
    std::vector<VariableAperture> apertures;  // `aperture` lines (only the stop row may name one)
    std::vector<Coating> coatings;    // named coatings defined in the file
    std::string defaultCoating = "none";
    // `finish` and `gloss_exponent` lines; unset: the scene's, else the built-in defaults.
    std::optional<FinishSpec> housingFinish, edgeFinish, irisFinish;
    std::optional<double> glossExponent;
    std::vector<PrescriptionRow> rows;

    int stopRow() const;  // index into rows, −1 if none
    const VariableGap* findGap(const std::string& name) const;
    const VariableAperture* findAperture(const std::string& name) const;
    // A coating by name: file-defined first, then built-ins ("none", "mgf2").
    std::optional<Coating> findCoating(const std::string& name) const;
};

}  // namespace flare
