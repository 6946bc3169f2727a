// How the final render's passes are shared among processes (mpirun -np R flare render ...;
// docs/distributed.md). The engine knows nothing of MPI: a transport implements this interface
// (the CLI's Processes.h over MPI) and the Renderer (Render.h, RenderDistributed.cpp) uses it.
//
// A pass's work is a fixed list of jobs, the same for any number of processes: its beams, then its
// photon batches, each with random numbers of its own (Render.h). The ranks trace the jobs
// (jobRank: rank 0 a share it adjusts, since it alone ends the pass, the others the rest in turn)
// and exchange what they produced (PassWire.h, allToAll): each rank owns a group of the film's
// bands and rasterises every beam over them, and rank 0, which holds the film, splats every hit,
// adds the owners' band images and ends the pass exactly as one process does: same jobs, same
// order in every band, same sums. The other ranks trace the next pass while rank 0 ends this one
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
};

// Rank 0's share of a pass's jobs is rootShare / kShareSteps.
inline constexpr int kShareSteps = 64;

// The rank that traces job `job` of a pass when rank 0 takes rootShare / kShareSteps of them:
// rank 0's jobs spread evenly (job j is its when ⌊(j + 1)·s⌋ > ⌊j·s⌋, so that every path's
// consecutive beams, which cost alike, are shared alike), the others' dealt in turn.
inline int jobRank(long job, int rootShare, int size) {
    if (size <= 1) return 0;
    const long rootBefore = job * rootShare / kShareSteps;  // rank 0's jobs among 0 .. job − 1
    if ((job + 1) * rootShare / kShareSteps > rootBefore) return 0;
    return 1 + static_cast<int>((job - rootBefore) % (size - 1));
}

// Rank 0's share (of kShareSteps, at most an equal one, at least none) that balances the ranks
// from the others' bands to the next pass's exchange: rank 0 busy `rootFirstS` (its wait and its
// end of the pass) and then tracing s·J jobs at `rootPerJobS` each takes as long as each other
// rank tracing its (1 − s)·J / (R − 1) jobs at `otherPerJobS` each:
// s = (J·a₁ / (R − 1) − rootFirstS) / (J·(a₀ + a₁ / (R − 1))), rounded to the nearest step, at
// most ⌊kShareSteps / R⌋.
inline int balancedShare(long jobs, int size, double rootPerJobS, double otherPerJobS, double rootFirstS) {
    const double others = otherPerJobS / (size - 1);  // the others' time per job of the pass
    const double share = (static_cast<double>(jobs) * others - rootFirstS) / (static_cast<double>(jobs) * (rootPerJobS + others));
    // (Clamped in steps: an equal share rounded up would be more than equal, 11 of 64 for 6 ranks.)
    const long steps = std::lround(std::max(share, 0.0) * kShareSteps);
    return static_cast<int>(std::min<long>(steps, kShareSteps / size));
}

}  // namespace flare
