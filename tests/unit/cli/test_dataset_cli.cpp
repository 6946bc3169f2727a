// `flare dataset` (docs/dataset.md): the same seed gives the same files, whether the set is made
// in one run, in two shards, by two MPI ranks, or resumed after images were lost; a bad spec is a
// file:line error with exit code 2 and nothing written.
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "TestUtil.h"

namespace flare {
namespace {

namespace fs = std::filesystem;

// Four small images: one or two lights (directional or point, half of them outside the frame),
// some dust, a coarse quality; a few seconds in all.
const char* kSpec = R"({
  "images": 4, "seed": 11,
  "lenses": ["double-gauss-50mm"],
  "f_number": [2.8, 8],
  "lights": { "count": [1, 2], "kinds": ["directional", "point"], "outside_frame": 0.5,
              "temperature_k": [3000, 6500], "power": [0.5, 2], "distance_mm": [3000, 30000] },
  "dust": [0, 0.01],
  "resolution": [64, 43],
  "quality": { "target_error": 0.3, "photons": 131072, "beams_per_pass": 64 },
  "diffraction": false
})";

std::map<std::string, std::string> filesOf(const fs::path& dir) {
    std::map<std::string, std::string> files;
    for (const auto& entry : fs::directory_iterator(dir)) {
        std::ifstream in(entry.path(), std::ios::binary);
        files[entry.path().filename().string()] = {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    }
    return files;
}

std::string writeSpec(const fs::path& dir, const std::string& text) {
    const std::string path = (dir / "spec.json").string();
    std::ofstream(path) << text;
    return path;
}

TEST(DatasetCli, TheSameSeedGivesTheSameFilesInOneRunTwoShardsAndAfterAResume) {
    const fs::path root = test::freshDir("flare_dataset_cli", "same");
    const std::string spec = writeSpec(root, kSpec);
    auto dataset = [&](const std::string& out, const std::string& extra) {
        const test::CliRun r = test::runCli("dataset " + spec + " -o " + (root / out).string() + " --quiet" + extra);
        ASSERT_EQ(r.exitCode, 0) << r.out;
    };
    dataset("a", "");
    dataset("b", " --threads 1");
    dataset("c", " --shard 1/2");
    EXPECT_FALSE(fs::exists(root / "c" / "index.csv"));  // the index waits for every image
    dataset("c", " --shard 0/2");
    const auto a = filesOf(root / "a");
    ASSERT_EQ(a.size(), 4u * 2u + 2u);
    for (const char* name : {"index.csv", "index.json", "image_000000.exr", "image_000003.json"})
        EXPECT_EQ(a.count(name), 1u) << name;
    EXPECT_TRUE(filesOf(root / "b") == a) << "a second run with the same seed differs";
    EXPECT_TRUE(filesOf(root / "c") == a) << "two shards differ from one run";

    // A killed run: image 2 never finished. The resumed run renders it alone, to the same bytes.
    fs::remove(root / "b" / "image_000002.json");
    fs::remove(root / "b" / "index.csv");
    const fs::file_time_type before = fs::last_write_time(root / "b" / "image_000001.exr");
    dataset("b", "");
    EXPECT_TRUE(filesOf(root / "b") == a);
    EXPECT_EQ(fs::last_write_time(root / "b" / "image_000001.exr"), before) << "a finished image was rendered again";

    // The images differ from one another (their scenes are drawn), and a light is out of frame.
    EXPECT_NE(a.at("image_000000.exr"), a.at("image_000001.exr"));
    const nlohmann::json index = nlohmann::json::parse(a.at("index.json"));
    ASSERT_EQ(index["rows"].size(), 4u);
    int lights = 0, inFrame = 0;
    for (const nlohmann::json& row : index["rows"]) {
        lights += row["lights"].get<int>();
        inFrame += row["lights_in_frame"].get<int>();
        EXPECT_GE(row["f_number"].get<double>(), 2.8);
        EXPECT_LE(row["f_number"].get<double>(), 8.0);
    }
    EXPECT_LT(inFrame, lights);
    EXPECT_GT(inFrame, 0);

#ifdef FLARE_MPIEXEC
    // Leak checking off for the ranks in a sanitizer build (test_distributed_cli.cpp says why).
    FILE* pipe = popen(("env ASAN_OPTIONS=\"${ASAN_OPTIONS:-}:detect_leaks=0\" " + std::string(FLARE_MPIEXEC) + " --allow-run-as-root --oversubscribe --bind-to none -np 2 " +
                        FLARE_CLI_PATH + " dataset " + spec + " -o " + (root / "mpi2").string() + " --quiet 2>&1")
                           .c_str(),
                       "r");
    ASSERT_NE(pipe, nullptr);
    char buffer[4096];
    std::string out;
    while (size_t n = fread(buffer, 1, sizeof buffer, pipe)) out.append(buffer, n);
    ASSERT_EQ(pclose(pipe), 0) << out;
    EXPECT_TRUE(filesOf(root / "mpi2") == a) << "two MPI ranks differ from one process";
#endif
}

TEST(DatasetCli, ABadSpecIsAFileLineErrorAndWritesNothing) {
    const fs::path root = test::freshDir("flare_dataset_cli", "bad");
    struct Case {
        const char* what;
        std::string text;
        std::string expected;  // in the message
    };
    const std::string base = R"({ "images": 2,
  "lenses": ["double-gauss-50mm"],
)";
    const Case cases[] = {
        {"unknown key", base + R"(  "f_numbr": [2, 4] })", "spec.json:3: spec: unknown key 'f_numbr'"},
        {"impossible range", base + R"(  "f_number": [8, 2] })", "spec.json:3: f_number: impossible range"},
        {"no such lens", R"({ "images": 2,
  "lenses": ["double-gauss-50mm",
             "no-such-lens-99mm"] })",
         "spec.json:3: lenses[1]: no lens 'no-such-lens-99mm'"},
        {"no lens has the tags", base.substr(0, base.find("\"lenses\"")) + R"("lenses": { "tags": ["no-such-tag"] } })",
         "spec.json:2: lenses: no library lens"},
        {"light count range", base + R"(  "lights": { "count": [3, 1] } })", "spec.json:3: lights.count: impossible range"},
    };
    for (const Case& c : cases) {
        const std::string spec = writeSpec(root, c.text);
        const fs::path out = root / "out";
        const test::CliRun r = test::runCli("dataset " + spec + " -o " + out.string());
        EXPECT_EQ(r.exitCode, 2) << c.what << ": " << r.out;
        EXPECT_NE(r.out.find(c.expected), std::string::npos) << c.what << ": " << r.out;
        EXPECT_FALSE(fs::exists(out)) << c.what;
    }
}

}  // namespace
}  // namespace flare
