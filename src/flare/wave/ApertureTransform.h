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
//
// Summing the edges incoherently misses their interference at the corners they share: an edge's
// transform is (k·n)(e^{−ik·a} − e^{−ik·b})/(i k·t), a term per end, and two edges meeting at a
// corner v both carry e^{−ik·v}, so their product does not average out with the fringes. Between
// the spikes the fringe-averaged |F|²|k|⁴ is Σ_corners (A_out − A_in)², A = (k·n)/(k·t) of the
// edges before and after the corner, while the edges alone give Σ_edges 2A² (a regular hexagon:
// two thirds of the truth midway between its spikes, a square: half). The corner term
// (cornerInterference) is kept for every corner between two straight edges (spikeEdges), in a
// form that stays finite on the spikes, where A diverges: on edge e's spike (|u_e| small, u = k·t
// L/2) the other edge's phase varies fast and the term averages to −2 A_other (k·n_e) L_e
// sin²(u_e)/u_e; away from both spikes to −2 A_in A_out.
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

// Two straight edges (indices into spikeEdges()) meeting at a corner of the outline, `in` before it
// and `out` after it (counter-clockwise).
struct ApertureCorner {
    int in = 0, out = 0;
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

    // The asymptotic, fringe-averaged |F(k)|² (mm⁴): spikes, their corners and the smooth halo.
    double incoherentIntensity(const glm::dvec2& kPerMm) const;
    // Corners between two straight edges (no curved edge on either side; a gap shorter than
    // spikeMinLengthMm between them, a corner cut by the outline's sampling, counts as a corner).
    const std::vector<ApertureCorner>& corners() const { return corners_; }
    // The straight edges (each run of a curved edge merged into one, with its fan).
    const std::vector<ApertureEdge>& spikeEdges() const { return spikes_; }
    // Smooth part: outline length per radian of outward-normal angle β (mm/rad), and its total.
    double smoothDensityMmPerRad(double normalAngleRad) const;
    double smoothLengthMm() const { return smoothLengthMm_; }

private:
    void mergeCurvedEdges();

    std::vector<ApertureEdge> runs_;    // the outline merged into straight runs (exact transform)
    std::vector<ApertureEdge> spikes_;  // the long runs
    std::vector<ApertureCorner> corners_;
    std::vector<double> smoothDensity_; // per normal-angle bin, mm/rad
    double smoothLengthMm_ = 0.0;
    double areaMm2_ = 0.0, perimeterMm_ = 0.0, diameterMm_ = 0.0;
    glm::dvec2 centroidMm_{0.0};
};

// Half-width, in an edge's phase u = k·t L/2, of the zone about its spike where the corner terms
// take their exact profile across it (beyond, their fringe average).
inline constexpr double kCornerZoneU = 4.0 * 3.14159265358979323846;

// The corner's interference term of the fringe-averaged |F(k)|²·|k|⁴ (dimensionless), the
// receiving cell spanning ±inSpanU, ±outSpanU of the edges' phases u = k·t L/2 (0: at k alone).
// Near an edge's spike (|u| < 4π) its sin²u/u is averaged over the span exactly; where both
// edges are that near (the core of a many-bladed iris) the exact product of the two edges'
// terms, 2 (k·n_in)L_in (k·n_out)L_out sinc u_in sinc u_out cos(u_in + u_out), is used.
double cornerInterference(const ApertureEdge& in, const ApertureEdge& out, const glm::dvec2& kPerMm, double inSpanU,
                          double outSpanU);

// Polygon outline of a circle of radius r (mm) with `segments` vertices, counter-clockwise.
std::vector<glm::dvec2> circleOutline(double radiusMm, int segments);

}  // namespace flare
