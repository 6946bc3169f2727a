// The guide mask: the live cells of a pupil region grown by one cell, its area, and uniform
// sampling over it (χ² over the cells and within them). Also checks the χ² and normal critical
// values of TestUtil.h that the sampler tests rely on against published tables.
#include <cmath>
#include <set>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/core/Random.h"
#include "flare/ghosts/GuideMask.h"
#include "flare/optics/SequentialTracer.h"
#include "flare/photons/LightSampler.h"
#include "flare/scene/Scene.h"

namespace flare {
namespace {

// Cells of a region named by (i, j), i along a, j along b, in the region's own indices.
using Cell = std::pair<int, int>;

LivePupilRegion makeRegion(double aMinMm, double bMinMm, double cellMm, int cellsA, int cellsB, const std::set<Cell>& live) {
    LivePupilRegion region;
    region.aMinMm = aMinMm;
    region.bMinMm = bMinMm;
    region.cellMm = cellMm;
    region.cellsA = cellsA;
    region.cellsB = cellsB;
    region.live.assign(static_cast<size_t>(cellsA) * cellsB, 0);
    for (const auto& [i, j] : live) region.live[static_cast<size_t>(j) * cellsA + i] = 1;
    return region;
}

// The expected mask, computed independently: every cell within one cell (8-neighbourhood) of a
// live cell, in the region's indices (so it may run from −1 to cellsA or cellsB).
std::set<Cell> grown(const std::set<Cell>& live) {
    std::set<Cell> out;
    for (const auto& [i, j] : live)
        for (int dj = -1; dj <= 1; ++dj)
            for (int di = -1; di <= 1; ++di) out.insert({i + di, j + dj});
    return out;
}

// An L of five cells and a lone cell in a corner of the region (its growth leaves the region).
const std::set<Cell> kLShape = {{1, 1}, {1, 2}, {1, 3}, {2, 3}, {3, 3}, {5, 0}};

// A random pattern on an irregular grid (cell size and corner not binary fractions), as the
// ghost analysis produces.
std::set<Cell> randomPattern(int cellsA, int cellsB) {
    std::set<Cell> live;
    Rng rng(41, 0);
    for (int j = 0; j < cellsB; ++j)
        for (int i = 0; i < cellsA; ++i)
            if (rng.uniform() < 0.15) live.insert({i, j});
    return live;
}

struct Case {
    LivePupilRegion region;
    std::set<Cell> expected;
    std::string name;
};

std::vector<Case> cases() {
    std::vector<Case> out;
    out.push_back({makeRegion(-3.0, 1.5, 0.5, 6, 5, kLShape), grown(kLShape), "L shape"});
    const std::set<Cell> pattern = randomPattern(20, 14);
    out.push_back({makeRegion(-12.3456, 4.0321, 0.3871, 20, 14, pattern), grown(pattern), "random pattern"});
    return out;
}

TEST(GuideMask, HoldsExactlyTheLiveCellsAndTheirEightNeighbours) {
    EXPECT_EQ(grown(kLShape).size(), 30u);  // 21 around the L, 9 around the lone cell
    for (const Case& c : cases()) {
        const GuideMask mask(c.region);
        const LivePupilRegion& r = c.region;
        ASSERT_FALSE(mask.empty()) << c.name;
        EXPECT_EQ(mask.cellCount(), static_cast<int>(c.expected.size())) << c.name;
        EXPECT_EQ(mask.cellMm(), r.cellMm) << c.name;
        // Every cell of a frame two cells wider than the grown region, probed at its centre, near
        // its lower corner and just inside its upper corner (cells are half-open).
        for (int j = -3; j < r.cellsB + 3; ++j)
            for (int i = -3; i < r.cellsA + 3; ++i) {
                const bool inside = c.expected.count({i, j}) > 0;
                for (const double f : {0.5, 1e-9, 1.0 - 1e-9}) {
                    const double a = r.aMinMm + (i + f) * r.cellMm, b = r.bMinMm + (j + f) * r.cellMm;
                    EXPECT_EQ(mask.contains(a, b), inside) << c.name << " cell " << i << ", " << j << " at fraction " << f;
                }
            }
    }
    // Exact cell corners of the binary-fraction grid belong to the cell above and to the right.
    const GuideMask l(makeRegion(-3.0, 1.5, 0.5, 6, 5, kLShape));
    EXPECT_TRUE(l.contains(-3.0, 1.5));     // cell (0, 0)'s corner, shared with three cells outside
    EXPECT_FALSE(l.contains(-1.5, 1.5));    // cell (3, 0) is outside, though (2, 0) to its left is inside
    EXPECT_FALSE(l.contains(-3.5, 1.0));    // cell (−1, −1)
    EXPECT_TRUE(l.contains(-1.0, 1.0));     // cell (4, −1): grown from the lone cell, beyond the region
    EXPECT_TRUE(l.contains(0.4999, 2.0));   // cell (6, 1), the last column ...
    EXPECT_FALSE(l.contains(0.5, 2.0));     // ... whose right edge is outside
}

TEST(GuideMask, AreaIsTheCellCountTimesTheCellArea) {
    for (const Case& c : cases()) {
        const GuideMask mask(c.region);
        EXPECT_DOUBLE_EQ(mask.areaMm2(), c.expected.size() * c.region.cellMm * c.region.cellMm) << c.name;
    }
    EXPECT_EQ(GuideMask(makeRegion(-3.0, 1.5, 0.5, 6, 5, kLShape)).areaMm2(), 7.5);
}

TEST(GuideMask, EmptyRegionsGiveAnEmptyMask) {
    for (const LivePupilRegion& region : {LivePupilRegion{}, makeRegion(-3.0, 1.5, 0.5, 6, 5, {})}) {
        const GuideMask mask(region);
        EXPECT_TRUE(mask.empty());
        EXPECT_EQ(mask.cellCount(), 0);
        EXPECT_EQ(mask.areaMm2(), 0.0);
        EXPECT_FALSE(mask.contains(-2.0, 2.0));
        EXPECT_FALSE(mask.contains(0.0, 0.0));
    }
    EXPECT_TRUE(GuideMask().empty());
    EXPECT_FALSE(GuideMask().contains(0.0, 0.0));
}

TEST(GuideMask, SamplesAreUniformOverTheMaskAndInsideIt) {
    for (const Case& c : cases()) {
        const GuideMask mask(c.region);
        const LivePupilRegion& r = c.region;
        // Index the expected cells; 2000 samples expected in each.
        std::vector<Cell> cells(c.expected.begin(), c.expected.end());
        const long n = 2000L * static_cast<long>(cells.size());
        std::vector<long> perCell(cells.size(), 0), withinCell(16, 0);
        Rng rng(42, cells.size());
        long outside = 0;
        for (long s = 0; s < n; ++s) {
            const glm::dvec2 p = mask.sample(rng.uniform(), rng.uniform(), rng.uniform());
            outside += !mask.contains(p.x, p.y);
            const double x = (p.x - r.aMinMm) / r.cellMm, y = (p.y - r.bMinMm) / r.cellMm;
            const Cell cell{static_cast<int>(std::floor(x)), static_cast<int>(std::floor(y))};
            const auto it = c.expected.find(cell);
            ASSERT_TRUE(it != c.expected.end()) << c.name << ": sample in cell " << cell.first << ", " << cell.second;
            ++perCell[std::distance(c.expected.begin(), it)];
            // Position within the cell, on a 4 × 4 grid pooled over the cells.
            const int fx = std::min(3, static_cast<int>((x - cell.first) * 4)), fy = std::min(3, static_cast<int>((y - cell.second) * 4));
            ++withinCell[fy * 4 + fx];
        }
        EXPECT_EQ(outside, 0) << c.name;
        // χ² against equal expectations, no fitted parameter: k − 1 degrees of freedom, p = 1e-4.
        const std::vector<double> expectedPerCell(cells.size(), 2000.0);
        EXPECT_LT(test::pearsonChiSquared(perCell, expectedPerCell), test::chiSquaredUpperCritical(static_cast<int>(cells.size()) - 1, 1e-4))
            << c.name << ": over the cells";
        const std::vector<double> expectedWithin(16, n / 16.0);
        EXPECT_LT(test::pearsonChiSquared(withinCell, expectedWithin), test::chiSquaredUpperCritical(15, 1e-4))
            << c.name << ": within the cells";

        // Near-extreme uniforms stay in the mask. (Not the exact extremes: sample() and contains()
        // round differently within an ulp of a cell edge. With u = 1 − 2^-53, the largest value
        // Rng::uniform returns, i + u rounds to i + 1 for cell indices i ≥ 1, and with u = 0 on a
        // grid whose corner and cell size are not binary fractions, (a − a0)/cell can round just
        // below the cell's index: the point is then given to a neighbouring cell, possibly outside
        // the mask. Either happens with probability ~1e-15 per draw and biases no estimate, since
        // the sampling density is unchanged almost everywhere; it is only noted here.)
        const int count = mask.cellCount();
        for (int k = 0; k < count; ++k)
            for (const double u : {0x1.0p-40, 0.5, 1.0 - 0x1.0p-40}) {
                const glm::dvec2 p = mask.sample((k + 0.5) / count, u, u);
                EXPECT_TRUE(mask.contains(p.x, p.y)) << c.name << " cell #" << k << " u " << u;
            }
        const glm::dvec2 last = mask.sample(1.0 - 0x1.0p-53, 0.5, 0.5);
        EXPECT_TRUE(mask.contains(last.x, last.y));
    }
}

// A car headlight (a disk 90 mm across, 8 m away) through the 28 mm wide angle: its analysis, and
// probes at three wavelengths at its centre and at four points of its rim.
struct Headlight {
    LensSystem lens;
    GhostReport report;
    std::vector<GuideMask::Probe> probes;
};
Headlight headlight() {
    const Scene scene = parseSceneText(R"({
  "lens": "wide-angle-28mm", "focus_distance_mm": 4000, "f_number": 5.6,
  "lights": [ { "type": "disk", "position_mm": [-900, -350, -8000], "radius_mm": 90, "spectrum": "d65", "power": 5 } ]
})", "headlight.json", "");
    Headlight h{buildSceneLens(scene), {}, {}};
    const LightSampler sampler(scene.lights[0], h.lens);
    h.report = analyseGhosts(h.lens, sampler.grid(), GhostAnalysisOptions{});
    h.probes.push_back({h.report.grid, h.lens.indicesAt(550.0)});
    for (double nm : {410.0, 690.0}) h.probes.push_back({h.report.grid, h.lens.indicesAt(nm)});
    for (double u2 : {0.125, 0.375, 0.625, 0.875})
        for (double nm : {410.0, 550.0, 690.0}) h.probes.push_back({sampler.gridFor(1.0, u2), h.lens.indicesAt(nm)});
    return h;
}

// A traced mask holds every cell, near the analysed region, whose ray from some probe (a
// wavelength, a point of the light) follows the path onto the sensor. The case that called for
// probes: a car headlight (a disk 90 mm across, 8 m away) through the 28 mm wide angle, whose
// ghost off the sensor and the third surface crosses the iris three times; its live region
// (0.6 mm across) moves by four of its cells between 410 and 550 nm. Traced at 550 nm alone, the
// mask missed cells whose rays the unguided tracer then carried, each with the weight of the whole
// entrance: the render's heaviest samples.
TEST(GuideMask, TracedMaskHoldsEveryCellLiveForAnyProbe) {
    const Headlight h = headlight();
    const LensSystem& lens = h.lens;
    const GhostReport& report = h.report;
    const std::vector<GuideMask::Probe>& probes = h.probes;
    const double marginMm = 1.0;
    const double halfW = 0.5 * lens.sensor().widthMm + marginMm, halfH = 0.5 * lens.sensor().heightMm + marginMm;
    int checkedPaths = 0, missedByOneProbe = 0;
    for (const GhostEstimate& e : report.ghosts) {
        if (e.pruned || e.pupil.empty()) continue;
        const GuideMask mask = GuideMask::traced(lens, probes, e.path, e.pupil, 4, marginMm, report.grid.halfSizeMm);
        const GuideMask oneProbe =
            GuideMask::traced(lens, std::span(probes).first(1), e.path, e.pupil, 4, marginMm, report.grid.halfSizeMm);
        ASSERT_FALSE(mask.empty()) << e.path.label();
        SequentialPath sequence;
        sequence.reflections = e.path.reflections;
        const LivePupilRegion& r = e.pupil;
        const int frame = 8;  // cells around the analysed region: two rings of growth
        for (int j = -frame; j < r.cellsB + frame; ++j)
            for (int i = -frame; i < r.cellsA + frame; ++i) {
                const double a = r.aMinMm + (i + 0.5) * r.cellMm, b = r.bMinMm + (j + 0.5) * r.cellMm;
                if (std::max(std::abs(a), std::abs(b)) > report.grid.halfSizeMm - r.cellMm) continue;
                for (const GuideMask::Probe& probe : probes) {
                    const TraceResult t = tracePath(lens, probe.indices, probe.grid.ray(a, b), sequence);
                    if (!t.ok() || std::abs(t.ray.originMm.x) > halfW || std::abs(t.ray.originMm.y) > halfH) continue;
                    EXPECT_TRUE(mask.contains(a, b)) << e.path.label() << " cell " << i << ", " << j;
                    missedByOneProbe += !oneProbe.contains(a, b);
                    break;
                }
            }
        ++checkedPaths;
    }
    EXPECT_GT(checkedPaths, 50);
    // The probes matter: the analysis's rays alone leave such cells out.
    EXPECT_GT(missedByOneProbe, 0);
}

// A traced mask starts one ray per probe at most from each cell, however it reaches the cell: a
// window cell every probe seeded is not traced again when a ring reaches it, and one the first
// probe seeded is traced again with the others only. And the seeds decide only the cost and what
// the window finds, never the cells found live: the mask seeded by every probe holds the mask
// seeded by the first.
TEST(GuideMask, TracedMaskStartsOneRayPerProbeAtMostFromEachCell) {
    const Headlight h = headlight();
    const LensSystem& lens = h.lens;
    const GhostReport& report = h.report;
    const std::vector<GuideMask::Probe>& probes = h.probes;
    int checkedPaths = 0;
    for (const GhostEstimate& e : report.ghosts) {
        if (e.pruned || e.pupil.empty() || e.pupil.liveCount() == 0) continue;
        const GuideMask first = GuideMask::traced(lens, probes, e.path, e.pupil, 4, 1.0, report.grid.halfSizeMm, 1);
        const GuideMask every = GuideMask::traced(lens, probes, e.path, e.pupil, 4, 1.0, report.grid.halfSizeMm, probes.size());
        for (const GuideMask* mask : {&first, &every}) {
            ASSERT_GT(mask->tracedCells(), 0u) << e.path.label();
            EXPECT_LE(mask->tracedRays(), probes.size() * mask->tracedCells())
                << e.path.label() << (mask == &first ? ", seeded by the first probe" : ", seeded by every probe");
            // (Every cell it counts was traced.)
            EXPECT_GE(mask->tracedRays(), mask->tracedCells()) << e.path.label();
        }
        for (int j = 0; j < first.cellsB(); ++j)
            for (int i = 0; i < first.cellsA(); ++i) {
                if (!first.liveCell(i, j)) continue;
                const double a = first.aMinMm() + (i + 0.5) * first.cellMm(), b = first.bMinMm() + (j + 0.5) * first.cellMm();
                EXPECT_TRUE(every.contains(a, b)) << e.path.label() << " cell " << i << ", " << j;
            }
        ++checkedPaths;
    }
    EXPECT_GT(checkedPaths, 50);
}

// The beams' lattice: the analysis's leaves, and the mask's cells they leave out, so that every
// point of the mask lies in exactly one leaf and no point outside the window is added.
TEST(GuideMask, CoveringLatticeCoversTheMaskOnceWithTheOriginalLeaves) {
    PupilLattice lattice;
    lattice.windowMinMm = glm::dvec2(-8.0);
    lattice.windowSizeMm = 16.0;
    lattice.baseCells = 16;  // level 0: 1 mm cells; level 1: 0.5 mm (the region's)
    // Level-1 cells (6..7, 6..7) with (7, 7) split into level 2, one of whose quarters is split again.
    lattice.leaves = {{1, 6, 6}, {1, 7, 6}, {1, 6, 7}, {2, 14, 15}, {2, 15, 14}, {2, 15, 15},
                      {3, 28, 28}, {3, 29, 28}, {3, 28, 29}, {3, 29, 29}};
    // A region at level 1 whose corner is lattice point (5, 5): cells 5..10 × 5..9, an L and a
    // lone cell; grown by one, the mask reaches lattice cells 4..11 (−6 to −2 mm) and beyond.
    const LivePupilRegion region = makeRegion(-8.0 + 5 * 0.5, -8.0 + 5 * 0.5, 0.5, 6, 5, kLShape);
    const GuideMask mask(region);
    const PupilLattice covering = mask.coveringLattice(lattice);
    ASSERT_GE(covering.leaves.size(), lattice.leaves.size());
    for (size_t k = 0; k < lattice.leaves.size(); ++k) {
        EXPECT_EQ(covering.leaves[k].level, lattice.leaves[k].level);
        EXPECT_EQ(covering.leaves[k].i, lattice.leaves[k].i);
        EXPECT_EQ(covering.leaves[k].j, lattice.leaves[k].j);
    }
    auto leavesHolding = [&](const glm::dvec2& p) {
        int n = 0;
        for (const PupilLattice::Leaf& leaf : covering.leaves) {
            const double h = covering.cellMm(leaf.level);
            const double x = (p.x - covering.windowMinMm.x) / h, y = (p.y - covering.windowMinMm.y) / h;
            n += std::floor(x) == static_cast<double>(leaf.i) && std::floor(y) == static_cast<double>(leaf.j);
        }
        return n;
    };
    // On a 1/16-mm grid of cell interiors over the whole window.
    int inMask = 0;
    for (int y = 0; y < 256; ++y)
        for (int x = 0; x < 256; ++x) {
            const glm::dvec2 p(-8.0 + (x + 0.5) / 16.0, -8.0 + (y + 0.5) / 16.0);
            const int n = leavesHolding(p);
            EXPECT_LE(n, 1) << p.x << ", " << p.y;
            if (mask.contains(p.x, p.y)) {
                ++inMask;
                EXPECT_EQ(n, 1) << p.x << ", " << p.y;
            }
        }
    EXPECT_EQ(inMask, static_cast<int>(std::lround(mask.areaMm2() * 256)));
    // A mask off the lattice (its corner between lattice points) leaves the lattice as it is.
    const GuideMask off(makeRegion(-8.0 + 5 * 0.5 + 0.1, -5.5, 0.5, 6, 5, kLShape));
    EXPECT_EQ(off.coveringLattice(lattice).leaves.size(), lattice.leaves.size());
}

// The critical values used by the sampler tests, against published tables (NIST/SEMATECH
// e-Handbook of Statistical Methods, §1.3.6.7.4 (χ²) and §1.3.6.7.1 (normal)).
TEST(GuideMaskTestUtil, CriticalValuesMatchTables) {
    EXPECT_NEAR(test::chiSquaredUpperCritical(1, 0.05), 3.841, 1e-3);
    EXPECT_NEAR(test::chiSquaredUpperCritical(10, 0.05), 18.307, 1e-3);
    EXPECT_NEAR(test::chiSquaredUpperCritical(10, 0.001), 29.588, 1e-3);
    EXPECT_NEAR(test::chiSquaredUpperCritical(100, 0.001), 149.449, 1e-3);
    EXPECT_NEAR(test::chiSquaredLowerCritical(10, 0.05), 3.940, 1e-3);
    EXPECT_NEAR(test::chiSquaredLowerCritical(100, 0.01), 70.065, 1e-3);
    EXPECT_NEAR(test::normalTwoSidedCritical(0.05), 1.960, 1e-3);
    EXPECT_NEAR(test::normalTwoSidedCritical(0.001), 3.291, 1e-3);
    // P(χ²_1 > z²) = P(|Z| > z): the two agree at p = 1e-4 (z = 3.8906).
    EXPECT_NEAR(test::chiSquaredUpperCritical(1, 1e-4), std::pow(test::normalTwoSidedCritical(1e-4), 2), 1e-6);
    EXPECT_NEAR(test::normalTwoSidedCritical(1e-4), 3.8906, 1e-4);
}

}  // namespace
}  // namespace flare
