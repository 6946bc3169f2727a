// How a render's beams are shared among the beam-rendered paths of all its lights, from each path's
// predicted variance per beam and cost per beam (BeamVariance.h). Internal to the renderer.
//
// A path p estimated by n_p beams a pass contributes about v_p / n_p to the ghost layer's summed
// pixel variance (v_p: one beam's variance, the spread of its image over the sampled wavelength,
// point of the light and kernel jitter) and costs c_p n_p. Minimising Σ v_p / n_p for a given
// cost Σ c_p n_p, with a floor f_p under each rate, gives (Lagrange, KKT)
//     n_p = max(f_p, λ √(v_p / c_p)),
// one λ for every path of every light: the variances are in the film's absolute units, so a light
// whose ghosts need few beams gets few, and one whose ghosts need many gets them, whatever the
// lights' number. λ is set so that the rates add up to the budget (the sum of the lights' beams
// per pass): every allocation of this form is the optimum for its own cost, so fixing the count
// rather than the cost keeps a pass's size where `--beams-per-pass` puts it.
//
// The floors (BeamStrategy.h's: a beam per pass for every path of a layer, no beam carrying more
// than a twentieth of its layer's power) keep every path with power sampled in every pass, so the
// estimate never rests on rare heavy draws and every path's spread shows in the error estimate.
// Each beam is weighted by one over its path's rate: unbiased whatever the rates.
#pragma once

#include <vector>

#include "flare/photons/PhotonTracer.h"
#include "flare/render/Render.h"
#include "flare/render/RenderPlan.h"

namespace flare::renderer {

// Rates n_p = max(floor_p, λ strength_p) with Σ n_p = budget (strength_p = √(v_p / c_p) ≥ 0). When
// the floors alone reach the budget (or no path has strength), the floors. Throws
// std::invalid_argument on sizes that differ or a negative or non-finite strength, floor or budget.
std::vector<double> waterFillRates(const std::vector<double>& strength, const std::vector<double>& floor, double budget);

// Sets the beam rates of every beam-rendered path of `lights` (LightState::beamRate, on entry the
// central probe's shares, BeamStrategy.h) from `options.beamVarianceProbes` probes of each
// (BeamVariance.h): waterFillRates over all of them, with each light's floors (beamRateFloors) and
// the lights' beams per pass added up as the budget, gives each light its beams; within a light,
// each path gets the larger of that rate and the central probe's scaled to the light's beams, all
// scaled back to them (at least half of what either predictor asks: the sampled probes count the
// colour of single-wavelength beams, which the sequences' stratified wavelengths integrate far
// faster than 1 / n; the central probe misses a disk light's moving, focused ghosts). With fewer
// than two lights with beams, nothing changes. The probes run in parallel; the rates do not depend
// on the threads.
void shareBeamsByVariance(const LensSystem& lens, const RenderOptions& options, const PhotonTracer& tracer,
                          std::vector<LightState>& lights);

}  // namespace flare::renderer
