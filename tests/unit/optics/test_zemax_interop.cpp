// Zemax interoperability (issue 28, item 8): coatings named in a .zmx that flare knows (MGF2,
// NONE, those flare's own notes define), what a .zmx cannot say surviving an export and re-import
// as notes Zemax keeps and ignores (the iris, the zoom positions' names, the coatings' layers), and
// a private glass catalogue (.agf) given to the library, the CLI and a scene.
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "TestUtil.h"
#include "flare/core/Error.h"
#include "flare/optics/AgfCatalog.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/Paraxial.h"
#include "flare/optics/ZemaxFile.h"
#include "flare/scene/Scene.h"

namespace flare {
namespace {

namespace fs = std::filesystem;

// The doublet of test_zemax_file.cpp, shortened: two surfaces with a coating, a stop, the image.
std::string doublet(const std::string& glass = "N-BK7", const std::string& catalog = "SCHOTT") {
    return "MODE SEQ\nNAME Doublet\nUNIT MM X W X CM MR CPMM\nGCAT " + catalog +
           "\nWAVM 1 0.55 1\nPWAV 1\n"
           "SURF 0\n  TYPE STANDARD\n  CURV 0\n  DISZ INFINITY\n"
           "SURF 1\n  TYPE STANDARD\n  CURV 0.016393442622950821\n  COAT AR\n  DISZ 6\n  GLAS " + glass +
           " 0 0 1.5168 64.17 0 0 0 0 0 0\n  DIAM 12\n"
           "SURF 2\n  TYPE STANDARD\n  CURV -0.0076923076923076927\n  COAT AR\n  DISZ 4\n  DIAM 12\n"
           "SURF 3\n  STOP\n  TYPE STANDARD\n  CURV 0\n  DISZ 90\n  DIAM 9\n"
           "SURF 4\n  TYPE STANDARD\n  CURV 0\n  DISZ 0\n  DIAM 20\n";
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
    const size_t at = text.find(from);
    if (at != std::string::npos) text.replace(at, from.size(), to);
    return text;
}

TEST(ZemaxInterop, MgF2AndNoneCoatingsAreReadAsFlaresOwn) {
    std::vector<std::string> warnings;
    const LensPrescription mgf2 = parseZemaxText(replaced(doublet(), "COAT AR", "COAT MGF2"), "mgf2.zmx", &warnings);
    EXPECT_TRUE(warnings.empty()) << warnings.front();
    ASSERT_TRUE(mgf2.rows[0].coatingName.has_value());
    EXPECT_EQ(*mgf2.rows[0].coatingName, "mgf2");  // a quarter wave of MgF2 at the 550 nm primary
    // At another primary wavelength: the same layer, a quarter wave there.
    const LensPrescription shifted =
        parseZemaxText(replaced(replaced(doublet(), "COAT AR", "COAT MgF2"), "WAVM 1 0.55 1", "WAVM 1 0.6 1"), "s.zmx",
                       &warnings);
    EXPECT_TRUE(warnings.empty());
    ASSERT_EQ(*shifted.rows[0].coatingName, "MGF2");
    const std::optional<Coating> layer = shifted.findCoating("MGF2");
    ASSERT_TRUE(layer && layer->layers.size() == 1);
    EXPECT_DOUBLE_EQ(layer->layers[0].index, 1.38);
    EXPECT_DOUBLE_EQ(layer->layers[0].index * layer->layers[0].thicknessNm, 600.0 / 4.0);
    const LensPrescription none = parseZemaxText(replaced(doublet(), "COAT AR", "COAT NONE"), "none.zmx", &warnings);
    EXPECT_TRUE(warnings.empty());
    EXPECT_EQ(*none.rows[0].coatingName, "none");
    // A coating flare does not know is still a warning, and the surface uncoated.
    const LensPrescription unknown = parseZemaxText(replaced(doublet(), "COAT AR", "COAT HEAR1"), "u.zmx", &warnings);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("u.zmx:14: surface 1, COAT: coating 'HEAR1'"), std::string::npos) << warnings[0];
    EXPECT_FALSE(unknown.rows[0].coatingName.has_value());
}

TEST(ZemaxInterop, IrisZoomPositionNamesAndCoatingsSurviveExportAndReimport) {
    for (const char* name : {"double-gauss-50mm", "zoom-24-70mm", "fisheye-16mm"}) {
        const LensPrescription original = loadLens(name);
        const std::string text = writeZemax(original);
        // Notes: lines Zemax keeps (its system notes) and gives no optical meaning.
        EXPECT_NE(text.find("\r\nNOTE 0 flare: iris blades=" + std::to_string(original.iris.blades)), std::string::npos)
            << name;
        std::vector<std::string> warnings;
        const LensPrescription copy = parseZemaxText(text, std::string(name) + ".zmx", &warnings);
        EXPECT_TRUE(warnings.empty()) << name << ": " << warnings.front();
        EXPECT_EQ(copy.iris.blades, original.iris.blades) << name;
        EXPECT_EQ(copy.iris.rotationDeg, original.iris.rotationDeg) << name;
        EXPECT_EQ(copy.iris.curvature, original.iris.curvature) << name;
        ASSERT_EQ(copy.zoomPositions.size(), original.zoomPositions.size()) << name;
        for (size_t z = 0; z < copy.zoomPositions.size(); ++z) {
            EXPECT_EQ(copy.zoomPositions[z].name, original.zoomPositions[z].name) << name;
            EXPECT_EQ(copy.zoomPositions[z].focalLengthMm, original.zoomPositions[z].focalLengthMm) << name;
            // The names reach the same lens as before (`--zoom tele` works on the copy).
            const LensSystem a = LensSystem::build(original, LensState{original.zoomPositions[z].name, {}, {}});
            const LensSystem b = LensSystem::build(copy, LensState{original.zoomPositions[z].name, {}, {}});
            EXPECT_NEAR(paraxialEflMm(b, b.indicesAt(kLineDNm)), paraxialEflMm(a, a.indicesAt(kLineDNm)), 1e-9);
        }
    }
    // Coatings of the lens's own: a stack and an ideal one, layer for layer.
    const LensPrescription original = parseLensText(R"(name coated
focal_length_mm 50
iris blades=5 rotation_deg=12.5 curvature=0.25
coating hard single n=1.45 quarter_wave_nm=500
coating v2 stack 1.38:99.637681159420296 2.1:65.5 1.46:94.2
coating ghostly ideal 400:0.01 550:0.004 700:0.02
default_coating v2
surfaces
  40    5     N-BK7         12   coating=hard
  -200  2     air           12   coating=ghostly
  stop  3     air           10
  80    4     N-SF5         11
  -150  auto  air           11
)", "coated.lens");
    std::vector<std::string> warnings;
    const LensPrescription copy = parseZemaxText(writeZemax(original), "coated.zmx", &warnings);
    EXPECT_TRUE(warnings.empty()) << warnings.front();
    EXPECT_EQ(copy.iris.blades, 5);
    EXPECT_EQ(copy.iris.rotationDeg, 12.5);
    EXPECT_EQ(copy.iris.curvature, 0.25);
    for (size_t i = 0; i < original.rows.size(); ++i) {
        if (original.rows[i].isStop) continue;
        const std::optional<Coating> a = original.findCoating(original.rows[i].coatingName.value_or(original.defaultCoating));
        const std::optional<Coating> b = copy.findCoating(copy.rows[i].coatingName.value_or(copy.defaultCoating));
        ASSERT_TRUE(a && b) << "row " << i + 1;
        EXPECT_EQ(b->name, a->name) << "row " << i + 1;
        ASSERT_EQ(b->layers.size(), a->layers.size()) << a->name;
        for (size_t k = 0; k < a->layers.size(); ++k) {
            EXPECT_EQ(b->layers[k].index, a->layers[k].index) << a->name;
            EXPECT_EQ(b->layers[k].thicknessNm, a->layers[k].thicknessNm) << a->name;
        }
        ASSERT_EQ(b->ideal.has_value(), a->ideal.has_value()) << a->name;
        if (a->ideal) {
            EXPECT_EQ(b->ideal->wavelengthsNm, a->ideal->wavelengthsNm);
            EXPECT_EQ(b->ideal->reflectances, a->ideal->reflectances);
        }
    }
    // A note of a newer flare is read past with a warning; a malformed one is an error at its line.
    const std::string text = writeZemax(original);
    parseZemaxText(replaced(text, "NOTE 0 flare: iris", "NOTE 0 flare: sparkle x=1\r\nNOTE 0 flare: iris"), "n.zmx",
                   &warnings);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("flare note 'sparkle'"), std::string::npos) << warnings[0];
    try {
        parseZemaxText(replaced(text, "blades=5", "blades=2"), "bad.zmx");
        ADD_FAILURE() << "two blades accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), "bad.zmx");
        EXPECT_GT(e.line(), 0);
        EXPECT_NE(e.problem().find("iris blades"), std::string::npos) << e.what();
    }
}

