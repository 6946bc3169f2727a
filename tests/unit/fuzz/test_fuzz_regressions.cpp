// Every input kept under tests/data/fuzz/<target>/ (crashes the fuzzers found, see
// docs/robustness.md) replays through the same target body the fuzzer ran (tests/fuzz/
// FuzzTargets.h) without escaping an unexpected exception; under scripts/test-sanitize.sh the
// same replay runs with ASan and UBSan. The seed corpus goes through the bodies as well, so the
// targets are known to work before anyone fuzzes.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "FuzzTargets.h"
#include "TestUtil.h"

namespace flare {
namespace {

namespace fs = std::filesystem;

std::string readBytes(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream buffer;
    buffer << in.rdbuf();
    return buffer.str();
}

// Regular files under dir (sorted; none if dir does not exist), optionally with one extension.
std::vector<fs::path> filesIn(const fs::path& dir, const std::string& extension = "") {
    std::vector<fs::path> files;
    if (!fs::is_directory(dir)) return files;
    for (const auto& entry : fs::directory_iterator(dir))
        if (entry.is_regular_file() && entry.path().filename().string()[0] != '.' &&
            entry.path().filename() != "README.md" && (extension.empty() || entry.path().extension() == extension))
            files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    return files;
}

using Body = std::function<void(std::string_view)>;

int replayAll(const std::vector<fs::path>& files, const Body& body) {
    int count = 0;
    for (const fs::path& file : files) {
        SCOPED_TRACE(file.string());
        try {
            body(readBytes(file));
        } catch (const std::exception& e) {
            ADD_FAILURE() << "unexpected exception: " << e.what();
        }
        ++count;
    }
    return count;
}

const std::pair<const char*, Body> kTargets[] = {
    {"lens", fuzz::lensInput},
    {"zmx", fuzz::zmxInput},
    {"agf", fuzz::agfInput},
    {"scene", fuzz::sceneInput},
    {"exr", fuzz::exrInput},
    {"checkpoint", fuzz::checkpointInput},
    {"vdb", fuzz::vdbInput},
};

TEST(FuzzRegressions, EveryKeptInputReplaysCleanly) {
    for (const auto& [target, body] : kTargets)
        replayAll(filesIn(test::sourcePath(std::string("tests/data/fuzz/") + target)), body);
}

TEST(FuzzRegressions, SeedCorpusRunsThroughTheTargets) {
    EXPECT_GE(replayAll(filesIn(test::sourcePath("lenses"), ".lens"), fuzz::lensInput), 5);
    EXPECT_EQ(replayAll({test::sourcePath("tests/data/dgauss.50mm.dat")}, fuzz::lensInput), 1);
    EXPECT_GE(replayAll(filesIn(test::sourcePath("docs/examples"), ".json"), fuzz::sceneInput), 3);
    EXPECT_GE(replayAll(filesIn(test::sourcePath("tests/data/scenes"), ".json"), fuzz::sceneInput), 1);

    const fs::path dir = test::processTempDir("flare_fuzz_seeds_test");
    fs::remove_all(dir);
    EXPECT_GT(fuzz::writeGeneratedSeeds(dir.string()), 0);
    // Every generated EXR and checkpoint is a good file, and so is every shipped volume: each must
    // reach its loader and be accepted (the bodies hand the loaders a memory file's path).
    long accepted = fuzz::acceptedInputCount();
    const int exrSeeds = replayAll(filesIn(dir / "exr"), fuzz::exrInput);
    EXPECT_GE(exrSeeds, 9);
    EXPECT_EQ(fuzz::acceptedInputCount() - accepted, exrSeeds);
    accepted = fuzz::acceptedInputCount();
    EXPECT_EQ(replayAll(filesIn(dir / "checkpoint"), fuzz::checkpointInput), 2);
    EXPECT_EQ(fuzz::acceptedInputCount() - accepted, 2);
    EXPECT_GE(replayAll(filesIn(dir / "vdb"), fuzz::vdbInput), 10);
    // writeGeneratedSeeds checks that each .zmx and .agf seed parses.
    EXPECT_GE(replayAll(filesIn(dir / "zmx"), fuzz::zmxInput), 10);
    EXPECT_EQ(replayAll(filesIn(dir / "agf"), fuzz::agfInput), 7);
    accepted = fuzz::acceptedInputCount();
    const int volumes = replayAll(filesIn(test::sourcePath("volumes"), ".vdb"), fuzz::vdbInput);
    EXPECT_GE(volumes, 4);
    EXPECT_EQ(fuzz::acceptedInputCount() - accepted, volumes);
    fs::remove_all(dir);
}

}  // namespace
}  // namespace flare
