// The pass plan of a guided render: how many beams and how many photons each pass gets, chosen
// from the passes before it so that the worst targeted error falls fastest per unit of cost.
// Internal to the renderer (Render.h).
//
// A pass of the guided render is two independent estimators of the image added together: the
// beams (the ghosts inside their masks, and the guided order-4 chains) and the photons (the direct
// image, the scattered light, what the masks leave out). A pass of beam scale β draws every beam
// path's planned rate × β beams, and one of π photon batches (the nominal pass: β = 1, π = the
// options' batches); each strategy's part of the pass is weighted by one over its own expected
// count, so the pass stays an unbiased estimate of the image whatever its sizes, and the film's
// image, the mean over passes, does too (the sizes of a pass are decided from earlier passes only).
//
// The model: over P passes, a targeted variance group's summed pixel variance is
//     V = (1/P²) Σ_p (a / β_p + c / π_p),
// a and c the beams' and the photons' variance of a nominal pass (measured: the film's estimate of
// the group split by a hidden beams-only variance group, Render.cpp). Each strategy's cost is
// proportional to its size: β·C_b + π·C_p with C_b, C_p a nominal pass's deterministic work (beam
// rays traced, photons traced: never wall time, so the plan is the same for any thread count and
// any number of ranks). The next pass keeps the nominal pass's cost and takes the split that
// minimises max over targets of (P² V + a/β + c/π) / (‖image‖² T²): the largest predicted
// relative error over its target. For one target and nothing yet accumulated this is the classic
// allocation n_i ∝ √(v_i / c_i) (the test checks it); the maximum of functions convex in the split
// is convex, so a golden-section search finds it.
#pragma once

#include <vector>

namespace flare::renderer {

// One pass's sizes.
struct PassSizes {
    double beamScale = 1.0;  // every beam path's planned rate × this
    int photonBatches = 0;   // photon batches of the pass
};

// One targeted variance group, as the plan sees it.
struct PlanTarget {
    double beamVariance = 0.0;    // a: a nominal pass's summed pixel variance from beams
    double photonVariance = 0.0;  // c: the same from photons
    double accumulated = 0.0;     // Σ over the passes so far of a/β_p + c/π_p (= P² × the variance now)
    // ‖image‖² × target²: a group's relative error over its target is √(P² V / this) / P.
    double normTimesTarget2 = 1.0;
};

// The split of one pass's cost, in units of the nominal pass.
struct PlanSplit {
    double beamScale = 1.0, photonScale = 1.0;
};

// The beam and photon scales of the next pass: β·beamCost + π·photonCost equals beamCost +
// photonCost (the nominal pass's cost), both within [minScale, maxScale], minimising the largest
// (accumulated + a/β + c/π) / normTimesTarget2 over the targets. With no target, no cost or no
// variance measured, the nominal pass (1, 1).
PlanSplit choosePassSplit(const std::vector<PlanTarget>& targets, double beamCost, double photonCost,
                          double minScale, double maxScale);

// A nominal pass's deterministic cost, in traced beam rays (the beams' work: BundleTracer rays,
// their rasterising included on average): a photon costs about kPhotonRays of them, plus
// kSplitRays per extra direction of its interior bounces (RenderOptions::scatterSplits). Measured
// on the 2-core Zen 4 machine (docs/BENCHMARKS.md, "the pass plan"); a constant, not a timing, so
// that every thread count and every rank plans alike.
inline constexpr double kPhotonRays = 2.4;
inline constexpr double kSplitRays = 0.2;
inline double photonCostInRays(int scatterSplits) { return kPhotonRays + kSplitRays * (scatterSplits - 1); }

// A beam scale is planned in steps of 1/kBeamScaleSteps (it travels to the ranks as an integer).
inline constexpr int kBeamScaleSteps = 1 << 16;

// The bounds of a pass's scales: a strategy keeps at least this share of its nominal size (its
// variance stays measured and its layers estimated), and takes at most this many times it.
inline constexpr double kMinPassScale = 0.125;
inline constexpr double kMaxPassScale = 4.0;

}  // namespace flare::renderer
