// The plan of a render's passes: for every light, which strategy owns each of its paths and how
// many beams each beam-rendered path draws per pass; and the mixture the pass budget's photons are
// drawn from. Internal to the renderer (Render.h), whose constructor plans every light once:
//   planLight       the ghost analysis, the choice of order-4 chains, every path's spectrum in the
//                   light and the second pruning, the guide masks, each path's strategy (beams,
//                   guided photons or unguided: beams only for directional lights, decided here)
//                   and the beams' rates (BeamStrategy.h);
//   photonComponents  the photon budget: lights in proportion to the power they send in, and
//                   within a light the unguided tracer, the direct image and the photon-guided
//                   ghosts.
// A light's paths are its slots: 0 the direct image, 1..G the enumerated ghosts (and order-4
// chains) in the report's order.
#pragma once

#include <memory>
#include <unordered_map>
#include <vector>

#include "flare/core/Spectrum.h"
#include "flare/ghosts/GhostAnalysis.h"
#include "flare/ghosts/GuideMask.h"
#include "flare/optics/PacketTracer.h"
#include "flare/photons/LightSampler.h"
#include "flare/render/Render.h"

namespace flare::renderer {

struct LightState {
    LightSampler sampler;
    WavelengthSampler wavelengths;
    GhostReport report;
    // Slots: 0 the direct image, 1..G the enumerated ghosts in report order.
    std::unordered_map<PathKey, int> slotOfKey;
    std::vector<GuideMask> masks;           // per slot; empty where the slot is not guided
    // Per beam slot: the cells its beams are meshed on, the analysis's lattice and the mask's
    // cells it leaves out (GuideMask::coveringLattice), so that the beams cover the mask.
    std::vector<PupilLattice> beamLattices;
    std::vector<int> ghostLayer;            // per slot: per-ghost film layer, −1 if none
    std::vector<PathStrategy> strategy;     // per slot
    std::vector<int> layer;                 // per slot: the fixed layer its light lands in
    // Beam-rendered slots: the wavelength sampler weighted by the path's throughput, and the
    // expected number of beams per pass (a pass draws its floor, plus one more with the
    // probability of its fraction, and weights every beam by one over the expectation).
    std::vector<std::unique_ptr<WavelengthSampler>> beamWavelengths;
    std::vector<double> beamRate;
    // Per slot: the path's power fraction over the light's spectrum (its beam probe's), or the
    // analysis's at its one wavelength where no probe ran; what per-ghost layers are ranked by.
    std::vector<double> pathPowerFraction;
    int tallyOffset = 0;                    // tallies: offset + slot, then higher, then scatter
    int slots = 0;
    // Per slot: the path's power fraction over the light's spectrum as its beam probe found it
    // (0 where none ran), which the rates' floors follow; and the light's beams per pass (its
    // share of the budget the paths of all lights share, BeamShare.h).
    std::vector<double> beamSpectralPower;
    int beamsPerPass = 0;

    int higherTally() const { return tallyOffset + slots; }
    int scatterTally() const { return tallyOffset + slots + 1; }
};

struct PlannedLight {
    LightState state;  // every per-ghost layer −1 and the tally offset 0: the renderer sets them
    LightPlan plan;
};

// Plans one light. `anyScattering`: the scene scatters light (interior finishes, dust, grease or
// bulk media), so that a light whose paths all miss the sensor may still reach it.
PlannedLight planLight(const LensSystem& lens, const LightSpec& spec, const RenderOptions& options, bool anyScattering);

// One component of the photon mixture: a light's unguided tracer or one of its photon-guided paths.
struct PhotonComponent {
    int light = 0;
    int slot = -1;  // −1: the unguided tracer
    double probability = 0.0;
    // A guided path's forced sequence in SIMD packets, its photons at their own wavelengths.
    std::shared_ptr<const PacketTracer> tracer;
};

// The photon budget's components; `lightWeight`: per light, the power it sends in (0: skipped).
std::vector<PhotonComponent> photonComponents(const LensSystem& lens, const RenderOptions& options,
                                              const std::vector<LightState>& lights,
                                              const std::vector<double>& lightWeight);
// The components' cumulative probabilities, the last exactly 1 (a photon's component is the first
// whose cumulative probability exceeds its uniform).
std::vector<double> cumulativeProbabilities(const std::vector<PhotonComponent>& components);

}  // namespace flare::renderer
