// The bytes ranks send each other in a shared pass (PassExchange.h). After tracing its share, a
// rank sends per job its index and what the merge reads of its result, copied bit for bit: to
// rank 0 a batch's hits, tallies and statistics and a beam's hits, power and rays; to the owner
// of a group of the film's bands, the part of a beam that reaches them (its triangles as
// GhostBeam::rasterise reads them, with their indices in the beam, its rim's segments reaching
// them, jitter, scale and seed), so that the owner rasterises those bands exactly as the tracing
// rank would have. A beam read back is good for the merge alone: its triangles' pupil points (the
// mesh's, for twins and for building a rim) are not sent, and its rim comes built. After
// rasterising, a band owner sends rank 0 its bands' images (writeBandImage). Both ends run the
// same build; a short or inconsistent message is an internal error (std::runtime_error). Internal
// to the renderer.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "flare/render/BeamStrategy.h"
#include "flare/render/PhotonBatches.h"

namespace flare::renderer {

// Appends batch `index` of the pass, or beam job `index`, to `out`.
void writeBatch(std::int64_t index, const BatchResult& batch, std::vector<char>& out);
void writeBeam(std::int64_t index, const BeamJob& job, std::vector<char>& out);
// Appends the part of beam job `index` that the owner of the film bands [firstBand, lastBand]
// rasterises (the triangles and rim segments reaching them, each with its index in the beam, and
// the jitter, scale and seed: GhostBeam::trianglesReaching), and with `withResults` what rank 0
// also reads of the job (the rays its mesh traced, its hits, power and photons). Appends nothing
// when there is neither. writeBeam(index, job, out) is the whole beam with its results.
void writeBeam(std::int64_t index, const BeamJob& job, int firstBand, int lastBand, bool withResults,
               std::vector<char>& out);

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
// Band owners (docs/distributed.md): the beams' image over a band as the merge hands it to the
// film (Renderer::rasteriseBeamsInBand, Film::addBand's arguments), the band's rows of widthPx
// pixels, only the tile-wide runs of a row (Film's tiles, 32 px) that hold a value other than
// zero: rank 0 adds the runs read back exactly as the band owner's buffer (addBand skips runs of
// zeros). Only the runs within the columns [xBegin, xEnd) are read, whole: the columns must be
// whole runs (both ends multiples of 32, or xEnd the frame's width), as Renderer::BandAdder's are.
// Appended to a band owner's message, after its bands' rasterising costs.
void writeBandImage(int band, int layer, bool inTotal, const double* rows, int widthPx, int heightPx, int xBegin, int xEnd,
                    std::vector<char>& out);
void writeBandCosts(int firstBand, const std::vector<double>& seconds, double phaseS, double phaseCpuS,
                    std::vector<char>& out);
struct BandImage {
    int band = 0, layer = 0;
    bool inTotal = true;
    size_t at = 0;  // its runs, in the message
};
struct BandMessage {
    std::vector<BandImage> images;  // in the order written
    int firstBand = 0;
    std::vector<double> bandSeconds;  // the owner's time rasterising each of its bands
    double phaseS = 0.0, phaseCpuS = 0.0;  // its time from the exchange of the beams to sending the bands
};
// Reads a band owner's message (bands of a film widthPx × heightPx, bandCount of them).
BandMessage readBandMessage(const std::vector<char>& message, int widthPx, int heightPx);
// Band image `image` of `message` into `rows` (kBandRows × widthPx × 3 values, zeroed here).
void readBandImage(const std::vector<char>& message, const BandImage& image, int widthPx, int heightPx,
                   std::vector<double>& rows);
// The same run by run, without a band of zeros around them: add(row, xBegin, xEnd, values) for each
// run in the order written (row: the film's; values: 3 per pixel, xEnd − xBegin pixels), as
// Film::addRowPart takes them: the film receives exactly what addBand of the band's rows adds.
using BandRunAdder = std::function<void(int rowPx, int xBeginPx, int xEndPx, const double* values)>;
void forEachBandImageRun(const std::vector<char>& message, const BandImage& image, int widthPx, int heightPx,
                         const BandRunAdder& add);

PassMessage readPassResults(const std::vector<char>& message, const FilmFrame& frame, std::vector<BatchResult>& batches,
                            std::vector<BeamJob>& beams);

}  // namespace flare::renderer
