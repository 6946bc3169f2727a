// The beams' Owen-scrambled Sobol' points: each point is uniform over the seeds (so averages are
// unbiased), every aligned block of 2^m points stays stratified (so they converge faster than
// Monte Carlo), and a smooth integral's error over independent seeds shows it.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <set>
#include <vector>

#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/normal.hpp>
#include <gtest/gtest.h>

#include "flare/core/ScrambledSobol.h"

namespace flare {
namespace {

constexpr int kDimensions = 5;

// Every aligned block of 2^m points (the first and a later one) puts exactly one point in each of
// the 2^m intervals of every coordinate: the scramble moves whole intervals, as a Sobol' sequence
// needs. (A scramble whose coin depended on the point's own low digits, or a random point, would
// put two in some interval.)
TEST(ScrambledSobol, AlignedBlocksAreStratifiedInEveryCoordinate) {
    const int m = 10, n = 1 << m;
    for (std::uint64_t seed : {1ull, 2ull, 0xdeadbeefull})
        for (std::uint64_t first : {std::uint64_t{0}, std::uint64_t{7} << m}) {
            const ScrambledSobol points(kDimensions, seed);
            std::vector<std::set<int>> cells(kDimensions);
            double u[kDimensions];
            for (int i = 0; i < n; ++i) {
                points.point(first + i, u);
                for (int d = 0; d < kDimensions; ++d) {
                    ASSERT_GE(u[d], 0.0);
                    ASSERT_LT(u[d], 1.0);
                    cells[d].insert(static_cast<int>(u[d] * n));
                }
            }
            for (int d = 0; d < kDimensions; ++d)
                EXPECT_EQ(static_cast<int>(cells[d].size()), n) << "seed " << seed << ", block at " << first << ", dimension " << d;
        }
}

// The first two coordinates of Sobol's sequence are a (0, m, 2)-net: every box of 2^−a × 2^−(m−a)
// holds exactly one of the first 2^m points, for every a. Scrambling keeps it.
TEST(ScrambledSobol, FirstTwoCoordinatesStayANet) {
    const int m = 8, n = 1 << m;
    const ScrambledSobol points(kDimensions, 42);
    std::vector<std::pair<double, double>> p(n);
    double u[kDimensions];
    for (int i = 0; i < n; ++i) {
        points.point(i, u);
        p[i] = {u[0], u[1]};
    }
    for (int a = 0; a <= m; ++a) {
        std::set<std::pair<int, int>> boxes;
        for (const auto& [x, y] : p) boxes.insert({static_cast<int>(x * (1 << a)), static_cast<int>(y * (1 << (m - a)))});
        EXPECT_EQ(static_cast<int>(boxes.size()), n) << "boxes of 2^-" << a << " x 2^-" << m - a;
    }
}

// Over the seeds, a point is uniform on the cube (even point 0, which unscrambled is the origin):
// a χ² test of 16 bins per coordinate, and of a 4 × 4 grid of two coordinates (independence).
TEST(ScrambledSobol, EachPointIsUniformOverTheSeeds) {
    const int seeds = 16000, bins = 16;
    const std::vector<std::uint64_t> indices = {0, 1, 5, 1000, 123456789};
    const int tests = static_cast<int>(indices.size()) * (kDimensions + 1);
    const double alpha = 1e-3 / tests;  // Bonferroni over every χ² below
    const double critical = boost::math::quantile(boost::math::complement(boost::math::chi_squared(bins - 1), alpha));
    for (std::uint64_t index : indices) {
        std::vector<std::vector<int>> counts(kDimensions, std::vector<int>(bins, 0));
        std::vector<int> pair(bins, 0);
        double u[kDimensions];
        for (int s = 0; s < seeds; ++s) {
            ScrambledSobol(kDimensions, 1000003ull * s + 17).point(index, u);
            for (int d = 0; d < kDimensions; ++d) ++counts[d][static_cast<int>(u[d] * bins)];
            ++pair[static_cast<int>(u[1] * 4) * 4 + static_cast<int>(u[3] * 4)];
        }
        const double expected = static_cast<double>(seeds) / bins;
        auto chiSquared = [&](const std::vector<int>& c) {
            double x = 0.0;
            for (int k : c) x += (k - expected) * (k - expected) / expected;
            return x;
        };
        for (int d = 0; d < kDimensions; ++d) EXPECT_LT(chiSquared(counts[d]), critical) << "point " << index << ", dimension " << d;
        EXPECT_LT(chiSquared(pair), critical) << "point " << index << ", dimensions 1 and 3 together";
    }
}

// The reason for all this: a smooth integrand's error over N = 1024 points, over independent
// seeds, is far below Monte Carlo's σ/√N (Owen-scrambled nets: O(N^−3/2) for smooth integrands);
// and the average over seeds is unbiased (the mean error is within its standard error).
TEST(ScrambledSobol, SmoothIntegralsConvergeFasterThanMonteCarloWithoutBias) {
    // f(u) = Π (1 + (u_d − ½)): exact integral 1, variance per point (1 + 1/12)^5 − 1.
    auto f = [](const double* u) {
        double v = 1.0;
        for (int d = 0; d < kDimensions; ++d) v *= 1.0 + (u[d] - 0.5);
        return v;
    };
    const double sigmaPerPoint = std::sqrt(std::pow(1.0 + 1.0 / 12.0, kDimensions) - 1.0);
    const int n = 1024, seeds = 200;
    double sum = 0.0, sumSquares = 0.0;
    double u[kDimensions];
    for (int s = 0; s < seeds; ++s) {
        const ScrambledSobol points(kDimensions, 99 + s);
        double mean = 0.0;
        for (int i = 0; i < n; ++i) {
            points.point(i, u);
            mean += f(u);
        }
        const double error = mean / n - 1.0;
        sum += error;
        sumSquares += error * error;
    }
    const double rms = std::sqrt(sumSquares / seeds);
    const double monteCarlo = sigmaPerPoint / std::sqrt(static_cast<double>(n));
    EXPECT_LT(rms, monteCarlo / 20.0) << "rms error " << rms << " against Monte Carlo's " << monteCarlo;
    const double meanError = sum / seeds;
    const double z = boost::math::quantile(boost::math::complement(boost::math::normal(), 0.5e-3));
    EXPECT_LT(std::abs(meanError), z * rms / std::sqrt(static_cast<double>(seeds)));
}

TEST(ScrambledSobol, PointsDependOnTheSeedAndIndexOnly) {
    const ScrambledSobol a(3, 7), b(3, 7), c(3, 8);
    double u[3], v[3], w[3];
    a.point(12345, u);
    a.point(3, w);
    b.point(12345, v);
    EXPECT_TRUE(std::equal(u, u + 3, v));
    c.point(12345, w);
    EXPECT_FALSE(std::equal(u, u + 3, w));
    EXPECT_THROW(ScrambledSobol(0, 1), std::invalid_argument);
    EXPECT_THROW(ScrambledSobol(ScrambledSobol::kMaxDimensions + 1, 1), std::invalid_argument);
}

}  // namespace
}  // namespace flare
