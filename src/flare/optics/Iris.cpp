#include "flare/optics/Iris.h"

#include <cassert>
#include <cmath>
#include <numbers>

namespace flare {

namespace {

struct BladeGeometry {
    double apothem, halfChord, sagitta, arcCentre, arcRadius, area;
};

// Polygon of unit circumradius with N edges bowed by `curvature` towards the circle.
BladeGeometry unitBlades(int blades, double curvature) {
    const double half = std::numbers::pi / blades;
    BladeGeometry g{};
    g.apothem = std::cos(half);
    g.halfChord = std::sin(half);
    g.sagitta = curvature * (1.0 - g.apothem);
    g.area = blades * g.apothem * g.halfChord;
    if (g.sagitta > 0.0) {
        // Circle through (apothem, ±halfChord) and (apothem + sagitta, 0).
        const double u = (g.halfChord * g.halfChord - g.sagitta * g.sagitta) / (2.0 * g.sagitta);
        g.arcRadius = u + g.sagitta;
        g.arcCentre = g.apothem - u;
        const double alpha = std::atan2(g.halfChord, u);
        const double segment = g.arcRadius * g.arcRadius * alpha - g.halfChord * u;
        g.area += blades * segment;
    }
    return g;
}

}  // namespace

Iris::Iris(int blades, double rotationRad, double curvature, double radiusMm)
    : blades_(blades), rotationRad_(rotationRad), curvature_(curvature), radiusMm_(radiusMm) {
    assert(blades == 0 || blades >= 3);
    if (blades_ == 0) {
        circumradiusMm_ = radiusMm;
        return;
    }
    const BladeGeometry unit = unitBlades(blades_, curvature_);
    const double scale = radiusMm * std::sqrt(std::numbers::pi / unit.area);
    circumradiusMm_ = scale;
    apothemMm_ = unit.apothem * scale;
    sectorRad_ = 2.0 * std::numbers::pi / blades_;
    arcCentreMm_ = unit.arcCentre * scale;
    arcRadiusMm_ = unit.arcRadius * scale;
    for (int k = 0; k < blades_; ++k) {
        const double mid = rotationRad_ + (k + 0.5) * sectorRad_;
        normalX_.push_back(std::cos(mid));
        normalY_.push_back(std::sin(mid));
    }
}

bool Iris::contains(double x, double y) const {
    const double r2 = x * x + y * y;
    if (blades_ == 0) return r2 <= radiusMm_ * radiusMm_;
    if (r2 > circumradiusMm_ * circumradiusMm_) return false;
    if (r2 <= apothemMm_ * apothemMm_) return true;
    // Rotate into the frame of the edge whose sector holds the point (mid-normal along +x).
    const double phi = std::atan2(y, x) - rotationRad_;
    const double sector = std::floor(phi / sectorRad_);
    // The sectors' mid-normals are margin()'s, computed from the same angle: the same cosine and
    // sine without evaluating them per ray (in the preview's profile, a sixth of contains()'s
    // samples). A sector outside [0, blades) (the rotation moves the angles' range) evaluates them.
    double cosMid, sinMid;
    if (sector >= 0.0 && sector < blades_) {
        cosMid = normalX_[static_cast<size_t>(sector)];
        sinMid = normalY_[static_cast<size_t>(sector)];
    } else {
        const double mid = rotationRad_ + (sector + 0.5) * sectorRad_;
        cosMid = std::cos(mid);
        sinMid = std::sin(mid);
    }
    const double xe = x * cosMid + y * sinMid;
    const double ye = -x * sinMid + y * cosMid;
    if (xe <= apothemMm_) return true;
    if (arcRadiusMm_ == 0.0) return false;
    const double dx = xe - arcCentreMm_;
    return dx * dx + ye * ye <= arcRadiusMm_ * arcRadiusMm_;
}

double Iris::margin(double x, double y) const {
    const double r2 = x * x + y * y;
    if (blades_ == 0) return r2 / (radiusMm_ * radiusMm_) - 1.0;
    if (r2 == 0.0) return -1.0;
    // The sector holding the point is the one whose edge's mid-normal is closest to the point's
    // direction (the largest projection), as contains() finds it by angle; its cosine and sine
    // relative to that normal follow without trigonometry.
    int sector = 0;
    double projection = -1e300;
    for (int k = 0; k < blades_; ++k) {
        const double p = x * normalX_[k] + y * normalY_[k];
        if (p > projection) projection = p, sector = k;
    }
    const double r = std::sqrt(r2);
    const double c = projection / r;
    const double s = (normalX_[sector] * y - normalY_[sector] * x) / r;
    // Straight blade: the edge is xe = apothem. Bowed blade: the arc bounding contains()'s disk,
    // which lies outside the chord within the sector, so it is the edge there.
    const double rho = arcRadiusMm_ == 0.0
                           ? apothemMm_ / c
                           : arcCentreMm_ * c + std::sqrt(arcRadiusMm_ * arcRadiusMm_ - arcCentreMm_ * arcCentreMm_ * s * s);
    return r2 / (rho * rho) - 1.0;
}

}  // namespace flare
