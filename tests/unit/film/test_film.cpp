// The sensor film as a density estimator: exact power conservation of its kernels (and the exact
// off-image loss at the border), the camera-view orientation, the progressive and adaptive radii,
// the per-pass variance estimate against a known variance (χ²), checkpoints and bad settings,
// the wide kernels added at the end of a pass (whole or band by band) and the adaptive kernel by
// power.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/core/Random.h"
#include "flare/core/Replicates.h"
#include "flare/core/Spectrum.h"
#include "flare/film/Film.h"
#include "flare/optics/PupilGrid.h"
#include "flare/optics/SequentialTracer.h"

namespace flare {
namespace {

using Kernel = FilmSettings::Kernel;

// A power of two: pixel ↔ millimetre conversions (and so the positions below) are exact.
constexpr double kPixelMm = 0.125;
constexpr double kM2PerMm2 = 1e-6;
// Film::irradianceXyz returns floats: each pixel is rounded with a relative error ≤ 2^-24
// (≈ 6e-8); a sum of positive pixels keeps that relative bound, and the double arithmetic before
// it adds ~1e-15. 1e-7 relative is therefore a strict bound for sums of positive pixels.
constexpr double kFloatRelative = 1e-7;

FilmSettings filmSettings(int widthPx, int heightPx, Kernel kernel = Kernel::Fixed, double radiusPx = 1.0) {
    FilmSettings s;
    s.widthPx = widthPx;
    s.heightPx = heightPx;
    s.widthMm = widthPx * kPixelMm;
    s.heightMm = heightPx * kPixelMm;
    s.kernel = kernel;
    s.radiusPx = radiusPx;
    return s;
}

// The sensor point (mm) at continuous pixel coordinates (px, py): the inverse of the mapping that
// Film::toPixel documents (the sensor image turned by 180°). Checked against toPixel below.
glm::dvec2 sensorAt(const FilmSettings& s, double px, double py) {
    return {0.5 * s.widthMm - px * kPixelMm, py * kPixelMm - 0.5 * s.heightMm};
}

double pixelAreaM2(const Film& film) { return film.pixelMm() * film.pixelMm() * kM2PerMm2; }

// Power (W, XYZ) held by a layer: Σ irradiance × pixel area × photons.
glm::dvec3 layerPowerW(const Film& film, int layer, double photons) {
    const std::vector<float> xyz = film.irradianceXyz(layer, photons);
    glm::dvec3 sum(0.0);
    for (size_t i = 0; i < xyz.size(); i += 3) sum += glm::dvec3(xyz[i], xyz[i + 1], xyz[i + 2]);
    return sum * pixelAreaM2(film) * photons;
}

// The documented kernel, written independently of Film: the bilinear tent for r ≤ 1, else the
// Epanechnikov profile 1 − d²/r² (unnormalised), as a function of the offset from the photon.
double kernelWeight(double radius, double dx, double dy) {
    if (radius <= 1.0) return std::max(0.0, 1.0 - std::abs(dx)) * std::max(0.0, 1.0 - std::abs(dy));
    return std::max(0.0, 1.0 - (dx * dx + dy * dy) / (radius * radius));
}

// The share of a photon at continuous pixel coordinates `p` that the kernel puts on the image's
// pixel centres, the kernel being normalised over all centres of the plane (brute force over a
// window wider than any kernel).
double onImageShare(double radius, const glm::dvec2& p, int width, int height) {
    double all = 0.0, onImage = 0.0;
    const int reach = static_cast<int>(std::ceil(radius)) + 2;
    for (int y = static_cast<int>(std::floor(p.y)) - reach; y <= static_cast<int>(std::floor(p.y)) + reach; ++y)
        for (int x = static_cast<int>(std::floor(p.x)) - reach; x <= static_cast<int>(std::floor(p.x)) + reach; ++x) {
            const double w = kernelWeight(radius, x + 0.5 - p.x, y + 0.5 - p.y);
            all += w;
            if (x >= 0 && y >= 0 && x < width && y < height) onImage += w;
        }
    return onImage / all;
}

constexpr double kRadii[] = {0.5, 1.0, 2.5, 7.0};  // two bilinear tents, two Epanechnikov kernels

TEST(Film, PowerIsConservedAndSpreadByTheDocumentedKernelAwayFromTheBorder) {
    const glm::dvec3 power(0.7, 1.3, 2.1);
    int r = 0;
    for (const double radius : kRadii) {
        Rng rng(101, r++);
        const FilmSettings s = filmSettings(64, 48, Kernel::Fixed, radius);
        for (int trial = 0; trial < 25; ++trial) {
            // At least 9 px from every edge: more than the widest kernel (7 px) plus one.
            const glm::dvec2 p(9.0 + 46.0 * rng.uniform(), 9.0 + 30.0 * rng.uniform());
            Film film(s, 1);
            film.splat(0, sensorAt(s, p.x, p.y), power);
            const double photons = 3.0;  // any count: irradiance × area × photons is the power
            const glm::dvec3 kept = layerPowerW(film, 0, photons);
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(kept[c], power[c], kFloatRelative * power[c]) << "radius " << radius << " at " << p.x << ", " << p.y;

            // Every pixel holds exactly its share of the documented kernel (so nothing is
            // spread beyond the radius, and the tent keeps the photon's centroid exactly).
            double total = 0.0;
            for (int y = -10; y < s.heightPx + 10; ++y)
                for (int x = -10; x < s.widthPx + 10; ++x) total += kernelWeight(radius, x + 0.5 - p.x, y + 0.5 - p.y);
            const std::vector<float> xyz = film.irradianceXyz(0, 1.0);
            for (int y = 0; y < s.heightPx; ++y)
                for (int x = 0; x < s.widthPx; ++x) {
                    const double expected = power.y * kernelWeight(radius, x + 0.5 - p.x, y + 0.5 - p.y) / total / pixelAreaM2(film);
                    const double got = xyz[(static_cast<size_t>(y) * s.widthPx + x) * 3 + 1];
                    // One float rounding (2^-24) on top of double arithmetic: 1e-7 relative.
                    ASSERT_NEAR(got, expected, kFloatRelative * expected + 1e-30)
                        << "radius " << radius << " pixel " << x << ", " << y;
                }
        }
    }
}

TEST(Film, AtTheBorderOnlyTheOffImagePartIsLost) {
    const glm::dvec3 power(1.0, 2.0, 4.0);
    for (const double radius : kRadii) {
        const FilmSettings s = filmSettings(64, 48, Kernel::Fixed, radius);
        // The pixel centres are symmetric about every pixel corner and edge line, and so is the
        // kernel about its photon: a photon on an image corner keeps exactly 1/4, on an edge 1/2.
        struct Case {
            glm::dvec2 pixel;
            double share;
        };
        const Case symmetric[] = {{{0.0, 0.0}, 0.25},       {{64.0, 48.0}, 0.25}, {{64.0, 0.0}, 0.25},
                                  {{0.0, 48.0}, 0.25},      {{0.0, 20.3}, 0.5},   {{37.7, 48.0}, 0.5},
                                  {{64.0, 17.25}, 0.5},     {{11.1, 0.0}, 0.5}};
        for (const Case& c : symmetric) {
            Film film(s, 1);
            film.splat(0, sensorAt(s, c.pixel.x, c.pixel.y), power);
            const glm::dvec3 kept = layerPowerW(film, 0, 1.0);
            for (int k = 0; k < 3; ++k)
                EXPECT_NEAR(kept[k], c.share * power[k], kFloatRelative * power[k])
                    << "radius " << radius << " at pixel " << c.pixel.x << ", " << c.pixel.y;
        }
        // Arbitrary points near and beyond the border: the share from the brute-force kernel.
        const glm::dvec2 points[] = {{-1.3, 20.7}, {-0.6, 0.2}, {3.4, -2.9}, {65.8, 47.1}, {30.2, 52.5}, {0.3, 47.6}};
        for (const glm::dvec2& p : points) {
            Film film(s, 1);
            film.splat(0, sensorAt(s, p.x, p.y), power);
            const double share = onImageShare(radius, p, s.widthPx, s.heightPx);
            const glm::dvec3 kept = layerPowerW(film, 0, 1.0);
            for (int k = 0; k < 3; ++k)
                EXPECT_NEAR(kept[k], share * power[k], kFloatRelative * power[k])
                    << "radius " << radius << " at pixel " << p.x << ", " << p.y;
        }
        // Far off the image, or at a non-finite position: nothing reaches the film.
        Film film(s, 1);
        film.splat(0, sensorAt(s, -100.0, 20.0), power);
        film.splat(0, sensorAt(s, 30.0, 1e9), power);
        film.splat(0, {std::numeric_limits<double>::quiet_NaN(), 0.0}, power);
        film.splat(0, {0.0, std::numeric_limits<double>::infinity()}, power);
        EXPECT_EQ(layerPowerW(film, 0, 1.0), glm::dvec3(0.0)) << "radius " << radius;
    }
}

TEST(Film, PictureIsTheSensorImageTurnedBy180Degrees) {
    const FilmSettings s = filmSettings(64, 48);
    const Film film(s, 1);
    // The formula: centre to centre, sensor +x to the left edge and sensor +y to the bottom row
    // (rows count from the top). Exact: every number here is a multiple of 1/8.
    EXPECT_EQ(film.toPixel({0.0, 0.0}), glm::dvec2(32.0, 24.0));
    EXPECT_EQ(film.toPixel({4.0, 3.0}), glm::dvec2(0.0, 48.0));    // sensor (+x, +y) corner: bottom left
    EXPECT_EQ(film.toPixel({-4.0, -3.0}), glm::dvec2(64.0, 0.0));  // sensor (−x, −y) corner: top right
    EXPECT_EQ(film.toPixel({1.0, 0.0}), glm::dvec2(24.0, 24.0));
    EXPECT_EQ(film.toPixel({0.0, 1.0}), glm::dvec2(32.0, 32.0));
    for (const glm::dvec2 p : {glm::dvec2(3.5, 7.25), glm::dvec2(60.125, 0.5)}) EXPECT_EQ(film.toPixel(sensorAt(s, p.x, p.y)), p);

    // A splat at sensor (+2.0625, +1.0625) mm is the centre of pixel (15, 32): left, lower half.
    Film splatted(s, 1);
    splatted.splat(0, {2.0625, 1.0625}, {0.0, 1.0, 0.0});
    const std::vector<float> xyz = splatted.irradianceXyz(0, 1.0);
    EXPECT_NEAR(xyz[(32 * 64 + 15) * 3 + 1] * pixelAreaM2(splatted), 1.0, kFloatRelative);

    // Physically: a light up and to the right in the scene (field +10°, +5°) is imaged by a real
    // lens onto the sensor's (−x, −y) quadrant, and must appear up and to the right in the picture,
    // near f·tan(field) (the double Gauss's distortion and aberrations at 11° are far below the
    // 1 mm allowed here; the quadrant is the point of the check). Preview.cpp (lines 136–137) maps
    // sensor points to pixels with the same expression.
    const LensSystem lens = test::loadLens("lenses/double-gauss-50mm.lens");
    FilmSettings sensor;  // the lens's 36 × 24 mm sensor at 0.25 mm per pixel
    sensor.widthMm = lens.sensor().widthMm;
    sensor.heightMm = lens.sensor().heightMm;
    sensor.widthPx = 144;
    sensor.heightPx = 96;
    const Film camera(sensor, 1);
    const glm::dvec3 direction = directionFromFieldDeg(10.0, 5.0);
    const PupilGrid grid = PupilGrid::forDirection(lens, direction);
    const SpectralIndices indices = lens.indicesAt(550.0);
    glm::dvec2 sum(0.0);
    int hits = 0;
    for (int j = -10; j <= 10; ++j)
        for (int i = -10; i <= 10; ++i) {
            const TraceResult result = traceForward(lens, indices, grid.ray(grid.halfSizeMm * i / 10.0, grid.halfSizeMm * j / 10.0));
            if (!result.ok()) continue;
            sum += glm::dvec2(result.ray.originMm.x, result.ray.originMm.y);
            ++hits;
        }
    ASSERT_GT(hits, 20);
    const glm::dvec2 imageMm = sum / static_cast<double>(hits);
    const glm::dvec2 pixel = camera.toPixel(imageMm);
    EXPECT_GT(pixel.x, 0.5 * sensor.widthPx) << "the light must appear right of centre";
    EXPECT_LT(pixel.y, 0.5 * sensor.heightPx) << "the light must appear above the centre (rows count from the top)";
    const double f = 50.0;
    const glm::dvec2 expectedPx = camera.toPixel({-f * std::tan(10.0 * std::numbers::pi / 180.0), -f * std::tan(5.0 * std::numbers::pi / 180.0)});
    EXPECT_NEAR(pixel.x, expectedPx.x, 1.0 / camera.pixelMm());
    EXPECT_NEAR(pixel.y, expectedPx.y, 1.0 / camera.pixelMm());
}

TEST(Film, ProgressiveRadiusShrinksAsInProgressivePhotonMapping) {
    // r_p = r_1 · p^(−(1−α)/2): with r_1 = 4 and α = 0.1 the radius passes below 1 px (the tent)
    // at p = 22, so both kernels are exercised. Layer p − 1 receives one photon in pass p; its
    // support must be exactly the pixel centres with positive weight at r_p.
    const double r1 = 4.0, alpha = 0.1;
    const int passes = 24;
    FilmSettings s = filmSettings(32, 32, Kernel::Progressive, r1);
    s.progressiveAlpha = alpha;
    Film film(s, passes);
    const glm::dvec2 p(15.3, 16.8);
    for (int pass = 1; pass <= passes; ++pass) {
        const double expected = r1 * std::pow(static_cast<double>(pass), -0.5 * (1.0 - alpha));
        EXPECT_NEAR(film.radiusPx(0, sensorAt(s, 3.0, 4.0)), expected, 1e-12 * expected) << "pass " << pass;
        EXPECT_EQ(film.radiusPx(pass - 1, sensorAt(s, p.x, p.y)), film.radiusPx(0, sensorAt(s, 3.0, 4.0)));
        film.splat(pass - 1, sensorAt(s, p.x, p.y), {1.0, 1.0, 1.0});
        film.endPass(1);
    }
    for (int pass = 1; pass <= passes; ++pass) {
        const double radius = r1 * std::pow(static_cast<double>(pass), -0.5 * (1.0 - alpha));
        const std::vector<float> xyz = film.irradianceXyz(pass - 1, 1.0);
        int mismatches = 0;
        for (int y = 0; y < s.heightPx; ++y)
            for (int x = 0; x < s.widthPx; ++x) {
                const bool covered = kernelWeight(radius, x + 0.5 - p.x, y + 0.5 - p.y) > 0.0;
                mismatches += covered != (xyz[(static_cast<size_t>(y) * s.widthPx + x) * 3] > 0.0f);
            }
        EXPECT_EQ(mismatches, 0) << "pass " << pass << ": the splat's support is not that of r = " << radius;
        EXPECT_NEAR(layerPowerW(film, pass - 1, 1.0).x, 1.0, kFloatRelative);
    }
}

// Block counts behind the adaptive radius: the radius of a block is sqrt(k / (π ρ)) with ρ the
// photons per px² of the finished passes, so k · 64 / (π r²) gives back the count of an 8 × 8 block.
double countFromRadius(double radius, int neighbours) { return neighbours * 64.0 / (std::numbers::pi * radius * radius); }

TEST(Film, AdaptiveRadiusFollowsTheDensityOfTheFinishedPasses) {
    FilmSettings s = filmSettings(128, 128, Kernel::Adaptive);
    s.neighbours = 400;
    s.maxRadiusPx = 8.0;
    Film film(s, 2);  // layer 1 receives nothing: its counts stay zero
    // Before any count: the widest kernel everywhere.
    EXPECT_EQ(film.radiusPx(0, sensorAt(s, 64.0, 64.0)), 8.0);

    // N photons uniform over the 64 × 64 px square [32, 96)², which is 8 × 8 whole blocks: 16
    // photons per px², so a block expects μ = N/64 = 1024 and r ≈ sqrt(400 / (16π)) = 2.82 px.
    const int n = 65536, blocks = 64;
    Rng rng(7, 0);
    auto splatUniform = [&] {
        // Zero power: they count towards the density but leave the layer black, so that the
        // kernel of a probe photon can be seen below.
        for (int i = 0; i < n; ++i) film.splat(0, sensorAt(s, 32.0 + 64.0 * rng.uniform(), 32.0 + 64.0 * rng.uniform()), glm::dvec3(0.0), false);
    };
    splatUniform();
    // Counts of the running pass are not used yet.
    EXPECT_EQ(film.radiusPx(0, sensorAt(s, 64.0, 64.0)), 8.0);
    film.endPass(n);

    // A block's count is Binomial(N·passes, 1/64). Bound: μ ± z σ, z two-sided at 1e-4 with a
    // Bonferroni correction over the 64 blocks (α = 1e-4/64 each, z ≈ 4.8; the normal
    // approximation is excellent at μ ≥ 1024).
    const double z = test::normalTwoSidedCritical(1e-4 / blocks);
    for (int passes = 1; passes <= 2; ++passes) {
        const double trials = static_cast<double>(n) * passes, p = 1.0 / blocks;
        const double mu = trials * p, sigma = std::sqrt(trials * p * (1.0 - p));
        const double rLow = std::sqrt(s.neighbours / (std::numbers::pi * (mu + z * sigma) / 64.0));
        const double rHigh = std::sqrt(s.neighbours / (std::numbers::pi * (mu - z * sigma) / 64.0));
        double countSum = 0.0;
        for (int by = 0; by < 16; ++by)
            for (int bx = 0; bx < 16; ++bx) {
                const double r = film.radiusPx(0, sensorAt(s, bx * 8 + 4.0, by * 8 + 4.0));
                const bool dense = bx >= 4 && bx < 12 && by >= 4 && by < 12;
                if (!dense) {
                    EXPECT_EQ(r, s.maxRadiusPx) << "empty block " << bx << ", " << by;
                    continue;
                }
                EXPECT_GT(r, rLow) << "block " << bx << ", " << by << " after " << passes << " passes";
                EXPECT_LT(r, rHigh) << "block " << bx << ", " << by << " after " << passes << " passes";
                // Exact: the radius is sqrt(k / (π · count / 64)) of an integer count.
                const double count = countFromRadius(r, s.neighbours);
                EXPECT_NEAR(count, std::round(count), 1e-9 * count);
                countSum += std::round(count);
            }
        // Every photon fell in a dense block and is counted once per finished pass ("about k
        // earlier photons": the counts accumulate over passes, so the radius keeps shrinking).
        EXPECT_EQ(countSum, trials) << "after " << passes << " passes";
        if (passes == 1) {
            splatUniform();
            film.endPass(n);
        }
    }

    // A block far denser than k per π px² is clamped to 1 px: 40000 photons in block (0, 0) give
    // 625 per px², r = sqrt(400 / (625π)) = 0.45 px before the clamp.
    for (int i = 0; i < 40000; ++i) film.splat(0, sensorAt(s, 8.0 * rng.uniform(), 8.0 * rng.uniform()), glm::dvec3(0.0), false);
    film.endPass(40000);
    EXPECT_EQ(film.radiusPx(0, sensorAt(s, 4.0, 4.0)), 1.0);
    // Counts are per layer: the other layer has seen nothing.
    EXPECT_EQ(film.radiusPx(1, sensorAt(s, 64.0, 64.0)), s.maxRadiusPx);

    // Splats use that radius: a probe photon in a dense block, one in an empty block and one in
    // the clamped block cover exactly the pixel centres of positive weight at radiusPx.
    for (const glm::dvec2 probe : {glm::dvec2(60.3, 70.6), glm::dvec2(112.2, 20.7), glm::dvec2(4.4, 3.7)}) {
        const double r = film.radiusPx(0, sensorAt(s, probe.x, probe.y));
        film.splat(0, sensorAt(s, probe.x, probe.y), {1.0, 1.0, 1.0});
        const std::vector<float> xyz = film.irradianceXyz(0, 1.0);
        int mismatches = 0, covered = 0;
        for (int y = 0; y < s.heightPx; ++y)
            for (int x = 0; x < s.widthPx; ++x) {
                const bool inside = kernelWeight(r, x + 0.5 - probe.x, y + 0.5 - probe.y) > 0.0;
                covered += inside;
                mismatches += inside != (xyz[(static_cast<size_t>(y) * s.widthPx + x) * 3 + 1] > 0.0f);
            }
        EXPECT_EQ(mismatches, 0) << "probe at " << probe.x << ", " << probe.y << " with r = " << r;
        EXPECT_GE(covered, 4);
        EXPECT_NEAR(layerPowerW(film, 0, 1.0).y, 1.0, kFloatRelative);
        // Remove the probe again (x + a − a is exactly x = 0) before the next one.
        film.splat(0, sensorAt(s, probe.x, probe.y), {-1.0, -1.0, -1.0});
    }
}

// A count block cut by the image's right or bottom edge (width or height not a multiple of 8) has
// its density over the part that lies on the image; counting the whole 64 px² would make its
// radius √2 too wide where half the block is on the image (a regression test: that was the bug).
TEST(Film, AdaptiveRadiusIsRightInBlocksCutByTheImageEdge) {
    // 36 × 16 px: four whole block columns and a fifth of 4 × 8 px. Uniform density ρ = 16 per px².
    FilmSettings s = filmSettings(36, 16, Kernel::Adaptive);
    s.neighbours = 400;
    s.maxRadiusPx = 8.0;
    Film film(s, 1);
    const int n = 16 * 36 * 16;
    Rng rng(8, 0);
    for (int i = 0; i < n; ++i) film.splat(0, sensorAt(s, 36.0 * rng.uniform(), 16.0 * rng.uniform()), {1.0, 1.0, 1.0}, false);
    film.endPass(n);
    // A block of A px² (64 or 32) holds Binomial(N, A/576) photons; the radius for its density
    // count/A must lie within the radii of μ ± z σ, z two-sided at 1e-4 Bonferroni-corrected over
    // the 10 blocks.
    const double z = test::normalTwoSidedCritical(1e-4 / 10);
    for (int by = 0; by < 2; ++by)
        for (int bx = 0; bx < 5; ++bx) {
            const double area = bx < 4 ? 64.0 : 32.0;
            const double p = area / (36.0 * 16.0), mu = n * p, sigma = std::sqrt(n * p * (1.0 - p));
            const double rLow = std::sqrt(s.neighbours / (std::numbers::pi * (mu + z * sigma) / area));
            const double rHigh = std::sqrt(s.neighbours / (std::numbers::pi * (mu - z * sigma) / area));
            const double r = film.radiusPx(0, sensorAt(s, bx * 8 + 2.0, by * 8 + 4.0));
            EXPECT_GT(r, rLow) << "block " << bx << ", " << by;
            EXPECT_LT(r, rHigh) << "block " << bx << ", " << by << " (area " << area << " px²; expected r ≈ "
                                << std::sqrt(s.neighbours / (std::numbers::pi * 16.0)) << ")";
        }
}

TEST(Film, VarianceEstimateMatchesTheKnownVarianceOfTheMean) {
    // Every pass: m photons at the centre of pixel (5, 9) (the tent puts all of a photon there),
    // each of power P · w with P ~ Normal(μ, σ²) and w a fixed XYZ colour. The pass image of
    // channel c is g_c ΣP / (m A) with g = xyzToLinearSrgb(w) (linear) and A the pixel area, so
    // its variance is g_c² σ² / (m A²), and the variance of the mean of n passes is that over n.
    // The film's estimate V is the unbiased sample variance over n, so for normal P,
    // (n − 1) V / Var(mean) ~ χ²(n − 1) exactly; two-sided bounds at p = 1e-4 (the channels are
    // exact multiples of one another: one test).
    const int n = 400, m = 4;
    const double mu = 5.0, sigma = 2.0;
    const glm::dvec3 w(0.4, 0.3, 0.2);
    const FilmSettings s = filmSettings(16, 16);
    Film film(s, 2), withExtra(s, 2);
    const glm::dvec2 at = sensorAt(s, 5.5, 9.5);
    EXPECT_TRUE(film.varianceRgb().empty());
    Rng rng(2024, 1), extra(2024, 2);
    for (int pass = 0; pass < n; ++pass) {
        for (int i = 0; i < m; ++i) {
            // Box–Muller from two uniforms.
            const double u1 = rng.uniform(), u2 = rng.uniform();
            const double power = mu + sigma * std::sqrt(-2.0 * std::log(1.0 - u1)) * std::cos(2.0 * std::numbers::pi * u2);
            // Half the photons in each layer: the variance is that of the total of the layers.
            film.splat(i % 2, at, power * w);
            withExtra.splat(i % 2, at, power * w);
            // Splats outside the total must not touch the variance.
            withExtra.splat(1, sensorAt(s, 5.5 + 3.0 * extra.uniform(), 9.5), 10.0 * extra.uniform() * w, false);
        }
        film.endPass(m);
        withExtra.endPass(m);
        if (pass == 0) EXPECT_TRUE(film.varianceRgb().empty()) << "one pass gives no spread";
    }
    const std::vector<float> variance = film.varianceRgb();
    ASSERT_EQ(variance.size(), static_cast<size_t>(s.widthPx * s.heightPx * 3));
    EXPECT_EQ(withExtra.varianceRgb(), variance);

    const glm::dvec3 g = xyzToLinearSrgb(w);
    const double area = pixelAreaM2(film);
    const double lower = test::chiSquaredLowerCritical(n - 1, 0.5e-4), upper = test::chiSquaredUpperCritical(n - 1, 0.5e-4);
    const size_t pixel = (9 * 16 + 5) * 3;
    for (int c = 0; c < 3; ++c) {
        const double varianceOfMean = g[c] * g[c] * sigma * sigma / (m * area * area) / n;
        const double statistic = (n - 1) * variance[pixel + c] / varianceOfMean;
        EXPECT_GT(statistic, lower) << "channel " << c;
        EXPECT_LT(statistic, upper) << "channel " << c;
    }
    // Every other pixel saw nothing: zero variance.
    for (size_t i = 0; i < variance.size(); ++i)
        if (i < pixel || i >= pixel + 3) ASSERT_EQ(variance[i], 0.0f) << "index " << i;
}

TEST(Film, VarianceIsTheSampleVarianceOfThePassImagesOverThePassCount) {
    // Deterministic: pass p holds one photon of power x_p · w (x_p = 1, 2, ..., 10) at a fixed point,
    // spread by the Epanechnikov kernel (r = 2.5 px) with shares k_i. Pixel i's pass image in
    // channel c is x_p k_i g_c / A, so its estimate must be (k_i g_c / A)² Σ (x − x̄)² / (n − 1) / n.
    // Tolerance: one float rounding (6e-8) plus the double cancellation in Σx² − n x̄² (x̄² / s² ≈ 3
    // here, so ~1e-15): 1e-6 relative.
    const FilmSettings s = filmSettings(16, 16, Kernel::Fixed, 2.5);
    Film film(s, 2);
    const glm::dvec2 p(6.3, 8.9);
    const glm::dvec3 w(0.4, 0.3, 0.2);
    const int n = 10;
    double mean = 0.0;
    for (int pass = 0; pass < n; ++pass) {
        film.splat(0, sensorAt(s, p.x, p.y), (1.0 + pass) * w);
        film.splat(1, sensorAt(s, 2.0, 3.0), 5.0 * w, false);  // outside the total
        film.endPass(1);
        mean += (1.0 + pass) / n;
    }
    double sumSquares = 0.0;
    for (int pass = 0; pass < n; ++pass) sumSquares += (1.0 + pass - mean) * (1.0 + pass - mean);
    const double varianceOfMean = sumSquares / (n - 1) / n;
    double total = 0.0;
    for (int y = -8; y < 24; ++y)
        for (int x = -8; x < 24; ++x) total += kernelWeight(2.5, x + 0.5 - p.x, y + 0.5 - p.y);
    const glm::dvec3 g = xyzToLinearSrgb(w);
    const std::vector<float> variance = film.varianceRgb();
    int covered = 0;
    for (int y = 0; y < s.heightPx; ++y)
        for (int x = 0; x < s.widthPx; ++x) {
            const double k = kernelWeight(2.5, x + 0.5 - p.x, y + 0.5 - p.y) / total;
            covered += k > 0.0;
            for (int c = 0; c < 3; ++c) {
                const double expected = std::pow(k * g[c] / pixelAreaM2(film), 2) * varianceOfMean;
                ASSERT_NEAR(variance[(static_cast<size_t>(y) * s.widthPx + x) * 3 + c], expected, 1e-6 * expected)
                    << "pixel " << x << ", " << y << " channel " << c;
            }
        }
    EXPECT_GT(covered, 15);
}

// With K replicates the variance of the mean is the replicates' spread (core/Replicates.h):
// Σ n_r (M_r − T)² / ((K − 1) P), M_r the mean of replicate r's n_r passes (pass p in replicate
// p mod K) and T the mean of all P. Deterministic: pass p holds one photon of power x_p · w at a
// pixel centre, x_p = 1, 4, 9, ... (P = 10 over K = 3: n = 4, 3, 3). Tolerance: a float rounding.
TEST(Film, ReplicateVarianceIsTheSpreadOfTheReplicateMeans) {
    const FilmSettings s = filmSettings(8, 8);
    Film film(s, 1);
    const int replicates = 3, passes = 10;
    film.setReplicates(replicates);
    EXPECT_EQ(film.replicates(), replicates);
    const glm::dvec3 w(0.4, 0.3, 0.2);
    double sum[replicates] = {}, total = 0.0;
    int count[replicates] = {};
    for (int pass = 0; pass < passes; ++pass) {
        const double x = (1.0 + pass) * (1.0 + pass);
        film.splat(0, sensorAt(s, 2.5, 5.5), x * w);
        film.endPass(1);
        sum[pass % replicates] += x, ++count[pass % replicates], total += x;
        if (pass < replicates - 1) EXPECT_TRUE(film.varianceRgb().empty()) << "a replicate without a pass";
    }
    double spread = 0.0;
    for (int r = 0; r < replicates; ++r) spread += count[r] * std::pow(sum[r] / count[r] - total / passes, 2);
    const double varianceOfMean = spread / ((replicates - 1) * passes);
    const glm::dvec3 g = xyzToLinearSrgb(w);
    const std::vector<float> variance = film.varianceRgb();
    const size_t pixel = (5 * 8 + 2) * 3;
    for (int c = 0; c < 3; ++c) {
        const double expected = std::pow(g[c] / pixelAreaM2(film), 2) * varianceOfMean;
        EXPECT_NEAR(variance[pixel + c], expected, 1e-6 * expected) << "channel " << c;
    }
    double squaredNorm = 0.0;
    for (int c = 0; c < 3; ++c) squaredNorm += std::pow(g[c] / pixelAreaM2(film) * total / passes, 2);
    const Film::ErrorEstimate e = film.errorEstimate(0);
    EXPECT_NEAR(e.squaredNorm, squaredNorm, 1e-9 * squaredNorm);
    EXPECT_NEAR(e.sumVariance, (variance[pixel] + variance[pixel + 1] + variance[pixel + 2]), 1e-6 * e.sumVariance);
    EXPECT_THROW(film.setReplicates(2), std::logic_error) << "after the first pass";
    Film other(s, 1);
    EXPECT_THROW(other.setReplicates(1), std::invalid_argument);
    EXPECT_THROW(other.setReplicates(kMaxReplicates + 1), std::invalid_argument);
}

// Why replicates: passes that continue a stratified sequence are correlated, and the spread of
// the passes overstates the error of their mean many times over. Each trial runs two replicates,
// each a van der Corput sequence rotated by its own uniform shift (a randomised quasi-random
// sequence, like the beams'), one photon of power f(x) = x² per pass. Over many trials the mean
// of the replicate estimate must equal the variance of the trials' means (a z-test whose
// standard error comes from both samples' own spread), while the pass-spread estimate of the
// same passes is refused (it is more than 5× too large).
TEST(Film, ReplicatesEstimateTheVarianceOfCorrelatedPasses) {
    const FilmSettings s = filmSettings(4, 4);
    const int trials = 4000, passes = 16, replicates = 2;
    const glm::dvec3 w(0.2, 0.3, 0.1);
    const size_t pixel = (1 * 4 + 1) * 3 + 1;  // the green channel of pixel (1, 1)
    auto vanDerCorput = [](unsigned j) {
        double x = 0.0, digit = 0.5;
        for (; j; j >>= 1, digit *= 0.5) x += (j & 1u) * digit;
        return x;
    };
    Rng rng(77, 3);
    std::vector<double> means, estimates, passEstimates;
    for (int trial = 0; trial < trials; ++trial) {
        Film film(s, 1), byPasses(s, 1);
        film.setReplicates(replicates);
        const double shift[replicates] = {rng.uniform(), rng.uniform()};
        for (int pass = 0; pass < passes; ++pass) {
            const double x = std::fmod(vanDerCorput(static_cast<unsigned>(pass / replicates)) + shift[pass % replicates], 1.0);
            for (Film* f : {&film, &byPasses}) {
                f->splat(0, sensorAt(s, 1.5, 1.5), x * x * w);
                f->endPass(1);
            }
        }
        const std::vector<float> xyz = film.irradianceXyz(0, passes);
        means.push_back(xyzToLinearSrgb({xyz[pixel - 1], xyz[pixel], xyz[pixel + 1]}).y);
        estimates.push_back(film.varianceRgb()[pixel]);
        passEstimates.push_back(byPasses.varianceRgb()[pixel]);
    }
    auto meanOf = [](const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0) / v.size(); };
    const double m = meanOf(means);
    double m2 = 0.0, m4 = 0.0;
    for (double v : means) m2 += std::pow(v - m, 2), m4 += std::pow(v - m, 4);
    m2 /= trials - 1;
    m4 /= trials;
    const double trueVariance = m2, trueVarianceError = std::sqrt((m4 - m2 * m2) / trials);
    const double estimated = meanOf(estimates);
    double e2 = 0.0;
    for (double v : estimates) e2 += std::pow(v - estimated, 2);
    const double estimatedError = std::sqrt(e2 / (trials - 1) / trials);
    const double z = (estimated - trueVariance) / std::hypot(estimatedError, trueVarianceError);
    EXPECT_LT(std::abs(z), 4.0) << "estimated " << estimated << ", true " << trueVariance;
    EXPECT_GT(meanOf(passEstimates), 5.0 * trueVariance) << "the pass spread should overstate correlated passes";
}

// Random photons over and around a film, in two layers, some outside the total.
void randomPass(Film& film, Rng& rng, int photons) {
    const FilmSettings& s = film.settings();
    for (int i = 0; i < photons; ++i) {
        const glm::dvec2 p(-3.0 + (s.widthPx + 6.0) * rng.uniform(), -3.0 + (s.heightPx + 6.0) * rng.uniform());
        const glm::dvec3 power(rng.uniform(), rng.uniform(), rng.uniform());
        film.splat(rng.uniform() < 0.5 ? 0 : 1, sensorAt(s, p.x, p.y), power, rng.uniform() < 0.8);
    }
    film.endPass(photons);
}

std::string saved(const Film& film) {
    std::ostringstream out;
    film.save(out);
    return out.str();
}

void expectSameFilm(const Film& a, const Film& b) {
    EXPECT_EQ(a.passes(), b.passes());
    for (int l = 0; l < a.layerCount(); ++l) EXPECT_EQ(a.irradianceXyz(l, 1000.0), b.irradianceXyz(l, 1000.0)) << "layer " << l;
    EXPECT_EQ(a.varianceRgb(), b.varianceRgb());
    const FilmSettings& s = a.settings();
    for (int l = 0; l < a.layerCount(); ++l)
        for (int y = 0; y < s.heightPx; y += 3)
            for (int x = 0; x < s.widthPx; x += 3)
                EXPECT_EQ(a.radiusPx(l, sensorAt(s, x + 0.5, y + 0.5)), b.radiusPx(l, sensorAt(s, x + 0.5, y + 0.5)));
}

TEST(Film, CheckpointRoundTripIsExactAndTheRenderContinuesIdentically) {
    for (const Kernel kernel : {Kernel::Adaptive, Kernel::Fixed, Kernel::Progressive}) {
        FilmSettings s = filmSettings(40, 35, kernel, kernel == Kernel::Fixed ? 2.5 : 3.0);
        s.neighbours = 10;
        s.maxRadiusPx = 6.0;
        Film original(s, 2);
        Rng rng(55, static_cast<int>(kernel));
        for (int pass = 0; pass < 3; ++pass) randomPass(original, rng, 400);
        const std::string bytes = saved(original);

        Film restored(s, 2);
        std::istringstream in(bytes);
        restored.load(in);
        expectSameFilm(original, restored);
        EXPECT_EQ(saved(restored), bytes);

        // A fourth pass with the same photons: the counts (adaptive radius), the pass number
        // (progressive radius) and the variance sums must have been restored.
        Rng a(56, 0), b(56, 0);
        randomPass(original, a, 400);
        randomPass(restored, b, 400);
        expectSameFilm(original, restored);
    }
}

// Replicates' sums are part of the checkpoint: a film resumed from one continues identically,
// and a film with another replicate count refuses it.
TEST(Film, ReplicatesSurviveACheckpoint) {
    const FilmSettings s = filmSettings(40, 35, Kernel::Fixed, 2.5);
    Film original(s, 2);
    original.setReplicates(3);
    Rng rng(58, 0);
    for (int pass = 0; pass < 4; ++pass) randomPass(original, rng, 300);
    const std::string bytes = saved(original);
    Film restored(s, 2);
    restored.setReplicates(3);
    std::istringstream in(bytes);
    restored.load(in);
    expectSameFilm(original, restored);
    Rng a(59, 0), b(59, 0);
    for (int pass = 0; pass < 2; ++pass) {
        randomPass(original, a, 300);
        randomPass(restored, b, 300);
    }
    expectSameFilm(original, restored);
    EXPECT_EQ(original.errorEstimate(0).sumVariance, restored.errorEstimate(0).sumVariance);
    for (int replicates : {0, 2}) {
        Film other(s, 2);
        if (replicates) other.setReplicates(replicates);
        std::istringstream again(bytes);
        EXPECT_THROW(other.load(again), std::runtime_error) << replicates << " replicates";
    }
}

TEST(Film, LoadRejectsACheckpointOfAnotherFilm) {
    FilmSettings s = filmSettings(40, 32, Kernel::Adaptive);
    Film original(s, 2);
    Rng rng(57, 0);
    randomPass(original, rng, 200);
    randomPass(original, rng, 200);
    const std::string bytes = saved(original);

    auto loadInto = [&](const FilmSettings& settings, int layers, const std::string& data) {
        Film film(settings, layers);
        std::istringstream in(data);
        film.load(in);
    };
    EXPECT_NO_THROW(loadInto(s, 2, bytes));
    EXPECT_THROW(loadInto(filmSettings(48, 32, Kernel::Adaptive), 2, bytes), std::runtime_error);  // wider
    EXPECT_THROW(loadInto(filmSettings(40, 40, Kernel::Adaptive), 2, bytes), std::runtime_error);  // taller
    EXPECT_THROW(loadInto(s, 3, bytes), std::runtime_error);                                         // more layers
    EXPECT_THROW(loadInto(s, 1, bytes), std::runtime_error);                                         // fewer layers
    EXPECT_THROW(loadInto(filmSettings(40, 32, Kernel::Fixed), 2, bytes), std::runtime_error);     // another kernel
    EXPECT_THROW(loadInto(s, 2, bytes.substr(0, bytes.size() / 2)), std::runtime_error);            // truncated
    EXPECT_THROW(loadInto(s, 2, bytes.substr(0, bytes.size() - 1)), std::runtime_error);            // one byte short
    EXPECT_THROW(loadInto(s, 2, std::string("not a film checkpoint at all")), std::runtime_error);
    EXPECT_THROW(loadInto(s, 2, std::string()), std::runtime_error);
    // A layer given its own kernel is part of the film: another layer kernel is refused.
    Film fixed(filmSettings(40, 32), 2);
    fixed.setLayerKernel(1, Kernel::Adaptive, 64, 6.0);
    randomPass(fixed, rng, 100);
    const std::string withLayerKernel = saved(fixed);
    auto loadWithKernel = [&](int neighbours) {
        Film film(filmSettings(40, 32), 2);
        film.setLayerKernel(1, Kernel::Adaptive, neighbours, 6.0);
        std::istringstream in(withLayerKernel);
        film.load(in);
    };
    EXPECT_NO_THROW(loadWithKernel(64));
    EXPECT_THROW(loadWithKernel(65), std::runtime_error);
    EXPECT_THROW(loadInto(filmSettings(40, 32), 2, withLayerKernel), std::runtime_error);
}

// A layer's own kernel: an adaptive layer beside a fixed one spreads its photons by its own
// radius (the widest before any count), conserves their power, and the fixed layer is untouched.
TEST(Film, ALayerCanHaveItsOwnAdaptiveKernel) {
    const FilmSettings s = filmSettings(128, 128);
    Film film(s, 2);
    film.setLayerKernel(1, Kernel::Adaptive, 100, 10.0);
    EXPECT_EQ(film.layerKernel(0), Kernel::Fixed);
    EXPECT_EQ(film.layerKernel(1), Kernel::Adaptive);
    EXPECT_EQ(film.radiusPx(0, sensorAt(s, 64.0, 64.0)), 1.0);
    EXPECT_EQ(film.radiusPx(1, sensorAt(s, 64.0, 64.0)), 10.0);
    film.splat(0, sensorAt(s, 64.0, 64.0), {1.0, 1.0, 1.0});
    film.splat(1, sensorAt(s, 64.0, 64.0), {1.0, 1.0, 1.0});
    film.endPass(1);
    for (int layer = 0; layer < 2; ++layer) {
        const std::vector<float> img = film.irradianceXyz(layer, 1.0);
        double power = 0.0;
        int lit = 0;
        for (size_t i = 1; i < img.size(); i += 3) power += img[i], lit += img[i] > 0.0f;
        power *= film.pixelMm() * film.pixelMm() * 1e-6;  // W/m² × pixel area
        EXPECT_NEAR(power, 1.0, 1e-6) << layer;
        // The fixed tent of radius 1 covers the 4 nearest centres; radius 10 about π·10² of them.
        if (layer == 0) EXPECT_LE(lit, 4);
        if (layer == 1) EXPECT_GT(lit, 250);
    }
    // After a pass, the adaptive layer's radius follows its own count: 400 photons in one 8 × 8
    // block give 6.25 per px² and r = sqrt(100 / (6.25 π)); the fixed layer keeps its radius.
    for (int i = 0; i < 400; ++i) film.splat(1, sensorAt(s, 60.0 + 0.001 * i, 60.0), glm::dvec3(0.0), false);
    film.endPass(1);
    EXPECT_NEAR(film.radiusPx(1, sensorAt(s, 60.0, 60.0)), std::sqrt(100.0 / (6.25 * std::numbers::pi)), 1e-12);
    EXPECT_EQ(film.radiusPx(0, sensorAt(s, 60.0, 60.0)), 1.0);
    EXPECT_THROW(film.setLayerKernel(1, Kernel::Adaptive, 100, 10.0), std::logic_error);  // after a pass
}

// A checkpoint whose sum tile is present but whose sum-of-squares tile is absent must be refused
// (it used to load, and varianceRgb() then dereferenced a missing tile). The byte layout below is
// Film::save's (magic, seven int32, per layer its kernel (two int32 and a double), then per tile a
// flag byte and 32 × 32 × 3 doubles).
TEST(Film, LoadRejectsAnInconsistentCheckpoint) {
    const FilmSettings s = filmSettings(32, 32);  // a single tile, Fixed kernel (no counts)
    Film original(s, 1);
    for (int pass = 0; pass < 2; ++pass) {
        original.splat(0, sensorAt(s, 10.5, 10.5), {1.0, 1.0, 1.0});
        original.endPass(1);
    }
    std::string bytes = saved(original);
    const size_t tileBytes = 32 * 32 * 3 * sizeof(double);
    ASSERT_EQ(bytes.size(), 8 + 7 * 4 + (4 + 4 + 8 + 1) + 1 + 3 * (1 + tileBytes));  // 1: the layer's precision
    bytes.resize(bytes.size() - tileBytes);  // drop the sum-of-squares tile ...
    bytes.back() = 0;                        // ... and mark it absent
    Film restored(s, 1);
    std::istringstream in(bytes);
    try {
        restored.load(in);
    } catch (const std::runtime_error&) {
        return;  // rejected: fine
    }
    EXPECT_EQ(restored.varianceRgb().size(), static_cast<size_t>(32 * 32 * 3));
}

// A layer's footprint is the bounding box of its non-zero pixels, with irradianceXyz's values there
// and zeros outside; its tiles are allocated only where light landed, in proportion to the
// footprint, not the frame.
TEST(Film, FootprintIsTheBoundingBoxOfTheLitPixels) {
    const FilmSettings s = filmSettings(256, 160);
    Film film(s, 3);
    film.setLayerSinglePrecision(2);
    // Layer 1 (double) and layer 2 (float): the same splats, at pixel centres and between them
    // (the tent shares a splat among up to four pixels), in a box from (40, 70) to (71, 90).
    for (int pass = 0; pass < 3; ++pass) {
        for (const auto& [px, py] : std::vector<std::pair<double, double>>{{40.5, 70.5}, {71.5, 90.5}, {55.25, 80.75}, {60.0, 72.0}})
            for (int layer : {1, 2}) film.splat(layer, sensorAt(s, px, py), {1.0 / 3.0, 2.0 / 7.0, 0.1 * (pass + 1)}, false);
        film.endPass(1000);
    }
    const double photons = 3000.0;
    EXPECT_TRUE(film.irradianceXyzFootprint(0, photons).empty());
    EXPECT_EQ(film.layerBytes(0), 0u);
    for (int layer : {1, 2}) {
        const std::vector<float> full = film.irradianceXyz(layer, photons);
        const FilmWindow window = film.irradianceXyzFootprint(layer, photons);
        EXPECT_EQ(window.x, 40);
        EXPECT_EQ(window.y, 70);
        EXPECT_EQ(window.width, 32);
        EXPECT_EQ(window.height, 21);
        for (int y = 0; y < s.heightPx; ++y)
            for (int x = 0; x < s.widthPx; ++x)
                for (int c = 0; c < 3; ++c) {
                    const float value = full[(static_cast<size_t>(y) * s.widthPx + x) * 3 + c];
                    const bool inside = x >= window.x && x < window.x + window.width && y >= window.y &&
                                        y < window.y + window.height;
                    if (!inside) ASSERT_EQ(value, 0.0f);
                    else ASSERT_EQ(value, window.xyz[(static_cast<size_t>(y - window.y) * window.width + (x - window.x)) * 3 + c]);
                }
        // Tiles (32 × 32) touched: columns 32–63 and 64–95, rows 64–95: two tiles of 40 (256 × 160).
        EXPECT_EQ(film.layerBytes(layer), 2u * 32 * 32 * 3 * (layer == 2 ? sizeof(float) : sizeof(double)));
        // The same two tiles in pixels, whatever the layer's precision (`flare render`'s --time
        // forecast counts a ghost layer's read-out by them).
        EXPECT_EQ(film.layerTilePixels(layer), 2u * 32 * 32);
    }
    EXPECT_EQ(film.layerTilePixels(0), 0u);
    // Single precision: each pixel within the rounding of its few additions (3 passes × at most
    // 4 splats, each adding one float rounding, 2⁻²⁴ of the running sum) of the double layer's.
    const std::vector<float> exact = film.irradianceXyz(1, photons), single = film.irradianceXyz(2, photons);
    for (size_t i = 0; i < exact.size(); ++i)
        ASSERT_NEAR(single[i], exact[i], (12 + 1) * std::ldexp(std::abs(exact[i]), -24)) << i;
    film.clearLayer(2);
    EXPECT_TRUE(film.irradianceXyzFootprint(2, photons).empty());
    EXPECT_EQ(film.layerBytes(2), 0u);
    EXPECT_THROW(film.setLayerSinglePrecision(0), std::logic_error);  // after the first pass
}

// A checkpoint keeps single-precision layers as they are, and refuses a film whose layers differ in
// precision.
TEST(Film, SinglePrecisionLayersSurviveACheckpoint) {
    const FilmSettings s = filmSettings(64, 64);
    Film film(s, 2);
    film.setLayerSinglePrecision(1);
    for (int pass = 0; pass < 2; ++pass) {
        film.splat(1, sensorAt(s, 20.3, 30.7), {1.0, 1.0, 1.0}, false);
        film.splat(0, sensorAt(s, 20.3, 30.7), {1.0, 1.0, 1.0});
        film.endPass(10);
    }
    const std::string bytes = saved(film);
    Film same(s, 2);
    same.setLayerSinglePrecision(1);
    std::istringstream in(bytes);
    same.load(in);
    EXPECT_EQ(same.irradianceXyz(1, 20.0), film.irradianceXyz(1, 20.0));
    EXPECT_EQ(same.irradianceXyz(0, 20.0), film.irradianceXyz(0, 20.0));
    Film doubles(s, 2);
    std::istringstream again(bytes);
    EXPECT_THROW(doubles.load(again), std::runtime_error);
}

TEST(Film, InvalidSettingsThrow) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    auto make = [](auto&& change) {
        FilmSettings s = filmSettings(64, 48, Kernel::Adaptive, 2.0);
        change(s);
        Film film(s, 1);
    };
    EXPECT_NO_THROW(make([](FilmSettings&) {}));
    EXPECT_THROW(make([](FilmSettings& s) { s.widthPx = 0; }), std::invalid_argument);
    EXPECT_THROW(make([](FilmSettings& s) { s.heightPx = -4; }), std::invalid_argument);
    EXPECT_THROW(make([](FilmSettings& s) { s.widthMm = 0.0; }), std::invalid_argument);
    EXPECT_THROW(make([&](FilmSettings& s) { s.heightMm = nan; }), std::invalid_argument);
    EXPECT_THROW(make([&](FilmSettings& s) { s.widthMm = nan; }), std::invalid_argument);
    EXPECT_THROW(make([](FilmSettings& s) { s.heightMm = -6.0; }), std::invalid_argument);
    EXPECT_THROW(make([](FilmSettings& s) { s.heightMm *= 1.01; }), std::invalid_argument);  // non-square pixels
    EXPECT_THROW(make([](FilmSettings& s) { s.radiusPx = 0.0; }), std::invalid_argument);
    EXPECT_THROW(make([&](FilmSettings& s) { s.radiusPx = nan; }), std::invalid_argument);
    EXPECT_THROW(make([](FilmSettings& s) { s.neighbours = 0; }), std::invalid_argument);
    EXPECT_THROW(make([](FilmSettings& s) { s.maxRadiusPx = 0.5; }), std::invalid_argument);
    EXPECT_THROW(make([](FilmSettings& s) { s.progressiveAlpha = 0.0; }), std::invalid_argument);
    EXPECT_THROW(make([](FilmSettings& s) { s.progressiveAlpha = 1.0; }), std::invalid_argument);
}

