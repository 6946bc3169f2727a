// Zemax .zmx files: every shipped lens and every library lens written as .zmx and read back (UTF-8
// and UTF-16 LE with a byte-order mark) has the same focal length and the same ghost table; units,
// glasses, coatings, the stop and configurations read as documented; every unsupported keyword and
// malformed line is an error naming the file, the line and the surface; the CLI reads and writes
// .zmx files; scenes name them.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/core/Error.h"
#include "flare/core/TextEncoding.h"
#include "flare/ghosts/GhostAnalysis.h"
#include "flare/ghosts/Ghosts.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/LensLibrary.h"
#include "flare/optics/Paraxial.h"
#include "flare/optics/ZemaxFile.h"
#include "flare/scene/Scene.h"

namespace flare {
namespace {

// The .zmx carries curvatures (1/R), so a radius comes back within a rounding of its reciprocal:
// every derived length agrees to a few ulps, far inside this.
constexpr double kRelativeTolerance = 1e-9;

void expectClose(double expected, double actual, const std::string& what) {
    EXPECT_NEAR(actual, expected, kRelativeTolerance * std::max(1.0, std::abs(expected))) << what;
}

std::vector<std::string> zoomStates(const LensPrescription& p) {
    std::vector<std::string> states;
    for (const ZoomPosition& z : p.zoomPositions) states.push_back(z.name);
    if (states.empty()) states.push_back("");
    return states;
}

// EFL and the paraxial ghost table (the order-2 paths with the sensor, each path's ghost focal
// length, focus and normal-incidence reflectance) of `copy` against `original`, position by position.
void expectSameLensAndGhostTable(const LensPrescription& original, const LensPrescription& copy, const std::string& what) {
    const std::vector<std::string> a = zoomStates(original), b = zoomStates(copy);
    ASSERT_EQ(a.size(), b.size()) << what;
    for (size_t z = 0; z < a.size(); ++z) {
        const std::string where = what + " zoom " + a[z];
        const LensSystem lensA = LensSystem::build(original, LensState{a[z], {}, {}});
        const LensSystem lensB = LensSystem::build(copy, LensState{b[z], {}, {}});
        ASSERT_EQ(lensA.surfaceCount(), lensB.surfaceCount()) << where;
        const SpectralIndices nA = lensA.indicesAt(kLineDNm), nB = lensB.indicesAt(kLineDNm);
        expectClose(paraxialEflMm(lensA, nA), paraxialEflMm(lensB, nB), where + " EFL");
        expectClose(lensA.sensorZMm(), lensB.sensorZMm(), where + " sensor");
        const std::vector<GhostPath> pathsA = enumerateGhosts(lensA, 2, true), pathsB = enumerateGhosts(lensB, 2, true);
        ASSERT_EQ(pathsA, pathsB) << where;
        for (const GhostPath& path : pathsA) {
            const std::string ghost = where + " ghost " + path.label();
            const GhostParaxial gA = analyseGhostParaxial(lensA, nA, path), gB = analyseGhostParaxial(lensB, nB, path);
            ASSERT_EQ(gA.eflMm.has_value(), gB.eflMm.has_value()) << ghost;
            if (gA.eflMm) expectClose(*gA.eflMm, *gB.eflMm, ghost + " EFL");
            if (gA.focusFromSensorMm && gB.focusFromSensorMm) expectClose(*gA.focusFromSensorMm, *gB.focusFromSensorMm, ghost + " focus");
            expectClose(normalIncidenceReflectance(lensA, nA, path), normalIncidenceReflectance(lensB, nB, path), ghost + " R");
        }
    }
}

LensPrescription roundTrip(const LensPrescription& p, bool utf16, const std::string& name) {
    const std::string text = writeZemax(p);
    std::vector<std::string> warnings;
    LensPrescription copy = parseZemaxText(utf16 ? encodeUtf16Le(text) : text, name, &warnings);
    EXPECT_TRUE(warnings.empty()) << name << ": " << (warnings.empty() ? "" : warnings.front());
    return copy;
}

TEST(ZemaxFile, ShippedLensesRoundTripInBothEncodings) {
    for (const char* file : test::kShippedLenses) {
        const LensPrescription original = loadLensFile(test::sourcePath(file));
        for (bool utf16 : {false, true}) {
            const LensPrescription copy = roundTrip(original, utf16, "copy.zmx");
            EXPECT_EQ(copy.name, original.name);
            EXPECT_EQ(copy.fNumber, original.fNumber);
            expectSameLensAndGhostTable(original, copy, std::string(file) + (utf16 ? " utf-16" : " utf-8"));
        }
    }
}

// The real-ray ghost analysis (power, footprint) agrees too, once the iris and sensor, which a .zmx
// file does not carry, are restored.
TEST(ZemaxFile, ShippedLensesKeepTheirRealRayGhostPowers) {
    for (const char* file : test::kShippedLenses) {
        const LensPrescription original = loadLensFile(test::sourcePath(file));
        LensPrescription copy = roundTrip(original, false, "copy.zmx");
        copy.iris = original.iris;
        copy.sensor = original.sensor;
        const LensSystem lensA = LensSystem::build(original), lensB = LensSystem::build(copy);
        // A coarse search: the two lenses are compared with each other, not with the truth.
        GhostAnalysisOptions options;
        options.coarseCells = 8;
        options.fineCells = 8;
        options.minLivePoints = 40;
        const glm::dvec3 direction = directionFromFieldDeg(5.0, 3.0);
        const GhostReport a = analyseGhosts(lensA, direction, options), b = analyseGhosts(lensB, direction, options);
        ASSERT_EQ(a.ghosts.size(), b.ghosts.size()) << file;
        expectClose(a.direct.powerFraction, b.direct.powerFraction, std::string(file) + " direct");
        // Matched by path: ghosts of nearly equal power may swap ranks.
        std::map<std::string, double> powers;
        for (const GhostEstimate& g : b.ghosts) powers[g.path.label()] = g.powerFraction;
        for (const GhostEstimate& g : a.ghosts)
            EXPECT_NEAR(powers.at(g.path.label()), g.powerFraction, 1e-6 * g.powerFraction) << file << " " << g.path.label();
    }
}

TEST(ZemaxFile, LibraryLensesRoundTripInBothEncodings) {
    const std::vector<LibraryLens>& lenses = LensLibrary::shared().lenses();
    ASSERT_GT(lenses.size(), 100u);
    int roundTripped = 0;
    for (const LibraryLens& lens : lenses) {
        const LensPrescription original = loadLensFile(lens.path);
        const std::string text = writeZemax(original);
        const LensPrescription utf8 = parseZemaxText(text, lens.id + ".zmx");
        expectSameLensAndGhostTable(original, utf8, lens.id);
        // The UTF-16 file decodes to the same text: the same prescription, row by row.
        const LensPrescription utf16 = parseZemaxText(encodeUtf16Le(text), lens.id + ".zmx");
        ASSERT_EQ(utf16.rows.size(), utf8.rows.size()) << lens.id;
        for (size_t i = 0; i < utf8.rows.size(); ++i) {
            EXPECT_EQ(utf16.rows[i].radiusMm, utf8.rows[i].radiusMm) << lens.id;
            EXPECT_EQ(utf16.rows[i].thickness.valueMm, utf8.rows[i].thickness.valueMm) << lens.id;
            EXPECT_EQ(utf16.rows[i].mediumAfter.describe(), utf8.rows[i].mediumAfter.describe()) << lens.id;
        }
        ++roundTripped;
        if (HasFailure()) break;  // one lens's report is enough to see what went wrong
    }
    EXPECT_EQ(roundTripped, static_cast<int>(lenses.size()));
}

// Catalogue glasses come back as the same glass: built-in ones (N-BK7 comes back from SCHOTT.agf,
// whose data the built-in table holds: the indices agree to 5e-16), one named with its catalogue,
// one found only in a shipped catalogue; and a constant
// index (pbrt's media) as a model glass without dispersion. Coatings: mgf2 is Zemax's AR; another
// coating keeps its name only, so it reads back uncoated with a warning.
TEST(ZemaxFile, CatalogueGlassesConstantIndicesAndCoatingsRoundTrip) {
    const LensPrescription original = parseLensText(R"(name glasses
focal_length_mm 50
coating hard single n=1.45 quarter_wave_nm=500
default_coating mgf2
surfaces
  40    5     N-BK7         12
  -60   1.5   HOYA:FCD1     12
  -200  2     air           12
  stop  3     air           10
  80    4     K-VC78        11
  -80   1     n=1.62        11
  -150  auto  air           11   coating=hard
)", "glasses.lens");
    const std::string text = writeZemax(original);
    EXPECT_NE(text.find("GCAT SCHOTT HOYA SUMITA\r\n"), std::string::npos) << text;
    std::vector<std::string> warnings;
    const LensPrescription copy = parseZemaxText(text, "glasses.zmx", &warnings);
    ASSERT_EQ(copy.rows.size(), original.rows.size());
    for (size_t i = 0; i < copy.rows.size(); ++i)
        for (double wavelength : {400.0, kLineDNm, 700.0})
            EXPECT_NEAR(copy.rows[i].mediumAfter.indexAt(wavelength), original.rows[i].mediumAfter.indexAt(wavelength), 1e-15)
                << "row " << i + 1 << " " << copy.rows[i].mediumAfter.describe() << " against "
                << original.rows[i].mediumAfter.describe();
    // The lens's own coating comes back from the note the writer puts it in (test_zemax_interop.cpp).
    EXPECT_TRUE(warnings.empty()) << warnings.front();
    EXPECT_EQ(*copy.rows[0].coatingName, "mgf2");
    EXPECT_EQ(copy.rows.back().coatingName.value_or(""), "hard");
    expectSameLensAndGhostTable(original, copy, "glasses");
}

// A small lens in the shape OpticStudio writes: a cemented doublet, the stop on a dummy surface.
std::string number(double value) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.17g", value);
    return buffer;
}

std::string doublet(const std::string& unit = "MM", double scale = 1.0) {
    auto v = [&](double mm) { return number(mm / scale); };
    auto c = [&](double perMm) { return number(perMm * scale); };
    return "VERS 190513 80 123457 L123457\n"
           "MODE SEQ\n"
           "NAME Test doublet\n"
           "UNIT " + unit + " X W X CM MR CPMM\n"
           "ENPD 20\n"
           "GCAT SCHOTT\n"
           "WAVM 1 0.55 1\n"
           "PWAV 1\n"
           "SURF 0\n"
           "  TYPE STANDARD\n"
           "  CURV 0.0 0 0 0 0 \"\"\n"
           "  DISZ INFINITY\n"
           "SURF 1\n"
           "  TYPE STANDARD\n"
           "  CURV " + c(1.0 / 61.0) + " 0 0 0 0 \"\"\n"
           "  COAT AR\n"
           "  DISZ " + v(6.0) + "\n"
           "  GLAS N-BK7 0 0 1.5168 64.17 0 0 0 0 0 0\n"
           "  DIAM " + v(12.0) + " 1 0 0 1 \"\"\n"
           "SURF 2\n"
           "  TYPE STANDARD\n"
           "  CURV " + c(-1.0 / 45.0) + "\n"
           "  DISZ " + v(2.5) + "\n"
           "  GLAS ___BLANK 1 0 1.7847 26.08 0 0 0 0 0 0\n"
           "  DIAM " + v(12.0) + "\n"
           "SURF 3\n"
           "  TYPE STANDARD\n"
           "  CURV " + c(-1.0 / 130.0) + "\n"
           "  COAT AR\n"
           "  DISZ " + v(4.0) + "\n"
           "  DIAM " + v(12.0) + "\n"
           "  MEMA " + v(13.0) + "\n"
           "SURF 4\n"
           "  STOP\n"
           "  TYPE STANDARD\n"
           "  CURV 0\n"
           "  DISZ " + v(90.0) + "\n"
           "  DIAM " + v(9.0) + "\n"
           "SURF 5\n"
           "  TYPE STANDARD\n"
           "  CURV 0\n"
           "  DISZ 0\n"
           "  DIAM " + v(20.0) + "\n";
}

InputError parseError(const std::string& text) {
    try {
        std::vector<std::string> warnings;
        parseZemaxText(text, "bad.zmx", &warnings);
    } catch (const InputError& e) {
        return e;
    }
    ADD_FAILURE() << "no error for:\n" << text;
    return InputError("", 0, "");
}

// Replaces the first occurrence of `from` in the doublet by `to` and expects an error at `line`.
void expectError(const std::string& from, const std::string& to, int line, const std::string& fragment) {
    std::string text = doublet();
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    const InputError e = parseError(text);
    EXPECT_EQ(e.file(), "bad.zmx");
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_NE(e.problem().find(fragment), std::string::npos) << "replacing '" << from << "': " << e.what();
}

TEST(ZemaxFile, ReadsTheDoubletAsWritten) {
    std::vector<std::string> warnings;
    const LensPrescription p = parseZemaxText(doublet(), "doublet.zmx", &warnings);
    EXPECT_TRUE(warnings.empty());
    EXPECT_EQ(p.name, "Test doublet");
    ASSERT_EQ(p.rows.size(), 4u);
    EXPECT_DOUBLE_EQ(p.rows[0].radiusMm, 61.0);
    EXPECT_EQ(p.rows[0].mediumAfter.describe(), Medium::catalog(*findCatalogGlass("SCHOTT:N-BK7")).describe());
    EXPECT_EQ(p.rows[1].mediumAfter.describe(), Medium::abbe(1.7847, 26.08).describe());
    EXPECT_EQ(*p.rows[0].coatingName, "mgf2");  // AR at a 550 nm primary wavelength
    EXPECT_FALSE(p.rows[1].coatingName.has_value());
    EXPECT_EQ(*p.rows[2].mechSemiDiameterMm, 13.0);
    EXPECT_TRUE(p.rows[3].isStop);
    EXPECT_EQ(p.rows[3].semiApertureMm, 9.0);
    EXPECT_TRUE(std::isinf(p.objectDistanceMm));
    const LensSystem lens = LensSystem::build(p);
    EXPECT_DOUBLE_EQ(lens.sensorZMm(), 6.0 + 2.5 + 4.0 + 90.0);
    EXPECT_EQ(lens.coating(0)->name, "mgf2");
    EXPECT_EQ(lens.coating(1), nullptr);  // cemented
    // UTF-16 with characters beyond ASCII (one beyond the basic plane: a surrogate pair).
    std::string named = doublet();
    named.replace(named.find("Test doublet"), 12, "Objectif \u00e0 \u00bd \u2014 \U0001F4F7");
    EXPECT_EQ(parseZemaxText(encodeUtf16Le(named), "named.zmx").name, "Objectif \u00e0 \u00bd \u2014 \U0001F4F7");
}

TEST(ZemaxFile, LensUnitsBecomeMillimetres) {
    const double efl = paraxialEflMm(LensSystem::build(parseZemaxText(doublet(), "mm.zmx")), LensSystem::build(parseZemaxText(doublet(), "mm.zmx")).indicesAt(kLineDNm));
    for (const auto& [unit, scale] : {std::pair{"CM", 10.0}, {"IN", 25.4}, {"METER", 1000.0}}) {
        const LensPrescription p = parseZemaxText(doublet(unit, scale), "unit.zmx");
        const LensSystem lens = LensSystem::build(p);
        EXPECT_NEAR(paraxialEflMm(lens, lens.indicesAt(kLineDNm)), efl, 1e-6 * efl) << unit;
        EXPECT_NEAR(p.rows[3].semiApertureMm, 9.0, 1e-4) << unit;
    }
    // Aspheric coefficients scale as length^(1 − power): the sag in millimetres is the same.
    std::string mm = doublet(), cm = doublet("CM", 10.0);
    mm.replace(mm.find("  TYPE STANDARD\n  CURV 0.0163"), 15, "  TYPE EVENASPH\n  PARM 2 2e-6\n  PARM 3 -1e-9");
    cm.replace(cm.find("  TYPE STANDARD\n  CURV 0.163"), 15, "  TYPE EVENASPH\n  PARM 2 2e-3\n  PARM 3 -1e-4");
    const LensPrescription pMm = parseZemaxText(mm, "mm.zmx"), pCm = parseZemaxText(cm, "cm.zmx");
    EXPECT_NEAR(pCm.rows[0].asphere[0], pMm.rows[0].asphere[0], 1e-15);
    EXPECT_NEAR(pCm.rows[0].asphere[1], pMm.rows[0].asphere[1], 1e-18);
    // An odd asphere's PARM i is the coefficient of r^i: its even terms are read.
    std::string odd = doublet();
    odd.replace(odd.find("  TYPE STANDARD\n  CURV 0.0163"), 15, "  TYPE ODDASPH\n  PARM 4 2e-6\n  PARM 6 -1e-9\n  PARM 3 0");
    const LensPrescription pOdd = parseZemaxText(odd, "odd.zmx");
    EXPECT_EQ(pOdd.rows[0].asphere[0], 2e-6);
    EXPECT_EQ(pOdd.rows[0].asphere[1], -1e-9);
}

TEST(ZemaxFile, StopOnALensSurfaceBecomesAStopRowBesideIt) {
    std::string text = doublet();
    // Move STOP from the dummy surface to surface 1 (convex: the stop goes in front of it).
    text.erase(text.find("  STOP\n"), 7);
    text.insert(text.find("SURF 1\n") + 7, "  STOP\n");
    const LensPrescription p = parseZemaxText(text, "stop.zmx");
    ASSERT_EQ(p.rows.size(), 5u);
    EXPECT_TRUE(p.rows[0].isStop);
    EXPECT_EQ(p.rows[0].thickness.valueMm, 0.0);
    EXPECT_EQ(p.rows[0].semiApertureMm, 12.0);
    // On surface 3 (concave towards the object): behind it, taking over its thickness.
    text = doublet();
    text.erase(text.find("  STOP\n"), 7);
    text.insert(text.find("SURF 3\n") + 7, "  STOP\n");
    const LensPrescription q = parseZemaxText(text, "stop.zmx");
    ASSERT_EQ(q.rows.size(), 5u);
    EXPECT_TRUE(q.rows[3].isStop);
    EXPECT_EQ(q.rows[2].thickness.valueMm, 0.0);
    EXPECT_EQ(q.rows[3].thickness.valueMm, 4.0);
}

TEST(ZemaxFile, GlassesModelGlassesAndCoatings) {
    std::string text = doublet();
    // A constant index (model glass with Vd 0), a glass named only by the catalogue list.
    text.replace(text.find("___BLANK 1 0 1.7847 26.08"), 25, "___BLANK 1 0 1.7 0");
    text.replace(text.find("GCAT SCHOTT"), 11, "GCAT HOYA");
    text.replace(text.find("N-BK7 0 0"), 9, "FCD1 0 0");
    const LensPrescription p = parseZemaxText(text, "glass.zmx");
    EXPECT_EQ(p.rows[0].mediumAfter.baseGlass(), findCatalogGlass("HOYA:FCD1"));
    EXPECT_EQ(p.rows[1].mediumAfter.kind(), Medium::Kind::Constant);
    EXPECT_EQ(p.rows[1].mediumAfter.nd(), 1.7);
    // AR at another primary wavelength: a quarter wave there.
    text = doublet();
    text.replace(text.find("WAVM 1 0.55 1"), 13, "WAVM 1 0.5875618 1");
    const LensPrescription q = parseZemaxText(text, "ar.zmx");
    ASSERT_EQ(*q.rows[0].coatingName, "AR");
    const std::optional<Coating> ar = q.findCoating("AR");
    ASSERT_TRUE(ar.has_value());
    ASSERT_EQ(ar->layers.size(), 1u);
    EXPECT_DOUBLE_EQ(ar->layers[0].index * ar->layers[0].thicknessNm, 587.5618 / 4.0);
    // An unknown coating: a warning naming the file and line, and the surface uncoated.
    text = doublet();
    text.replace(text.find("COAT AR"), 7, "COAT HEAR1");
    std::vector<std::string> warnings;
    const LensPrescription r = parseZemaxText(text, "coat.zmx", &warnings);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("coat.zmx:16: surface 1, COAT: coating 'HEAR1'"), std::string::npos) << warnings[0];
    EXPECT_NE(warnings[0].find("uncoated"), std::string::npos);
    EXPECT_FALSE(r.rows[0].coatingName.has_value());
    // Unknown keywords are read past with one warning each.
    warnings.clear();
    parseZemaxText(doublet() + "ZZZZ 1\nZZZZ 2\n", "unknown.zmx", &warnings);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("unknown.zmx:44: unknown keyword 'ZZZZ'"), std::string::npos) << warnings[0];
}

