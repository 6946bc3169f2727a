// The thesis reproduction's lens (docs/thesis.md): the Nikon AI-S Zoom-Nikkor 80-200 mm f/2.8 ED of
// JP S58-54312 A Example 2, entered by hand into the library. Its focal lengths and back focus at
// the three zoom positions against the patent and against an independent paraxial trace, its
// reversibility, its ghost count, and its place in the library (and so in the library stress run).
#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/ghosts/GhostAnalysis.h"
#include "flare/ghosts/Ghosts.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/LensLibrary.h"
#include "flare/optics/Paraxial.h"
#include "flare/optics/PupilGrid.h"
#include "flare/optics/RealRays.h"
#include "flare/optics/SequentialTracer.h"

namespace flare {
namespace {

constexpr const char* kId = "nikon-ai-s-zoom-nikkor-80-200mm-f2.8-ed";
constexpr const char* kFile = "lenses/library/nikon/nikon-ai-s-zoom-nikkor-80-200mm-f2.8-ed.lens";

struct Position {
    const char* name;
    double patentEflMm;       // the patent's focal length at this gap set
    double independentEflMm;  // y-nu trace of the patent's rows with nd (Python, by hand), d line
};
// The independent values come from a separate paraxial trace of the patent's table (the rows as
// printed, the stop a plane in air): they pin the transcription and flare's paraxial code together.
constexpr Position kPositions[] = {
    {"wide", 80.0, 80.00006604},
    {"mid", 140.0, 139.99986112},
    {"tele", 200.0, 199.99986018},
};
constexpr double kPatentBackFocusMm = 40.639;  // the patent's Bf, the same at every position

TEST(ThesisLens, FocalLengthAndBackFocusAtEachZoomPositionMatchThePatent) {
    for (const Position& p : kPositions) {
        const LensSystem lens = test::loadLens(kFile, LensState{p.name, {}, {}});
        const ParaxialData para = analyseParaxial(lens, kLineDNm);
        // The bound: within 0.5 % of the patent's focal length at every position.
        EXPECT_LT(std::abs(para.eflMm / p.patentEflMm - 1.0), 0.005) << p.name;
        // The independent trace used the same nd values: agreement to its printed 8 digits.
        EXPECT_NEAR(para.eflMm, p.independentEflMm, 2e-7 * p.independentEflMm) << p.name;
        // The patent prints Bf to 0.001 mm: the focus solve must land within that rounding.
        EXPECT_NEAR(para.bflMm, kPatentBackFocusMm, 0.0006) << p.name;
        // G1-G3 are afocal, so the stop (fixed to G4) gives f/2.8 at every position; the stop's
        // 20.52 mm radius is the f/2.8 marginal ray's 20.513 mm rounded up.
        EXPECT_NEAR(para.fNumber, 2.8 * 20.513 / 20.52, 2e-3) << p.name;
    }
}

TEST(ThesisLens, ZoomingByFocalLengthReachesEveryPatentPosition) {
    // The zoom solve (TOMS 748 between positions) finds a focal length asked for; at a patent
    // position it must land on that position's EFL, in between on the asked value.
    for (double asked : {80.0001, 100.0, 139.9999, 170.0, 199.9998}) {
        const LensSystem lens = test::loadLens(kFile, LensState{std::to_string(asked), {}, {}});
        EXPECT_NEAR(analyseParaxial(lens, kLineDNm).eflMm, asked, 1e-6 * asked);
    }
}

TEST(ThesisLens, ForwardThenBackwardReturnsToTheStartAtEveryPosition) {
    std::mt19937_64 rng(30);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (const Position& p : kPositions) {
        const LensSystem lens = test::loadLens(kFile, LensState{p.name, {}, {}});
        const double maxFieldRad = 0.5 * analyseParaxial(lens, kLineDNm).paraxialFieldOfViewDeg * std::numbers::pi / 180.0;
        const double stopRadius = lens.iris().radiusMm();
        int tested = 0;
        for (double wavelength : {450.0, 550.0, 650.0}) {
            const SpectralIndices idx = lens.indicesAt(wavelength);
            for (int i = 0; i < 100; ++i) {
                const std::optional<Ray> aimed =
                    aimAtStop(lens, idx, maxFieldRad * u(rng), 0.9 * stopRadius * u(rng), 0.6 * stopRadius * u(rng));
                if (!aimed) continue;
                const TraceResult forward = traceForward(lens, idx, *aimed);
                if (!forward.ok()) continue;
                ++tested;
                const TraceResult backward = traceBackward(lens, idx, Ray{forward.ray.originMm, -forward.ray.direction});
                ASSERT_TRUE(backward.ok()) << p.name << " " << toString(backward.status);
                EXPECT_NEAR(glm::dot(backward.ray.direction, -aimed->direction), 1.0, 1e-12) << p.name;
                const glm::dvec3 v = aimed->originMm - backward.ray.originMm;
                const double offLine = glm::length(v - glm::dot(v, backward.ray.direction) * backward.ray.direction);
                // 27 interfaces and a 200 mm track: a few ulps per surface, far below a nanometre.
                EXPECT_LT(offLine, 1e-8) << p.name;
                EXPECT_NEAR(backward.throughput, forward.throughput, 1e-12) << p.name;
            }
        }
        EXPECT_GT(tested, 100) << p.name;
    }
}

TEST(ThesisLens, GhostCountIsEveryPairOfReflectingSurfaces) {
    // 26 optical surfaces (the stop reflects nothing) and the sensor: 27 choose 2 two-reflection
    // paths, 26 choose 2 without the sensor.
    const LensSystem lens = test::loadLens(kFile, LensState{"mid", {}, {}});
    EXPECT_EQ(enumerateGhosts(lens, 2, true).size(), 351u);
    EXPECT_EQ(enumerateGhosts(lens, 2, false).size(), 325u);
    GhostAnalysisOptions options;
    options.coarseCells = 8;
    options.fineCells = 8;
    const GhostReport report = analyseGhosts(lens, directionFromFieldDeg(5.0, 0.0), options);
    // Every enumerated path is estimated and kept in the table; the weakest are flagged pruned.
    EXPECT_EQ(report.ghosts.size(), 351u);
    EXPECT_EQ(std::count_if(report.ghosts.begin(), report.ghosts.end(), [](const GhostEstimate& g) { return g.pruned; }),
              report.prunedCount);
    EXPECT_LT(report.prunedCount, 351);
    EXPECT_GT(report.direct.powerFraction, 0.0);
    for (const GhostEstimate& g : report.ghosts) EXPECT_TRUE(std::isfinite(g.powerFraction) && g.powerFraction >= 0.0);
}

TEST(ThesisLens, IsInTheLibraryWithItsPositionsAndTheThesisTag) {
    // The library stress run (tests/stress/test_library_stress.cpp) checks every library lens, and
    // always the ones tagged "thesis", even when FLARE_LIBRARY_LENSES samples the library.
    const LensLibrary library = LensLibrary::load({test::sourcePath("lenses/library")});
    const LibraryLens* entry = library.find(kId);
    ASSERT_NE(entry, nullptr);
    EXPECT_EQ(entry->path, test::sourcePath(kFile));
    EXPECT_EQ(entry->zoomPositions, (std::vector<std::string>{"wide", "mid", "tele"}));
    EXPECT_EQ(entry->zoomFocalLengthsMm, (std::vector<double>{80.0, 140.0, 200.0}));
    EXPECT_NE(std::find(entry->tags.begin(), entry->tags.end(), "thesis"), entry->tags.end());
}

}  // namespace
}  // namespace flare
