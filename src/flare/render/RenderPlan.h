// The plan of a render's passes: for every light, which strategy owns each of its paths and how
// many beams each beam-rendered path draws per pass (LightState); and the components of the
// mixture the pass budget's photons are drawn from. Internal to the renderer (Render.h), whose
// constructor plans every light once. A light's paths are its slots: 0 the direct image, 1..G the
// enumerated ghosts (and order-4 chains) in the report's order.
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
    std::vector<int> ghostLayer;            // per slot: per-ghost film layer, −1 if none
    std::vector<PathStrategy> strategy;     // per slot
    std::vector<int> layer;                 // per slot: the fixed layer its light lands in
    // Beam-rendered slots: the wavelength sampler weighted by the path's throughput, and the
    // expected number of beams per pass (a pass draws its floor, plus one more with the
    // probability of its fraction, and weights every beam by one over the expectation).
    std::vector<std::unique_ptr<WavelengthSampler>> beamWavelengths;
    std::vector<double> beamRate;
    int tallyOffset = 0;                    // tallies: offset + slot, then higher, then scatter
    int slots = 0;

    int higherTally() const { return tallyOffset + slots; }
    int scatterTally() const { return tallyOffset + slots + 1; }
};

// One component of the photon mixture: a light's unguided tracer or one of its photon-guided paths.
struct PhotonComponent {
    int light = 0;
    int slot = -1;  // −1: the unguided tracer
    double probability = 0.0;
    // A guided path's forced sequence in SIMD packets, its photons at their own wavelengths.
    std::shared_ptr<const PacketTracer> tracer;
};

}  // namespace flare::renderer
