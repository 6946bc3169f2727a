// `flare render` run as a subprocess: the EXR layers, the report's keys, resuming from a
// checkpoint, and exit code 2 with nothing written for bad input.
#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>

#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfMultiPartInputFile.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "TestUtil.h"
#include "flare/film/ImageIO.h"

namespace flare {
namespace {

using test::CliRun;
CliRun run(const std::string& arguments) { return test::runCli(arguments); }

std::string tempPath(const std::string& name) {
    const auto dir = test::processTempDir("flare_render_cli");
    std::filesystem::create_directories(dir);
    std::filesystem::remove(dir / name);
    return (dir / name).string();
}

// The default scene at a small resolution (the scene file sets it).
std::string smallScene() {
    const std::string path = tempPath("small.json");
    std::ofstream(path) << R"({
  "lens": "double-gauss-50mm", "f_number": 4.0,
  "sensor": { "resolution": [192, 128] },
  "lights": [ { "type": "directional", "field_deg": [11, 8], "angular_diameter_deg": 0.53,
                "spectrum": { "blackbody_k": 5778 } } ]
})";
    return path;
}

TEST(RenderCli, WritesLayersVarianceAndAReport) {
    const std::string exr = tempPath("r.exr"), report = tempPath("r.json"), png = tempPath("r.png");
    const CliRun r = run("render " + smallScene() + " -o " + exr + " --photons 150000 --layers --quiet --report " +
                         report + " --png " + png);
    ASSERT_EQ(r.exitCode, 0) << r.out;
    std::vector<std::string> names;
    for (const ImageLayer& l : readExr(exr)) names.push_back(l.name);
    for (const char* name : {"", "direct", "ghost", "higher", "scatter", "variance"})
        EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
    EXPECT_GT(names.size(), 10u);  // per-ghost layers
    EXPECT_TRUE(std::filesystem::exists(png));

    std::ifstream in(report);
    const nlohmann::json j = nlohmann::json::parse(in);
    EXPECT_GE(j["photons"].get<long>(), 150000);
    EXPECT_GT(j["wall_time_s"].get<double>(), 0.0);
    for (const char* layer : {"direct", "ghost", "higher", "scatter"}) {
        EXPECT_TRUE(j["layers"][layer]["power_w"].is_number()) << layer;
        EXPECT_TRUE(j["layers"][layer]["standard_error_w"].is_number()) << layer;
    }
    ASSERT_FALSE(j["ghosts"].empty());
    const nlohmann::json& g = j["ghosts"][0];
    for (const char* key : {"power_w", "standard_error_w", "power_fraction"}) EXPECT_TRUE(g[key].is_number()) << key;
    EXPECT_TRUE(g["surfaces"].is_array());
    EXPECT_TRUE(j["skipped"].is_array());
}

// --compression: the file's compression, the same image (naive photons: the fastest render).
TEST(RenderCli, CompressionChangesTheFileNotThePixels) {
    const std::string piz = tempPath("c-piz.exr"), zip = tempPath("c-zip.exr");
    for (const auto& [out, extra] : {std::pair{piz, std::string()}, std::pair{zip, std::string(" --compression ZIP")}}) {
        const CliRun r = run("render " + smallScene() + " -o " + out +
                             " --mode naive --photons 20000 --target-error 0 --no-diffraction --quiet" + extra);
        ASSERT_EQ(r.exitCode, 0) << r.out;
    }
    EXPECT_EQ(Imf::MultiPartInputFile(piz.c_str()).header(0).compression(), Imf::PIZ_COMPRESSION);
    EXPECT_EQ(Imf::MultiPartInputFile(zip.c_str()).header(0).compression(), Imf::ZIP_COMPRESSION);
    const ImageLayer a = readExrLayer(piz, ""), b = readExrLayer(zip, "");
    EXPECT_GT(std::count_if(a.rgb.begin(), a.rgb.end(), [](float v) { return v > 0.0f; }), 100);
    EXPECT_TRUE(a.rgb == b.rgb);
}

TEST(RenderCli, CheckpointResumesAndContinuesAccumulating) {
    const std::string exr = tempPath("c.exr"), checkpoint = tempPath("c.checkpoint"), report = tempPath("c.json");
    const std::string scene = smallScene();
    // Two guided passes of 262 144 photons (kGuidedBatchesPerPass), then two more.
    ASSERT_EQ(run("render " + scene + " -o " + exr + " --photons 524288 --quiet --checkpoint " + checkpoint).exitCode, 0);
    ASSERT_TRUE(std::filesystem::exists(checkpoint));
    const CliRun more = run("render " + scene + " -o " + exr + " --photons 1048576 --checkpoint " + checkpoint +
                            " --report " + report);
    ASSERT_EQ(more.exitCode, 0) << more.out;
    EXPECT_NE(more.out.find("resumed"), std::string::npos) << more.out;
    std::ifstream in(report);
    // (--photons counts nominal passes: the adaptive plan sizes the fourth pass's photons.)
    EXPECT_EQ(nlohmann::json::parse(in)["passes"].get<int>(), 4);
}

TEST(RenderCli, BadInputExitsWithCodeTwoAndWritesNothing) {
    const std::string exr = tempPath("bad.exr");
    const std::string scene = tempPath("bad.json");
    std::ofstream(scene) << "{\n  \"lens\": \"double-gauss-50mm\",\n  \"lights\": [ { \"type\": \"laser\" } ]\n}\n";
    const CliRun r = run("render " + scene + " -o " + exr + " --photons 1000");
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.out.find("bad.json:3"), std::string::npos) << r.out;
    EXPECT_FALSE(std::filesystem::exists(exr));
    EXPECT_EQ(run("render -o " + exr + " --mode sideways").exitCode, 2);
    EXPECT_EQ(run("render -o " + exr + " --photons -5").exitCode, 2);
    EXPECT_FALSE(std::filesystem::exists(exr));
}

}  // namespace
}  // namespace flare
