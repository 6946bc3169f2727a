#include "flare/optics/LensSystem.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

#include <boost/math/tools/roots.hpp>

#include "flare/core/Error.h"
#include "flare/optics/Paraxial.h"

namespace flare {

// A resolved zoom state: gaps at (1 − t)·position a + t·position b.
struct ZoomWeights {
    int a = 0, b = 0;  // bracketing zoom positions
    double t = 0.0;    // weight of b
    std::string name;
    std::optional<double> focalLengthMm;
    std::optional<double> solveForEflMm;  // a focal length asked for: t is still to be solved
};

namespace {

std::string formatMm(double value) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.4g", value);
    return buffer;
}

ZoomWeights resolveZoom(const LensPrescription& p, const std::string& zoom) {
    ZoomWeights w;
    if (p.zoomPositions.empty()) return w;  // a zoom asked of a lens without positions: see build()
    if (zoom.empty()) {
        w.name = p.zoomPositions[0].name;
        w.focalLengthMm = p.zoomPositions[0].focalLengthMm;
        return w;
    }
    for (size_t i = 0; i < p.zoomPositions.size(); ++i) {
        if (p.zoomPositions[i].name == zoom) {
            w.a = w.b = static_cast<int>(i);
            w.name = zoom;
            w.focalLengthMm = p.zoomPositions[i].focalLengthMm;
            return w;
        }
    }
    double focal = 0.0;
    const auto [end, ec] = std::from_chars(zoom.data(), zoom.data() + zoom.size(), focal);
    std::string names;
    for (const ZoomPosition& z : p.zoomPositions) names += (names.empty() ? "" : ", ") + z.name;
    if (ec != std::errc() || end != zoom.data() + zoom.size() || !(focal > 0.0) || !std::isfinite(focal))
        throw InputError(p.sourceFile, 0,
                         "unknown zoom position '" + zoom + "' (positions: " + names +
                             ", or a focal length in mm)");
    w.solveForEflMm = focal;
    return w;
}

// Consecutive surfaces must not cross anywhere inside the barrel: that is an element (or an air
// space) with a negative edge thickness. The profile checked is the one the photon tracer closes
// its cells with: each surface out to its clear radius, then flat (the element's bevel under its
// retaining ring) out to its edge; the stop is a plane, the blades, reaching the barrel. So next to
// the stop, too, the check runs out to the larger clear radius: a surface whose rim lies beyond
// the stop plane crosses the blades (checking only out to the smaller radius accepted lenses in
// which light slipped from one cell into another through the crossing).
void checkEdgeThickness(const LensPrescription& p, const std::vector<Surface>& surfaces) {
    constexpr int kSamples = 64;
    for (size_t i = 0; i + 1 < surfaces.size(); ++i) {
        const Surface& a = surfaces[i];
        const Surface& b = surfaces[i + 1];
        // Beyond both clear radii both profiles are flat: the gap no longer changes.
        const double rMax = std::max(a.semiApertureMm, b.semiApertureMm);
        for (int k = 0; k <= kSamples; ++k) {
            const double r = rMax * k / kSamples;
            const double gap = (b.vertexZMm + b.profileSagMm(r, b.semiApertureMm)) -
                               (a.vertexZMm + a.profileSagMm(r, a.semiApertureMm));
            if (gap < -1e-9) {
                const bool glass = !p.rows[i].mediumAfter.isAir();
                throw InputError(p.sourceFile, b.fileLine,
                                 "surface " + std::to_string(i + 2) + " crosses surface " +
                                     std::to_string(i + 1) + " at r = " + formatMm(r) + " mm (" +
                                     (glass ? "element" : "air space") + " edge thickness " +
                                     formatMm(gap) + " mm)");
            }
        }
    }
}

}  // namespace

