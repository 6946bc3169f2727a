// A pass of the final render shared among processes (PassExchange.h). The jobs (beams, photon
// batches) are shared as before; the film's rows are shared too, in contiguous groups of its bands
// (Film::kBandRows), one group per rank:
//   1. the ranks take the pass's jobs in chunks from a shared counter as they become free
//      (PassExchange::claimJobs: rank 0, which alone ends the last pass, takes fewer, and all end
//      their tracing together whatever the jobs cost); the ranks exchange what they traced: each beam's part that a band owner
//      rasterises (its triangles and rim segments reaching the owner's bands) to that owner, and
//      everything rank 0 reads (the batches' hits, tallies and statistics, the beams' hits, power
//      and rays) to rank 0;
//   2. each rank rasterises every beam over its own bands (the merge's largest part, nearly all
//      of it with beams), rank 0 meanwhile its bands and every band's hits; the others send rank 0
//      their bands' images as the merge would add them to the film (Renderer::rasteriseBeamsInBand)
//      without waiting for rank 0 to take them (PassExchange::sendToRoot), and trace their share
//      of the next pass at once;
//   3. rank 0 adds them to the film in their bands, after the hits, as one process adds them,
//      and ends the pass: the film, its error sums and the tallies stay rank 0's alone. It ends
//      its own bands' pass (the film's per-pass sums, the error estimates asked after every pass)
//      before the others' images arrive, band by band as one process ends them (Film::endPassInBand),
//      so that what it does alone after them is their bands' part.
// So every band receives the same additions in the same order as one process makes them: the
// image is bitwise one process's, whatever the split of the jobs and of the bands, which may
// therefore follow the ranks' timing: the jobs go to whichever rank claims them first, and at
// every pass's exchange rank 0 broadcasts the next pass's split of the bands, chosen from the
// costs measured so far. The exchange is
// the one point of a pass where the ranks wait for each other: rank 0 waits for the others' band
// images only when its own bands are done first, and no other rank waits for rank 0 but at the
// exchange (docs/distributed.md).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <ctime>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "flare/render/BandSplit.h"
#include "flare/render/BeamStrategy.h"
#include "flare/render/PassExchange.h"
#include "flare/render/PassWire.h"
#include "flare/render/PhotonBatches.h"
#include "flare/render/Render.h"
#include "flare/render/RenderPlan.h"

