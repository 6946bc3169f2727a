// MajorantGrid: its cell maxima bound every lookup (shipped grids, a rotated grid, rays through
// the DDA), the walk cuts a ray into contiguous pieces covering exactly its part inside the box,
// sparse grids get mostly empty cells, and delta and ratio tracking through it reproduce
// Beer–Lambert through a constant grid and through a grid with a step in density.
#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/core/Random.h"
#include "flare/photons/MajorantGrid.h"
#include "flare/photons/VolumeGrid.h"
#include "flare/photons/VolumeMake.h"

namespace flare {
namespace {

const char* const kShippedGrids[] = {"volumes/haze.vdb", "volumes/striae.vdb", "volumes/bubbles.vdb",
                                     "volumes/inclusions.vdb"};

glm::dvec3 randomPoint(Rng& rng, const glm::dvec3& lo, const glm::dvec3& hi) {
    return {lo.x + (hi.x - lo.x) * rng.uniform(), lo.y + (hi.y - lo.y) * rng.uniform(), lo.z + (hi.z - lo.z) * rng.uniform()};
}

glm::dvec3 randomDirection(Rng& rng) {
    const double z = 2.0 * rng.uniform() - 1.0, phi = 2.0 * std::numbers::pi * rng.uniform(), r = std::sqrt(1.0 - z * z);
    return {r * std::cos(phi), r * std::sin(phi), z};
}

// Every density along random rays lies under its segment's maximum, and the segments tile the
// ray's part inside the box without gaps or overlaps. Lookups at voxel faces (where rounding
// decides the voxel) come from points snapped to the voxel lattice.
void expectBoundsAlongRays(const VolumeGrid& grid, const std::string& what) {
    const MajorantGrid majorants(grid);
    ASSERT_FALSE(majorants.empty()) << what;
    EXPECT_EQ(majorants.maxValue(), grid.maxValue()) << what;
    VolumeGrid::Sampler s = grid.sampler();
    const glm::dvec3 lo = grid.boundsMinMm(), hi = grid.boundsMaxMm(), margin = 0.1 * (hi - lo);
    Rng rng(17, 0);
    for (int ray = 0; ray < 2000; ++ray) {
        const glm::dvec3 origin = randomPoint(rng, lo - margin, hi + margin), direction = randomDirection(rng);
        const double tEnd = 2.0 * glm::length(hi - lo);
        MajorantGrid::Walk walk(majorants, origin, direction, tEnd);
        double previousEnd = -1.0, covered = 0.0;
        const double inBox = walk.lengthInBoxMm();
        MajorantGrid::Segment seg;
        while (walk.next(seg)) {
            if (previousEnd >= 0.0) ASSERT_EQ(seg.t0Mm, previousEnd) << what;
            ASSERT_LE(seg.t0Mm, seg.t1Mm) << what;
            previousEnd = seg.t1Mm;
            covered += seg.t1Mm - seg.t0Mm;
            for (int k = 0; k < 4; ++k) {
                const double t = seg.t0Mm + (seg.t1Mm - seg.t0Mm) * (k < 2 ? k : rng.uniform());
                ASSERT_LE(s.densityAt(origin + t * direction), seg.maximum) << what << " ray " << ray << " t " << t;
            }
        }
        ASSERT_NEAR(covered, inBox, 1e-9 * tEnd) << what;
    }
    // Points on voxel faces and corners, where a lookup may round either way.
    const double v = grid.voxelSizeMm();
    for (int n = 0; n < 20000; ++n) {
        const glm::dvec3 p = randomPoint(rng, lo, hi);
        const glm::dvec3 onFace = lo + glm::round((p - lo) / (0.5 * v)) * (0.5 * v);
        ASSERT_LE(s.densityAt(onFace), majorants.majorantAt(onFace)) << what;
        ASSERT_LE(s.densityAt(p), majorants.majorantAt(p)) << what;
    }
}

TEST(MajorantGrid, CellMaximaBoundEveryLookupInTheShippedGrids) {
    for (const char* file : kShippedGrids) expectBoundsAlongRays(VolumeGrid::load(test::sourcePath(file)), file);
}

TEST(MajorantGrid, CellMaximaBoundEveryLookupInAConstantBoxOfPartialVoxels) {
    // The last voxel row overhangs the box; lookups are clipped to it.
    expectBoundsAlongRays(VolumeGrid::constant(2.0, {-1.3, -0.7, 0.0}, {2.1, 0.9, 1.05}, 0.2), "constant");
}

TEST(MajorantGrid, CellMaximaBoundEveryLookupInAMadeGrid) {
    VolumeMakeOptions o;
    o.kind = VolumeMakeOptions::Kind::Inclusions;
    o.radiusMm = 3.0, o.thicknessMm = 1.5, o.voxelMm = 0.05, o.count = 5, o.featureMm = 0.15, o.density = 40.0;
    expectBoundsAlongRays(makeVolume(o), "inclusions");
}

TEST(MajorantGrid, SparseGridsHaveMostlyEmptyCells) {
    // bubbles.vdb: 1567 active voxels of ~3·10⁶ in its box. The cells a proposal can land in are
    // the non-empty ones; their share of the box is what the global majorant wasted.
    const VolumeGrid grid = VolumeGrid::load(test::sourcePath("volumes/bubbles.vdb"));
    const MajorantGrid majorants(grid);
    const glm::ivec3 n = majorants.cellCounts();
    long nonEmpty = 0, total = 0;
    for (int z = 0; z < n.z; ++z)
        for (int y = 0; y < n.y; ++y)
            for (int x = 0; x < n.x; ++x) {
                const glm::dvec3 centre = grid.boundsMinMm() + (glm::dvec3(x, y, z) + 0.5) * majorants.cellSizeMm();
                nonEmpty += majorants.majorantAt(centre) > 0.0;
                ++total;
            }
    EXPECT_LT(nonEmpty, total / 20) << nonEmpty << " of " << total;
}

TEST(MajorantGrid, EmptyGridWalksNothingAndTracksNothing) {
    const MajorantGrid none;
    MajorantGrid::Walk walk(none, {0, 0, 0}, {0, 0, 1}, 10.0);
    MajorantGrid::Segment seg;
    EXPECT_FALSE(walk.next(seg));
    VolumeGrid::Sampler s;
    Rng rng(1, 0);
    int nulls = 0;
    EXPECT_TRUE(std::isinf(sampleFreeFlight(none, s, 1.0, {0, 0, 0}, {0, 0, 1}, 10.0, rng, nulls)));
    EXPECT_EQ(ratioTrackingTransmittance(none, s, 1.0, {0, 0, 0}, {0, 0, 1}, 10.0, rng), 1.0);
}

// A 4 × 4 × 5 mm block of 0.5 mm voxels: densityFront for z < 2.5 mm, densityBack behind.
VolumeGrid stepGrid(double densityFront, double densityBack) {
    VolumeGrid::Builder b("density", 0.5, {-2.0, -2.0, 0.0});
    for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 8; ++j)
            for (int k = 0; k < 10; ++k) b.set(i, j, k, k < 5 ? densityFront : densityBack);
    return b.build();
}

// Delta tracking's collision distances follow the CDF 1 − T(t), T(t) = exp(−∫₀ᵗ σt density):
// a χ² test over distance bins between tIn and tEnd (where the ray crosses the medium; there
// can be no collision before tIn) plus one bin for no collision at all, the transmittance; and
// ratio tracking's mean is T(tEnd) within its standard error.
void expectBeerLambert(const VolumeGrid& grid, double sigmaT, const glm::dvec3& origin, const glm::dvec3& direction,
                       double tIn, double tEnd, const std::function<double(double)>& opticalDepth, const char* what) {
    const MajorantGrid majorants(grid);
    VolumeGrid::Sampler s = grid.sampler();
    constexpr int kBins = 24;
    constexpr long kSamples = 200000;
    std::vector<long> observed(kBins + 1, 0);
    Rng rng(23, 0);
    int nulls = 0;
    for (long i = 0; i < kSamples; ++i) {
        const double t = sampleFreeFlight(majorants, s, sigmaT, origin, direction, tEnd, rng, nulls);
        ASSERT_GE(t, tIn) << what;
        observed[t < tEnd ? std::min(kBins - 1, static_cast<int>((t - tIn) / (tEnd - tIn) * kBins)) : kBins]++;
    }
    std::vector<double> expected(kBins + 1);
    auto binStart = [&](int b) { return tIn + (tEnd - tIn) * b / kBins; };
    for (int b = 0; b < kBins; ++b)
        expected[b] = kSamples * (std::exp(-opticalDepth(binStart(b))) - std::exp(-opticalDepth(binStart(b + 1))));
    expected[kBins] = kSamples * std::exp(-opticalDepth(tEnd));
    EXPECT_LT(test::pearsonChiSquared(observed, expected), test::chiSquaredUpperCritical(kBins, 1e-4)) << what;

    double sum = 0.0, sumSquares = 0.0;
    for (long i = 0; i < kSamples; ++i) {
        const double T = ratioTrackingTransmittance(majorants, s, sigmaT, origin, direction, tEnd, rng);
        sum += T, sumSquares += T * T;
    }
    const double mean = sum / kSamples, se = std::sqrt(std::max(0.0, sumSquares / kSamples - mean * mean) / kSamples);
    EXPECT_NEAR(mean, std::exp(-opticalDepth(tEnd)), test::normalTwoSidedCritical(1e-4) * se) << what;
}

TEST(MajorantGrid, DeltaAndRatioTrackingFollowBeerLambertThroughAConstantGrid) {
    const VolumeGrid grid = VolumeGrid::constant(1.5, {-2.0, -2.0, 0.0}, {2.0, 2.0, 5.0}, 0.5);
    const double sigmaT = 0.15;
    const glm::dvec3 direction = glm::normalize(glm::dvec3(0.3, -0.2, 1.0));
    const glm::dvec3 origin(-1.0, 1.0, -1.0);
    const double tIn = 1.0 / direction.z, tEnd = 6.0 / direction.z;  // from z = −1 to z = 5: the block's back face
    // Inside the block (z in [0, 5]) the density is 1.5; the ray stays inside its x and y range.
    auto depth = [&](double t) {
        const double z = std::clamp(origin.z + t * direction.z, 0.0, 5.0);
        return sigmaT * 1.5 * z / direction.z;
    };
    expectBeerLambert(grid, sigmaT, origin, direction, tIn, tEnd, depth, "constant");
}

TEST(MajorantGrid, DeltaAndRatioTrackingFollowBeerLambertThroughAStep) {
    // Transmittance exp(−σ1 d1 − σ2 d2); the step lies inside a coarse cell (2 mm cells), so
    // proposals there meet both densities under one maximum.
    const double front = 1.0, back = 3.0, sigmaT = 0.1;
    const VolumeGrid grid = stepGrid(front, back);
    const glm::dvec3 direction = glm::normalize(glm::dvec3(0.3, -0.2, 1.0));
    const glm::dvec3 origin(-1.0, 1.0, -1.0);
    const double tIn = 1.0 / direction.z, tEnd = 6.0 / direction.z;
    auto depth = [&](double t) {
        const double z = std::clamp(origin.z + t * direction.z, 0.0, 5.0);
        return sigmaT * (front * std::min(z, 2.5) + back * std::max(z - 2.5, 0.0)) / direction.z;
    };
    expectBeerLambert(grid, sigmaT, origin, direction, tIn, tEnd, depth, "step");
}

}  // namespace
}  // namespace flare