// The zoom state whose paraxial EFL (d line) is the asked focal length. The gaps run linearly
// between consecutive positions; along that path the EFL is found at the positions, the first
// pair that brackets the asked value is taken, and inside it the weight is solved with TOMS 748
// (bracketing, superlinear) to the last few bits of a double.
ZoomWeights LensSystem::solveZoomForEfl(const LensPrescription& p, double eflMm, const LensState& state) {
    auto eflAt = [&](int a, int b, double t) {
        ZoomWeights w;
        w.a = a;
        w.b = b;
        w.t = t;
        const LensSystem lens = buildAt(p, LensState{"", state.objectDistanceMm, {}}, w);
        return paraxialEflMm(lens, lens.indicesAt(kLineDNm));
    };
    const int n = static_cast<int>(p.zoomPositions.size());
    std::vector<double> efls;
    for (int i = 0; i < n; ++i) efls.push_back(eflAt(i, i, 0.0));
    for (int i = 0; i < n; ++i) {
        if (efls[i] == eflMm) {
            ZoomWeights w;
            w.a = w.b = i;
            w.focalLengthMm = eflMm;
            return w;
        }
    }
    for (int i = 0; i + 1 < n; ++i) {
        const double f0 = efls[i] - eflMm, f1 = efls[i + 1] - eflMm;
        if ((f0 < 0.0) == (f1 < 0.0)) continue;
        boost::uintmax_t iterations = 200;
        const auto [lo, hi] = boost::math::tools::toms748_solve(
            [&](double t) { return eflAt(i, i + 1, t) - eflMm; }, 0.0, 1.0, f0, f1,
            boost::math::tools::eps_tolerance<double>(std::numeric_limits<double>::digits - 3), iterations);
        ZoomWeights w;
        w.a = i;
        w.b = i + 1;
        w.t = 0.5 * (lo + hi);
        w.focalLengthMm = eflMm;
        return w;
    }
    std::string positions;
    for (int i = 0; i < n; ++i) {
        char buffer[96];
        std::snprintf(buffer, sizeof buffer, "%s%s %.3f mm", i ? ", " : "", p.zoomPositions[i].name.c_str(), efls[i]);
        positions += buffer;
    }
    throw InputError(p.sourceFile, 0,
                     "zoom focal length " + formatMm(eflMm) + " mm is outside the lens's range: its paraxial EFL is " +
                         positions + ", and between them the gaps run linearly");
}

LensSystem LensSystem::build(const LensPrescription& p, const LensState& state) {
    if (p.zoomPositions.empty() && !state.zoom.empty()) {
        // Say which state the file holds: a library file may be one state of a zoom lens.
        const LensSystem fixed = build(p, LensState{"", state.objectDistanceMm, {}});
        char efl[64];
        std::snprintf(efl, sizeof efl, "%.3f", paraxialEflMm(fixed, fixed.indicesAt(kLineDNm)));
        throw InputError(p.sourceFile, 0,
                         "zoom '" + state.zoom + "' asked, but the lens has no zoom positions: the file holds one state, " +
                             "paraxial EFL " + efl + " mm" + (p.focalLengthMm ? " (stated " + formatMm(*p.focalLengthMm) + " mm)" : "") +
                             ", and cannot be zoomed");
    }
    ZoomWeights zoom = resolveZoom(p, state.zoom);
    if (zoom.solveForEflMm) zoom = solveZoomForEfl(p, *zoom.solveForEflMm, state);
    return buildAt(p, state, zoom);
}

