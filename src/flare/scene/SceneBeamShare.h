// How a scene's pass of beams is shared among its lights when its render.beams_by_power is set
// (`flare composite` sets it for a plate's region lights): by their share of the power. Each light's ghosts are estimated by its own beams; the ghost layer's variance is the sum
// over the lights of (power)² × (its ghosts' relative variance per beam) / (its beams), so for
// lights whose ghosts are alike per unit of power the total beams N are best shared in proportion
// to the power (minimising Σ P²/n under Σ n = N gives n ∝ P). Equal beams, as before, spent a
// dim region's 256 beams on a part of the flare a thousand times weaker than the brightest's.
// The estimate stays unbiased whatever the split (each path's beams are weighted by one over their
// rate); the floor keeps every light with power sampled in every pass, so that its part is never
// left to a heavy-tailed rare draw and its spread shows in the error estimate.
#pragma once

#include <vector>

#include "flare/photons/Light.h"

namespace flare {

// Beams per pass for lights of the given powers (≥ 0): `totalBeams` shared in proportion to the
// power, rounded, each light with power at least `floorBeams` (a light without power gets the
// floor too: its beams cost little and it is never left out). The sum exceeds totalBeams by at
// most the floors' excess. Throws std::invalid_argument on a negative or non-finite power or a
// floor below 1.
std::vector<int> beamsByPowerShare(const std::vector<double>& powers, long totalBeams, int floorBeams);

// The fewest beams per pass a light is given when the beams follow the power (or beamsPerPass,
// if fewer): every kept path of it then draws a beam in most passes (BeamStrategy.h's floors
// share these among its paths).
inline constexpr int kMinLightBeams = 16;

// Per light: beamsPerPass × the number of lights shared by each light's irradiance at the lens
// (a directional light's power; a point or disk light's intensity over its distance squared), at
// least min(beamsPerPass, kMinLightBeams) each.
std::vector<int> lightBeamsByPower(const std::vector<LightSpec>& lights, int beamsPerPass);

}  // namespace flare
