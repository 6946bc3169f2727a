// The bytes a rank sends rank 0 after tracing its share of a pass (PassExchange.h): per job its
// index and what the merge reads of its result (a batch's hits, tallies and statistics; a beam's
// triangles as GhostBeam::rasterise reads them, its rim's segments, jitter, scale, seed, hits and
// power), copied bit for bit, so that rank 0's merge sees exactly what its own trace would have
// produced. A beam read back is good for the merge alone: its triangles' pupil points (the mesh's,
// for twins and for building a rim) are not sent, and its rim comes built. Both ends run the same
// build; a short or inconsistent message is an internal error (std::runtime_error). Internal to
// the renderer.
#pragma once

#include <cstdint>
#include <vector>

#include "flare/render/BeamStrategy.h"
#include "flare/render/PhotonBatches.h"

namespace flare::renderer {

// Appends batch `index` of the pass, or beam job `index`, to `out`.
void writeBatch(std::int64_t index, const BatchResult& batch, std::vector<char>& out);
void writeBeam(std::int64_t index, const BeamJob& job, std::vector<char>& out);

// Appends the time the sending rank took to trace its share and encode it (wall and CPU seconds),
// by which rank 0 balances the shares and reports the costs.
void writeTraceTime(double seconds, double cpuSeconds, std::vector<char>& out);

// Reads a rank's message into the pass's `batches` and `beams` (whose light, slot, index,
// replicate and sequence index rank 0 drew itself), each entry at its index; `frame` is the film's
// (the beams' images). Returns how many jobs it held and its trace time.
struct PassMessage {
    long jobs = 0;
    double traceS = 0.0, traceCpuS = 0.0;
};
PassMessage readPassResults(const std::vector<char>& message, const FilmFrame& frame, std::vector<BatchResult>& batches,
                            std::vector<BeamJob>& beams);

}  // namespace flare::renderer
