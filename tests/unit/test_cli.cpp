// The command-line front end, run as a subprocess: the JSON keys other tools read, the SVG
// drawing, and the exit code 2 with a file:line message for bad input.
#include <array>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "TestUtil.h"

namespace flare {
namespace {

struct CliRun {
    int exitCode;
    std::string out;
};

CliRun run(const std::string& arguments) {
    const std::string command = std::string(FLARE_CLI_PATH) + " " + arguments + " 2>&1";
    FILE* pipe = popen(command.c_str(), "r");
    EXPECT_NE(pipe, nullptr);
    std::string out;
    std::array<char, 4096> buffer{};
    while (size_t n = fread(buffer.data(), 1, buffer.size(), pipe)) out.append(buffer.data(), n);
    const int status = pclose(pipe);
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

TEST(Cli, LensInfoJsonHasTheDocumentedKeys) {
    const CliRun r = run("lens info " + test::sourcePath("lenses/double-gauss-50mm.lens") + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_NEAR(j["efl_mm"].get<double>(), 50.0, 0.25);
    for (const char* key : {"bfl_mm", "entrance_pupil_diameter_mm", "f_number"}) EXPECT_TRUE(j[key].is_number()) << key;
    EXPECT_EQ(j["surfaces"].get<int>(), 11);
}

TEST(Cli, LensInfoZoomAndWavelength) {
    const CliRun tele = run("lens info " + test::sourcePath("lenses/zoom-24-70mm.lens") + " --zoom tele --json");
    ASSERT_EQ(tele.exitCode, 0) << tele.out;
    const CliRun wide = run("lens info " + test::sourcePath("lenses/zoom-24-70mm.lens") + " --zoom wide --json");
    EXPECT_GT(nlohmann::json::parse(tele.out)["efl_mm"].get<double>(),
              2.0 * nlohmann::json::parse(wide.out)["efl_mm"].get<double>());
    const CliRun blue = run("lens info " + test::sourcePath("lenses/double-gauss-50mm.lens") + " --wavelength 450 --json");
    EXPECT_EQ(nlohmann::json::parse(blue.out)["wavelength_nm"].get<double>(), 450.0);
}

TEST(Cli, LensDrawWritesAnSvg) {
    const std::string out = testing::TempDir() + "/flare_cli_lens.svg";
    std::remove(out.c_str());
    const CliRun r = run("lens draw " + test::sourcePath("lenses/double-gauss-50mm.lens") + " -o " + out + " --rays 5 --field 10");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    std::ifstream in(out);
    std::stringstream svg;
    svg << in.rdbuf();
    EXPECT_NE(svg.str().find("<svg"), std::string::npos);
    EXPECT_NE(svg.str().find("<polyline"), std::string::npos);
    EXPECT_NE(svg.str().find("</svg>"), std::string::npos);
}

TEST(Cli, BadLensFileExitsWithCodeTwoAndNamesFileAndLine) {
    const std::string path = testing::TempDir() + "/flare_cli_bad.lens";
    std::ofstream(path) << "name bad\nfocal_length_mm 50\nsurfaces\n40 5 UNOBTAINIUM 10\nstop 2 air 8\n-60 auto air 10\n";
    const std::string svg = testing::TempDir() + "/flare_cli_bad.svg";
    std::remove(svg.c_str());
    const CliRun r = run("lens draw " + path + " -o " + svg);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.out.find(path + ":4:"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("unknown glass"), std::string::npos) << r.out;
    EXPECT_FALSE(std::ifstream(svg).good()) << "no output may be written on error";
}

TEST(Cli, MissingFileAndBadArgumentsExitWithCodeTwo) {
    EXPECT_EQ(run("lens info /nonexistent.lens").exitCode, 2);
    EXPECT_EQ(run("lens info " + test::sourcePath("lenses/zoom-24-70mm.lens") + " --zoom nowhere").exitCode, 2);
    EXPECT_EQ(run("lens info").exitCode, 2);
    EXPECT_EQ(run("no-such-command").exitCode, 2);
}

}  // namespace
}  // namespace flare
