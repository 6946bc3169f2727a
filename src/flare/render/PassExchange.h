// How the final render's passes are shared among processes (mpirun -np R flare render ...;
// docs/distributed.md). The engine knows nothing of MPI: a transport implements this interface
// (the CLI's Processes.h over MPI) and the Renderer (Render.h, RenderDistributed.cpp) uses it.
//
// A pass's work is a fixed list of jobs, the same for any number of processes: its beams, then its
// photon batches, each with random numbers of its own (Render.h). The ranks take the jobs as they
// become free, in chunks claimed from a counter shared by all (claimJobs, claimChunk): so a rank
// busy elsewhere (rank 0 ending the last pass) takes fewer, and all finish tracing together
// whatever the jobs cost. They exchange what they produced (PassWire.h, allToAll): each rank
// owns a group of the film's bands and rasterises every beam over them, and rank 0, which holds
// the film, splats every hit, adds the owners' band images and ends the pass exactly as one
// process does: same jobs, same order in every band, same sums. The other ranks trace the next pass while rank 0 ends this one
// (they need nothing from the film). So the image, the tallies and the report are bitwise those
// of one process, for any number of processes and threads, and a checkpoint written by R
// processes resumes with any other number.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

namespace flare {

class PassExchange {
public:
    virtual ~PassExchange() = default;
    virtual int rank() const = 0;
    virtual int size() const = 0;
    // A rank ≠ 0 starts sending `mine` to rank 0 and returns at once, without waiting for rank 0
    // to take it: `mine` must stay as it is until the rank's next sendToRoot or finishSends. Rank
    // 0 takes every other rank's message with receiveAtRoot, in the order they were sent: their
    // messages in `all` indexed by rank (its own entry left empty), waiting for those not there
    // yet. `all` keeps its buffers from call to call: a pass's messages are tens of MB, and fresh
    // memory every pass costs page faults. (A band owner's images: rank 0 waits for them only if
    // it finishes its own bands first, and the owner goes on at once with the next pass.)
    virtual void sendToRoot(const std::vector<char>& mine) = 0;
    virtual void receiveAtRoot(std::vector<std::vector<char>>& all) = 0;
    // Returns when what this rank sent with sendToRoot has gone (its buffer may change).
    virtual void finishSends() = 0;
    // Collective: `out[q]` of every rank at rank q, in its `in` indexed by the sending rank (a
    // rank's own entry is left empty: what it keeps stays where it is). `in` keeps its buffers
    // from call to call, as receiveAtRoot's `all`.
    virtual void allToAll(const std::vector<std::vector<char>>& out, std::vector<std::vector<char>>& in) = 0;
    // Collective: rank 0's `value` at every rank.
    virtual int broadcastFromRoot(int value) = 0;
    // Collective: rank 0's `values` at every rank (every rank passes as many).
    virtual void broadcastFromRoot(std::vector<int>& values) = 0;
    // The shared job counters (two: a pass's and the next's, which the others trace ahead): adds
    // `count` to counter `slot` (0 or 1) and returns its value before, atomically across the ranks
    // and without any other rank taking part (one-sided), so that a rank claims the next `count`
    // jobs of a pass while the others trace.
    virtual long claimJobs(int slot, long count) = 0;
    // Rank 0: counter `slot` back to 0, done when this returns. No rank may claim from it until a
    // collective call of rank 0's after this one (a pass's counter is reset after its exchange,
    // which every rank reaches having claimed its last jobs of the pass, and is next claimed from
    // two passes on, after the next exchange).
    virtual void resetClaims(int slot) = 0;
};

// How many jobs a rank claims at a time when `remaining` of the pass's jobs are not yet claimed
// (as its last claim saw), with `ranks` ranks of `threads` threads each: guided, a fraction of
// what is left (tens of claims a pass, each a few microseconds, whatever its size), never fewer than one job per thread (the
// rank's threads trace a claim in parallel), so that the last claims, one job per thread, leave
// the ranks within a job of each other at the exchange.
inline long claimChunk(long remaining, int ranks, int threads) {
    const long perThread = std::max(1, threads);
    // (A quarter of an equal share of what is left: the first claims are large, the last small.)
    const long guided = (std::max(0L, remaining) + 4L * std::max(1, ranks) - 1) / (4L * std::max(1, ranks));
    return std::max(perThread, (guided + perThread - 1) / perThread * perThread);
}

}  // namespace flare
