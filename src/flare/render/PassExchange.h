// How the final render's passes are shared among processes (mpirun -np R flare render ...;
// docs/distributed.md). The engine knows nothing of MPI: a transport implements this interface
// (the CLI's Processes.h over MPI) and the Renderer (Render.h, RenderDistributed.cpp) uses it.
//
// A pass's work is a fixed list of jobs, the same for any number of processes: its beams, then its
// photon batches, each with random numbers of its own (Render.h). Rank r traces the jobs
// j ≡ r (mod R) (interleaved, so that the beams, which cost more each, are shared too), and sends
// what they produced (PassWire.h) to rank 0, which puts every job's result in its place and merges
// the pass into the film exactly as one process does: same jobs, same order, same sums. So the
// image, the tallies and the report are bitwise those of one process, for any number of processes
// and threads, and a checkpoint written by R processes resumes with any other number.
#pragma once

#include <vector>

namespace flare {

class PassExchange {
public:
    virtual ~PassExchange() = default;
    virtual int rank() const = 0;
    virtual int size() const = 0;
    // Collective: every rank's bytes at rank 0, indexed by rank (rank 0's own included); the other
    // ranks get an empty list.
    virtual std::vector<std::vector<char>> gatherAtRoot(std::vector<char> mine) = 0;
};

// Whether job `job` of a pass is this rank's (interleaved: job mod size).
inline bool ownsJob(const PassExchange& exchange, long job) { return job % exchange.size() == exchange.rank(); }

}  // namespace flare
