// The Fraunhofer transform of a hard-edged aperture, F(k) = ∫_A exp(−i k·x) d²x, from its outline.
//
// By the divergence theorem F(k) = (i/|k|²) ∮ (k·n) exp(−i k·x) ds, which is analytic on each
// straight piece of the outline (a sinc): the transform is evaluated at any spatial frequency with
// no sampling grid, so there is no wrap-around, no staircase and no limit on how far out the
// pattern is computed. Far out, the fringes between different pieces of the outline are finer
// than any pixel, and what a pixel (or a band of wavelengths) sees is their average: the
// incoherent sum of the pieces, which is the asymptotic model kept here,
//   straight edges (a spike each):  ⟨|F|²⟩ = Σ (k·n)² L² sinc²(k·t L/2) / |k|⁴,
//   curved outline (a smooth halo): ⟨|F|²⟩ = 2π (ρ(k̂) + ρ(−k̂)) / |k|³,
// ρ(β) being the outline's length per unit angle of its outward normal (a circle of radius R has
// ρ = R, which gives the envelope of the Airy rings). A run of the outline counts as straight when
// it stays within `straightToleranceMm` of its chord (λ/8: such an edge diffracts as a straight
// one) and is long enough for its spike to stay narrower than its own angle to its neighbours;
// shorter runs make up the smooth part.
#pragma once

#include <complex>
#include <vector>

#include <glm/vec2.hpp>

namespace flare {

struct ApertureEdge {
    glm::dvec2 midpointMm{0.0};
    glm::dvec2 normal{0.0};   // outward, unit
    glm::dvec2 tangent{0.0};  // unit, counter-clockwise along the outline
    double lengthMm = 0.0;
    // A spike's fan: a curved edge is split into straight runs whose normals turn a little from one
    // to the next, and its spike spreads over those normals, from β − fanBeforeRad to β +
    // fanAfterRad (half the turn to each neighbouring run of the same edge; 0 at a corner).
    double fanBeforeRad = 0.0, fanAfterRad = 0.0;
};

struct ApertureTransformOptions {
    double straightToleranceMm = 550e-6 / 8.0;  // λ/8 at 550 nm
    // Runs shorter than this join the smooth part (their spikes, 2π/(L|k|) wide in angle, merge
    // with their neighbours' over the frame).
    double spikeMinLengthMm = 0.05;
};

class ApertureTransform {
public:
    // `outlineMm`: the aperture's outline as a simple polygon (either orientation; at least 3
    // vertices, positive area), in the pupil plane, mm. Else std::invalid_argument.
    explicit ApertureTransform(std::vector<glm::dvec2> outlineMm, const ApertureTransformOptions& options = {});

    double areaMm2() const { return areaMm2_; }
    double perimeterMm() const { return perimeterMm_; }
    // Largest extent of the outline (mm): sets the fringe spacing 2π/D of the transform.
    double diameterMm() const { return diameterMm_; }
    glm::dvec2 centroidMm() const { return centroidMm_; }

    // Exact transform at spatial frequency k (rad/mm), with the outline's centroid as origin (so
    // that a symmetric aperture gives a real transform). F(0) = area.
    std::complex<double> transform(const glm::dvec2& kPerMm) const;

    // The asymptotic, fringe-averaged |F(k)|² (mm⁴): spikes plus smooth halo.
    double incoherentIntensity(const glm::dvec2& kPerMm) const;
    // The straight edges (each run of a curved edge merged into one, with its fan).
    const std::vector<ApertureEdge>& spikeEdges() const { return spikes_; }
    // Smooth part: outline length per radian of outward-normal angle β (mm/rad), and its total.
    double smoothDensityMmPerRad(double normalAngleRad) const;
    double smoothLengthMm() const { return smoothLengthMm_; }

private:
    void mergeCurvedEdges();

    std::vector<ApertureEdge> runs_;    // the outline merged into straight runs (exact transform)
    std::vector<ApertureEdge> spikes_;  // the long runs
    std::vector<double> smoothDensity_; // per normal-angle bin, mm/rad
    double smoothLengthMm_ = 0.0;
    double areaMm2_ = 0.0, perimeterMm_ = 0.0, diameterMm_ = 0.0;
    glm::dvec2 centroidMm_{0.0};
};

// Polygon outline of a circle of radius r (mm) with `segments` vertices, counter-clockwise.
std::vector<glm::dvec2> circleOutline(double radiusMm, int segments);

}  // namespace flare