TEST(ZemaxFile, ConfigurationsBecomeZoomPositionsInFocalLengthOrder) {
    // The front element's thickness and the distance to the sensor vary (a thickness is a thickness
    // to flare, glass or air); the positions come out sorted by the focal length each configuration
    // has, whatever their order in the file. Configuration 2 is active: DISZ holds its values.
    std::string text = doublet();
    text += "MNUM 2 2\nMOFF 0 1 \"\" 0 0 0 1 1 0 0.0 \"\"\nTHIC 1 1 9 0 0 0 1 1 1 0 0 \"\" 0\nTHIC 1 2 6 0 0 0 1 1 1 0 0 \"\" 0\n"
            "THIC 4 1 89 0 0 0 1 1 1 0 0 \"\" 0\nTHIC 4 2 90 0 0 0 1 1 1 0 0 \"\" 0\nAPER 0 1 20 0\nAPER 0 2 20 0\n";
    const LensPrescription p = parseZemaxText(text, "zoom.zmx");
    ASSERT_EQ(p.zoomPositions.size(), 2u);
    ASSERT_EQ(p.gaps.size(), 2u);
    EXPECT_EQ(p.rows[0].thickness.gapName, "d1");
    EXPECT_EQ(p.rows[3].thickness.gapName, "d4");
    EXPECT_LT(p.zoomPositions[0].focalLengthMm, p.zoomPositions[1].focalLengthMm);
    for (const ZoomPosition& z : p.zoomPositions) {
        const LensSystem lens = LensSystem::build(p, LensState{z.name, {}, {}});
        EXPECT_DOUBLE_EQ(paraxialEflMm(lens, lens.indicesAt(kLineDNm)), z.focalLengthMm);
        EXPECT_DOUBLE_EQ(lens.surface(1).vertexZMm, z.name == "config1" ? 9.0 : 6.0) << z.name;
        EXPECT_DOUBLE_EQ(lens.sensorZMm() - lens.surface(3).vertexZMm, z.name == "config1" ? 89.0 : 90.0) << z.name;
    }
}

