// The starburst far field's SIMD row (FarFieldRow.h) against its scalar loop, bit for bit, on every
// instruction set this processor runs and Highway compiled: spikes of every direction with fans
// from none to wide, bands about the crop, crops inside and outside the frame, one taper and a
// cluster's several, rows of every length modulo the lane count, and a row that already holds
// values (−0 among them: a pixel whose taper is 0 must keep its −0). The scalar terms (FarRowTerms)
// here depend on the value they are given, so a term taken in another order would show.
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <hwy/targets.h>

#include "flare/core/Random.h"
#include "flare/wave/FarFieldRow.h"

namespace flare {
namespace {

constexpr double kPi = 3.141592653589793;

template <class Body>
void forEachTarget(Body body) {
    for (const std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
        hwy::SetSupportedTargetsForTest(target);
        ASSERT_STREQ(detail::farRowTargetName(), hwy::TargetName(target));
        body(std::string(hwy::TargetName(target)));
    }
    hwy::SetSupportedTargetsForTest(0);
}

bool sameBits(float a, float b) { return std::signbit(a) == std::signbit(b) && (a == b || (a != a && b != b)); }

// Scalar terms whose result depends on the value so far (a reordering changes the bits), which
// count their calls and keep every pixel's spike sum as they are given it (in double: a rounding
// the float image would hide shows there).
class CountingTerms final : public detail::FarRowTerms {
public:
    void spikeShare(int x, size_t spike, glm::dvec3& value) const override {
        ++spikeCalls;
        value = value * 0.75 + glm::dvec3(1e-3 * (x % 7 + 1), 1e-3 * (spike + 1), 1e-4 * x);
    }
    void haloAndCorners(int x, glm::dvec3& value) const override {
        ++haloCalls;
        sums.push_back(value);
        value = value * 1.25 - glm::dvec3(1e-5 * x, 2e-5, 1e-6 * (x % 3));
    }
    mutable long spikeCalls = 0, haloCalls = 0;
    mutable std::vector<glm::dvec3> sums;
};

// A spike as addFarField sets one up: unit direction and its normal, a fan (often none), a band
// about the crop a few to tens of pixels wide, a sinc² up to a few pixels wide.
detail::FarSpike randomSpike(Rng& rng) {
    detail::FarSpike s;
    const double angle = 2.0 * kPi * rng.uniform();
    s.directionX = std::cos(angle), s.directionY = std::sin(angle);
    s.transverseX = -s.directionY, s.transverseY = s.directionX;
    if (rng.uniform() < 0.5) {
        s.fanFromRad = -0.05 * rng.uniform();
        s.fanToRad = 0.05 * rng.uniform();
    }
    const double band = 2.0 + 40.0 * rng.uniform();
    s.bandLoPx = -band, s.bandHiPx = band * (0.8 + 0.4 * rng.uniform());
    s.widestPx = 0.2 + 3.0 * rng.uniform();
    s.tailScale = glm::dvec3(0.5 + rng.uniform(), 1.0, 0.5 + rng.uniform()) * (1e2 * rng.uniform());
    return s;
}

TEST(FarFieldRow, SameBitsAsTheScalarLoopOnEveryInstructionSet) {
    forEachTarget([](const std::string& target) {
        Rng rng(4211, 0);
        long compared = 0, touched = 0, untouched = 0, fastTerms = 0, scalarTermCalls = 0;
        for (int field = 0; field < 40; ++field) {
            std::vector<detail::FarSpike> spikes;
            const int count = 1 + static_cast<int>(14.0 * rng.uniform());
            for (int s = 0; s < count; ++s) spikes.push_back(randomSpike(rng));
            std::vector<detail::FarTaperRing> tapers;
            const int rings = rng.uniform() < 0.5 ? 1 : 2 + static_cast<int>(3.0 * rng.uniform());
            const double centreX = -50.0 + 400.0 * rng.uniform(), centreY = -20.0 + 200.0 * rng.uniform();
            for (int k = 0; k < rings; ++k) {
                detail::FarTaperRing t;
                t.centreX = centreX + (rings == 1 ? 0.0 : 30.0 * (rng.uniform() - 0.5));
                t.centreY = centreY + (rings == 1 ? 0.0 : 30.0 * (rng.uniform() - 0.5));
                t.startPx = 5.0 + 40.0 * rng.uniform();
                t.widthPx = t.startPx;
                t.weight = 1.0 / rings;
                tapers.push_back(t);
            }
            for (int r = 0; r < 6; ++r) {
                const int width = static_cast<int>(rng.uniform() * 360.0);  // empty rows too
                const double pixelY = std::floor(centreY - 80.0 + 160.0 * rng.uniform()) + 0.5;
                std::vector<float> simd(3 * static_cast<size_t>(width));
                for (float& v : simd) v = rng.uniform() < 0.3 ? -0.0f : static_cast<float>(rng.uniform() - 0.5);
                std::vector<float> scalar = simd;
                const std::vector<float> before = simd;
                CountingTerms simdTerms, scalarTerms;
                detail::FarRow row;
                row.pixelY = pixelY;
                row.centreX = centreX, row.centreY = centreY;
                row.width = width;
                row.spikes = spikes.data(), row.spikeCount = spikes.size();
                row.tapers = tapers.data(), row.taperCount = tapers.size();
                double simdY = 0.25, scalarY = 0.25;
                row.terms = &simdTerms, row.xyz = simd.data(), row.rowY = &simdY;
                detail::addFarRow(row);
                row.terms = &scalarTerms, row.xyz = scalar.data(), row.rowY = &scalarY;
                detail::addFarRowScalar(row);
                ASSERT_EQ(simdTerms.spikeCalls, scalarTerms.spikeCalls) << target << ": field " << field;
                ASSERT_EQ(simdTerms.haloCalls, scalarTerms.haloCalls) << target << ": field " << field;
                ASSERT_EQ(simdY, scalarY) << target << ": field " << field << " row " << r;
                for (size_t i = 0; i < scalarTerms.sums.size(); ++i)
                    for (int c = 0; c < 3; ++c)
                        ASSERT_EQ(simdTerms.sums[i][c], scalarTerms.sums[i][c]) << target << ": field " << field << " row " << r;
                for (size_t i = 0; i < simd.size(); ++i) {
                    ++compared;
                    ASSERT_TRUE(sameBits(simd[i], scalar[i]))
                        << target << ": field " << field << " row " << r << " value " << i << ": " << simd[i] << " vs " << scalar[i];
                    if (i % 3 == 1) (sameBits(scalar[i], before[i]) ? untouched : touched) += 1;
                }
                fastTerms += scalarTerms.haloCalls * count - scalarTerms.spikeCalls;
                scalarTermCalls += scalarTerms.spikeCalls;
            }
        }
        // Pixels inside the tapers' start and beyond, and both kinds of spike term, many of each.
        EXPECT_GT(touched, 5000) << target;
        EXPECT_GT(untouched, 500) << target;
        EXPECT_GT(fastTerms, 50000) << target;
        EXPECT_GT(scalarTermCalls, 5000) << target;
        EXPECT_GT(compared, 80000) << target;
    });
}

}  // namespace
}  // namespace flare
