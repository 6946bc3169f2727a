// Removes this test process's scratch root (TestUtil.h, scratchRoot) after its tests, pass or fail.
#include <filesystem>

#include <gtest/gtest.h>

#include "TestUtil.h"

namespace flare::test {
namespace {

class ScratchCleanup : public ::testing::Environment {
public:
    void TearDown() override {
        std::error_code ec;
        std::filesystem::remove_all(scratchRoot(), ec);
    }
};

// Registered before main() runs the tests; gtest owns the environment.
[[maybe_unused]] ::testing::Environment* const kScratchCleanup =
    ::testing::AddGlobalTestEnvironment(new ScratchCleanup);

}  // namespace
}  // namespace flare::test
