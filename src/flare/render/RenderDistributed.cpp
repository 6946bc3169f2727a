// A pass of the final render shared among processes (PassExchange.h): each rank traces its jobs,
// rank 0 gathers every job's result in its place and merges the pass as one process would.
//
// The merge (rasterising every beam, splatting the hits, the film's per-pass bookkeeping) is rank
// 0's alone and, with beams, costs about as much as tracing the pass (docs/scaling.md). Two things
// keep every rank busy all the same:
//   - the other ranks trace ahead: having sent pass p they trace their share of pass p + 1 at
//     once, while rank 0 merges pass p (nothing in a pass's jobs depends on the film: their random
//     numbers follow from the seed and the pass), and send it when pass p + 1 starts; if the render
//     stops after pass p, that work is dropped (never past the pass limit, setPassLimit);
//   - rank 0 traces a smaller share (jobRank), chosen after every pass from what the last passes
//     cost so that its tracing and merging take as long as another rank's tracing.
// Which rank traces a job changes nothing in the image: a job's result is the same wherever it is
// traced, and rank 0 merges every result in the job order.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <stdexcept>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "flare/render/BeamStrategy.h"
#include "flare/render/PassExchange.h"
#include "flare/render/PassWire.h"
#include "flare/render/PhotonBatches.h"
#include "flare/render/Render.h"

