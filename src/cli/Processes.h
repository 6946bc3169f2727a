// The processes a command runs as (docs/distributed.md): under mpirun (Open MPI), MPI's world of
// ranks; else this process alone. The engine shares a render's passes through the PassExchange
// interface this implements; `flare dataset` shares its images. MPI is an optional component:
// ProcessesMpi.cpp when the build found it, else Processes.cpp (one process, whatever the
// environment says).
#pragma once

#include <cstdio>
#include <exception>
#include <vector>

#include "flare/core/Error.h"
#include "flare/render/PassExchange.h"

namespace flare::cli {

class Processes final : public PassExchange {
public:
    // The world: initialises MPI on the first call when the program was started by mpirun (and
    // finalises it at exit); a program started alone never touches MPI. A build without MPI started
    // by mpirun as several processes throws (each would do the whole work).
    static Processes& world();

    int rank() const override { return rank_; }
    int size() const override { return size_; }
    bool root() const { return rank_ == 0; }

    void sendToRoot(const std::vector<char>& mine) override;
    void receiveAtRoot(std::vector<std::vector<char>>& all) override;
    void finishSends() override;
    void allToAll(const std::vector<std::vector<char>>& out, std::vector<std::vector<char>>& in) override;
    int broadcastFromRoot(int value) override;
    void broadcastFromRoot(std::vector<int>& values) override;
    // Over an MPI window at rank 0 (MPI_Fetch_and_op): no rank 0 thread takes part in a claim.
    long claimJobs(int slot, long count) override;
    void resetClaims(int slot) override;
    // Collective: returns when every rank has called it.
    void barrier();
    // Ends every rank with `code` (an error on one rank, which the others would wait for forever).
    [[noreturn]] void abort(int code);

private:
    Processes() = default;
    int rank_ = 0, size_ = 1;
    long localClaims_[2] = {0, 0};  // the job counters of a process alone
};

// Runs a command's body; with several ranks, an exception on one rank prints its message with the
// rank and ends them all (exit 2 for an input error, 1 otherwise) instead of leaving the others
// waiting; with one rank it propagates as usual.
template <class Body>
auto runOnEveryRank(const char* command, Body&& body) -> decltype(body()) {
    Processes& processes = Processes::world();
    if (processes.size() == 1) return body();
    try {
        return body();
    } catch (const InputError& e) {
        std::fprintf(stderr, "flare: error: %s (%s, rank %d of %d)\n", e.what(), command, processes.rank(), processes.size());
        std::fflush(stderr);
        processes.abort(kExitInputError);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "flare: error: %s (%s, rank %d of %d)\n", e.what(), command, processes.rank(), processes.size());
        std::fflush(stderr);
        processes.abort(1);
    }
}

}  // namespace flare::cli
