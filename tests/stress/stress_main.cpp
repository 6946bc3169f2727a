// flare_stress: the long stress run (ctest label `stress`), or `flare_stress --replay FILE...` to
// re-run failures written by a stress run (exit code 1 if any still fails).
#include <cstring>
#include <iostream>

#include <gtest/gtest.h>

#include "Stress.h"

int main(int argc, char** argv) {
    if (argc >= 2 && std::strcmp(argv[1], "--replay") == 0) {
        int failed = 0;
        for (int i = 2; i < argc; ++i) {
            try {
                const std::string problem = flare::stress::replay(argv[i]);
                std::cout << argv[i] << ": " << (problem.empty() ? "ok" : problem) << "\n";
                failed += !problem.empty();
            } catch (const std::exception& e) {
                std::cout << argv[i] << ": cannot replay: " << e.what() << "\n";
                ++failed;
            }
        }
        return failed ? 1 : 0;
    }
    testing::InitGoogleTest(&argc, argv);
    return RUN_ALL_TESTS();
}
