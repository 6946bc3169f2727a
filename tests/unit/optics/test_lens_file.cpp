// Lens file parsing: every shipped lens loads, the pbrt importer, and every bad-input case gives
// one clear error naming the file and line.
#include <string>

#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/core/Error.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/PbrtLensFile.h"

namespace flare {
namespace {

const char* kHeader = "name test lens\nfocal_length_mm 50\n";

// Parses `body` after a valid header and returns the error (fails the test if none is raised).
InputError parseError(const std::string& text) {
    try {
        parseLensText(text, "bad.lens");
    } catch (const InputError& e) {
        return e;
    }
    ADD_FAILURE() << "no error for:\n" << text;
    return InputError("", 0, "");
}

void expectError(const std::string& text, int line, const std::string& fragment) {
    const InputError e = parseError(text);
    EXPECT_EQ(e.file(), "bad.lens");
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_NE(e.problem().find(fragment), std::string::npos) << "message: " << e.what();
}

std::string lens(const std::string& rows) { return std::string(kHeader) + "surfaces\n" + rows; }

TEST(LensFile, ShippedLensesLoadWithSourcesAndCoatings) {
    for (const char* file : test::kShippedLenses) {
        const LensPrescription p = loadLensFile(test::sourcePath(file));
        EXPECT_FALSE(p.name.empty()) << file;
        EXPECT_FALSE(p.source.empty()) << file;
        EXPECT_GE(p.stopRow(), 0) << file;
        EXPECT_NE(p.defaultCoating, "") << file;
    }
}

TEST(LensFile, ShippedLensesAreEmbeddedAndLoadByName) {
    for (const char* file : test::kShippedLenses) {
        std::string name = std::string(file).substr(std::string("lenses/").size());
        name.resize(name.size() - 5);
        const LensPrescription embedded = loadLens(name);
        const LensPrescription onDisk = loadLensFile(test::sourcePath(file));
        EXPECT_EQ(embedded.name, onDisk.name);
        ASSERT_EQ(embedded.rows.size(), onDisk.rows.size()) << name;
        for (size_t i = 0; i < onDisk.rows.size(); ++i)
            EXPECT_EQ(embedded.rows[i].radiusMm, onDisk.rows[i].radiusMm) << name << " row " << i;
    }
    EXPECT_THROW(loadLens("no-such-lens"), InputError);
}

TEST(LensFile, WellFormedRowsWithOptions) {
    const LensPrescription p = parseLensText(std::string(kHeader) + R"(
iris blades=7 rotation_deg=10 curvature=0.3
coating ar2 stack 1.38:99.6 2.05:67.1
default_coating ar2
surfaces
  40   5    N-BK7   10  k=-0.5 A4=1e-5 A6=-2e-8
  -80  2    air     10  coating=mgf2 mech=11
  stop 2    air     8
  50   4    1.62/36 9
  -70  auto air     9   coating=none
)", "good.lens");
    ASSERT_EQ(p.rows.size(), 5u);
    EXPECT_EQ(p.rows[0].conic, -0.5);
    EXPECT_EQ(p.rows[0].asphere[0], 1e-5);
    EXPECT_EQ(p.rows[0].asphere[1], -2e-8);
    EXPECT_EQ(*p.rows[1].coatingName, "mgf2");
    EXPECT_EQ(*p.rows[1].mechSemiDiameterMm, 11.0);
    EXPECT_EQ(p.iris.blades, 7);
    const LensSystem system = LensSystem::build(p);
    ASSERT_NE(system.coating(0), nullptr);
    EXPECT_EQ(system.coating(0)->name, "ar2");
    EXPECT_EQ(system.coating(1)->name, "mgf2");
    EXPECT_EQ(system.coating(2), nullptr);  // the stop
    EXPECT_EQ(system.coating(3)->name, "ar2");
    EXPECT_EQ(system.coating(4), nullptr);  // explicitly uncoated
    EXPECT_EQ(system.surface(1).mechSemiDiameterMm, 11.0);
}

TEST(LensFile, PbrtImporterReadsDiametersAndConstantIndices) {
    const LensPrescription p = loadLensFile(test::sourcePath("tests/data/dgauss.50mm.dat"));
    ASSERT_EQ(p.rows.size(), 11u);
    EXPECT_EQ(p.stopRow(), 5);
    EXPECT_DOUBLE_EQ(p.rows[0].semiApertureMm, 12.6);
    EXPECT_DOUBLE_EQ(p.rows[0].mediumAfter.indexAt(400.0), 1.67);
    EXPECT_TRUE(p.rows[1].mediumAfter.isAir());
}

// Glasses beyond the built-in table come from the shipped vendor catalogues (lenses/glass).
TEST(LensFile, GlassesFromTheShippedCatalogues) {
    const LensPrescription p = parseLensText(lens("40 5 J-LASF016 10\n-200 2 air 10\nstop 2 air 8\n-60 3 HOYA:FCD1 10\n-80 auto air 10\n"),
                                             "good.lens");
    EXPECT_EQ(p.rows[0].mediumAfter.describe(), "J-LASF016 (NIKON-HIKARI)");
    EXPECT_EQ(p.rows[3].mediumAfter.describe(), "FCD1 (HOYA)");
    EXPECT_NEAR(p.rows[3].mediumAfter.nd(), 1.49700, 1e-5);
    expectError(lens("40 5 HWS1 10\nstop 2 air 8\n-60 auto air 10\n"), 4, "not made for the visible");
}

TEST(LensFileErrors, NonNumericField) { expectError(lens("40 5x N-BK7 10\nstop 2 air 8\n-60 auto air 10\n"), 4, "not a number"); }

TEST(LensFileErrors, UnknownGlass) { expectError(lens("40 5 UNOBTAINIUM 10\nstop 2 air 8\n-60 auto air 10\n"), 4, "unknown glass"); }

TEST(LensFileErrors, MissingStop) {
    const InputError e = parseError(lens("40 5 N-BK7 10\n-60 auto air 10\n"));
    EXPECT_NE(e.problem().find("stop"), std::string::npos) << e.what();
}

TEST(LensFileErrors, SemiApertureLargerThanRadius) {
    expectError(lens("8 5 N-BK7 10\nstop 2 air 8\n-60 auto air 10\n"), 4, "larger than |radius|");
}

TEST(LensFileErrors, IntersectingElements) {
    // A strongly curved back surface bulges through the front one: negative edge thickness.
    expectError(lens("15 2 N-BK7 10\n-15 5 air 10\nstop 2 air 8\n-60 auto air 10\n"), 5,
                "element edge thickness");
}

TEST(LensFileErrors, NegativeAirSpaceEdgeThickness) {
    // The first element's rear surface curves back towards +z while the next element's front
    // curves towards −z: across a 0.5 mm vertex gap they cross well inside the aperture.
    expectError(lens("40 5 N-BK7 10\n20 0.5 air 10\n-20 4 N-BK7 10\n-30 3 air 10\nstop 3 air 8\n-60 auto air 10\n"),
                6, "air space edge thickness");
}

TEST(LensFileErrors, SurfaceCrossingTheIrisBlades) {
    // The blades (the stop plane) reach out to the barrel, not only to the stop's clear radius:
    // this bowl lies in front of the stop plane from r ≈ 6.3 mm on, inside its 9.9 mm edge.
    expectError(lens("stop 2 air 5\n-10 4 N-BK7 9.9\n40 30 air 9.9\n"), 5, "air space edge thickness");
}

TEST(LensFileErrors, UnknownVariableGap) {
    expectError(std::string(kHeader) + "zoom wide=20 tele=40\ngap D1 wide=1 tele=2\nsurfaces\n"
                "40 5 N-BK7 10\n-60 D1 air 10\nstop D9 air 8\n50 3 N-BK7 9\n-80 auto air 9\n",
                8, "unknown variable gap 'D9'");
}

TEST(LensFileErrors, GapMissingAZoomPosition) {
    expectError(std::string(kHeader) + "zoom wide=20 mid=30 tele=40\ngap D1 wide=1 tele=2\nsurfaces\n"
                "40 5 N-BK7 10\n-60 D1 air 10\nstop 2 air 8\n-80 auto air 9\n",
                4, "no value for zoom position 'mid'");
}

TEST(LensFileErrors, WrongColumnCount) {
    expectError(lens("40 5 N-BK7\nstop 2 air 8\n-60 auto air 10\n"), 4, "expected 4 columns");
    expectError(lens("40 5 N-BK7 10 11\nstop 2 air 8\n-60 auto air 10\n"), 4, "expected 4 columns");
}

TEST(LensFileErrors, OtherMistakes) {
    expectError(lens("40 5 N-BK7 10 q=3\nstop 2 air 8\n-60 auto air 10\n"), 4, "unknown surface option");
    expectError(lens("40 auto N-BK7 10\nstop 2 air 8\n-60 3 air 10\n"), 4, "only allowed on the last row");
    expectError(lens("40 5 N-BK7 10\nstop 2 air 8\nstop 2 air 8\n-60 auto air 10\n"), 6, "second aperture stop");
    expectError(lens("40 -5 N-BK7 10\nstop 2 air 8\n-60 auto air 10\n"), 4, "must not be negative");
    expectError(lens("40 5 N-BK7 10 coating=gold\nstop 2 air 8\n-60 auto air 10\n"), 4, "unknown coating");
    expectError(lens("40 5 1.5/abc 10\nstop 2 air 8\n-60 auto air 10\n"), 4, "not a number");
    expectError(std::string(kHeader) + "bogus 3\nsurfaces\n", 3, "unknown header keyword");
    expectError(std::string(kHeader) + "coating c stack 0.9:100\nsurfaces\n", 3, "at least 1");
    expectError(std::string(kHeader) + "iris blades=2\nsurfaces\n", 3, "iris blades");
    const InputError noTable = parseError(std::string(kHeader));
    EXPECT_NE(noTable.problem().find("surfaces"), std::string::npos);
}

TEST(LensFileErrors, PbrtColumnCount) {
    try {
        parsePbrtLensText("# comment\n29.475 3.76 1.67 25.2\n84.83 0.12 1\n", "bad.dat");
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_EQ(e.line(), 3);
        EXPECT_NE(e.problem().find("expected 4 columns"), std::string::npos);
    }
}

TEST(LensFileErrors, MissingFile) {
    try {
        loadLensFile("/nonexistent/lens.lens");
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), "/nonexistent/lens.lens");
        EXPECT_NE(e.problem().find("cannot open"), std::string::npos);
    }
}

}  // namespace
}  // namespace flare