// From Film::kWideKernelPx on, an adaptive layer's kernel is the separable tent of half-width
// m = round(r) about the pixel centre nearest the photon, (m − |dx|)(m − |dy|)/m⁴, added at the
// end of the pass: every pixel holds exactly its share (the off-image part is lost), a banded
// splat is the same image, and before endPass nothing shows.
TEST(Film, WideKernelsAreTheDocumentedTentAddedAtTheEndOfThePass) {
    FilmSettings s = filmSettings(120, 90, Kernel::Adaptive);
    s.maxRadiusPx = 20.3;  // no counts yet: every photon gets it, m = 20
    const int m = 20;
    const glm::dvec3 power(0.5, 1.5, 3.0);
    // Inside, near a corner (part off the image) and off the image by more than the half-width
    // in x (only its far tail is on it).
    const glm::dvec2 points[] = {{60.3, 41.8}, {4.6, 85.2}, {-12.5, 30.1}};
    for (const glm::dvec2& p : points) {
        Film whole(s, 1), banded(s, 1);
        whole.splat(0, sensorAt(s, p.x, p.y), power);
        for (int band = 0; band < banded.bandCount(); ++band)
            banded.splatInBand(band, 0, sensorAt(s, p.x, p.y), power);
        EXPECT_EQ(layerPowerW(whole, 0, 1.0), glm::dvec3(0.0)) << "before the end of the pass";
        whole.endPass(1);
        banded.endPass(1);
        EXPECT_EQ(whole.irradianceXyz(0, 1.0), banded.irradianceXyz(0, 1.0));
        const int cx = static_cast<int>(std::floor(p.x)), cy = static_cast<int>(std::floor(p.y));
        auto weight = [&](int x, int y) {
            return std::max(0, m - std::abs(x - cx)) * std::max(0, m - std::abs(y - cy)) / std::pow(m, 4.0);
        };
        double onImage = 0.0;
        const std::vector<float> xyz = whole.irradianceXyz(0, 1.0);
        for (int y = 0; y < s.heightPx; ++y)
            for (int x = 0; x < s.widthPx; ++x) {
                const double expected = power.z * weight(x, y) / pixelAreaM2(whole);
                onImage += weight(x, y);
                ASSERT_NEAR(xyz[(static_cast<size_t>(y) * s.widthPx + x) * 3 + 2], expected, kFloatRelative * expected + 1e-30)
                    << "at " << p.x << ", " << p.y << ": pixel " << x << ", " << y;
            }
        EXPECT_NEAR(layerPowerW(whole, 0, 1.0).y, onImage * power.y, kFloatRelative * power.y);
        EXPECT_GT(onImage, 0.0);
    }
}

