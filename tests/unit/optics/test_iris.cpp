// The iris: circular and polygonal openings, with area equal to the nominal circle.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

#include <gtest/gtest.h>

#include "flare/optics/Iris.h"

namespace flare {
namespace {

// Fraction of a square [−R, R]² inside the iris, on a fine deterministic grid.
double openArea(const Iris& iris, double halfSide, int grid) {
    std::int64_t inside = 0;
    for (int i = 0; i < grid; ++i)
        for (int j = 0; j < grid; ++j) {
            const double x = -halfSide + (i + 0.5) * 2.0 * halfSide / grid;
            const double y = -halfSide + (j + 0.5) * 2.0 * halfSide / grid;
            inside += iris.contains(x, y);
        }
    return 4.0 * halfSide * halfSide * static_cast<double>(inside) / (static_cast<double>(grid) * grid);
}

TEST(Iris, CircularIsADisk) {
    const Iris iris(0, 0.0, 0.0, 5.0);
    EXPECT_TRUE(iris.contains(4.99, 0.0));
    EXPECT_FALSE(iris.contains(3.6, 3.6));
}

TEST(Iris, PolygonsHaveTheAreaOfTheNominalCircle) {
    // Grid integration: the boundary cells give an error of order perimeter·cell / area; 1000²
    // cells over a square just enclosing the opening bound it well below 0.3 %.
    const double circle = std::numbers::pi * 25.0;
    for (int blades : {3, 5, 6, 9}) {
        for (double curvature : {0.0, 0.5, 1.0}) {
            const Iris iris(blades, 0.3, curvature, 5.0);
            EXPECT_NEAR(openArea(iris, 1.05 * iris.circumradiusMm(), 1000) / circle, 1.0, 0.003)
                << blades << " blades, curvature " << curvature;
        }
    }
}

TEST(Iris, HexagonVerticesAndEdges) {
    const Iris iris(6, 0.0, 0.0, 5.0);
    const double R = iris.circumradiusMm();
    const double apothem = R * std::cos(std::numbers::pi / 6);
    EXPECT_TRUE(iris.contains(0.999 * R, 0.0));  // a vertex at the rotation angle
    EXPECT_FALSE(iris.contains(1.001 * R, 0.0));
    // Edge midpoint at 30°.
    const double c = std::cos(std::numbers::pi / 6), s = std::sin(std::numbers::pi / 6);
    EXPECT_TRUE(iris.contains(0.999 * apothem * c, 0.999 * apothem * s));
    EXPECT_FALSE(iris.contains(1.001 * apothem * c, 1.001 * apothem * s));
}

TEST(Iris, FullyCurvedBladesAreTheCircumcircle) {
    const Iris iris(7, 0.2, 1.0, 5.0);
    EXPECT_NEAR(iris.circumradiusMm(), 5.0, 1e-12);
    for (int i = 0; i < 360; i += 7) {
        const double a = i * std::numbers::pi / 180.0;
        EXPECT_TRUE(iris.contains(4.999 * std::cos(a), 4.999 * std::sin(a)));
        EXPECT_FALSE(iris.contains(5.001 * std::cos(a), 5.001 * std::sin(a)));
    }
}

TEST(Iris, MarginIsNegativeExactlyInsideAndContinuous) {
    for (int blades : {0, 3, 6, 9}) {
        for (double curvature : {0.0, 0.7, 1.0}) {
            const Iris iris(blades, 0.3, curvature, 5.0);
            const double half = 1.2 * iris.circumradiusMm();
            const int grid = 301;
            const double step = 2.0 * half / (grid - 1);
            for (int i = 0; i < grid; ++i)
                for (int j = 0; j < grid; ++j) {
                    const double x = -half + i * step, y = -half + j * step;
                    const double m = iris.margin(x, y);
                    // The sign decides the same as contains() except within rounding of the edge.
                    if (std::abs(m) > 1e-12)
                        ASSERT_EQ(m < 0.0, iris.contains(x, y)) << blades << " blades at " << x << ", " << y;
                    // Continuity: over one grid step the margin (≈ r²/ρ² − 1, ρ ≥ the apothem)
                    // changes by at most about 2·r·step/ρ², with slack for the bowed blades.
                    const double rho = iris.circumradiusMm() * std::cos(std::numbers::pi / std::max(blades, 3));
                    const double bound = 4.0 * (std::hypot(x, y) + step) * step / (rho * rho) + 1e-12;
                    EXPECT_LE(std::abs(iris.margin(x + step, y) - m), bound) << blades << " blades";
                }
        }
    }
}

// contains() takes each sector's mid-normal from a table instead of evaluating its cosine and sine
// per point: against the straight-bladed polygon evaluated the plain way (the sector by angle,
// the point turned into its frame with std::cos and std::sin), point for point, at rotations
// that move the sectors' indices out of [0, blades) and with points crowded onto the edges.
TEST(Iris, StraightBladesDecideAsTheSectorsTrigonometry) {
    for (int blades : {3, 5, 6, 8}) {
        for (double rotation : {0.0, 0.3, -2.5, 2.0, 7.1}) {
            const Iris iris(blades, rotation, 0.0, 5.0);
            const double sector = 2.0 * std::numbers::pi / blades;
            auto reference = [&](double x, double y) {
                const double r2 = x * x + y * y;
                if (r2 > iris.circumradiusMm() * iris.circumradiusMm()) return false;
                if (r2 <= iris.apothemMm() * iris.apothemMm()) return true;
                const double k = std::floor((std::atan2(y, x) - rotation) / sector);
                const double mid = rotation + (k + 0.5) * sector;
                return x * std::cos(mid) + y * std::sin(mid) <= iris.apothemMm();
            };
            std::int64_t inside = 0, outside = 0;
            for (int n = 0; n < 20000; ++n) {
                // On rays through the corners and the edges' middles too, at radii about the edge.
                const double angle = n % 4 == 0 ? rotation + (n / 4 % blades) * 0.5 * sector : 0.000731 * n;
                const double edge = iris.apothemMm() / std::max(0.2, std::cos(std::remainder(angle - rotation - 0.5 * sector, sector)));
                const double r = edge * (1.0 + (n % 7 - 3) * 1e-13 + ((n / 7) % 11 - 5) * 0.01);
                const double x = r * std::cos(angle), y = r * std::sin(angle);
                const bool in = iris.contains(x, y);
                ASSERT_EQ(in, reference(x, y)) << blades << " blades, rotation " << rotation << ", point " << n;
                (in ? inside : outside) += 1;
            }
            EXPECT_GT(inside, 5000);
            EXPECT_GT(outside, 5000);
        }
    }
}

}  // namespace
}  // namespace flare
