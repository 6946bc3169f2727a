// A lens at one zoom/focus/f-stop state: surfaces placed along the axis, the media between them,
// coatings, the iris, the housing (barrel) profile and the sensor. Built from a LensPrescription;
// immutable afterwards and safe to share between threads.
#pragma once

#include <array>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "flare/optics/Coating.h"
#include "flare/optics/Iris.h"
#include "flare/optics/LensPrescription.h"
#include "flare/optics/Surface.h"

namespace flare {

struct ZoomWeights;

struct LensState {
    // "" = first zoom position; a position name, or a focal length in mm: the state between the
    // bracketing positions (gaps linear between them) whose paraxial EFL at the d line is that length.
    std::string zoom;
    std::optional<double> objectDistanceMm;  // focus; default: the prescription's (infinity)
    std::optional<double> fNumber;           // stop down the iris; default: wide open
};

// Refractive indices of every medium at one wavelength: n[i] is the medium before surface i, so
// n[0] is object space and n[surfaceCount] image space.
struct SpectralIndices {
    double wavelengthNm = 587.5618;
    std::array<double, kMaxSurfaces + 1> n{};
};

// The inside of the barrel between two axial positions (a cylinder of the given radius).
struct HousingSection {
    double zStartMm = 0.0;
    double zEndMm = 0.0;
    double innerRadiusMm = 0.0;
};

class LensSystem {
public:
    // Throws InputError (naming the prescription file and row) if the state is invalid or the
    // resolved geometry has crossing surfaces.
    static LensSystem build(const LensPrescription& prescription, const LensState& state = {});

    const std::string& name() const { return name_; }
    const std::string& sourceFile() const { return sourceFile_; }
    int surfaceCount() const { return static_cast<int>(surfaces_.size()); }
    const Surface& surface(int i) const { return surfaces_[i]; }
    std::span<const Surface> surfaces() const { return surfaces_; }
    // i in [0, surfaceCount]: the medium in front of surface i (surfaceCount: image space).
    const Medium& mediumBefore(int i) const { return media_[i]; }
    int stopIndex() const { return stopIndex_; }
    const Iris& iris() const { return iris_; }
    double sensorZMm() const { return sensorZMm_; }
    const SensorSpec& sensor() const { return sensor_; }
    double sensorHalfDiagonalMm() const;
    std::span<const HousingSection> housing() const { return housing_; }
    // The coating on surface i, or nullptr (uncoated, cemented, or the stop).
    const Coating* coating(int i) const;
    // True where light can reflect: every surface whose two media differ (not the stop).
    bool isReflecting(int i) const;
    SpectralIndices indicesAt(double wavelengthNm) const;

    // Resolved zoom: the position's name (or "" when interpolated) and its focal length: the
    // position's stated one, or the EFL asked for (and reached) between positions.
    const std::string& zoomName() const { return zoomName_; }
    std::optional<double> zoomFocalLengthMm() const { return zoomFocalLengthMm_; }
    double objectDistanceMm() const { return objectDistanceMm_; }
    // Distance from the first vertex to the sensor.
    double totalTrackMm() const { return sensorZMm_ - (surfaces_.empty() ? 0.0 : surfaces_[0].vertexZMm); }

private:
    static LensSystem buildAt(const LensPrescription& prescription, const LensState& state, const ZoomWeights& zoom);
    static ZoomWeights solveZoomForEfl(const LensPrescription& prescription, double eflMm, const LensState& state);

    std::string name_;
    std::string sourceFile_;
    std::vector<Surface> surfaces_;
    std::vector<Medium> media_;  // size surfaceCount + 1
    std::vector<int> coatingIndex_;  // per surface, −1 for none
    std::vector<bool> reflecting_;
    std::vector<Coating> coatings_;
    std::vector<HousingSection> housing_;
    Iris iris_;
    int stopIndex_ = -1;
    double sensorZMm_ = 0.0;
    SensorSpec sensor_;
    std::string zoomName_;
    std::optional<double> zoomFocalLengthMm_;
    double objectDistanceMm_ = 0.0;
};

}  // namespace flare
