// The aperture stop's opening: a circle, or an N-blade polygon whose blades may bow outwards.
// The polygon is scaled to the same area as the circle of radius `radiusMm`, so a given f-number
// passes the same power whatever the blade count.
#pragma once

#include <vector>

namespace flare {

class Iris {
public:
    Iris() = default;
    // blades = 0 for a circular iris, else ≥ 3. curvature in [0, 1]: 0 straight blades,
    // 1 blades on the circumscribed circle. rotationRad: angle of the first polygon vertex.
    Iris(int blades, double rotationRad, double curvature, double radiusMm);

    bool contains(double xMm, double yMm) const;
    // A continuous measure of how far a point lies outside the opening: (r/ρ(φ))² − 1, where ρ(φ)
    // is the opening's radius in the point's direction. Negative inside, zero on the edge (its sign
    // agrees with contains() up to rounding). Used to locate the edge between traced rays.
    double margin(double xMm, double yMm) const;

    int blades() const { return blades_; }
    double radiusMm() const { return radiusMm_; }          // area-equivalent radius
    double circumradiusMm() const { return circumradiusMm_; }  // farthest opening point
    double apothemMm() const { return apothemMm_; }  // bladed: every point this near passes (0 round)
    double rotationRad() const { return rotationRad_; }
    double curvature() const { return curvature_; }
    // What margin() computes with (for a vector version of it): the unit mid-normal of edge k
    // (0 ≤ k < blades) and a bowed blade's arc (radius 0: straight blades).
    double edgeNormalX(int k) const { return normalX_[k]; }
    double edgeNormalY(int k) const { return normalY_[k]; }
    double arcCentreMm() const { return arcCentreMm_; }
    double arcRadiusMm() const { return arcRadiusMm_; }

private:
    int blades_ = 0;
    double rotationRad_ = 0.0;
    double curvature_ = 0.0;
    double radiusMm_ = 0.0;
    double circumradiusMm_ = 0.0;
    double apothemMm_ = 0.0;
    double sectorRad_ = 0.0;
    double arcCentreMm_ = 0.0;  // along the edge's mid-normal, from the iris centre
    double arcRadiusMm_ = 0.0;  // 0 for straight blades
    std::vector<double> normalX_, normalY_;  // unit mid-normal of each edge, for margin()
};

}  // namespace flare