TEST(ZemaxFile, UnsupportedKeywordsAndMalformedLinesNameFileLineAndSurface) {
    // Line numbers in the doublet: SURF 1 is line 13, its TYPE 14, CURV 15, COAT 16, DISZ 17,
    // GLAS 18, DIAM 19; SURF 2 is line 20 (its GLAS 24), SURF 4 (the stop) 33, SURF 5 39; the
    // last line is 43.
    expectError("MODE SEQ", "MODE NSC", 2, "MODE: only sequential");
    expectError("UNIT MM", "UNIT FT", 4, "unknown lens unit 'FT'");
    expectError("  TYPE STANDARD\n  CURV 0.0163", "  TYPE COORDBRK\n  CURV 0.0163", 14, "surface 1, TYPE: coordinate breaks");
    expectError("  TYPE STANDARD\n  CURV 0.0163", "  TYPE GRINSUR1\n  CURV 0.0163", 14, "surface 1, TYPE: gradient-index");
    expectError("  TYPE STANDARD\n  CURV 0.0163", "  TYPE TOROIDAL\n  CURV 0.0163", 14, "surface 1, TYPE: surface type TOROIDAL");
    expectError("GLAS N-BK7", "GLAS MIRROR", 18, "surface 1, GLAS: mirrors are not supported");
    expectError("GLAS N-BK7", "GLAS UNOBTAINIUM", 18, "surface 1, GLAS: unknown glass 'UNOBTAINIUM'");
    expectError("GLAS N-BK7 0 0 1.5168 64.17 0 0 0 0 0 0", "GLAS N-BK7 4 0 1.5168 64.17 0 0 0 0 0.001 0.2", 18,
                "surface 1, GLAS: glass offsets");
    expectError("GLAS N-BK7 0", "GLAS N-BK7 7", 18, "surface 1, GLAS: glass status 7");
    expectError("___BLANK 1 0 1.7847 26.08", "___BLANK 1 0 1.7847 2", 24, "surface 2, GLAS: model glass Vd");
    expectError("  COAT AR\n  DISZ 6", "  COAT AR\n  DECX 0.5\n  DISZ 6", 17, "surface 1, DECX: tilts and decentres");
    expectError("  COAT AR\n  DISZ 6", "  COAT AR\n  SCBD 1 0 0.2 0 0\n  DISZ 6", 17, "surface 1, SCBD: tilts and decentres");
    expectError("  COAT AR\n  DISZ 6", "  COAT AR\n  SQAP 5 5\n  DISZ 6", 17, "surface 1, SQAP: this aperture type");
    expectError("  COAT AR\n  DISZ 6", "  COAT AR\n  CLAP 2 10 0\n  DISZ 6", 17, "surface 1, CLAP: an annular aperture");
    expectError("  COAT AR\n  DISZ 6", "  COAT AR\n  OBDC 0 1\n  DISZ 6", 17, "surface 1, OBDC: a decentred aperture");
    expectError("  TYPE STANDARD\n  CURV 0.0163", "  TYPE EVENASPH\n  PARM 1 1e-3\n  CURV 0.0163", 15,
                "surface 1, PARM 1: the r^2 aspheric term");
    expectError("  TYPE STANDARD\n  CURV 0.0163", "  TYPE ODDASPH\n  PARM 3 1e-5\n  CURV 0.0163", 15,
                "surface 1, PARM 3: the r^3 aspheric term");
    expectError("  DISZ 6", "  DISZ INFINITY", 17, "surface 1, DISZ: INFINITY is only allowed on the object");
    expectError("  DISZ 6", "  DISZ -1", 17, "surface 1, DISZ: negative thicknesses");
    expectError("  DISZ 6", "  DISZ six", 17, "surface 1, DISZ: 'six' is not a number");
    expectError("  CURV " + number(1.0 / 61.0) + " 0 0 0 0 \"\"\n", "  CURV\n", 15, "surface 1, CURV is missing");
    expectError("  DIAM 12 1", "  DIAM 0 1", 13, "surface 1, DIAM: the surface needs a positive semi-diameter");
    expectError("SURF 2\n", "SURF 7\n", 20, "SURF 7: expected surface 2");
    expectError("  STOP\n", "", 42, "no surface is marked STOP");
    expectError("  COAT AR\n  DISZ 6", "  STOP\n  COAT AR\n  DISZ 6", 34, "surface 4, STOP: a second aperture stop");
    expectError("  CURV 0.0 0 0 0 0 \"\"\n  DISZ INFINITY", "  CURV 0.0 0 0 0 0 \"\"\n  DISZ INFINITY\n  GLAS N-BK7", 13,
                "surface 0, GLAS: object space must be air");
    expectError("SURF 5\n  TYPE STANDARD\n  CURV 0", "SURF 5\n  TYPE STANDARD\n  CURV 0.01", 41, "surface 5, CURV: a curved image");
    expectError("PWAV 1", "PWAV 3", 8, "PWAV: no wavelength number 3");
    // Configurations: operands flare cannot vary, values missing or out of range, solves.
    const std::string mnum = "MNUM 2 1\n";
    std::string text = doublet() + mnum + "CRVT 1 1 0.01\n";
    EXPECT_EQ(parseError(text).line(), 45);
    EXPECT_NE(parseError(text).problem().find("operand CRVT is not supported"), std::string::npos);
    text = doublet() + mnum + "THIC 3 1 5\n";
    EXPECT_NE(parseError(text).problem().find("THIC: surface 3 has no value for configuration 2"), std::string::npos);
    text = doublet() + mnum + "THIC 3 3 5\n";
    EXPECT_EQ(parseError(text).line(), 45);
    EXPECT_NE(parseError(text).problem().find("configuration 3 is outside 1..2"), std::string::npos);
    text = doublet() + "THIC 3 1 5\n";
    EXPECT_NE(parseError(text).problem().find("THIC: a multi-configuration operand before MNUM"), std::string::npos);
    text = doublet();
    text.insert(text.find("  DIAM 12 1 0"), "  TCOM 1 10\n");
    text += mnum + "THIC 3 1 4\nTHIC 3 2 5\n";
    EXPECT_EQ(parseError(text).line(), 19);
    EXPECT_NE(parseError(text).problem().find("surface 1, TCOM: a thickness solve"), std::string::npos);
    // Geometry the lens checks reject names the row's SURF line.
    expectError("  DIAM 12 1 0 0 1", "  DIAM 70 1 0 0 1", 13, "semi-aperture 70");
    // Too few surfaces.
    const InputError e = parseError("MODE SEQ\nSURF 0\n  DISZ INFINITY\nSURF 1\n  DISZ 0\n");
    EXPECT_EQ(e.line(), 5);
    EXPECT_NE(e.problem().find("at least one lens surface"), std::string::npos);
}

