// The command-line front end, run as a subprocess: the JSON keys other tools read, the SVG
// drawing, and the exit code 2 with a file:line message for bad input.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>
#include <sys/wait.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "TestUtil.h"
#include "flare/film/ImageIO.h"

namespace flare {
namespace {

using test::CliRun;
CliRun run(const std::string& arguments) { return test::runCli(arguments); }

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
    const std::string out = (test::processTempDir("cli") / "lens.svg").string();
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

TEST(Cli, LensDrawGhostPathsAndRejectsNonGhosts) {
    const std::string out = (test::processTempDir("cli") / "ghost.svg").string();
    std::remove(out.c_str());
    const CliRun r = run("lens draw double-gauss-50mm --ghost 7,3 --field 5 --rays 5 -o " + out);
    ASSERT_EQ(r.exitCode, 0) << r.out;
    std::ifstream in(out);
    std::stringstream svg;
    svg << in.rdbuf();
    EXPECT_NE(svg.str().find("#e377c2"), std::string::npos);  // the ghost rays' colour
    EXPECT_NE(svg.str().find("ghost 7-3"), std::string::npos);
    // Two reflections name one ghost in either order, titled as the light meets them.
    const std::string swapped = (test::processTempDir("cli") / "ghost_swapped.svg").string();
    ASSERT_EQ(run("lens draw double-gauss-50mm --ghost 3,7 --field 5 --rays 5 -o " + swapped).exitCode, 0);
    std::ifstream inSwapped(swapped);
    std::stringstream svgSwapped;
    svgSwapped << inSwapped.rdbuf();
    EXPECT_EQ(svgSwapped.str(), svg.str());
    EXPECT_EQ(run("lens draw double-gauss-50mm --ghost 7,3,2,5 -o " + out).exitCode, 2);  // 2 lies behind 3
    EXPECT_EQ(run("lens draw double-gauss-50mm --ghost 6,3 -o " + out).exitCode, 2);  // 6 is the stop
}

TEST(Cli, GhostsJsonHasTheDocumentedKeys) {
    const CliRun r = run("ghosts double-gauss-50mm --field-deg 10,5 --json --all");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    ASSERT_EQ(j["ghosts"].size(), 55u);
    double previous = 1.0;
    for (const auto& g : j["ghosts"]) {
        for (const char* key : {"ghost_efl_mm", "ghost_focus_mm", "power_fraction"}) EXPECT_TRUE(g.contains(key)) << key;
        EXPECT_EQ(g["surfaces"].size(), 2u);
        EXPECT_TRUE(g["footprint_mm"].contains("x_min"));
        EXPECT_TRUE(g["pruned"].is_boolean());
        EXPECT_TRUE(g["resolved"].get<bool>());  // a shipped lens never exhausts the ray budget
        EXPECT_LE(g["power_fraction"].get<double>(), previous);  // sorted by power
        previous = g["power_fraction"].get<double>();
    }
    const CliRun csv = run("ghosts double-gauss-50mm --csv");
    EXPECT_EQ(csv.exitCode, 0);
    EXPECT_EQ(csv.out.rfind("surfaces,label,ghost_efl_mm,ghost_focus_mm", 0), 0u);
}

TEST(Cli, PreviewOfTheDefaultSceneWritesExrAndPng) {
    const std::string exr = (test::processTempDir("cli") / "preview.exr").string();
    const std::string png = (test::processTempDir("cli") / "preview.png").string();
    const std::string scene = (test::processTempDir("cli") / "small.json").string();
    // The default scene at a quarter of its resolution, to keep the test quick.
    std::ofstream(scene) << R"({"lens": "double-gauss-50mm", "f_number": 4,
        "sensor": {"resolution": [384, 256]},
        "lights": [{"type": "directional", "field_deg": [11, 8], "angular_diameter_deg": 0.53}],
        "render": {"preview_wavelengths": 3}})";
    std::remove(exr.c_str());
    const CliRun r = run("preview " + scene + " -o " + exr + " --png " + png + " --layers --quiet");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    EXPECT_TRUE(std::ifstream(exr).good());
    EXPECT_TRUE(std::ifstream(png).good());
    // `compare` sums layers joined by +: the image against itself is 0 off, a missing layer is
    // an input error.
    const CliRun same = run("compare " + exr + " " + exr + " --layer ghost+direct --json");
    ASSERT_EQ(same.exitCode, 0) << same.out;
    const nlohmann::json j = nlohmann::json::parse(same.out.substr(same.out.find('{')));
    EXPECT_EQ(j["layer"], "ghost+direct");
    EXPECT_EQ(j["rel_l2"], 0.0);
    const CliRun missing = run("compare " + exr + " " + exr + " --layer ghost+nosuch");
    EXPECT_EQ(missing.exitCode, 2);
    EXPECT_NE(missing.out.find("nosuch"), std::string::npos) << missing.out;
    std::ofstream(scene) << R"({"lens": "double-gauss-50mm", "lights": [{"type": "directional", "field_deg": [11, 8], "angular_diameter_deg": -1}]})";
    const CliRun bad = run("preview " + scene + " -o " + exr);
    EXPECT_EQ(bad.exitCode, 2);
    EXPECT_NE(bad.out.find("angular_diameter_deg"), std::string::npos) << bad.out;
}

