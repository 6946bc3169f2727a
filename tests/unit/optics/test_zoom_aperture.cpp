// A zoom's iris that opens as it zooms (docs/lens-format.md, "Zoom and focus"): the stop row's
// semi-aperture named by an `aperture` line, one value per zoom position, linear between positions
// like the gaps. Parsed, interpolated, refused with file:line when malformed, checked at every
// position by the library's stop check, and carried through a Zemax export (SDIA operands).
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/core/Error.h"
#include "flare/optics/EmbeddedLenses.h"
#include "flare/optics/LensCheck.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/LensSystem.h"
#include "flare/optics/Paraxial.h"
#include "flare/optics/ZemaxFile.h"

namespace flare {
namespace {

// The shipped 24-70 mm zoom (US 7,508,592 Ex. 2): its stop row and the gap before it.
constexpr const char* kStopRow = "   stop        1.65       air               12.82";
constexpr double kFixedStopMm = 12.82;
const char* kPositions[] = {"wide", "mid", "tele"};

std::string zoomText() {
    for (const EmbeddedLens& lens : embeddedLenses())
        if (std::string(lens.name) == "zoom-24-70mm") return std::string(lens.text);
    ADD_FAILURE() << "no embedded zoom-24-70mm";
    return "";
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
    const size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
    return text;
}

// The zoom with its stop row naming `iris` and the line `apertureLine` before the surfaces.
std::string withAperture(const std::string& apertureLine, const std::string& stopColumn = "iris") {
    std::string text = replaced(zoomText(), kStopRow, std::string("   stop        1.65       air               ") + stopColumn);
    return replaced(text, "\nsurfaces\n", "\n" + apertureLine + "\nsurfaces\n");
}

int lineOf(const std::string& text, const std::string& fragment) {
    const size_t at = text.find(fragment);
    EXPECT_NE(at, std::string::npos) << fragment;
    return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

void expectError(const std::string& text, int line, const std::string& fragment) {
    try {
        parseLensText(text, "iris.lens");
        ADD_FAILURE() << "no error; expected: " << fragment;
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), "iris.lens");
        EXPECT_EQ(e.line(), line) << e.what();
        EXPECT_NE(e.problem().find(fragment), std::string::npos) << e.what();
    }
}

TEST(ZoomAperture, EachPositionOpensItsOwnIris) {
    const LensPrescription p = parseLensText(withAperture("aperture iris wide=10.5 mid=12 tele=12.82"), "iris.lens");
    ASSERT_EQ(p.apertures.size(), 1u);
    const int stop = p.stopRow();
    EXPECT_EQ(p.rows[stop].semiApertureName, "iris");
    // The row keeps the widest opening: the iris mount holds it at every position.
    EXPECT_DOUBLE_EQ(p.rows[stop].semiApertureMm, 12.82);
    const LensPrescription fixed = parseLensText(zoomText(), "fixed.lens");
    const double values[] = {10.5, 12.0, 12.82};
    for (int i = 0; i < 3; ++i) {
        const LensSystem lens = LensSystem::build(p, LensState{kPositions[i], {}, {}});
        const LensSystem same = LensSystem::build(fixed, LensState{kPositions[i], {}, {}});
        EXPECT_DOUBLE_EQ(lens.surface(stop).semiApertureMm, values[i]) << kPositions[i];
        EXPECT_DOUBLE_EQ(lens.iris().radiusMm(), values[i]) << kPositions[i];
        // The barrel beside the stop does not move with the iris.
        EXPECT_DOUBLE_EQ(lens.surface(stop).mechSemiDiameterMm, same.surface(stop).mechSemiDiameterMm);
        // Paraxially the entrance pupil scales with the stop: the f-number goes as 1/radius, and
        // nothing else (EFL, sensor) changes.
        const ParaxialData a = analyseParaxial(lens, kLineDNm), b = analyseParaxial(same, kLineDNm);
        EXPECT_NEAR(a.eflMm, b.eflMm, 1e-12 * b.eflMm);
        EXPECT_NEAR(a.fNumber, b.fNumber * kFixedStopMm / values[i], 1e-9 * a.fNumber) << kPositions[i];
        EXPECT_DOUBLE_EQ(lens.sensorZMm(), same.sensorZMm());
    }
}

TEST(ZoomAperture, BetweenPositionsTheIrisRunsLinearlyLikeTheGaps) {
    const LensPrescription p = parseLensText(withAperture("aperture iris wide=10.5 mid=12 tele=12.82"), "iris.lens");
    // 40 mm lies between wide (24.78) and mid (51.92): the weight the EFL solve found is read off
    // gap d6 (47.46 at wide, 9.09 at mid), and the iris must sit at the same weight.
    const LensSystem lens = LensSystem::build(p, LensState{"40", {}, {}});
    EXPECT_NEAR(paraxialEflMm(lens, lens.indicesAt(kLineDNm)), 40.0, 1e-9);
    const double d6 = lens.surface(6).vertexZMm - lens.surface(5).vertexZMm;
    const double t = (d6 - 47.46) / (9.09 - 47.46);
    ASSERT_GT(t, 0.0);
    ASSERT_LT(t, 1.0);
    EXPECT_NEAR(lens.iris().radiusMm(), (1.0 - t) * 10.5 + t * 12.0, 1e-9);
    // Stopping down is relative to this position's opening: f/2.9 wide open there is reachable only
    // if the iris gives it, and the error names the f-number it does give.
    const double wideOpen = analyseParaxial(lens, kLineDNm).fNumber;
    EXPECT_NO_THROW(LensSystem::build(p, LensState{"40", {}, wideOpen * 1.01}));
    try {
        LensSystem::build(p, LensState{"40", {}, wideOpen * 0.99});
        ADD_FAILURE() << "a faster f-number than the position's iris gives was accepted";
    } catch (const InputError& e) {
        char expected[32];
        std::snprintf(expected, sizeof expected, "opens to f/%.4g", wideOpen);
        EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
}

// The library's stop check runs at every position with that position's iris: an iris sized for
// f/2.91 at each position passes everywhere; one too small at tele fails there only.
TEST(ZoomAperture, TheFNumberIsCheckedAtEveryPosition) {
    const LensPrescription fixed = parseLensText(zoomText(), "fixed.lens");
    const LensCheckReport fixedReport = checkLens(fixed);
    ASSERT_EQ(fixedReport.positions.size(), 3u);
    std::string line = "aperture iris";
    double radii[3];
    for (int i = 0; i < 3; ++i) {
        // f-number ∝ 1/radius: the radius that opens to exactly f/2.91, rounded up to 1 µm.
        radii[i] = std::ceil(kFixedStopMm * fixedReport.positions[i].wideOpenFNumber / 2.91 * 1000.0) / 1000.0;
        char buffer[64];
        std::snprintf(buffer, sizeof buffer, " %s=%.3f", kPositions[i], radii[i]);
        line += buffer;
    }
    const LensCheckReport report = checkLens(parseLensText(withAperture(line), "iris.lens"));
    EXPECT_TRUE(report.ok()) << (report.failures.empty() ? "" : report.failures[0].detail);
    ASSERT_EQ(report.positions.size(), 3u);
    for (int i = 0; i < 3; ++i) {
        EXPECT_LE(report.positions[i].wideOpenFNumber, 2.91) << kPositions[i];
        EXPECT_GT(report.positions[i].wideOpenFNumber, 2.91 * (1.0 - 1e-3 / radii[i])) << kPositions[i];
    }
    // The tele iris 5 % too small: f/3.06 > 2.91 + 0.05 there, a stop failure at tele only.
    char smaller[200];
    std::snprintf(smaller, sizeof smaller, "aperture iris wide=%.3f mid=%.3f tele=%.3f", radii[0], radii[1], 0.95 * radii[2]);
    const LensCheckReport broken = checkLens(parseLensText(withAperture(smaller), "iris.lens"));
    ASSERT_EQ(broken.failures.size(), 1u);
    EXPECT_EQ(broken.failures[0].check, "stop");
    EXPECT_EQ(broken.failures[0].zoom, "tele");
}

TEST(ZoomAperture, MistakesNameTheFileAndLine) {
    const std::string ok = "aperture iris wide=10.5 mid=12 tele=12.82";
    auto at = [&](const std::string& line, const std::string& stopColumn = "iris") {
        const std::string text = withAperture(line, stopColumn);
        return std::pair{text, lineOf(text, line)};
    };
    for (const auto& [line, problem] : std::initializer_list<std::pair<std::string, std::string>>{
             {"aperture iris wide=10.5 tele=12.82", "aperture 'iris' has no value for zoom position 'mid'"},
             {"aperture iris wide=10.5 mid=12 tele=12.82 wide=11", "zoom position 'wide' is given twice"},
             {"aperture iris wide=10.5 middle=12 tele=12.82", "unknown zoom position 'middle'"},
             {"aperture iris wide=10.5 mid=0 tele=12.82", "must be positive at 'mid'"},
             {"aperture iris wide=10.5 mid=-1 tele=12.82", "must be positive at 'mid'"},
             {"aperture iris wide=10.5 mid=x tele=12.82", "'x' is not a number"},
             {"aperture 12 wide=10.5 mid=12 tele=12.82", "must begin with a letter"},
             {"aperture iris", "no value for zoom position 'wide'"}}) {
        const auto [text, number] = at(line);
        expectError(text, number, problem);
    }
    {  // before the zoom line
        std::string text = replaced(withAperture(ok), ok + "\n", "");
        text = replaced(text, "zoom            wide=", ok + "\nzoom            wide=");
        expectError(text, lineOf(text, ok), "aperture lines must follow the zoom line");
    }
    {  // defined twice
        const std::string text = withAperture(ok + "\n" + ok);
        expectError(text, lineOf(text, ok) + 1, "aperture 'iris' is defined twice");
    }
    {  // the stop names an aperture nobody defined
        const std::string text = withAperture("", "pupil");
        expectError(text, lineOf(text, "air               pupil"), "unknown aperture 'pupil'");
    }
    {  // an element's clear aperture cannot be named
        std::string text = withAperture(ok);
        text = replaced(text, "   -1292.82    3.05       1.846660/23.78    12.85", "   -1292.82    3.05       1.846660/23.78    iris");
        expectError(text, lineOf(text, "1.846660/23.78    iris"), "only the stop row's semi-aperture may change with zoom");
    }
    {  // defined and not used
        const std::string text = withAperture(ok, "12.82");
        expectError(text, lineOf(text, ok), "aperture 'iris' is defined but the stop row does not use it");
    }
}

// Exported to Zemax, the iris is an SDIA operand of the stop surface per configuration (DIAM holds
// the first position's), and reads back as the same opening at every position.
TEST(ZoomAperture, SurvivesAZemaxExport) {
    const LensPrescription p = parseLensText(withAperture("aperture iris wide=10.5 mid=12 tele=12.82"), "iris.lens");
    const int stopSurface = p.stopRow() + 1;
    const std::string zmx = writeZemax(p);
    for (int c = 1; c <= 3; ++c)
        EXPECT_NE(zmx.find("SDIA " + std::to_string(stopSurface) + " " + std::to_string(c) + " "), std::string::npos) << c;
    std::vector<std::string> warnings;
    const LensPrescription copy = parseZemaxText(zmx, "iris.zmx", &warnings);
    EXPECT_TRUE(warnings.empty()) << (warnings.empty() ? "" : warnings[0]);
    ASSERT_EQ(copy.zoomPositions.size(), 3u);
    ASSERT_EQ(copy.apertures.size(), 1u);
    for (int i = 0; i < 3; ++i) {
        EXPECT_EQ(copy.zoomPositions[i].name, kPositions[i]);
        const LensSystem a = LensSystem::build(p, LensState{kPositions[i], {}, {}});
        const LensSystem b = LensSystem::build(copy, LensState{kPositions[i], {}, {}});
        EXPECT_DOUBLE_EQ(b.iris().radiusMm(), a.iris().radiusMm()) << kPositions[i];
        EXPECT_NEAR(analyseParaxial(b, kLineDNm).fNumber, analyseParaxial(a, kLineDNm).fNumber,
                    1e-9 * analyseParaxial(a, kLineDNm).fNumber);
    }
    // The written file read as a reader without SDIA would: DIAM is the first position's opening.
    const size_t stopAt = zmx.find("SURF " + std::to_string(stopSurface) + "\r\n");
    ASSERT_NE(stopAt, std::string::npos);
    EXPECT_NE(zmx.find("  DIAM 10.5\r\n", stopAt), std::string::npos);
}

TEST(ZoomAperture, ZemaxSdiaOnlyOnTheStop) {
    const LensPrescription p = parseLensText(withAperture("aperture iris wide=10.5 mid=12 tele=12.82"), "iris.lens");
    const std::string zmx = writeZemax(p);
    const int stopSurface = p.stopRow() + 1;
    // Moved to surface 2 (a lens surface): refused, naming the line.
    std::string onLens = zmx;
    const std::string first = "SDIA " + std::to_string(stopSurface) + " 1 ";
    const size_t at = onLens.find(first);
    ASSERT_NE(at, std::string::npos);
    for (int c = 1; c <= 3; ++c) {
        const std::string from = "SDIA " + std::to_string(stopSurface) + " " + std::to_string(c) + " ";
        onLens = replaced(onLens, from, "SDIA 2 " + std::to_string(c) + " ");
    }
    try {
        parseZemaxText(onLens, "bad.zmx");
        ADD_FAILURE() << "SDIA on a lens surface accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.line(), lineOf(onLens, "SDIA 2 1 "));
        EXPECT_NE(e.problem().find("flare varies only the aperture stop's"), std::string::npos) << e.what();
    }
    // A configuration without its value.
    const std::string missing = replaced(zmx, "SDIA " + std::to_string(stopSurface) + " 2 12\r\n", "");
    try {
        parseZemaxText(missing, "bad.zmx");
        ADD_FAILURE() << "SDIA missing a configuration accepted";
    } catch (const InputError& e) {
        EXPECT_NE(e.problem().find("has no value for configuration 2"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace flare
