// A pass of the final render shared among processes (PassExchange.h): each rank traces its jobs,
// rank 0 gathers every job's result in its place and merges the pass as one process would.
#include <chrono>
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

void Renderer::runDistributedPass() {
    const auto start = std::chrono::steady_clock::now();
    auto secondsSince = [](std::chrono::steady_clock::time_point t) {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    };
    PassExchange& exchange = *exchange_;
    const int batches = static_cast<int>(batches_.size());  // 0 without photons
    const int replicate = replicateOfPass(statistics_.passes);
    // Every rank draws the pass's beam jobs (their counts and sequence points follow from the seed
    // and the passes before), so that job j is the same job on every rank.
    std::vector<renderer::BeamJob> beamJobs = drawBeamJobs();
    const int beams = static_cast<int>(beamJobs.size());
    const int jobs = beams + batches;
    std::vector<int> mine;
    for (int j = 0; j < jobs; ++j)
        if (ownsJob(exchange, j)) mine.push_back(j);

    const renderer::PhotonBatchInputs batchInputs{*lens_, options_, tracer_, indexTable_, lightStates_, components_,
                                                  componentCdf_, scatterSourceLayer_, tallies_.size()};
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

    exchangeCosts_.traceS += secondsSince(start);
    // Rank 0 keeps its own results where they are; the others send theirs.
    const auto gatherStart = std::chrono::steady_clock::now();
    std::vector<char> message;
    if (exchange.rank() != 0) {
        for (int j : mine) {
            if (j < beams) {
                renderer::writeBeam(j, beamJobs[j], message);
                beamJobs[j] = renderer::BeamJob();  // (its triangles are rank 0's now)
            } else {
                renderer::writeBatch(j - beams, batches_[j - beams], message);
            }
        }
    }
    const std::vector<std::vector<char>> messages = exchange.gatherAtRoot(std::move(message));
    if (exchange.rank() == 0) {
        long received = static_cast<long>(mine.size());
        const FilmFrame frame = renderer::filmFrame(options_.film);
        for (size_t r = 1; r < messages.size(); ++r) {
            received += renderer::readPassResults(messages[r], frame, batches_, beamJobs);
            exchangeCosts_.bytesReceived += static_cast<double>(messages[r].size());
        }
        exchangeCosts_.gatherS += secondsSince(gatherStart);
        const auto mergeStart = std::chrono::steady_clock::now();
        if (received != jobs)
            throw std::runtime_error("distributed render: pass " + std::to_string(statistics_.passes) + " gathered " +
                                     std::to_string(received) + " job results of " + std::to_string(jobs));
        merge(batches_, beamJobs);
        addPassTallies(beamJobs, replicate);
        film_.endPass(options_.photonsPerPass());
        exchangeCosts_.mergeS += secondsSince(mergeStart);
    }
    ++exchangeCosts_.passes;
    batchesDone_ += batches;
    ++statistics_.passes;
    statistics_.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace flare
