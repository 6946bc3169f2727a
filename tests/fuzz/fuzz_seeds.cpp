// flare_fuzz_seeds DIR: writes the generated part of the seed corpus (small EXRs, a checkpoint and
// a bare film of the checkpoint target's render, small .vdb files) under DIR/exr, DIR/checkpoint
// and DIR/vdb.
#include <cstdio>
#include <exception>

#include "FuzzTargets.h"

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: flare_fuzz_seeds DIR\n");
        return 2;
    }
    try {
        const int written = flare::fuzz::writeGeneratedSeeds(argv[1]);
        std::printf("wrote %d seed files under %s\n", written, argv[1]);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "flare_fuzz_seeds: %s\n", e.what());
        return 1;
    }
    return 0;
}
