// Processes.h over MPI (Open MPI): the build found it. MPI is initialised only when the program
// was started by mpirun (its environment says so), so that a program started alone runs exactly
// as a build without MPI does.
#include "Processes.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>

#include <mpi.h>

namespace flare::cli {

namespace {

// Open MPI's mpirun (and PMIx-based launchers such as srun) set these in every rank.
bool startedByMpirun() {
    return std::getenv("OMPI_COMM_WORLD_SIZE") != nullptr || std::getenv("PMIX_RANK") != nullptr ||
           std::getenv("PMI_RANK") != nullptr;
}

// Messages go in pieces of at most 1 GiB (MPI counts are ints).
constexpr std::uint64_t kPieceBytes = std::uint64_t(1) << 30;
constexpr int kGatherTag = 31, kAllToAllTag = 32;

struct MpiSession {
    bool active = false;
    MpiSession() {
        if (!startedByMpirun()) return;
        // Only the main thread calls MPI; the worker threads (TBB) never do.
        int provided = 0;
        MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
        active = true;
    }
    ~MpiSession() {
        int finalized = 0;
        if (active && MPI_Finalized(&finalized) == MPI_SUCCESS && !finalized) MPI_Finalize();
    }
};

}  // namespace

Processes& Processes::world() {
    static MpiSession session;
    static Processes world = [] {
        Processes p;
        if (session.active) {
            MPI_Comm_rank(MPI_COMM_WORLD, &p.rank_);
            MPI_Comm_size(MPI_COMM_WORLD, &p.size_);
        }
        return p;
    }();
    return world;
}

void Processes::gatherAtRoot(const std::vector<char>& mine, std::vector<std::vector<char>>& all) {
    if (size_ == 1) return;
    std::uint64_t bytes = mine.size();
    std::vector<std::uint64_t> sizes(root() ? size_ : 0);
    MPI_Gather(&bytes, 1, MPI_UINT64_T, sizes.data(), 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    if (!root()) {
        for (std::uint64_t at = 0; at < bytes; at += kPieceBytes)
            MPI_Send(mine.data() + at, static_cast<int>(std::min(kPieceBytes, bytes - at)), MPI_BYTE, 0, kGatherTag,
                     MPI_COMM_WORLD);
        return;
    }
    all.resize(size_);
    all[0].clear();
    for (int r = 1; r < size_; ++r) {
        all[r].resize(sizes[r]);  // (within the capacity of the last pass's message, mostly)
        for (std::uint64_t at = 0; at < sizes[r]; at += kPieceBytes)
            MPI_Recv(all[r].data() + at, static_cast<int>(std::min(kPieceBytes, sizes[r] - at)), MPI_BYTE, r,
                     kGatherTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    }
}

void Processes::allToAll(const std::vector<std::vector<char>>& out, std::vector<std::vector<char>>& in) {
    if (size_ == 1) return;
    std::vector<std::uint64_t> sending(size_), receiving(size_);
    for (int r = 0; r < size_; ++r) sending[r] = r == rank_ ? 0 : out[r].size();
    MPI_Alltoall(sending.data(), 1, MPI_UINT64_T, receiving.data(), 1, MPI_UINT64_T, MPI_COMM_WORLD);
    in.resize(size_);
    in[rank_].clear();
    // Every piece to and from every other rank at once (nonblocking), so that no pair of ranks
    // waits on the other's send.
    std::vector<MPI_Request> requests;
    for (int r = 0; r < size_; ++r) {
        if (r == rank_) continue;
        in[r].resize(receiving[r]);
        for (std::uint64_t at = 0; at < receiving[r]; at += kPieceBytes)
            MPI_Irecv(in[r].data() + at, static_cast<int>(std::min(kPieceBytes, receiving[r] - at)), MPI_BYTE, r,
                      kAllToAllTag, MPI_COMM_WORLD, &requests.emplace_back());
        for (std::uint64_t at = 0; at < sending[r]; at += kPieceBytes)
            MPI_Isend(out[r].data() + at, static_cast<int>(std::min(kPieceBytes, sending[r] - at)), MPI_BYTE, r,
                      kAllToAllTag, MPI_COMM_WORLD, &requests.emplace_back());
    }
    MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE);
}

void Processes::broadcastFromRoot(std::vector<int>& values) {
    if (size_ > 1 && !values.empty())
        MPI_Bcast(values.data(), static_cast<int>(values.size()), MPI_INT, 0, MPI_COMM_WORLD);
}

int Processes::broadcastFromRoot(int value) {
    if (size_ > 1) MPI_Bcast(&value, 1, MPI_INT, 0, MPI_COMM_WORLD);
    return value;
}

void Processes::barrier() {
    if (size_ > 1) MPI_Barrier(MPI_COMM_WORLD);
}

void Processes::abort(int code) {
    if (size_ > 1) MPI_Abort(MPI_COMM_WORLD, code);
    std::exit(code);
}

}  // namespace flare::cli
