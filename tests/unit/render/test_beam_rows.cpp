// The beams' SIMD rows against their scalar loops, bit for bit, on every instruction set this
// processor runs and Highway compiled. The rim's (BeamRimRow.h): random segments (every wedge
// orientation and side), rows crossing them at every distance, spans of every length modulo the
// lane count, and a row that already holds values (−0 among them: a pixel the scalar loop skips
// must stay −0, not become +0 by adding a zero); a whole rim's rasterisation too. The triangles'
// (BeamTriangleRow.h): spans of every length from 0 to several registers, planes of every slope,
// and the values beyond the span untouched.
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <glm/geometric.hpp>

#include "flare/core/FresnelIntegrals.h"
#include "flare/core/Random.h"
#include "flare/render/BeamRim.h"
#include "flare/render/BeamRimRow.h"
#include "flare/render/BeamTriangleRow.h"

namespace flare {
namespace {

template <class Body>
void forEachTarget(Body body) {
    for (const std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
        hwy::SetSupportedTargetsForTest(target);
        ASSERT_STREQ(detail::rimRowTargetName(), hwy::TargetName(target));
        ASSERT_STREQ(detail::triangleRowTargetName(), hwy::TargetName(target));
        body(std::string(hwy::TargetName(target)));
    }
    hwy::SetSupportedTargetsForTest(0);
}

glm::dvec2 unit(double angle) { return {std::cos(angle), std::sin(angle)}; }

// A segment as BeamRim::build makes one: ends, unit direction and inward normal, bisectors leaning
// at most ±60° from the normal, the sides from them.
BeamRim::Segment randomSegment(Rng& rng) {
    constexpr double kPi = 3.141592653589793;
    BeamRim::Segment s;
    s.a = {100.0 + 50.0 * rng.uniform(), 20.0 + 10.0 * rng.uniform()};
    const double length = 0.5 + 40.0 * rng.uniform();
    s.along = unit(2.0 * kPi * rng.uniform());
    s.b = s.a + length * s.along;
    s.length = glm::length(s.b - s.a);
    s.along = (s.b - s.a) / s.length;
    s.inward = glm::dvec2(-s.along.y, s.along.x) * (rng.uniform() < 0.5 ? 1.0 : -1.0);
    const double normalAngle = std::atan2(s.inward.y, s.inward.x);
    s.bisectorA = unit(normalAngle + (rng.uniform() - 0.5) * 2.0 * kPi / 3.0);
    s.bisectorB = unit(normalAngle + (rng.uniform() - 0.5) * 2.0 * kPi / 3.0);
    auto cross = [](const glm::dvec2& a, const glm::dvec2& b) { return a.x * b.y - a.y * b.x; };
    s.sideA = cross(s.bisectorA, s.b - s.a) > 0.0 ? 1.0 : -1.0;
    s.sideB = cross(s.bisectorB, s.a - s.b) > 0.0 ? 1.0 : -1.0;
    s.irradianceA = 0.1 + rng.uniform();
    s.irradianceB = rng.uniform() < 0.2 ? 0.0 : 0.1 + rng.uniform();
    return s;
}

bool sameBits(double a, double b) { return std::signbit(a) == std::signbit(b) && (a == b || (a != a && b != b)); }

TEST(BeamRimRow, SameBitsAsTheScalarLoopOnEveryInstructionSet) {
    forEachTarget([](const std::string& target) {
        Rng rng(2711, 0);
        long touched = 0, skipped = 0, compared = 0;
        for (int segment = 0; segment < 300; ++segment) {
            const BeamRim::Segment s = randomSegment(rng);
            const double w = 0.3 + 4.0 * rng.uniform();
            detail::RimRowSpan span;
            span.reach = FresnelEdgeExcess::kReach * w;
            span.inverseScale = 1.0 / w;
            span.jitterX = 2.0 * rng.uniform() - 1.0;
            for (int row = 0; row < 12; ++row) {
                span.y = std::floor(s.a.y - 40.0 + 80.0 * rng.uniform()) + 0.5 + (2.0 * rng.uniform() - 1.0);
                span.first = static_cast<int>(40.0 + 100.0 * rng.uniform());
                span.last = span.first + static_cast<int>(rng.uniform() * 140.0) - 1;  // empty spans too
                const int pixels = std::max(0, span.last - span.first + 1);
                std::vector<double> simd(static_cast<size_t>(pixels) * 3), scalar;
                for (double& v : simd) v = rng.uniform() < 0.3 ? -0.0 : rng.uniform() - 0.5;
                scalar = simd;
                const std::vector<double> before = simd;
                const glm::dvec3 scale(0.3 + rng.uniform(), 1.0, 0.5 * rng.uniform());
                detail::addRimRow(s, span, scale, simd.data());
                detail::addRimRowScalar(s, span, scale, scalar.data());
                for (size_t i = 0; i < simd.size(); ++i) {
                    ++compared;
                    ASSERT_TRUE(sameBits(simd[i], scalar[i]))
                        << target << ": segment " << segment << " value " << i << ": " << simd[i] << " vs " << scalar[i];
                    if (i % 3 == 1) (sameBits(scalar[i], before[i]) ? skipped : touched) += 1;
                }
            }
        }
        // Both kinds of pixel, many of each.
        EXPECT_GT(touched, 10000) << target;
        EXPECT_GT(skipped, 10000) << target;
        EXPECT_GT(compared, 300000) << target;
    });
}

// A whole rim (a square's four sides, ringing) through BeamRim::rasterise, which runs the row on
// the dispatcher's instruction set: the same film whichever it is.
TEST(BeamRimRow, WholeRimIsTheSameOnEveryInstructionSet) {
    // Two triangles of a square in the pupil, mapped onto 40 × 40 px of a 96 × 64 film.
    auto vertex = [](double x, double y) {
        RimVertex v;
        v.pupilMm = {x, y};
        v.pixel = {28.0 + 40.0 * x + 0.3, 12.0 + 40.0 * y + 0.1};
        v.irradiance = 1.0 + 0.5 * x;
        return v;
    };
    std::vector<RimTriangle> triangles(2);
    triangles[0].v = {vertex(0, 0), vertex(1, 0), vertex(1, 1)};
    triangles[1].v = {vertex(0, 0), vertex(1, 1), vertex(0, 1)};
    const BeamRim rim = BeamRim::build(triangles, 1.7, 96, 64, [](const glm::dvec2& p) {
        return p.x >= 0.0 && p.x <= 1.0 && p.y >= 0.0 && p.y <= 1.0;
    });
    ASSERT_EQ(rim.segmentCount(), 4u);
    std::vector<double> reference;
    forEachTarget([&](const std::string& target) {
        std::vector<double> film(96 * 64 * 3, 0.0);
        const glm::dvec2 jitter(0.37, -0.61);
        for (int band = 0; band * 32 < 64; ++band)
            rim.rasterise(band, jitter, glm::dvec3(0.9, 1.0, 1.1), 96, 64, film.data() + static_cast<size_t>(band) * 32 * 96 * 3);
        if (reference.empty()) {
            reference = film;
            double ringing = 0.0;
            for (double v : film) ringing += std::abs(v);
            EXPECT_GT(ringing, 10.0);  // the rim rings
        }
        for (size_t i = 0; i < film.size(); ++i) ASSERT_TRUE(sameBits(film[i], reference[i])) << target << " at " << i;
    });
}

TEST(BeamTriangleRow, SameBitsAsTheScalarLoopOnEveryInstructionSet) {
    forEachTarget([](const std::string& target) {
        Rng rng(1207, 0);
        long compared = 0;
        for (int trial = 0; trial < 4000; ++trial) {
            const int first = static_cast<int>(2000.0 * rng.uniform());
            const int count = trial % 41;  // 0 … 40 pixels: every remainder of every lane count
            const int last = first + count - 1;
            // A plane as a triangle gives one: any sign and slope, the value at large columns
            // from a large constant cancelling (what rounding exposes).
            const double gx = (rng.uniform() - 0.5) * std::pow(10.0, 4.0 * rng.uniform() - 3.0);
            const double rowValue = -gx * (first + count * rng.uniform()) + (rng.uniform() - 0.3);
            const glm::dvec3 scale(rng.uniform(), 0.5 + rng.uniform(), 1e-3 * rng.uniform());
            // Two pixels of margin on either side, which must stay as they are.
            std::vector<double> simd(static_cast<size_t>(count + 4) * 3);
            for (double& v : simd) v = rng.uniform() < 0.2 ? -0.0 : rng.uniform() - 0.5;
            std::vector<double> scalar = simd;
            detail::addTriangleRow(rowValue, gx, first, last, scale, simd.data() + 6);
            detail::addTriangleRowScalar(rowValue, gx, first, last, scale, scalar.data() + 6);
            for (size_t i = 0; i < simd.size(); ++i, ++compared)
                ASSERT_TRUE(sameBits(simd[i], scalar[i]))
                    << target << ": trial " << trial << " value " << i << ": " << simd[i] << " vs " << scalar[i];
        }
        EXPECT_GT(compared, 250000) << target;
    });
}

// The batched calls (a triangle's or a segment's rows in one call, their set-up shared) against
// the scalar loop row by row: rows of different lengths, y and values, one slope or segment.
TEST(BeamTriangleRow, ATrianglesRowsInOneCallAreTheScalarRows) {
    forEachTarget([](const std::string& target) {
        Rng rng(4409, 0);
        long compared = 0;
        for (int trial = 0; trial < 300; ++trial) {
            const double gx = (rng.uniform() - 0.5) * std::pow(10.0, 4.0 * rng.uniform() - 3.0);
            const glm::dvec3 scale(rng.uniform(), 0.5 + rng.uniform(), 1e-3 * rng.uniform());
            const int rows = 1 + trial % 32, width = 64;
            std::vector<double> simd(static_cast<size_t>(rows) * width * 3);
            for (double& v : simd) v = rng.uniform() < 0.2 ? -0.0 : rng.uniform() - 0.5;
            std::vector<double> scalar = simd;
            std::vector<detail::TriangleRowSpan> spans;
            for (int r = 0; r < rows; ++r) {
                const int first = static_cast<int>(20.0 * rng.uniform());
                const int last = first + static_cast<int>(41.0 * rng.uniform()) - 1;  // empty rows too
                const double rowValue = -gx * (first + 10.0 * rng.uniform()) + (rng.uniform() - 0.3);
                spans.push_back({rowValue, first, last, simd.data() + (static_cast<size_t>(r) * width + first) * 3});
                detail::addTriangleRowScalar(rowValue, gx, first, last, scale,
                                             scalar.data() + (static_cast<size_t>(r) * width + first) * 3);
            }
            detail::addTriangleRows(spans.data(), spans.size(), gx, scale);
            for (size_t i = 0; i < simd.size(); ++i, ++compared)
                ASSERT_TRUE(sameBits(simd[i], scalar[i])) << target << ": trial " << trial << " value " << i;
        }
        EXPECT_GT(compared, 500000) << target;
    });
}

TEST(BeamRimRow, ASegmentsRowsInOneCallAreTheScalarRows) {
    forEachTarget([](const std::string& target) {
        Rng rng(5501, 0);
        long touched = 0, compared = 0;
        for (int segment = 0; segment < 200; ++segment) {
            const BeamRim::Segment s = randomSegment(rng);
            const double w = 0.3 + 4.0 * rng.uniform();
            const glm::dvec3 scale(0.3 + rng.uniform(), 1.0, 0.5 * rng.uniform());
            const int rows = 1 + segment % 32, width = 200;
            std::vector<double> simd(static_cast<size_t>(rows) * width * 3);
            for (double& v : simd) v = rng.uniform() < 0.3 ? -0.0 : rng.uniform() - 0.5;
            std::vector<double> scalar = simd;
            const std::vector<double> before = simd;
            std::vector<detail::RimRowSpan> spans;
            const double jitterX = 2.0 * rng.uniform() - 1.0;
            for (int r = 0; r < rows; ++r) {
                detail::RimRowSpan span;
                span.reach = FresnelEdgeExcess::kReach * w;
                span.inverseScale = 1.0 / w;
                span.jitterX = jitterX;
                span.y = std::floor(s.a.y - 20.0 + 40.0 * rng.uniform()) + 0.5 + (2.0 * rng.uniform() - 1.0);
                span.first = static_cast<int>(40.0 + 60.0 * rng.uniform());
                span.last = span.first + static_cast<int>(rng.uniform() * 100.0) - 1;
                double* row = simd.data() + (static_cast<size_t>(r) * width + span.first) * 3;
                span.row = row;
                spans.push_back(span);
                detail::addRimRowScalar(s, span, scale, scalar.data() + (row - simd.data()));
            }
            detail::addRimRows(s, spans.data(), spans.size(), scale);
            for (size_t i = 0; i < simd.size(); ++i, ++compared) {
                ASSERT_TRUE(sameBits(simd[i], scalar[i])) << target << ": segment " << segment << " value " << i;
                if (!sameBits(scalar[i], before[i])) ++touched;
            }
        }
        EXPECT_GT(touched, 10000) << target;
        EXPECT_GT(compared, 1000000) << target;
    });
}

}  // namespace
}  // namespace flare