// A private catalogue holding N-BK7's Sellmeier data under another name.
fs::path privateCatalogue(const fs::path& dir) {
    const fs::path path = dir / "PRIVATE.agf";
    std::ofstream(path) << "CC a private catalogue for the tests\n"
                           "NM PRIV-BK7 2 517642.251 1.5168 64.17 0 1\n"
                           "CD 1.039612120E+00 6.000698670E-03 2.317923440E-01 2.001791440E-02 1.010469450E+00 "
                           "1.035606530E+02 0.000000000E+00 0.000000000E+00\n"
                           "LD 3.00000E-01 2.50000E+00\n";
    return path;
}

TEST(ZemaxInterop, APrivateGlassCatalogueServesTheLibraryTheCliAndScenes) {
    const fs::path dir = test::processTempDir("zemax_interop");
    const fs::path agf = privateCatalogue(dir), zmx = dir / "private.zmx";
    std::ofstream(zmx, std::ios::binary) << doublet("PRIV-BK7", "PRIVATE");

    // The CLI without the catalogue: the glass is unknown, and the message says how to give one.
    test::CliRun r = test::runCli("lens info " + zmx.string() + " --json");
    EXPECT_EQ(r.exitCode, 2) << r.out;
    EXPECT_NE(r.out.find("unknown glass 'PRIV-BK7'"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("--glass-catalog"), std::string::npos) << r.out;
    // With it: the lens is the N-BK7 doublet.
    r = test::runCli("lens info " + zmx.string() + " --glass-catalog " + agf.string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    const double efl = nlohmann::json::parse(r.out)["efl_mm"].get<double>();
    const LensSystem reference = LensSystem::build(parseZemaxText(doublet(), "reference.zmx"));
    EXPECT_NEAR(efl, paraxialEflMm(reference, reference.indicesAt(kLineDNm)), 1e-9 * efl);
    EXPECT_EQ(test::runCli("ghosts " + zmx.string() + " --glass-catalog " + agf.string() + " --json").exitCode, 0);
    r = test::runCli("lens info " + zmx.string() + " --glass-catalog " + (dir / "missing.agf").string());
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.out.find("missing.agf"), std::string::npos) << r.out;

    // A scene's glass_catalog, relative to the scene's folder; a missing one at its line.
    std::ofstream(dir / "scene.json") << "{\n  \"lens\": \"private.zmx\",\n  \"glass_catalog\": \"PRIVATE.agf\",\n"
                                         "  \"lights\": [ { \"type\": \"directional\", \"field_deg\": [5, 0] } ]\n}\n";
    r = test::runCli("ghosts " + (dir / "scene.json").string() + " --json");
    EXPECT_EQ(r.exitCode, 0) << r.out;
    std::ofstream(dir / "bad.json") << "{\n  \"lens\": \"private.zmx\",\n  \"glass_catalog\": [\"NOPE.agf\"],\n"
                                       "  \"lights\": [ { \"type\": \"directional\" } ]\n}\n";
    r = test::runCli("ghosts " + (dir / "bad.json").string());
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.out.find("bad.json:3: glass_catalog"), std::string::npos) << r.out;

    // The library: the catalogue's glasses have N-BK7's indices, found by GCAT name and bare.
    EXPECT_THROW(parseZemaxText(doublet("PRIV-BK7", "PRIVATE"), "before.zmx"), InputError);
    useGlassCatalog(agf.string());
    const LensPrescription p = parseZemaxText(doublet("PRIV-BK7", "PRIVATE"), "after.zmx");
    const LensPrescription bare = parseZemaxText(doublet("PRIV-BK7", "SCHOTT"), "bare.zmx");
    for (double wavelength : {400.0, kLineDNm, 700.0}) {
        EXPECT_EQ(p.rows[0].mediumAfter.indexAt(wavelength), reference.indicesAt(wavelength).n[1]) << wavelength;
        EXPECT_EQ(bare.rows[0].mediumAfter.indexAt(wavelength), reference.indicesAt(wavelength).n[1]) << wavelength;
    }
    EXPECT_EQ(findCatalogGlass("PRIVATE:PRIV-BK7"), p.rows[0].mediumAfter.baseGlass());
    EXPECT_EQ(&useGlassCatalog(agf.string()), privateGlassCatalogs().front());  // read once
}

}  // namespace
}  // namespace flare