TEST(ZemaxFile, CliReadsAndWritesZmxFiles) {
    const auto dir = test::processTempDir("zemax");
    const std::string zmx = (dir / "DOUBLET.ZMX").string();
    std::ofstream(zmx, std::ios::binary) << encodeUtf16Le(doublet());
    test::CliRun run = test::runCli("lens info " + zmx + " --json");
    EXPECT_EQ(run.exitCode, 0) << run.out;
    EXPECT_NE(run.out.find("\"name\": \"Test doublet\""), std::string::npos) << run.out;

    const std::string exported = (dir / "dg.zmx").string();
    run = test::runCli("lens export double-gauss-50mm -o " + exported + " --utf16");
    ASSERT_EQ(run.exitCode, 0) << run.out;
    expectSameLensAndGhostTable(loadLens("double-gauss-50mm"), loadLensFile(exported), "exported");

    std::string bad = doublet();
    bad.replace(bad.find("GLAS N-BK7"), 10, "GLAS MIRROR");
    const std::string badFile = (dir / "bad.zmx").string();
    std::ofstream(badFile, std::ios::binary) << bad;
    run = test::runCli("lens info " + badFile);
    EXPECT_EQ(run.exitCode, kExitInputError);
    EXPECT_NE(run.out.find(badFile + ":18: surface 1, GLAS: mirrors are not supported"), std::string::npos) << run.out;
    run = test::runCli("lens export double-gauss-50mm -o " + (dir / "dg.txt").string());
    EXPECT_EQ(run.exitCode, kExitInputError);
}