// A layer whose adaptive kernel is by power: the radius holds k times the photon's own power of
// the earlier photons, so with equal weights it is the count rule, and a photon four times as
// heavy gets twice the radius (while both stay between 1 px and the largest radius).
TEST(Film, AKernelByPowerSpreadsAHeavyPhotonWider) {
    FilmSettings s = filmSettings(64, 64, Kernel::Fixed);
    Film film(s, 2);
    film.setLayerKernel(0, Kernel::Adaptive, 50, 30.0);        // by count
    film.setLayerKernel(1, Kernel::Adaptive, 50, 30.0, true);  // by power
    Rng rng(3, 0);
    const glm::dvec3 unit(1.0, 2.0, 1.0);  // kernelPower 4
    for (int i = 0; i < 4096; ++i) {
        const glm::dvec2 at = sensorAt(s, 64.0 * rng.uniform(), 64.0 * rng.uniform());
        film.splat(0, at, unit);
        film.splat(1, at, unit);
    }
    film.endPass(4096);
    const glm::dvec2 probe = sensorAt(s, 20.5, 36.5);
    const double byCount = film.radiusPx(0, probe);
    EXPECT_GT(byCount, 1.5);
    EXPECT_LT(byCount, 15.0);
    EXPECT_NEAR(film.radiusPx(1, probe, Film::kernelPower(unit)), byCount, 1e-12 * byCount);
    EXPECT_NEAR(film.radiusPx(1, probe, 4.0 * Film::kernelPower(unit)), 2.0 * byCount, 1e-12 * byCount);
    EXPECT_EQ(film.radiusPx(1, probe, 0.0), 1.0);
    // The count layer ignores the power.
    EXPECT_EQ(film.radiusPx(0, probe, 100.0), byCount);
}

