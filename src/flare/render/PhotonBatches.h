// Photon batches of the final render's passes (Render.h): a pass's photon budget in batches, each
// drawing its photons from the plan's mixture (RenderPlan.h) with random numbers of its own (seed,
// batch), so that a batch's result depends on neither the thread nor the order it ran in.
// Internal to the renderer. A photon's component decides how it is traced:
//   guided photons    emitted over their path's guide mask and traced through its forced sequence,
//                     weighted by the Fresnel and coating factors: each path's photons of a batch
//                     together in SIMD packets (PacketTracer) at the batch's end, or one at a time
//                     where dust, grease or bulk media need the path's points;
//   unguided photons  emitted uniformly over the light's emission disk and traced non-sequentially
//                     in packets (PhotonTracer::tracePacket); an arrival is scored to its path
//                     unless a guided strategy owns it (the photon left inside the path's mask),
//                     or to the higher or the scatter tally.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "flare/optics/IndexTable.h"
#include "flare/photons/PhotonTracer.h"
#include "flare/render/Render.h"
#include "flare/render/RenderPlan.h"
#include "flare/render/SensorHit.h"

namespace flare::renderer {

// The scatter sources a scattered photon met first (housing, dust, grease, bulk: ScatterSource
// without None), indexed by ScatterSource − 1.
constexpr int kScatterSources = static_cast<int>(ScatterSource::Count) - 1;

struct BatchResult {
    std::vector<SensorHit> hits;
    std::vector<double> tallySums;  // Σ Y power (W) per tally
    double layerSums[kFixedLayerCount] = {};
    double sourceSums[kScatterSources] = {};
    RenderStatistics statistics;    // photon counts and fates of this batch
};

// What every batch of a render reads.
struct PhotonBatchInputs {
    const LensSystem& lens;
    const RenderOptions& options;
    const PhotonTracer& tracer;
    const IndexTable& indexTable;
    const std::vector<LightState>& lights;
    const std::vector<PhotonComponent>& components;
    const std::vector<double>& componentCdf;      // cumulativeProbabilities(components)
    const std::vector<int>& scatterSourceLayer;   // per scatter source: its film layer, −1 if none
    size_t tallyCount;
};

// Traces batch `batchIndex` (options.batchPhotons photons) into `out`.
void traceBatch(const PhotonBatchInputs& in, std::int64_t batchIndex, BatchResult& out);

}  // namespace flare::renderer
