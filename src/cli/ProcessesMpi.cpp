// Processes.h over MPI (Open MPI): the build found it. MPI is initialised only when the program
// was started by mpirun (its environment says so), so that a program started alone runs exactly
// as a build without MPI does.
#include "Processes.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>

#include <mpi.h>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace flare::cli {

namespace {

// Open MPI's mpirun (and PMIx-based launchers such as srun) set these in every rank.
bool startedByMpirun() {
    return std::getenv("OMPI_COMM_WORLD_SIZE") != nullptr || std::getenv("PMIX_RANK") != nullptr ||
           std::getenv("PMI_RANK") != nullptr;
}

// Messages go in pieces of at most 1 GiB (MPI counts are ints).
constexpr std::uint64_t kPieceBytes = std::uint64_t(1) << 30;
constexpr int kToRootTag = 31, kAllToAllTag = 32;

// sendToRoot's message in flight: its size (sent first) and its pieces.
struct Sending {
    std::uint64_t bytes = 0;
    std::vector<MPI_Request> requests;
    void finish() {
        if (!requests.empty()) MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE);
        requests.clear();
    }
};
Sending gSending;

// The shared job counters (PassExchange::claimJobs): two 64-bit integers in a window at rank 0,
// which every rank adds to with MPI_Fetch_and_op in one passive-target epoch open all session
// (MPI_Win_lock_all): a claim needs nothing from rank 0's threads. On one node Open MPI's shared
// memory window (osc sm) makes it an atomic add in rank 0's memory; across nodes, a network with
// remote atomics (UCX) does the same, and the others progress it when rank 0 next calls MPI.
struct JobCounters {
    MPI_Win window = MPI_WIN_NULL;
    std::int64_t* counts = nullptr;
    void open(int rank) {
        const MPI_Aint bytes = rank == 0 ? 2 * sizeof(std::int64_t) : 0;
        MPI_Win_allocate(bytes, sizeof(std::int64_t), MPI_INFO_NULL, MPI_COMM_WORLD, &counts, &window);
        if (rank == 0) counts[0] = counts[1] = 0;
        // (Rank 0's zeros are in place before any rank's first claim.)
        MPI_Barrier(MPI_COMM_WORLD);
        MPI_Win_lock_all(MPI_MODE_NOCHECK, window);
    }
    void close() {
        if (window == MPI_WIN_NULL) return;
        MPI_Win_unlock_all(window);
        MPI_Win_free(&window);  // (collective: every rank leaves here)
    }
};
JobCounters gCounters;

// A shared pass allocates and frees tens of MB at every rank that one process does not (the
// others' beams decoded and re-bucketed by band, the messages' records), in blocks of a few
// hundred kB to a few MB. glibc hands such blocks back to the kernel when they are freed (mmap
// above its threshold, heap trimming), and the next pass faults every page in again, zeroed. A
// rank under mpirun keeps what it frees for the next pass instead (a rank's peak memory is what
// it holds anyway): measured with the band images' buffers kept too, the second of two ranks took
// 164 000–176 000 page faults in the default scene's 8 passes where it took 213 000–231 000
// (docs/scaling.md). A process started alone keeps glibc's defaults.
void keepFreedMemory() {
#if defined(__GLIBC__)
    mallopt(M_MMAP_THRESHOLD, 32 << 20);  // (glibc's largest: blocks above 32 MB still map)
    mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
}

struct MpiSession {
    bool active = false;
    MpiSession() {
        if (!startedByMpirun()) return;
        keepFreedMemory();
        // Only the main thread calls MPI; the worker threads (TBB) never do.
        int provided = 0;
        MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
        active = true;
        int rank = 0, size = 1;
        MPI_Comm_rank(MPI_COMM_WORLD, &rank);
        MPI_Comm_size(MPI_COMM_WORLD, &size);
        if (size > 1) gCounters.open(rank);
    }
    ~MpiSession() {
        int finalized = 0;
        // (rank 0 has received everything sent to it: it receives each pass's messages in that pass.)
        if (active && MPI_Finalized(&finalized) == MPI_SUCCESS && !finalized) gSending.finish();
        if (active && MPI_Finalized(&finalized) == MPI_SUCCESS && !finalized) gCounters.close();
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

void Processes::sendToRoot(const std::vector<char>& mine) {
    if (size_ == 1 || root()) return;
    gSending.finish();
    gSending.bytes = mine.size();
    // Nonblocking: the rank goes on with its work while rank 0 takes the message (with Open MPI's
    // shared memory, rank 0 copies a large message out of this rank's memory itself, CMA).
    MPI_Isend(&gSending.bytes, 1, MPI_UINT64_T, 0, kToRootTag, MPI_COMM_WORLD, &gSending.requests.emplace_back());
    for (std::uint64_t at = 0; at < gSending.bytes; at += kPieceBytes)
        MPI_Isend(mine.data() + at, static_cast<int>(std::min(kPieceBytes, gSending.bytes - at)), MPI_BYTE, 0,
                  kToRootTag, MPI_COMM_WORLD, &gSending.requests.emplace_back());
}

void Processes::finishSends() {
    if (size_ > 1) gSending.finish();
}

void Processes::receiveAtRoot(std::vector<std::vector<char>>& all) {
    if (size_ == 1 || !root()) return;
    all.resize(size_);
    all[0].clear();
    // (MPI keeps the order of messages between two ranks with one tag: the size, then its pieces.)
    for (int r = 1; r < size_; ++r) {
        std::uint64_t bytes = 0;
        MPI_Recv(&bytes, 1, MPI_UINT64_T, r, kToRootTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        all[r].resize(bytes);  // (within the capacity of the last pass's message, mostly)
        for (std::uint64_t at = 0; at < bytes; at += kPieceBytes)
            MPI_Recv(all[r].data() + at, static_cast<int>(std::min(kPieceBytes, bytes - at)), MPI_BYTE, r, kToRootTag,
                     MPI_COMM_WORLD, MPI_STATUS_IGNORE);
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

long Processes::claimJobs(int slot, long count) {
    if (size_ == 1) {
        const long before = localClaims_[slot & 1];
        localClaims_[slot & 1] += count;
        return before;
    }
    const std::int64_t add = count;
    std::int64_t before = 0;
    MPI_Fetch_and_op(&add, &before, MPI_INT64_T, 0, slot & 1, MPI_SUM, gCounters.window);
    MPI_Win_flush(0, gCounters.window);
    return static_cast<long>(before);
}

void Processes::resetClaims(int slot) {
    if (size_ == 1) {
        localClaims_[slot & 1] = 0;
        return;
    }
    // (Through the window, as every claim: an atomic replace, complete at rank 0 when flushed.)
    const std::int64_t zero = 0;
    std::int64_t before = 0;
    MPI_Fetch_and_op(&zero, &before, MPI_INT64_T, 0, slot & 1, MPI_REPLACE, gCounters.window);
    MPI_Win_flush(0, gCounters.window);
}

void Processes::barrier() {
    if (size_ > 1) MPI_Barrier(MPI_COMM_WORLD);
}

void Processes::abort(int code) {
    if (size_ > 1) MPI_Abort(MPI_COMM_WORLD, code);
    std::exit(code);
}

}  // namespace flare::cli