// A distributed render's rank 0 ends its own bands' pass before the others' band images arrive
// (Film::beginEndPass, endPassInBand, finishEndPass): every band, ended when its additions are
// all in and in any order, gives bitwise the film of endPass, every layer, group and estimate.
// Wide kernels (added in endPassInBand, after the band's other additions) and tight ones, two
// layers, a further variance group (its estimate made as the bands end: estimateAtPassEnd), three
// passes, with independent passes and with replicates; one band's rows arrive after another band
// has ended (a wide kernel's rows added in beginEndPass would come before them and round otherwise).
TEST(Film, TheEndOfAPassInStepsIsTheWholeEndPassBitwise) {
  for (const int replicates : {0, 2}) {
    SCOPED_TRACE("replicates " + std::to_string(replicates));
    FilmSettings s = filmSettings(100, 90, Kernel::Adaptive);  // bands of rows 0-31, 32-63, 64-89
    s.maxRadiusPx = 20.3;  // no counts in the first pass: every photon a wide tent
    Film whole(s, 2), steps(s, 2);
    for (Film* film : {&whole, &steps}) {
        film->setLayerKernel(1, Kernel::Fixed, 1, 1.0);
        film->addVarianceGroup({1});
        film->setReplicates(replicates);
    }
    // Group 1's estimate made as each band ends (estimateAtPassEnd), group 0's when asked.
    steps.estimateAtPassEnd({1});
    Rng rng(7, 31);
    std::vector<double> rows(static_cast<size_t>(Film::kBandRows) * s.widthPx * 3);
    for (int pass = 0; pass < 3; ++pass) {
        for (int n = 0; n < 200; ++n) {
            const glm::dvec2 at = sensorAt(s, -10.0 + 120.0 * rng.uniform(), -10.0 + 110.0 * rng.uniform());
            const glm::dvec3 power(rng.uniform(), rng.uniform(), rng.uniform());
            const int layer = n % 2;
            whole.splat(layer, at, power, n % 3 != 0);
            for (int band = 0; band < steps.bandCount(); ++band) steps.splatInBand(band, layer, at, power, n % 3 != 0);
        }
        // Two images per band (two beams' layers), every other run of them lit: a pixel's
        // additions round differently in another order (a + b + wide against a + wide + b).
        std::vector<std::vector<double>> images;
        for (int band = 0; band < whole.bandCount(); ++band)
            for (int image = 0; image < 2; ++image) {
                for (size_t i = 0; i < rows.size(); ++i) rows[i] = (i / 96) % 2 == 0 ? rng.uniform() : 0.0;
                images.push_back(rows);
                whole.addBand(band, 0, rows.data());
            }
        steps.addBand(1, 0, images[2].data());
        steps.addBand(1, 0, images[3].data());
        steps.beginEndPass();
        steps.endPassInBand(1, 1000);
        steps.addBand(2, 0, images[4].data());
        steps.addBand(2, 0, images[5].data());
        steps.endPassInBand(2, 1000);
        // Band 0 row by row, as the band images' runs arrive (Film::addRowPart).
        for (int image = 0; image < 2; ++image)
            for (int y = 0; y < Film::kBandRows; ++y)
                steps.addRowPart(0, y, 0, s.widthPx, images[image].data() + static_cast<size_t>(y) * s.widthPx * 3);
        steps.endPassInBand(0, 1000);
        steps.finishEndPass();
        whole.endPass(1000);
        if (pass >= 1) {
            EXPECT_EQ(whole.errorEstimate(1).sumVariance, steps.errorEstimate(1).sumVariance) << "pass " << pass;
            EXPECT_EQ(whole.errorEstimate(1).squaredNorm, steps.errorEstimate(1).squaredNorm) << "pass " << pass;
            EXPECT_GT(steps.errorEstimate(1).sumVariance, 0.0);
        }
    }
    ASSERT_EQ(steps.passes(), 3);
    for (int layer = 0; layer < 2; ++layer) {
        const std::vector<float> a = whole.irradianceXyz(layer, 3000.0), b = steps.irradianceXyz(layer, 3000.0);
        EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0) << "layer " << layer;
        EXPECT_GT(*std::max_element(a.begin(), a.end()), 0.0f);
    }
    for (int group = 0; group < 2; ++group) {
        EXPECT_EQ(whole.varianceRgb(group), steps.varianceRgb(group)) << "group " << group;
        EXPECT_EQ(whole.errorEstimate(group).sumVariance, steps.errorEstimate(group).sumVariance) << "group " << group;
        EXPECT_EQ(whole.errorEstimate(group).squaredNorm, steps.errorEstimate(group).squaredNorm) << "group " << group;
    }
  }
}

}  // namespace
}  // namespace flare
