// The margin model of the pupil mesher against exact answers: a plane is fitted exactly, a
// quadratic's curvature is its second difference, too few margins are not judged, and clipping
// the cell square by half-planes gives the areas of the pieces.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "flare/ghosts/MarginModel.h"

namespace flare {
namespace {

// block[row][column] at (u, v) = (column − 1, row − 1) cells.
template <typename F>
void fill(double block[4][4], F f) {
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) block[y][x] = f(x - 1.0, y - 1.0);
}

TEST(MarginModel, APlaneIsFittedExactly) {
    double block[4][4];
    fill(block, [](double u, double v) { return 0.3 + 0.5 * u - 0.2 * v; });
    const MarginModel m = fitMarginModel(block, 0.25);
    ASSERT_TRUE(m.judged);
    EXPECT_NEAR(m.p0, 0.3, 1e-12);
    EXPECT_NEAR(m.px, 0.5, 1e-12);
    EXPECT_NEAR(m.py, -0.2, 1e-12);
    EXPECT_NEAR(m.allowance, 0.0, 1e-12);
    EXPECT_NEAR(m.curvaturePerMm2, 0.0, 1e-9);
}

TEST(MarginModel, CurvatureIsTheLargestSecondDifferencePerSquareMillimetre) {
    double block[4][4];
    fill(block, [](double u, double v) { return u * u + 0.5 * v; });  // second difference along u: 2
    const double h = 0.5;
    const MarginModel m = fitMarginModel(block, h);
    ASSERT_TRUE(m.judged);
    EXPECT_NEAR(m.curvaturePerMm2, 2.0 / (h * h), 1e-12);
    EXPECT_GT(m.allowance, 0.0);  // the plane misses the parabola at the corners
}

TEST(MarginModel, TooFewOrCollinearMarginsAreNotJudged) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    double block[4][4];
    fill(block, [&](double, double) { return nan; });
    block[1][1] = 1.0, block[1][2] = 2.0;
    EXPECT_FALSE(fitMarginModel(block, 1.0).judged);
    block[1][3] = 3.0;  // three, on one row: collinear
    EXPECT_FALSE(fitMarginModel(block, 1.0).judged);
    block[2][1] = 0.0;
    EXPECT_TRUE(fitMarginModel(block, 1.0).judged);
}

TEST(MarginModel, ClippingTheSquareGivesThePiecesAreas) {
    CellPolygon square;
    square.size = 4;
    square.p[0] = {0.0, 0.0}, square.p[1] = {1.0, 0.0}, square.p[2] = {1.0, 1.0}, square.p[3] = {0.0, 1.0};
    EXPECT_DOUBLE_EQ(polygonArea(square), 1.0);
    EXPECT_NEAR(polygonArea(clipBelow(square, -0.5, 1.0, 0.0)), 0.5, 1e-15);      // u ≤ 0.5
    EXPECT_NEAR(polygonArea(clipBelow(square, -1.0, 1.0, 1.0)), 0.5, 1e-15);      // u + v ≤ 1
    EXPECT_NEAR(polygonArea(clipBelow(square, -0.25, 1.0, 1.0)), 1.0 / 32.0, 1e-15);  // u + v ≤ 0.25
    EXPECT_EQ(clipBelow(square, 1.0, 0.0, 0.0).size, 0);                            // nowhere
    EXPECT_DOUBLE_EQ(polygonArea(clipBelow(clipBelow(square, -0.5, 1.0, 0.0), -0.5, 0.0, 1.0)), 0.25);
}

}  // namespace
}  // namespace flare
