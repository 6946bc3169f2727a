// The split of a distributed pass's bands among the ranks (BandSplit.h): the bands' pixel counts
// under beam footprints against a count pixel by pixel, and the balanced split against the costs
// it is given: every split is a partition in row order, rank 0's phase leads the others' by
// kRootBandLead of the mean within a band's cost, and footprints in one part of the frame draw
// the boundaries there.
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "flare/render/BandSplit.h"

namespace flare {
namespace {

using renderer::PixelBox;

void expectPartition(const std::vector<int>& start, int bands, int ranks) {
    ASSERT_EQ(start.size(), static_cast<size_t>(ranks) + 1);
    EXPECT_EQ(start.front(), 0);
    EXPECT_EQ(start.back(), bands);
    for (int r = 0; r < ranks; ++r) EXPECT_LE(start[r], start[r + 1]) << r;
}

TEST(BandSplit, BandPixelsCountEveryPixelUnderTheBoxesOnce) {
    constexpr int kWidth = 97, kHeight = 203, kBandRows = 32;
    std::mt19937 random(7);
    std::uniform_int_distribution<int> x(-20, kWidth + 20), y(-20, kHeight + 20);
    std::vector<PixelBox> boxes;
    for (int k = 0; k < 60; ++k) {
        int x0 = x(random), x1 = x(random), y0 = y(random), y1 = y(random);
        if (k % 5 != 0) x0 = std::clamp(x0, 0, kWidth), x1 = std::clamp(x1, 0, kWidth);
        if (x0 > x1 && k % 7 != 0) std::swap(x0, x1);  // (a few empty or reversed boxes)
        if (y0 > y1 && k % 7 != 0) std::swap(y0, y1);
        boxes.push_back({x0, y0, x1, y1});
    }
    std::vector<double> expected((kHeight + kBandRows - 1) / kBandRows, 0.0);
    for (const PixelBox& b : boxes)
        for (int py = std::max(0, b.y0); py < std::min(kHeight, b.y1); ++py)
            if (b.x1 > b.x0) expected[py / kBandRows] += b.x1 - b.x0;
    EXPECT_EQ(renderer::bandPixels(boxes, kHeight, kBandRows), expected);
    EXPECT_TRUE(renderer::bandPixels({}, 0, kBandRows).empty());
}

TEST(BandSplit, ABalancedSplitGivesRankZeroItsLead) {
    std::mt19937 random(11);
    std::uniform_real_distribution<double> cost(0.0, 1.0);
    for (const int ranks : {2, 3, 5}) {
        constexpr int kBands = 400;
        std::vector<double> bandCost(kBands), besides(ranks);
        for (double& c : bandCost) c = 0.01 * cost(random);
        for (double& b : besides) b = 0.2 * cost(random);
        const std::vector<int> start = renderer::balancedBands(bandCost, besides);
        expectPartition(start, kBands, ranks);
        const double total = std::accumulate(bandCost.begin(), bandCost.end(), 0.0);
        const double mean = (total + std::accumulate(besides.begin(), besides.end(), 0.0)) / ranks;
        // Each rank's phase: its besides and its bands; each boundary lies within half a band's
        // cost of its target, so a phase within one band's cost of its plan.
        const double largestBand = *std::max_element(bandCost.begin(), bandCost.end());
        for (int r = 0; r < ranks; ++r) {
            const double phase =
                besides[r] + std::accumulate(bandCost.begin() + start[r], bandCost.begin() + start[r + 1], 0.0);
            const double planned = mean + (r == 0 ? renderer::kRootBandLead * mean
                                                  : -renderer::kRootBandLead * mean / (ranks - 1));
            EXPECT_NEAR(phase, planned, largestBand) << ranks << " ranks, rank " << r;
        }
    }
}

TEST(BandSplit, FootprintsInTheLowerRowsDrawTheBoundaryThere) {
    // 1080 rows, 34 bands; every ghost in the lowest quarter: by rows rank 0 would own half the
    // bands and nothing to rasterise. Balanced on the pixels, the boundary falls in that quarter,
    // where rank 0 gets kRootBandLead more than half of the pixels.
    constexpr int kWidth = 1920, kHeight = 1080, kBandRows = 32;
    std::vector<PixelBox> boxes;
    for (int k = 0; k < 50; ++k) boxes.push_back({100 + k, 820 + k, 900 + 10 * k, 1070});
    const std::vector<double> pixels = renderer::bandPixels(boxes, kHeight, kBandRows);
    const std::vector<int> start = renderer::balancedBands(pixels, std::vector<double>(2, 0.0));
    expectPartition(start, 34, 2);
    EXPECT_GT(start[1], 820 / kBandRows);
    const double total = std::accumulate(pixels.begin(), pixels.end(), 0.0);
    const double rankZero = std::accumulate(pixels.begin(), pixels.begin() + start[1], 0.0);
    const double largestBand = *std::max_element(pixels.begin(), pixels.end());
    EXPECT_NEAR(rankZero, 0.5 * (1.0 + renderer::kRootBandLead) * total, 0.5 * largestBand);
    // No cost at all: by rows.
    EXPECT_EQ(renderer::balancedBands(std::vector<double>(34, 0.0), std::vector<double>(2, 0.0)),
              renderer::bandsByRows(34, 2));
}

}  // namespace
}  // namespace flare
