// Beams as a strategy of the final render (Render.h): a kept ghost path's image estimated per pass
// by beams (GhostBeam.h), each the path meshed at a sampled wavelength, sample of the light's
// extent (a direction within a directional light's disk, a point of a disk light; a point light's
// rays fan from it) and film-kernel jitter, its irradiance integrated over the pupil
// deterministically.
// Internal to the renderer:
//   probeBeamPath  a path's beam wavelengths (where its coatings reflect) and, from a probe beam,
//                  its weight in the share of the pass's beams;
//   beamRates      the pass's beams of a light shared among its beam-rendered paths, with floors;
//   beamCount      the beams a path draws in a pass;
//   traceBeam      one beam of a path in a pass, with its correction photons.
// Every light's kept ghosts get beams (RenderPlan.h). Everything the beams need of the light comes
// through its LightState (its sampler's grids and powers, its report, the masks and wavelength
// samplers), never from its kind.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "flare/core/Spectrum.h"
#include "flare/ghosts/GhostAnalysis.h"
#include "flare/photons/PhotonTracer.h"
#include "flare/render/GhostBeam.h"
#include "flare/render/Render.h"
#include "flare/render/RenderPlan.h"
#include "flare/render/SensorHit.h"

namespace flare::renderer {

// Where the film's pixels are, for the beams' images.
FilmFrame filmFrame(const FilmSettings& film);

// What a beam costs, in traced rays: its rays, a tenth of one per pixel of its image rasterised,
// and its correction photons with their twins.
double beamCostRays(const GhostBeam& beam, int correctionPhotonsPerBeam);

// A path's plan for beams, from a probe beam at the analysis's wavelength and the light's central
// direction.
struct BeamProbe {
    bool beams = false;  // the probe beam is not empty: beams render the path
    std::unique_ptr<WavelengthSampler> wavelengths;  // the light's spectrum × the path's throughput
    double spectralPower = 0.0;  // the path's power fraction over the light's spectrum
    double weight = 0.0;         // its share of the pass's beams, before the floors
};
// Probes a guided ghost path (slot ≥ 1, its mask traced) of `light`; `indices` at the analysis's
// wavelength, `pathShape` the path's spectrum in the light (GhostAnalysis.h).
BeamProbe probeBeamPath(const LensSystem& lens, const SpectralIndices& indices, const LightState& light, int slot,
                        const PathSpectrum& pathShape, const Spectrum& lightSpectrum, const RenderOptions& options);

// Per slot: the least beams per pass each of the light's beam-rendered paths draws (0 for the
// others), from their spectral powers (per slot) and the light's beams per pass: a beam per pass
// for every path of a layer (or an equal share of a tenth of the budget), and no beam expected to
// carry more than a twentieth of its layer's power.
std::vector<double> beamRateFloors(const LightState& light, const std::vector<double>& spectralPower, int beamsPerPass);

// Per slot: the expected beams per pass of the light's beam-rendered paths (0 for the others),
// from their probes' weights and spectral powers (per slot), with beamRateFloors' floors (the
// central probe's plan: RenderOptions::beamVarianceProbes 0; BeamShare.h otherwise).
std::vector<double> beamRates(const LightState& light, const std::vector<double>& weight,
                              const std::vector<double>& spectralPower, int beamsPerPass);

// The beams a path draws in a pass: the floor of its rate, and one more with the probability of
// its fraction (a function of the seed, the pass and the path).
int beamCount(std::uint64_t seed, double rate, int pass, size_t light, int slot);

// One beam of one path in one pass, and what it produced.
struct BeamJob {
    int light = 0, slot = 0, index = 0;  // index: the beam's number within the path's pass
    int replicate = 0;
    double rate = 0.0;                   // the path's expected beams in this pass (its weight is 1 / rate)
    std::uint64_t sequenceIndex = 0;     // the beam's point in its replicate's sequence
    GhostBeam beam;
    glm::dvec2 jitterPx{0.0};
    glm::dvec3 scale{0.0};     // film units per unit irradiance × pupil area
    std::uint64_t seed = 0;    // the small triangles' random points
    std::vector<SensorHit> hits;  // correction photons (+) and their twins (−)
    double powerY = 0.0;       // the beam's Y power on the sensor plus its corrections (W)
    std::int64_t photons = 0;
};

// Traces `job` (its light, slot, index, replicate and sequence index set) in pass `pass`: the beam
// and its correction photons. `tracer`: the render's photon tracer (the clear crossing of dust,
// grease and bulk media).
void traceBeam(const LensSystem& lens, const RenderOptions& options, const PhotonTracer& tracer,
               const LightState& light, int pass, BeamJob& job);

}  // namespace flare::renderer