LensSystem LensSystem::buildAt(const LensPrescription& p, const LensState& state, const ZoomWeights& zoom) {
    LensSystem lens;
    lens.name_ = p.name;
    lens.sourceFile_ = p.sourceFile;
    lens.sensor_ = p.sensor;
    lens.stopIndex_ = p.stopRow();
    if (lens.stopIndex_ < 0) throw InputError(p.sourceFile, 0, "the lens has no aperture stop row");
    if (static_cast<int>(p.rows.size()) > kMaxSurfaces)
        throw InputError(p.sourceFile, 0, "more than " + std::to_string(kMaxSurfaces) + " surfaces");

    lens.zoomName_ = zoom.name;
    lens.zoomFocalLengthMm_ = zoom.focalLengthMm;

    // Place the vertices.
    double z = 0.0;
    bool autoFocus = false;
    lens.media_.push_back(Medium::air());
    for (size_t i = 0; i < p.rows.size(); ++i) {
        const PrescriptionRow& row = p.rows[i];
        Surface s;
        s.radiusMm = row.radiusMm;
        s.conic = row.conic;
        s.asphere = row.asphere;
        s.semiApertureMm = row.semiApertureMm;
        if (!row.semiApertureName.empty()) {
            // The iris of a zoom: its opening at this position, linear between positions like a gap.
            const VariableAperture* aperture = p.findAperture(row.semiApertureName);
            if (!aperture)
                throw InputError(p.sourceFile, row.line, "unknown aperture '" + row.semiApertureName + "'");
            s.semiApertureMm = (1.0 - zoom.t) * aperture->valuesMm[zoom.a] + zoom.t * aperture->valuesMm[zoom.b];
        }
        s.vertexZMm = z;
        s.isStop = row.isStop;
        s.fileLine = row.line;
        lens.surfaces_.push_back(s);
        lens.media_.push_back(row.mediumAfter);

        double thickness = 0.0;
        switch (row.thickness.kind) {
            case ThicknessSpec::Kind::Value: thickness = row.thickness.valueMm; break;
            case ThicknessSpec::Kind::Gap: {
                const VariableGap* gap = p.findGap(row.thickness.gapName);
                if (!gap)
                    throw InputError(p.sourceFile, row.line,
                                     "unknown variable gap '" + row.thickness.gapName + "'");
                thickness = (1.0 - zoom.t) * gap->valuesMm[zoom.a] + zoom.t * gap->valuesMm[zoom.b];
                break;
            }
            case ThicknessSpec::Kind::Auto: autoFocus = true; break;
        }
        z += thickness;
    }
    lens.sensorZMm_ = z;

    // Mechanical edges: every surface of a glass group (an element or a cemented group) shares the
    // group's largest clear radius unless the file gives `mech=`.
    for (size_t i = 0; i < p.rows.size();) {
        size_t j = i;
        while (j + 1 < p.rows.size() && !p.rows[j].mediumAfter.isAir()) ++j;
        double groupRadius = 0.0;
        for (size_t k = i; k <= j; ++k) groupRadius = std::max(groupRadius, p.rows[k].semiApertureMm);
        for (size_t k = i; k <= j; ++k)
            lens.surfaces_[k].mechSemiDiameterMm =
                std::max(p.rows[k].mechSemiDiameterMm.value_or(groupRadius), p.rows[k].semiApertureMm);
        i = j + 1;
    }

    // The iris, wide open. A bladed opening reaches out to its circumradius, beyond the stop's
    // nominal (area-equivalent) radius: the stop's mechanical radius, from which the barrel on
    // both sides of it is sized, must take that in, or light through the opening's corners would
    // pass outside the barrel of the cell beside the stop.
    // A zoom's iris (an `aperture` line) opens to its position's radius; its mount, and so the
    // barrel beside it, is sized for the widest opening at any position (stopRow.semiApertureMm).
    const PrescriptionRow& stopRow = p.rows[lens.stopIndex_];
    Surface& stop = lens.surfaces_[lens.stopIndex_];
    const double openStopMm = stop.semiApertureMm;
    lens.iris_ = Iris(p.iris.blades, p.iris.rotationDeg * std::numbers::pi / 180.0,
                      p.iris.curvature, openStopMm);
    const Iris widestIris(p.iris.blades, p.iris.rotationDeg * std::numbers::pi / 180.0, p.iris.curvature,
                          stopRow.semiApertureMm);
    stop.mechSemiDiameterMm = std::max(stop.mechSemiDiameterMm, widestIris.circumradiusMm());

    // Coatings sit on air–glass interfaces only.
    for (size_t i = 0; i < p.rows.size(); ++i) {
        const bool airBefore = lens.media_[i].isAir();
        const bool airAfter = lens.media_[i + 1].isAir();
        int index = -1;
        if (!p.rows[i].isStop && airBefore != airAfter) {
            const std::string name = p.rows[i].coatingName.value_or(p.defaultCoating);
            const std::optional<Coating> coating = p.findCoating(name);
            if (!coating)
                throw InputError(p.sourceFile, p.rows[i].line, "unknown coating '" + name + "'");
            if (coating->changesInterface()) {
                auto it = std::find_if(lens.coatings_.begin(), lens.coatings_.end(),
                                       [&](const Coating& c) { return c.name == coating->name; });
                if (it == lens.coatings_.end()) {
                    lens.coatings_.push_back(*coating);
                    it = lens.coatings_.end() - 1;
                }
                index = static_cast<int>(it - lens.coatings_.begin());
            }
        }
        lens.coatingIndex_.push_back(index);
    }

    // An interface reflects wherever the media on its two sides differ at any wavelength.
    for (int i = 0; i < lens.surfaceCount(); ++i) {
        bool differ = false;
        for (double wavelength : {kLineFNm, kLineDNm, kLineCNm})
            differ |= lens.media_[i].indexAt(wavelength) != lens.media_[i + 1].indexAt(wavelength);
        lens.reflecting_.push_back(!lens.surfaces_[i].isStop && differ);
    }

    checkEdgeThickness(p, lens.surfaces_);

    // Focus solve and f-stop: both first-order, at the d line.
    const SpectralIndices dLine = lens.indicesAt(kLineDNm);
    lens.objectDistanceMm_ = state.objectDistanceMm.value_or(p.objectDistanceMm);
    if (autoFocus || state.objectDistanceMm) {
        const double minimum = lens.surfaces_.back().vertexZMm;
        const double imageZ = paraxialImageZMm(lens, dLine, lens.objectDistanceMm_);
        if (!std::isfinite(imageZ) || imageZ <= minimum)
            throw InputError(p.sourceFile, p.rows.back().line,
                             "focus solve failed: the image of an object at " +
                                 formatMm(lens.objectDistanceMm_) +
                                 " mm does not lie behind the last surface");
        lens.sensorZMm_ = imageZ;
    }
    if (state.fNumber) {
        const double efl = paraxialEflMm(lens, dLine);
        const double pupilRadius = std::abs(efl) / (2.0 * *state.fNumber);
        const double stopRadius = pupilRadius / pupilMagnification(lens, dLine);
        if (!(*state.fNumber > 0.0) || stopRadius > openStopMm * (1.0 + 1e-9)) {
            const double wideOpen = std::abs(efl) / (2.0 * openStopMm *
                                                     pupilMagnification(lens, dLine));
            throw InputError(p.sourceFile, 0,
                             "f/" + formatMm(*state.fNumber) + " is not available: the lens opens to f/" +
                                 formatMm(wideOpen) + " at this zoom");
        }
        lens.iris_ = Iris(p.iris.blades, p.iris.rotationDeg * std::numbers::pi / 180.0,
                          p.iris.curvature, stopRadius);
    }

    // Barrel: between consecutive surfaces, a cylinder just outside the larger edge.
    const double margin = p.housingMarginMm;
    const int n = lens.surfaceCount();
    for (int i = 0; i < n; ++i) {
        const Surface& a = lens.surfaces_[i];
        const double zEnd = i + 1 < n ? lens.surfaces_[i + 1].vertexZMm : lens.sensorZMm_;
        double radius = a.mechSemiDiameterMm;
        if (i + 1 < n) radius = std::max(radius, lens.surfaces_[i + 1].mechSemiDiameterMm);
        else radius = std::max(radius, lens.sensorHalfDiagonalMm());
        lens.housing_.push_back({a.vertexZMm, zEnd, radius + margin});
    }
    return lens;
}

double LensSystem::sensorHalfDiagonalMm() const {
    return 0.5 * std::hypot(sensor_.widthMm, sensor_.heightMm);
}

const Coating* LensSystem::coating(int i) const {
    const int index = coatingIndex_[i];
    return index < 0 ? nullptr : &coatings_[index];
}

bool LensSystem::isReflecting(int i) const { return reflecting_[i]; }

SpectralIndices LensSystem::indicesAt(double wavelengthNm) const {
    SpectralIndices indices;
    indices.wavelengthNm = wavelengthNm;
    for (size_t i = 0; i < media_.size(); ++i) indices.n[i] = media_[i].indexAt(wavelengthNm);
    return indices;
}

}  // namespace flare
