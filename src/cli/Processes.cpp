// Processes.h without MPI (the build found no Open MPI): one process, rank 0 of 1.
#include "Processes.h"

#include <cstdlib>
#include <stdexcept>
#include <string>

namespace flare::cli {

Processes& Processes::world() {
    // Started by mpirun with several processes, each would do the whole work and write the same
    // outputs: refuse instead.
    for (const char* variable : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"})
        if (const char* value = std::getenv(variable); value != nullptr && std::atoi(value) > 1)
            throw std::runtime_error(std::string("this flare was built without MPI (FLARE_WITH_MPI off), so it cannot "
                                                 "share the work among the ") +
                                     value + " processes mpirun started; run it alone, or rebuild with Open MPI");
    static Processes world;
    return world;
}

void Processes::sendToRoot(const std::vector<char>&) {}

void Processes::receiveAtRoot(std::vector<std::vector<char>>& all) {
    all.resize(1);
    all[0].clear();
}

void Processes::finishSends() {}

void Processes::allToAll(const std::vector<std::vector<char>>&, std::vector<std::vector<char>>& in) {
    in.resize(1);
    in[0].clear();
}

int Processes::broadcastFromRoot(int value) { return value; }

void Processes::broadcastFromRoot(std::vector<int>&) {}

long Processes::claimJobs(int slot, long count) {
    const long before = localClaims_[slot & 1];
    localClaims_[slot & 1] += count;
    return before;
}

void Processes::resetClaims(int slot) { localClaims_[slot & 1] = 0; }

void Processes::barrier() {}

void Processes::abort(int code) { std::exit(code); }

}  // namespace flare::cli
