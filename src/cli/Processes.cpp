// Processes.h without MPI (the build found no Open MPI): one process, rank 0 of 1.
#include "Processes.h"

#include <cstdlib>

namespace flare::cli {

Processes& Processes::world() {
    static Processes world;
    return world;
}

bool Processes::mpiAvailable() { return false; }

std::vector<std::vector<char>> Processes::gatherAtRoot(std::vector<char> mine) {
    std::vector<std::vector<char>> all;
    all.push_back(std::move(mine));
    return all;
}

int Processes::broadcastFromRoot(int value) { return value; }

void Processes::barrier() {}

void Processes::abort(int code) { std::exit(code); }

}  // namespace flare::cli