// --layers top:N writes N per-ghost parts and ghost_other (a part each, over its footprint), whose
// sum with the kept ones is the ghost layer; a bare --layers before the scene still takes it as the
// scene; a selection it does not know is an input error saying what it accepts.
TEST(Cli, PreviewLayersTopNWritesThePartsAndGhostOther) {
    const std::string dir = test::processTempDir("cli").string();
    const std::string scene = dir + "/layers.json", top = dir + "/top.exr", every = dir + "/every.exr";
    std::ofstream(scene) << R"({"lens": "double-gauss-50mm", "f_number": 8,
        "sensor": {"resolution": [192, 128]},
        "lights": [{"type": "directional", "field_deg": [6, 4], "angular_diameter_deg": 0.53}],
        "render": {"preview_wavelengths": 3, "diffraction": false}})";
    const CliRun r = run("preview " + scene + " -o " + top + " --layers top:3 --float-layers --quiet");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    const ExrImage image = readExrImage(top);
    std::vector<std::string> parts(image.ownParts.begin(), image.ownParts.end());
    ASSERT_EQ(parts.size(), 4u);
    EXPECT_EQ(parts.back(), "ghost_other");
    std::vector<double> sum(3 * 192 * 128, 0.0);
    for (const ImageLayer& layer : image.layers) {
        if (!image.ownParts.count(layer.name)) continue;
        for (int y = 0; y < layer.height; ++y)
            for (int x = 0; x < layer.width; ++x)
                for (int c = 0; c < 3; ++c)
                    sum[(static_cast<size_t>(y + layer.y) * 192 + x + layer.x) * 3 + c] +=
                        layer.rgb[(static_cast<size_t>(y) * layer.width + x) * 3 + c];
    }
    const ImageLayer ghost = readExrLayer(top, "ghost");
    double largest = 0.0, difference = 0.0;
    for (size_t i = 0; i < sum.size(); ++i) {
        largest = std::max(largest, std::abs(static_cast<double>(ghost.rgb[i])));
        difference = std::max(difference, std::abs(sum[i] - ghost.rgb[i]));
    }
    EXPECT_GT(largest, 0.0);
    EXPECT_LT(difference, 1e-5 * largest);  // float roundings of a few layers and passes (test_ghost_layers.cpp bounds them per pixel)

    const CliRun before = run("preview --layers " + scene + " -o " + every + " --quiet");
    ASSERT_EQ(before.exitCode, 0) << before.out;
    EXPECT_GT(readExrImage(every).ownParts.size(), 4u);
    for (const char* bad : {"top:0", "share:2", "best:3"}) {
        const CliRun wrong = run("preview " + scene + " -o " + every + " --layers " + bad + " --quiet");
        EXPECT_EQ(wrong.exitCode, 2) << bad;
        EXPECT_NE(wrong.out.find("share:F"), std::string::npos) << wrong.out;
    }
}

TEST(Cli, BadLensFileExitsWithCodeTwoAndNamesFileAndLine) {
    const std::string path = (test::processTempDir("cli") / "bad.lens").string();
    std::ofstream(path) << "name bad\nfocal_length_mm 50\nsurfaces\n40 5 UNOBTAINIUM 10\nstop 2 air 8\n-60 auto air 10\n";
    const std::string svg = (test::processTempDir("cli") / "bad.svg").string();
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

// A data file named in a scene whose name is too long for the system: the scene's file and line,
// exit code 2 (it was an uncaught filesystem_error: "File name too long", exit code 1).
TEST(Cli, OverlongDataFileNameInASceneIsAFileLineError) {
    const std::string scene = (test::processTempDir("cli") / "long.json").string();
    std::ofstream(scene) << R"({"lens": "double-gauss-50mm",
  "lights": [{"type": "directional", "field_deg": [0, 5]}],
  "scattering": {"bulk": [{"element": 1, "scattering_per_mm": 0.01,
    "grid": ")" << std::string(300, 'g') << R"(.vdb"}]}})";
    const CliRun r = test::runCli("preview " + scene + " -o " + (test::processTempDir("cli") / "x.exr").string());
    EXPECT_EQ(r.exitCode, 2) << r.out;
    EXPECT_NE(r.out.find(scene + ":4: scattering.bulk[0].grid"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("File name too long"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace flare