// A UTF-16 file with an odd number of bytes (cut short, or not UTF-16 after all) loaded silently,
// its last byte dropped; now it is refused, naming the file.
TEST(ZemaxFile, Utf16WithAnOddNumberOfBytesIsRefused) {
    const std::string whole = encodeUtf16Le(doublet());
    EXPECT_NO_THROW(parseZemaxText(whole, "whole.zmx"));
    for (const std::string& odd : {whole + "x", whole.substr(0, whole.size() - 1)}) {
        try {
            parseZemaxText(odd, "odd.zmx");
            ADD_FAILURE() << "no InputError";
        } catch (const InputError& e) {
            EXPECT_EQ(e.file(), "odd.zmx");
            EXPECT_NE(e.problem().find("odd number of bytes"), std::string::npos) << e.problem();
        }
    }
    // Big-endian too.
    std::string big = "\xFE\xFF";
    for (const char c : std::string("VERS 1\n")) big += std::string{'\0', c};
    EXPECT_THROW(parseZemaxText(big + "\n", "big.zmx"), InputError);
}

// Random edits of a valid zoom file (lines dropped, repeated or swapped, tokens replaced by
// tokens seen elsewhere or by odd numbers): the reader returns a lens that builds at every position
// or raises InputError, nothing else.
TEST(ZemaxFile, EditedFilesGiveALensOrAnInputError) {
    std::string base = doublet();
    base += "MNUM 2 1\nTHIC 1 1 6\nTHIC 1 2 9\nTHIC 4 1 90\nTHIC 4 2 89\n";
    std::vector<std::string> lines;
    for (size_t start = 0, end; start < base.size(); start = end + 1) {
        end = base.find('\n', start);
        lines.push_back(base.substr(start, end - start));
    }
    const std::vector<std::string> odd = {"0", "-1", "1e308", "nan", "INFINITY", "-INFINITY", "99999", "2.5", "\"\"", "MIRROR"};
    std::mt19937 rng(12345);
    auto pick = [&](size_t n) { return static_cast<size_t>(rng() % n); };
    int parsed = 0;
    for (int trial = 0; trial < 3000; ++trial) {
        std::vector<std::string> edited = lines;
        for (int edit = 0, edits = 1 + static_cast<int>(pick(3)); edit < edits; ++edit) {
            const size_t i = pick(edited.size()), j = pick(edited.size());
            switch (pick(4)) {
                case 0: edited.erase(edited.begin() + i); break;
                case 1: {
                    const std::string repeated = edited[j];  // a copy: the insertion may move the lines
                    edited.insert(edited.begin() + i, repeated);
                    break;
                }
                case 2: std::swap(edited[i], edited[j]); break;
                default: {
                    std::vector<std::string> tokens;
                    std::istringstream in(edited[i]);
                    for (std::string t; in >> t;) tokens.push_back(t);
                    if (tokens.empty()) break;
                    tokens[pick(tokens.size())] = pick(2) ? odd[pick(odd.size())] : lines[pick(lines.size())].substr(0, 4);
                    edited[i].clear();
                    for (const std::string& t : tokens) edited[i] += t + " ";
                }
            }
            if (edited.empty()) edited.push_back("");
        }
        std::string text;
        for (const std::string& l : edited) text += l + "\n";
        try {
            std::vector<std::string> warnings;
            const LensPrescription p = parseZemaxText(pick(2) ? encodeUtf16Le(text) : text, "edited.zmx", &warnings);
            for (const std::string& zoom : zoomStates(p)) LensSystem::build(p, LensState{zoom, {}, {}});
            ++parsed;
        } catch (const InputError& e) {
            EXPECT_EQ(e.file(), "edited.zmx");
        }
    }
    EXPECT_GT(parsed, 100);  // the edits leave many files valid: the reader is not just rejecting
}

TEST(ZemaxFile, ScenesNameZmxLenses) {
    const auto dir = test::processTempDir("zemax-scene");
    std::ofstream(dir / "doublet.zmx", std::ios::binary) << doublet();
    const Scene scene = parseSceneText(
        R"({"lens": "doublet.zmx", "lights": [{"type": "directional", "field_deg": [1, 0]}]})", "scene.json", dir.string());
    const LensSystem lens = buildSceneLens(scene);
    EXPECT_EQ(lens.name(), "Test doublet");
    EXPECT_EQ(lens.surfaceCount(), 4);
}

}  // namespace
}  // namespace flare