namespace flare {

namespace renderer {

struct DistributedPasses {
    std::vector<char> outbox;               // this rank's results of a pass (ranks ≠ 0)
    std::vector<std::vector<char>> inbox;   // the others' results (rank 0)
    // Ranks ≠ 0: the pass traced ahead (its beams; its batches are in the renderer's batches_), and
    // how long tracing it took.
    bool ahead = false;
    std::vector<BeamJob> beamJobs;
    double traceS = 0.0, traceCpuS = 0.0;
    // Rank 0's share (of kShareSteps) of the pass the others trace next: every rank knows it.
    int rootShare = 0;
    // Rank 0: whether the others have traced the current pass before it started (every pass but a
    // session's first), and the last pass's costs: its own trace (and how many jobs), the others'
    // (their mean), and its decoding and merging.
    bool othersAhead = false;
    double rootTraceS = 0.0, othersTraceS = 0.0, mergeS = -1.0;
    long rootJobs = 0, othersJobs = 0;
};

namespace {

double secondsSince(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}
// The process's CPU time (all its threads), s.
double cpuSeconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

// Rank 0's share (of kShareSteps) that balances the ranks: rank 0 tracing s·W and merging in M
// takes as long as another rank tracing (1 − s)·W / (R − 1), W the whole pass's tracing on one
// rank, estimated from the jobs' measured cost; at most an equal share, at least none.
// Before rank 0 has merged a pass (its cost unknown): half an equal share.
int balancedRootShare(const DistributedPasses& d, long jobs, int ranks) {
    const double tracedS = d.rootTraceS + d.othersTraceS * (ranks - 1);
    const long traced = d.rootJobs + d.othersJobs * (ranks - 1);
    if (!(tracedS > 0.0) || traced <= 0 || !(d.mergeS >= 0.0)) return kShareSteps / (2 * ranks);
    const double wholeS = tracedS / static_cast<double>(traced) * static_cast<double>(jobs);
    const double share = (wholeS - (ranks - 1) * d.mergeS) / (ranks * wholeS);
    return static_cast<int>(std::lround(std::clamp(share, 0.0, 1.0 / ranks) * kShareSteps));
}

}  // namespace

}  // namespace renderer

void Renderer::setExchange(PassExchange* exchange) {
    exchange_ = exchange;
    distributed_.reset();
    if (exchange_ == nullptr || exchange_->size() <= 1) return;
    distributed_ = std::make_shared<renderer::DistributedPasses>();
    distributed_->inbox.resize(static_cast<size_t>(exchange_->size()));
    // A session's first pass: an equal share (every rank traces it at once, and rank 0 has no
    // pass to merge meanwhile).
    distributed_->rootShare = kShareSteps / exchange_->size();
}

void Renderer::runDistributedPass() {
    const auto start = std::chrono::steady_clock::now();
    PassExchange& exchange = *exchange_;
    renderer::DistributedPasses& d = *distributed_;
    const int rank = exchange.rank(), ranks = exchange.size();
    const int batches = static_cast<int>(batches_.size());  // 0 without photons
    const renderer::PhotonBatchInputs batchInputs{*lens_, options_, tracer_, indexTable_, lightStates_, components_,
                                                  componentCdf_, scatterSourceLayer_, tallies_.size()};
    // This rank's jobs of the current pass at rank 0's share `rootShare`, traced in parallel on its
    // threads; returns how many.
    auto traceShare = [&](std::vector<renderer::BeamJob>& beamJobs, int rootShare) {
        const int beams = static_cast<int>(beamJobs.size());
        std::vector<int> mine;
        for (int j = 0; j < beams + batches; ++j)
            if (jobRank(j, rootShare, ranks) == rank) mine.push_back(j);
        tbb::parallel_for(tbb::blocked_range<size_t>(0, mine.size(), 1), [&](const tbb::blocked_range<size_t>& range) {
            for (size_t i = range.begin(); i != range.end(); ++i) {
                const int j = mine[i];
                if (j < beams)
                    renderer::traceBeam(*lens_, options_, tracer_, lightStates_[beamJobs[j].light], statistics_.passes,
                                        beamJobs[j]);
                else
                    renderer::traceBatch(batchInputs, batchesDone_ + (j - beams), batches_[j - beams]);
            }
        });
        return static_cast<long>(mine.size());
    };

    if (rank != 0) {
        // The pass's beam jobs drawn, and this rank's share traced and timed.
        auto drawAndTraceShare = [&] {
            d.beamJobs = drawBeamJobs();
            const auto traceStart = std::chrono::steady_clock::now();
            const double cpuStart = renderer::cpuSeconds();
            traceShare(d.beamJobs, d.rootShare);
            d.traceS = renderer::secondsSince(traceStart);
            d.traceCpuS = renderer::cpuSeconds() - cpuStart;
        };
        // Every rank draws the pass's beam jobs (their counts and sequence points follow from the
        // seed and the passes before), so that job j is the same job on every rank.
        if (!d.ahead) drawAndTraceShare();
        const int beams = static_cast<int>(d.beamJobs.size());
        const auto encodeStart = std::chrono::steady_clock::now();
        const double encodeCpuStart = renderer::cpuSeconds();
        d.outbox.clear();
        for (int j = 0; j < beams + batches; ++j) {
            if (jobRank(j, d.rootShare, ranks) != rank) continue;
            if (j < beams) renderer::writeBeam(j, d.beamJobs[j], d.outbox);
            else renderer::writeBatch(j - beams, batches_[j - beams], d.outbox);
        }
        renderer::writeTraceTime(d.traceS + renderer::secondsSince(encodeStart),
                                 d.traceCpuS + renderer::cpuSeconds() - encodeCpuStart, d.outbox);
        exchange.gatherAtRoot(d.outbox, d.inbox);
        d.rootShare = exchange.broadcastFromRoot(0);
        ++exchangeCosts_.passes;
        batchesDone_ += batches;
        ++statistics_.passes;
        // The next pass's share, now, while rank 0 merges this one.
        d.ahead = passLimit_ <= 0 || statistics_.passes < passLimit_;
        if (d.ahead) drawAndTraceShare();
        statistics_.seconds += renderer::secondsSince(start);
        return;
    }

    const int replicate = replicateOfPass(statistics_.passes);
    std::vector<renderer::BeamJob> beamJobs = drawBeamJobs();
    const int beams = static_cast<int>(beamJobs.size());
    const long jobs = beams + batches;
    const int share = d.rootShare;
    long traced = 0;
    auto traceMine = [&] {
        const auto traceStart = std::chrono::steady_clock::now();
        const double cpuStart = renderer::cpuSeconds();
        traced = traceShare(beamJobs, share);
        d.rootTraceS = renderer::secondsSince(traceStart);
        d.rootJobs = traced;
        exchangeCosts_.traceS += d.rootTraceS;
        exchangeCosts_.traceCpuS += renderer::cpuSeconds() - cpuStart;
    };
    // A session's first pass: the others trace it now, and so does rank 0. After it, they traced
    // it while rank 0 merged the last one: their results are waiting.
    if (!d.othersAhead) traceMine();
    const auto gatherStart = std::chrono::steady_clock::now();
    d.outbox.clear();
    exchange.gatherAtRoot(d.outbox, d.inbox);
    exchangeCosts_.gatherS += renderer::secondsSince(gatherStart);
    // The share of the next pass, which the others trace as soon as they have it.
    d.rootShare = renderer::balancedRootShare(d, jobs, ranks);
    exchange.broadcastFromRoot(d.rootShare);
    if (d.othersAhead) traceMine();
    d.othersAhead = passLimit_ <= 0 || statistics_.passes + 1 < passLimit_;

    const auto mergeStart = std::chrono::steady_clock::now();
    const double mergeCpuStart = renderer::cpuSeconds();
    const FilmFrame frame = renderer::filmFrame(options_.film);
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
    d.othersTraceS = othersTraceS / (ranks - 1);
    d.othersJobs = (jobs - traced + (ranks - 2)) / (ranks - 1);
    exchangeCosts_.othersTraceS += d.othersTraceS;
    exchangeCosts_.othersTraceCpuS += othersTraceCpuS / (ranks - 1);
    exchangeCosts_.rootShare += static_cast<double>(share) / kShareSteps;
    merge(batches_, beamJobs);
    addPassTallies(beamJobs, replicate);
    film_.endPass(options_.photonsPerPass());
    d.mergeS = renderer::secondsSince(mergeStart);
    exchangeCosts_.mergeS += d.mergeS;
    exchangeCosts_.mergeCpuS += renderer::cpuSeconds() - mergeCpuStart;
    ++exchangeCosts_.passes;
    batchesDone_ += batches;
    ++statistics_.passes;
    statistics_.seconds += renderer::secondsSince(start);
}

}  // namespace flare