namespace flare {

namespace renderer {

struct DistributedPasses {
    std::vector<std::vector<char>> outboxes;  // per rank: what this rank sends it in a pass's exchange
    std::vector<std::vector<char>> inbox;     // per rank: what it sent this one
    std::vector<char> bandsOut;               // a band owner's images (ranks ≠ 0)
    // (Ranks ≠ 0: each of its bands' images as rasterised, before they are joined into bandsOut;
    // kept from pass to pass, as the messages are, so that tens of MB a pass are not allocated,
    // grown and faulted in afresh.)
    std::vector<std::vector<char>> bandImages;
    std::vector<std::vector<char>> bandsIn;   // the owners' images (rank 0)
    // Ranks ≠ 0: the pass traced ahead (its beams; its batches are in the renderer's batches_),
    // the jobs this rank claimed of it, in order, and how long tracing them took.
    bool ahead = false;
    // The session's first pass, whose bands are split by the beams' footprints (footprintBands).
    bool firstPass = true;
    std::vector<BeamJob> beamJobs;
    std::vector<int> mine;
    double traceS = 0.0, traceCpuS = 0.0;
    // What every rank knows of the current pass: the bands' owners (rank r owns bands
    // [bandStart[r], bandStart[r + 1])); and of the next pass (broadcast with the pass's exchange,
    // so that the others trace the next pass at once).
    std::vector<int> bandStart, nextBandStart;
    // Rank 0: each band's rasterising in the last pass (per thread of its owner) and each rank's
    // time besides its bands in the band phase, of which rank 0's splatting every hit (rootHitsS);
    // and that pass's sizes, by which they are scaled to the pass they split (balancedBands).
    std::vector<double> bandSeconds, besidesBandsS;
    double rootHitsS = 0.0;
    PassSizes costSizes;
};

namespace {

double secondsSince(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}
// The process's CPU time (all its threads), s.
double cpuSeconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

// A session's first split, before any band's cost has been measured: each beam's rasterising taken
// as the pixels of its path's analysed footprint (the bounding box of its landings on the sensor),
// spread evenly over the footprint's rows. A beam's triangles cover its ghost's image, so its
// cost grows with that area (the ghosts of a frame are mostly wide, dim discs), and where the
// ghosts fall is far from even over the rows (the row split left rank 0 waiting for the others'
// images of the first pass). The footprints are known on every rank before anything is traced,
// and the count is in whole pixels: every rank computes the same split without an exchange. Rank 0's
// time besides its bands (every band's hits, decoding) is not known yet: the split gives it the
// lead alone (balancedBands), the side where a misjudged phase costs nothing.
std::vector<int> footprintBands(const std::vector<BeamJob>& beamJobs, const std::vector<LightState>& lights,
                                const FilmFrame& frame, int bands, int ranks) {
    std::vector<PixelBox> boxes;
    boxes.reserve(beamJobs.size());
    auto clampedPx = [](double v, int size) {
        return std::isfinite(v) ? static_cast<int>(std::clamp(v, 0.0, static_cast<double>(size))) : 0;
    };
    for (const BeamJob& job : beamJobs) {
        const std::vector<GhostEstimate>& ghosts = lights[static_cast<size_t>(job.light)].report.ghosts;
        if (job.slot < 1 || job.slot > static_cast<int>(ghosts.size())) continue;
        const GhostEstimate& ghost = ghosts[static_cast<size_t>(job.slot - 1)];
        const glm::dvec2 a = frame.toPixel(ghost.footprintMinMm), b = frame.toPixel(ghost.footprintMaxMm);
        boxes.push_back({clampedPx(std::floor(std::min(a.x, b.x)), frame.widthPx),
                         clampedPx(std::floor(std::min(a.y, b.y)), frame.heightPx),
                         clampedPx(std::ceil(std::max(a.x, b.x)), frame.widthPx),
                         clampedPx(std::ceil(std::max(a.y, b.y)), frame.heightPx)});
    }
    const std::vector<double> pixels = bandPixels(boxes, frame.heightPx, Film::kBandRows);
    if (static_cast<int>(pixels.size()) != bands) return bandsByRows(bands, ranks);
    return balancedBands(pixels, std::vector<double>(static_cast<size_t>(ranks), 0.0));
}

}  // namespace

}  // namespace renderer

void Renderer::setExchange(PassExchange* exchange) {
    exchange_ = exchange;
    distributed_.reset();
    if (exchange_ == nullptr || exchange_->size() <= 1) return;
    distributed_ = std::make_shared<renderer::DistributedPasses>();
    const int ranks = exchange_->size();
    distributed_->outboxes.resize(static_cast<size_t>(ranks));
    distributed_->inbox.resize(static_cast<size_t>(ranks));
    // Until the first pass's beams are drawn (footprintBands): the bands split by rows.
    distributed_->bandStart = renderer::bandsByRows(film_.bandCount(), ranks);
    distributed_->nextBandStart = distributed_->bandStart;
    // Rank 0 makes the error estimates asked after every pass (the flare's: the progress line and
    // the stop rule; the adaptive plan's) band by band as the pass ends: its own bands' part while
    // the others' bands are on their way (Film::estimateAtPassEnd).
    if (exchange_->rank() == 0) {
        std::vector<int> groups;
        if (!options_.ghostGroupsOnly) groups.push_back(kGroupFlare);
        for (const RenderOptions::ErrorTarget& target : options_.errorTargets)
            if (target.group >= 0 && target.group < kVarianceGroupCount) groups.push_back(target.group);
        if (beamsGroup_ >= 0) groups.push_back(beamsGroup_);
        film_.estimateAtPassEnd(groups);
    }
}

void Renderer::runDistributedPass() {
    const auto start = std::chrono::steady_clock::now();
    PassExchange& exchange = *exchange_;
    renderer::DistributedPasses& d = *distributed_;
    const int rank = exchange.rank(), ranks = exchange.size();
    // (The current pass's batches, 0 without photons: the plan sizes each pass, startPass.)
    auto batchCount = [&] { return static_cast<int>(batches_.size()); };
    const int width = options_.film.widthPx, height = options_.film.heightPx;
    const FilmFrame frame = renderer::filmFrame(options_.film);
    const renderer::PhotonBatchInputs batchInputs{*lens_, options_, tracer_, indexTable_, lightStates_, components_,
                                                  componentCdf_, scatterSourceLayer_, tallies_.size()};
    // The current pass's jobs this rank claims (PassExchange::claimJobs, on the pass's counter),
    // chunk by chunk as its threads become free, each chunk traced in parallel on them; returns the
    // jobs it traced, in order. (Claims are made by this thread alone: MPI is called from the main
    // thread only.)
    auto traceClaimed = [&](std::vector<renderer::BeamJob>& beamJobs) {
        const int beams = static_cast<int>(beamJobs.size());
        const long jobs = beams + batchCount();
        const int slot = statistics_.passes % 2;
        const int threads = tbb::this_task_arena::max_concurrency();
        std::vector<int> mine;
        for (;;) {
            // (What is left read first, so that a rank back from a long chunk does not claim by
            // what was left before it: two claims of a few microseconds.)
            const long count = claimChunk(jobs - exchange.claimJobs(slot, 0), ranks, threads);
            const long first = exchange.claimJobs(slot, count);
            if (first >= jobs) break;
            const long end = std::min(jobs, first + count);
            tbb::parallel_for(tbb::blocked_range<long>(first, end, 1), [&](const tbb::blocked_range<long>& range) {
                for (long j = range.begin(); j != range.end(); ++j) {
                    if (j < beams)
                        renderer::traceBeam(*lens_, options_, tracer_, lightStates_[beamJobs[j].light],
                                            statistics_.passes, beamJobs[j]);
                    else
                        renderer::traceBatch(batchInputs, batchesDone_ + (j - beams), batches_[j - beams]);
                }
            });
            for (long j = first; j < end; ++j) mine.push_back(static_cast<int>(j));
        }
        return mine;
    };
    // What this rank traced of the pass (`mine`), into the outboxes: each beam's part for every
    // other band owner, and to rank 0 the results it reads (rank 0's own stay where they are).
    auto encodeShare = [&](const std::vector<renderer::BeamJob>& beamJobs, const std::vector<int>& mine) {
        const int beams = static_cast<int>(beamJobs.size());
        for (auto& box : d.outboxes) box.clear();
        for (const int j : mine) {
            if (j >= beams) {
                if (rank != 0) renderer::writeBatch(j - beams, batches_[j - beams], d.outboxes[0]);
                continue;
            }
            for (int q = 0; q < ranks; ++q)
                if (q != rank)
                    renderer::writeBeam(j, beamJobs[j], d.bandStart[q], d.bandStart[q + 1] - 1, q == 0, d.outboxes[q]);
        }
    };
    // This rank's bands of the pass: for each, `perBand(band)` and then the beams' images, handed
    // to `add`; returns each band's time (per thread of this rank: the arena's threads share them).
    auto ownBands = [&](const std::vector<renderer::BeamJob>& beamJobs, const auto& perBand, const auto& add) {
        const int first = d.bandStart[rank], count = d.bandStart[rank + 1] - first;
        std::vector<double> seconds(static_cast<size_t>(count), 0.0);
        tbb::parallel_for(tbb::blocked_range<int>(0, count, 1), [&](const tbb::blocked_range<int>& range) {
            std::array<std::vector<double>, 3> scratch;
            for (int i = range.begin(); i != range.end(); ++i) {
                const int band = first + i;
                perBand(band);
                const auto bandStart = std::chrono::steady_clock::now();
                rasteriseBeamsInBand(band, beamJobs, scratch,
                                     [&](int layer, const double* rows, bool inTotal, int xBegin, int xEnd) {
                                         add(band, i, layer, rows, inTotal, xBegin, xEnd);
                                     });
                seconds[i] = renderer::secondsSince(bandStart);
            }
        });
        const double threads = std::max(1, tbb::this_task_arena::max_concurrency());
        for (double& s : seconds) s /= threads;
        return seconds;
    };
    // The next pass's bands and sizes (planned by rank 0 a pass earlier), from rank 0 to every
    // rank, at the pass's exchange (where every rank meets anyway).
    auto broadcastNextSplit = [&] {
        std::vector<int> values(d.nextBandStart.begin(), d.nextBandStart.end());
        const int next = statistics_.passes + 1;
        passSizes_.resize(static_cast<size_t>(std::max<int>(next + 1, static_cast<int>(passSizes_.size()))));
        values.push_back(static_cast<int>(std::lround(passSizes(next).beamScale * renderer::kBeamScaleSteps)));
        values.push_back(passSizes(next).photonBatches);
        exchange.broadcastFromRoot(values);
        passSizes_[static_cast<size_t>(next)] = {static_cast<double>(values[values.size() - 2]) / renderer::kBeamScaleSteps,
                                                 values.back()};
        values.resize(values.size() - 2);
        d.nextBandStart.assign(values.begin(), values.end());
    };
    // The pass is over: the next pass's split is the current one.
    auto advanceSplit = [&] { d.bandStart = d.nextBandStart; };

    if (rank != 0) {
        // The pass's beam jobs drawn, and this rank's share traced and timed.
        auto drawAndTraceShare = [&] {
            startPass();
            d.beamJobs = drawBeamJobs();
            if (d.firstPass)
                d.bandStart = renderer::footprintBands(d.beamJobs, lightStates_, frame, film_.bandCount(), ranks);
            const auto traceStart = std::chrono::steady_clock::now();
            const double cpuStart = renderer::cpuSeconds();
            d.mine = traceClaimed(d.beamJobs);
            d.traceS = renderer::secondsSince(traceStart);
            d.traceCpuS = renderer::cpuSeconds() - cpuStart;
        };
        // Every rank draws the pass's beam jobs (their counts and sequence points follow from the
        // seed and the passes before), so that job j is the same job on every rank.
        if (!d.ahead) drawAndTraceShare();
        const int batches = batchCount();
        const auto encodeStart = std::chrono::steady_clock::now();
        const double encodeCpuStart = renderer::cpuSeconds();
        encodeShare(d.beamJobs, d.mine);
        renderer::writeTraceTime(d.traceS + renderer::secondsSince(encodeStart),
                                 d.traceCpuS + renderer::cpuSeconds() - encodeCpuStart, d.outboxes[0]);
        broadcastNextSplit();
        exchange.allToAll(d.outboxes, d.inbox);
        // The others' beams, cut to this rank's bands, beside its own; its bands' images to rank 0.
        const auto phaseStart = std::chrono::steady_clock::now();
        const double phaseCpuStart = renderer::cpuSeconds();
        for (int q = 0; q < ranks; ++q)
            if (q != rank) renderer::readPassResults(d.inbox[q], frame, batches_, d.beamJobs);
        const int first = d.bandStart[rank], count = d.bandStart[rank + 1] - first;
        // (Band i of this pass's share in bandImages[i], whichever band it is: the buffers keep
        // their capacity whatever the split.)
        if (d.bandImages.size() < static_cast<size_t>(count)) d.bandImages.resize(static_cast<size_t>(count));
        for (std::vector<char>& image : d.bandImages) image.clear();
        const std::vector<double> seconds = ownBands(
            d.beamJobs, [](int) {},
            [&](int band, int i, int layer, const double* rows, bool inTotal, int xBegin, int xEnd) {
                renderer::writeBandImage(band, layer, inTotal, rows, width, height, xBegin, xEnd, d.bandImages[i]);
            });
        exchange.finishSends();  // (the last pass's images: d.bandsOut is reused)
        d.bandsOut.clear();
        size_t imageBytes = 0;
        for (int i = 0; i < count; ++i) imageBytes += d.bandImages[i].size();
        d.bandsOut.reserve(imageBytes + 64 + sizeof(double) * static_cast<size_t>(count));  // (and the costs)
        for (int i = 0; i < count; ++i)
            d.bandsOut.insert(d.bandsOut.end(), d.bandImages[i].begin(), d.bandImages[i].end());
        renderer::writeBandCosts(first, seconds, renderer::secondsSince(phaseStart),
                                 renderer::cpuSeconds() - phaseCpuStart, d.bandsOut);
        // Without waiting for rank 0 to take them: the next pass needs nothing from rank 0 but
        // its exchange.
        exchange.sendToRoot(d.bandsOut);
        d.firstPass = false;
        advanceSplit();
        ++exchangeCosts_.passes;
        batchesDone_ += batches;
        ++statistics_.passes;
        // The next pass's share, now, while rank 0 adds the bands and ends the pass.
        d.ahead = passLimit_ <= 0 || statistics_.passes < passLimit_;
        if (d.ahead) drawAndTraceShare();
        statistics_.seconds += renderer::secondsSince(start);
        return;
    }

    const int replicate = replicateOfPass(statistics_.passes);
    startPass();
    const int batches = batchCount();
    std::vector<renderer::BeamJob> beamJobs = drawBeamJobs();
    if (d.firstPass) d.bandStart = renderer::footprintBands(beamJobs, lightStates_, frame, film_.bandCount(), ranks);
    const int beams = static_cast<int>(beamJobs.size());
    const long jobs = beams + batches;
    const auto traceStart = std::chrono::steady_clock::now();
    const double traceCpuStart = renderer::cpuSeconds();
    const std::vector<int> mine = traceClaimed(beamJobs);
    const long traced = static_cast<long>(mine.size());
    encodeShare(beamJobs, mine);
    exchangeCosts_.traceS += renderer::secondsSince(traceStart);
    exchangeCosts_.traceCpuS += renderer::cpuSeconds() - traceCpuStart;

    // The next pass's bands, from the last pass's costs, which the others use as soon as their
    // bands of this pass are done; then the others' results (their beams cut to rank 0's bands),
    // while they receive rank 0's beams. Every rank has claimed its last job of the pass: its
    // counter starts again for the pass after next.
    const auto exchangeStart = std::chrono::steady_clock::now();
    if (d.bandSeconds.empty()) {
        d.nextBandStart = d.bandStart;
    } else {
        // The costs are pass p − 1's, the split pass p + 1's: the adaptive plan changes the beams and
        // the photon batches from pass to pass, and rasterising scales with the beams, rank 0's
        // splatting the hits with the batches (the rest, decoding and ending its bands, is taken
        // as it was).
        const int next = statistics_.passes + 1;
        const renderer::PassSizes& from = d.costSizes;
        const renderer::PassSizes to = next < static_cast<int>(passSizes_.size()) ? passSizes(next) : from;
        const double beamsRatio = from.beamScale > 0.0 ? to.beamScale / from.beamScale : 1.0;
        const double batchesRatio =
            from.photonBatches > 0 ? static_cast<double>(to.photonBatches) / static_cast<double>(from.photonBatches) : 1.0;
        std::vector<double> bandSeconds = d.bandSeconds, besidesS = d.besidesBandsS;
        for (double& seconds : bandSeconds) seconds *= beamsRatio;
        besidesS[0] += d.rootHitsS * (batchesRatio - 1.0);
        d.nextBandStart = renderer::balancedBands(bandSeconds, besidesS);
    }
    broadcastNextSplit();
    exchange.allToAll(d.outboxes, d.inbox);
    exchange.resetClaims(statistics_.passes % 2);
    exchangeCosts_.gatherS += renderer::secondsSince(exchangeStart);
    const auto bandsStart = std::chrono::steady_clock::now();
    const double bandsCpuStart = renderer::cpuSeconds();
    long received = traced;
    double othersTraceS = 0.0, othersTraceCpuS = 0.0;
    for (int r = 1; r < ranks; ++r) {
        const renderer::PassMessage message = renderer::readPassResults(d.inbox[r], frame, batches_, beamJobs);
        received += message.jobs;
        othersTraceS += message.traceS;
        othersTraceCpuS += message.traceCpuS;
        exchangeCosts_.bytesReceived += static_cast<double>(d.inbox[r].size());
    }
    if (received != jobs)
        throw std::runtime_error("distributed render: pass " + std::to_string(statistics_.passes) + " gathered " +
                                 std::to_string(received) + " job results of " + std::to_string(jobs));
    weightPhotonHits(batches_);
    exchangeCosts_.othersTraceS += othersTraceS / (ranks - 1);
    exchangeCosts_.othersTraceCpuS += othersTraceCpuS / (ranks - 1);
    exchangeCosts_.rootShare += jobs > 0 ? static_cast<double>(traced) / static_cast<double>(jobs) : 0.0;

    // Every band's hits (the adaptive kernels' counts and the wide kernels' sums need them all,
    // Film.h), rank 0's bands' beams too: each band's hits before its beams, as one process.
    const int bandCount = film_.bandCount();
    const HitsByBand byBand = hitsByBand(batches_, beamJobs);
    const int firstOwn = d.bandStart[0], endOwn = d.bandStart[1];
    std::vector<double> ownHitsS(static_cast<size_t>(endOwn - firstOwn), 0.0);
    std::vector<double> ownSeconds = ownBands(
        beamJobs,
        [&](int band) {
            const auto hitsStart = std::chrono::steady_clock::now();
            splatHitsInBand(band, byBand[band]);
            ownHitsS[static_cast<size_t>(band - firstOwn)] = renderer::secondsSince(hitsStart);
        },
        [&](int band, int, int layer, const double* rows, bool inTotal, int xBegin, int xEnd) {
            film_.addBandColumns(band, layer, rows, inTotal, xBegin, xEnd);
        });
    const auto othersHitsStart = std::chrono::steady_clock::now();
    tbb::parallel_for(tbb::blocked_range<int>(0, bandCount, 1), [&](const tbb::blocked_range<int>& range) {
        for (int band = range.begin(); band != range.end(); ++band)
            if (band < firstOwn || band >= endOwn) splatHitsInBand(band, byBand[band]);
    });
    // (Per thread, as the bands' costs.)
    d.rootHitsS = renderer::secondsSince(othersHitsStart) +
                  std::accumulate(ownHitsS.begin(), ownHitsS.end(), 0.0) / std::max(1, tbb::this_task_arena::max_concurrency());
    d.costSizes = passSizes(statistics_.passes);
    // Every hit is in: the wide kernels are integrated, and rank 0's bands, complete, end their pass
    // now, while the others' bands are on their way (Film::beginEndPass).
    const std::int64_t photons = options_.photonsPerPass();
    film_.beginEndPass();
    tbb::parallel_for(tbb::blocked_range<int>(firstOwn, endOwn, 1), [&](const tbb::blocked_range<int>& range) {
        for (int band = range.begin(); band != range.end(); ++band) film_.endPassInBand(band, photons);
    });
    const double rootBandsS = renderer::secondsSince(bandsStart);
    exchangeCosts_.bandsS += rootBandsS;
    exchangeCosts_.bandsCpuS += renderer::cpuSeconds() - bandsCpuStart;
    exchangeCosts_.rootBands += static_cast<double>(endOwn - firstOwn) / bandCount;

    const auto gatherStart = std::chrono::steady_clock::now();
    exchange.receiveAtRoot(d.bandsIn);
    const double bandsWaitS = renderer::secondsSince(gatherStart);
    exchangeCosts_.bandsWaitS += bandsWaitS;
    const auto mergeStart = std::chrono::steady_clock::now();
    const double mergeCpuStart = renderer::cpuSeconds();
    // The bands' images, each band's in the order its owner made them; each rank's costs.
    std::vector<std::vector<std::pair<int, renderer::BandImage>>> imagesOfBand(static_cast<size_t>(bandCount));
    d.bandSeconds.assign(static_cast<size_t>(bandCount), 0.0);
    d.besidesBandsS.assign(static_cast<size_t>(ranks), 0.0);
    std::copy(ownSeconds.begin(), ownSeconds.end(), d.bandSeconds.begin() + firstOwn);
    d.besidesBandsS[0] = std::max(0.0, rootBandsS - std::accumulate(ownSeconds.begin(), ownSeconds.end(), 0.0));
    exchangeCosts_.besidesBandsS += d.besidesBandsS[0];
    double othersBandsS = 0.0, othersBandsCpuS = 0.0;
    for (int r = 1; r < ranks; ++r) {
        const renderer::BandMessage message = renderer::readBandMessage(d.bandsIn[r], width, height);
        exchangeCosts_.bytesReceived += static_cast<double>(d.bandsIn[r].size());
        for (const renderer::BandImage& image : message.images) {
            if (image.band < d.bandStart[r] || image.band >= d.bandStart[r + 1] || image.layer >= film_.layerCount())
                throw std::runtime_error("distributed render: rank " + std::to_string(r) + " sent an image of band " +
                                         std::to_string(image.band) + ", layer " + std::to_string(image.layer) +
                                         ", which is not its own");
            imagesOfBand[image.band].emplace_back(r, image);
        }
        if (message.firstBand != d.bandStart[r] ||
            message.bandSeconds.size() != static_cast<size_t>(d.bandStart[r + 1] - d.bandStart[r]))
            throw std::runtime_error("distributed render: rank " + std::to_string(r) + " reported the costs of other bands");
        std::copy(message.bandSeconds.begin(), message.bandSeconds.end(), d.bandSeconds.begin() + message.firstBand);
        d.besidesBandsS[r] =
            std::max(0.0, message.phaseS - std::accumulate(message.bandSeconds.begin(), message.bandSeconds.end(), 0.0));
        othersBandsS += message.phaseS;
        othersBandsCpuS += message.phaseCpuS;
    }
    exchangeCosts_.othersBandsS += othersBandsS / (ranks - 1);
    exchangeCosts_.othersBandsCpuS += othersBandsCpuS / (ranks - 1);

    // The others' bands: their images, each band's in its owner's order, straight from the
    // messages' runs, then the band's end of the pass.
    tbb::parallel_for(tbb::blocked_range<int>(0, bandCount, 1), [&](const tbb::blocked_range<int>& range) {
        for (int band = range.begin(); band != range.end(); ++band) {
            if (band >= firstOwn && band < endOwn) continue;
            for (const auto& [r, image] : imagesOfBand[band])
                renderer::forEachBandImageRun(d.bandsIn[r], image, width, height,
                                              [&](int row, int xBegin, int xEnd, const double* values) {
                                                  film_.addRowPart(image.layer, row, xBegin, xEnd, values, image.inTotal);
                                              });
            film_.endPassInBand(band, photons);
        }
    });
    addPassTallies(beamJobs, replicate);
    film_.finishEndPass();
    exchangeCosts_.mergeS += renderer::secondsSince(mergeStart);
    exchangeCosts_.mergeCpuS += renderer::cpuSeconds() - mergeCpuStart;
    d.firstPass = false;
    advanceSplit();
    ++exchangeCosts_.passes;
    batchesDone_ += batches;
    ++statistics_.passes;
    planPassAfterNext();
    statistics_.seconds += renderer::secondsSince(start);
}

}  // namespace flare
