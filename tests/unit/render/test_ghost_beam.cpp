// Beams (GhostBeam): the jittered raster averages to the tent-filtered irradiance computed
// independently (exact polygon quadrature), small triangles splat their exact power, the power on
// the sensor is the clipped integral, twins land with the beam's irradiance, only the masked part
// of a region is kept, and the recovered irradiance keeps every triangle's power.
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "TestUtil.h"
#include "flare/core/Random.h"
#include "flare/ghosts/GhostAnalysis.h"
#include "flare/optics/PupilGrid.h"
#include "flare/render/GhostBeam.h"
#include "flare/scene/Scene.h"

namespace flare {
namespace {

constexpr int kWidth = 12, kHeight = 10;

FilmFrame smallFrame() { return {kWidth, kHeight, 12.0, 10.0, 1.0}; }

// A triangle with a given linear irradiance at its vertices (pixel coordinates).
BeamTriangle triangle(glm::dvec2 a, glm::dvec2 b, glm::dvec2 c, double ea, double eb, double ec, bool small = false) {
    BeamTriangle t;
    const glm::dvec2 p[3] = {a, b, c};
    const double e[3] = {ea, eb, ec};
    for (int k = 0; k < 3; ++k) {
        t.pixel[k] = p[k];
        t.pupilMm[k] = p[k] * 0.1;  // any non-degenerate pupil triangle
        t.irradiance[k] = e[k];
        t.throughput[k] = e[k];
    }
    t.imageAreaPx2 = 0.5 * std::abs((b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y));
    t.pupilAreaMm2 = 0.01 * t.imageAreaPx2;
    t.small = small;
    return t;
}

// The tent-filtered image of a triangle with linear irradiance, computed independently of the
// jittered raster: the triangle is clipped against each unit cell between four pixel centres
// (where the tent of each of them is bilinear) and (irradiance × tent) integrated over the pieces
// with Strang and Fix's 6-point rule, exact for polynomials of degree 4 (the integrand has degree
// 3). Pixel (i, j) has its centre at (i + 0.5, j + 0.5).
std::vector<double> exactTentImage(const BeamTriangle& t) {
    std::vector<double> image(kWidth * kHeight, 0.0);
    auto irradiance = [&](const glm::dvec2& p) {
        const glm::dvec2 a = t.pixel[0], b = t.pixel[1], c = t.pixel[2];
        const double d = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
        const double l1 = ((p.x - a.x) * (c.y - a.y) - (c.x - a.x) * (p.y - a.y)) / d;
        const double l2 = ((b.x - a.x) * (p.y - a.y) - (p.x - a.x) * (b.y - a.y)) / d;
        return (1 - l1 - l2) * t.irradiance[0] + l1 * t.irradiance[1] + l2 * t.irradiance[2];
    };
    auto clip = [](const std::vector<glm::dvec2>& in, int axis, double bound, bool below) {
        std::vector<glm::dvec2> out;
        for (size_t k = 0; k < in.size(); ++k) {
            const glm::dvec2 p = in[k], q = in[(k + 1) % in.size()];
            const double dp = below ? bound - p[axis] : p[axis] - bound, dq = below ? bound - q[axis] : q[axis] - bound;
            if (dp >= 0.0) out.push_back(p);
            if ((dp >= 0.0) != (dq >= 0.0)) out.push_back(p + (dp / (dp - dq)) * (q - p));
        }
        return out;
    };
    // Strang–Fix 6-point rule on a triangle (barycentric points and weights summing to 1).
    const double a1 = 0.816847572980459, b1 = 0.091576213509771, w1 = 0.109951743655322;
    const double a2 = 0.108103018168070, b2 = 0.445948490915965, w2 = 0.223381589678011;
    const double points[6][3] = {{a1, b1, b1}, {b1, a1, b1}, {b1, b1, a1}, {a2, b2, b2}, {b2, a2, b2}, {b2, b2, a2}};
    const double weights[6] = {w1, w1, w1, w2, w2, w2};
    // Light that falls off the sensor is not seen: the triangle is clipped to the sensor first.
    std::vector<glm::dvec2> onSensor = {t.pixel[0], t.pixel[1], t.pixel[2]};
    onSensor = clip(onSensor, 0, 0.0, false);
    onSensor = clip(onSensor, 0, kWidth, true);
    onSensor = clip(onSensor, 1, 0.0, false);
    onSensor = clip(onSensor, 1, kHeight, true);
    for (int cy = -1; cy <= kHeight; ++cy)
        for (int cx = -1; cx <= kWidth; ++cx) {
            // The cell between pixel centres (cx + 0.5, cy + 0.5) and (cx + 1.5, cy + 1.5).
            std::vector<glm::dvec2> poly = onSensor;
            poly = clip(poly, 0, cx + 0.5, false);
            poly = clip(poly, 0, cx + 1.5, true);
            poly = clip(poly, 1, cy + 0.5, false);
            poly = clip(poly, 1, cy + 1.5, true);
            for (size_t k = 1; k + 1 < poly.size(); ++k) {
                const glm::dvec2 p0 = poly[0], p1 = poly[k], p2 = poly[k + 1];
                const double area = 0.5 * std::abs((p1.x - p0.x) * (p2.y - p0.y) - (p2.x - p0.x) * (p1.y - p0.y));
                for (int q = 0; q < 6; ++q) {
                    const glm::dvec2 x = points[q][0] * p0 + points[q][1] * p1 + points[q][2] * p2;
                    const double value = area * weights[q] * irradiance(x);
                    // The four pixels at the cell's corners, with their tents' (bilinear) weights.
                    const double fx = x.x - (cx + 0.5), fy = x.y - (cy + 0.5);
                    for (int dy = 0; dy < 2; ++dy)
                        for (int dx = 0; dx < 2; ++dx) {
                            const int px = cx + dx, py = cy + dy;
                            if (px < 0 || py < 0 || px >= kWidth || py >= kHeight) continue;
                            image[py * kWidth + px] += value * (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy);
                        }
                }
            }
        }
    return image;
}

// The beam's raster for one jitter (Y only: scale (0, 1, 0)).
std::vector<double> raster(const GhostBeam& beam, const glm::dvec2& jitter, std::uint64_t seed) {
    std::vector<double> rows(static_cast<size_t>(kWidth) * 32 * 3, 0.0), image(kWidth * kHeight, 0.0);
    beam.rasterise(0, jitter, {0.0, 1.0, 0.0}, seed, rows.data());
    for (int i = 0; i < kWidth * kHeight; ++i) image[i] = rows[static_cast<size_t>(i) * 3 + 1];
    return image;
}

TEST(GhostBeam, TentJitterHasTheTentDistribution) {
    // χ² of 20 equal-width bins over [−1, 1] for each axis, 2e5 draws; the bins' probabilities
    // are the tent's integrals over them. Critical value at p = 1e-4 (19 degrees of freedom).
    constexpr int kBins = 20, kDraws = 200000;
    Rng rng(3, 9);
    std::vector<int> counts[2] = {std::vector<int>(kBins, 0), std::vector<int>(kBins, 0)};
    for (int i = 0; i < kDraws; ++i) {
        const glm::dvec2 d = tentJitter(rng.uniform(), rng.uniform());
        for (int a = 0; a < 2; ++a) {
            ASSERT_GE(d[a], -1.0);
            ASSERT_LE(d[a], 1.0);
            ++counts[a][std::min(kBins - 1, static_cast<int>((d[a] + 1.0) * 0.5 * kBins))];
        }
    }
    auto cdf = [](double x) { return x < 0.0 ? 0.5 * (1.0 + x) * (1.0 + x) : 1.0 - 0.5 * (1.0 - x) * (1.0 - x); };
    for (int a = 0; a < 2; ++a) {
        double chi2 = 0.0;
        for (int b = 0; b < kBins; ++b) {
            const double expected = kDraws * (cdf(-1.0 + 2.0 * (b + 1) / kBins) - cdf(-1.0 + 2.0 * b / kBins));
            chi2 += (counts[a][b] - expected) * (counts[a][b] - expected) / expected;
        }
        EXPECT_LT(chi2, test::chiSquaredUpperCritical(kBins - 1, 1e-4)) << "axis " << a;
    }
}

// The raster at jitters drawn from the tent, averaged, against the exact tent-filtered image:
// a z-test per pixel on the jitters' sample mean, Bonferroni-corrected over the pixels.
void expectRasterAveragesToTheTentImage(const BeamTriangle& t, std::uint64_t seed) {
    const GhostBeam beam = GhostBeam::fromTriangles({t}, smallFrame());
    const std::vector<double> exact = exactTentImage(t);
    constexpr int kJitters = 20000;
    std::vector<double> sum(kWidth * kHeight, 0.0), sumSquares(kWidth * kHeight, 0.0);
    Rng rng(seed, 1);
    for (int n = 0; n < kJitters; ++n) {
        const std::vector<double> image = raster(beam, tentJitter(rng.uniform(), rng.uniform()), seed + n);
        for (int i = 0; i < kWidth * kHeight; ++i) sum[i] += image[i], sumSquares[i] += image[i] * image[i];
    }
    const double z = test::normalTwoSidedCritical(1e-4 / (kWidth * kHeight));
    const double largest = std::max({t.irradiance[0], t.irradiance[1], t.irradiance[2]});
    int covered = 0;
    for (int i = 0; i < kWidth * kHeight; ++i) {
        const double mean = sum[i] / kJitters;
        // A pixel's sample lies in [0, largest irradiance], so its variance is at most
        // largest × its mean: a bound that holds where the triangle is rarely sampled (the
        // sample variance would be zero there).
        const double variance = std::max(0.0, sumSquares[i] / kJitters - mean * mean) / (kJitters - 1);
        const double bound = std::max(variance, largest * exact[i] / kJitters);
        covered += exact[i] > 0.0;
        // 1e-12: rounding of the exact quadrature where a pixel's image is (nearly) constant.
        EXPECT_LE(std::abs(mean - exact[i]), z * std::sqrt(bound) + 1e-12 * (1.0 + std::abs(exact[i])))
            << "pixel " << i % kWidth << ", " << i / kWidth << ": raster " << mean << ", exact " << exact[i];
    }
    EXPECT_GT(covered, 10);
}

TEST(GhostBeam, JitteredRasterAveragesToTheTentFilteredIrradiance) {
    // A large triangle with an irradiance gradient, reaching over the image's left edge.
    expectRasterAveragesToTheTentImage(triangle({-1.3, 1.2}, {9.7, 2.6}, {3.1, 8.9}, 1.0, 2.5, 0.4), 5);
}

TEST(GhostBeam, SmallTrianglesSplatTheirExactPowerAroundTheirImage) {
    // Wholly inside the image, a small triangle's splats carry its power: their sum (the tent's
    // weights sum to one) is the throughput at a few stratified points × the pupil area, whose
    // mean over seeds is the power (z-test at 1e-4 on the sample mean).
    const BeamTriangle t = triangle({4.2, 4.1}, {5.0, 4.4}, {4.5, 4.9}, 3.0, 1.0, 2.0, true);
    ASSERT_LT(t.imageAreaPx2, 1.0);
    const GhostBeam beam = GhostBeam::fromTriangles({t}, smallFrame());
    const double power = t.pupilAreaMm2 * (t.throughput[0] + t.throughput[1] + t.throughput[2]) / 3.0;
    Rng rng(8, 8);
    constexpr int kCalls = 2000;
    double sum = 0.0, sumSquares = 0.0;
    for (int n = 0; n < kCalls; ++n) {
        double total = 0.0;
        for (double v : raster(beam, tentJitter(rng.uniform(), rng.uniform()), n)) total += v;
        sum += total, sumSquares += total * total;
    }
    const double mean = sum / kCalls, sd = std::sqrt((sumSquares / kCalls - mean * mean) / (kCalls - 1));
    EXPECT_LT(std::abs(mean - power), test::normalTwoSidedCritical(1e-4) * sd) << "mean " << mean << ", power " << power;
    // On average over seeds the splats give the tent-filtered image of the triangle's irradiance
    // (throughput × pupil area per image area, linear): z-test per pixel, Bonferroni.
    BeamTriangle linear = t;
    for (int k = 0; k < 3; ++k) linear.irradiance[k] = t.throughput[k] * t.pupilAreaMm2 / t.imageAreaPx2;
    linear.small = false;
    const std::vector<double> exact = exactTentImage(linear);
    std::vector<double> pixelSum(kWidth * kHeight, 0.0), pixelSquares(kWidth * kHeight, 0.0);
    constexpr int kSeeds = 4000;
    for (int n = 0; n < kSeeds; ++n) {
        const std::vector<double> image = raster(beam, {0.0, 0.0}, 1000 + n);
        for (int i = 0; i < kWidth * kHeight; ++i) pixelSum[i] += image[i], pixelSquares[i] += image[i] * image[i];
    }
    const double z = test::normalTwoSidedCritical(1e-4 / (kWidth * kHeight));
    for (int i = 0; i < kWidth * kHeight; ++i) {
        const double m = pixelSum[i] / kSeeds;
        const double v = std::max(0.0, pixelSquares[i] / kSeeds - m * m) / (kSeeds - 1);
        EXPECT_LE(std::abs(m - exact[i]), z * std::sqrt(v) + 1e-12 * power) << "pixel " << i << ": " << m << " vs " << exact[i];
    }
}

TEST(GhostBeam, PowerOnSensorIsTheIntegralOverTheSensorRectangle) {
    // Inside: the exact integral (area × mean irradiance). Straddling the left edge: the part with
    // x ≥ 0, integrated independently here by the same quadrature over the clipped pieces.
    const BeamTriangle inside = triangle({1.0, 1.0}, {6.0, 2.0}, {2.0, 7.0}, 1.0, 2.0, 3.0);
    const double area = inside.imageAreaPx2;
    EXPECT_NEAR(GhostBeam::fromTriangles({inside}, smallFrame()).powerOnSensor(), area * 2.0, 1e-12 * area);
    const BeamTriangle across = triangle({-4.0, 1.0}, {6.0, 2.0}, {2.0, 7.0}, 1.0, 2.0, 3.0);
    double expected = 0.0;
    for (double v : exactTentImage(across)) expected += v;  // tents at the left edge lose a share...
    // ...so integrate directly instead: the clipped polygon x ≥ 0 (a quadrilateral) by fan.
    const glm::dvec2 a = across.pixel[0], b = across.pixel[1], c = across.pixel[2];
    auto at = [&](const glm::dvec2& p, const glm::dvec2& q, double e1, double e2) {
        const double s = (0.0 - p.x) / (q.x - p.x);
        return std::pair{p + s * (q - p), e1 + s * (e2 - e1)};
    };
    const auto [pab, eab] = at(a, b, 1.0, 2.0);
    const auto [pac, eac] = at(a, c, 1.0, 3.0);
    auto fan = [](glm::dvec2 p0, double e0, glm::dvec2 p1, double e1, glm::dvec2 p2, double e2) {
        return 0.5 * std::abs((p1.x - p0.x) * (p2.y - p0.y) - (p2.x - p0.x) * (p1.y - p0.y)) * (e0 + e1 + e2) / 3.0;
    };
    expected = fan(pab, eab, b, 2.0, c, 3.0) + fan(pab, eab, c, 3.0, pac, eac);
    EXPECT_NEAR(GhostBeam::fromTriangles({across}, smallFrame()).powerOnSensor(), expected, 1e-12 * expected);
}

// A beam of a real ghost: the uncoated doublet's strongest ghost for a light 4° off axis.
struct RealBeam {
    LensSystem lens;
    GhostReport report;
    const GhostEstimate* ghost = nullptr;
    FilmFrame frame;
};

RealBeam realBeam() {
    RealBeam r{LensSystem::build(loadLensFile(test::sourcePath("tests/data/dgauss.50mm.dat")), LensState{}), {}, nullptr,
               {}};
    r.report = analyseGhosts(r.lens, directionFromFieldDeg(4.0, 2.5), GhostAnalysisOptions{});
    r.ghost = &r.report.ghosts.front();
    r.frame = {180, 120, r.lens.sensor().widthMm, r.lens.sensor().heightMm, r.lens.sensor().widthMm / 180};
    return r;
}

// The ghost's beam at 550 nm over `mask`, its mesh refined from level 2.
GhostBeam beamOf(const RealBeam& r, const GuideMask& mask) {
    const SpectralIndices indices = r.lens.indicesAt(550.0);
    const BundleTracer tracer(r.lens, indices, r.ghost->path.reflections);
    PupilRemeshOptions options;
    options.minLevel = 2;
    return GhostBeam::build(tracer, r.report.grid, r.ghost->lattice, mask, r.frame, options);
}

TEST(GhostBeam, RecoveredIrradianceKeepsEveryTrianglesPowerAndSmoothsTheJumps) {
    // The default scene's strongest ghost (a caustic, the most curved map) at full resolution.
    const Scene scene = defaultScene();
    RealBeam r{buildSceneLens(scene), {}, nullptr, {}};
    r.report = analyseGhosts(r.lens, scene.lights.front().travelDirection(), GhostAnalysisOptions{});
    r.ghost = &r.report.ghosts.front();
    r.frame = {1536, 1024, r.lens.sensor().widthMm, r.lens.sensor().heightMm, r.lens.sensor().widthMm / 1536};
    const GuideMask mask(r.ghost->pupil);
    const SpectralIndices indices = r.lens.indicesAt(550.0);
    const BundleTracer tracer(r.lens, indices, r.ghost->path.reflections);
    PupilRemeshOptions options;
    options.minLevel = 2;
    const GhostBeam beam = GhostBeam::build(tracer, r.report.grid, r.ghost->lattice, mask, r.frame, options);
    ASSERT_FALSE(beam.empty());
    // The image's integral equals the pupil's power (each recovered triangle is rescaled to its
    // own power; the others carry it by construction): Σ image area × mean irradiance against
    // Σ pupil area × mean throughput.
    double image = 0.0, pupil = 0.0;
    for (const BeamTriangle& t : beam.triangles()) {
        if (t.small) continue;
        image += t.imageAreaPx2 * (t.irradiance[0] + t.irradiance[1] + t.irradiance[2]) / 3.0;
        pupil += t.pupilAreaMm2 * (t.throughput[0] + t.throughput[1] + t.throughput[2]) / 3.0;
    }
    EXPECT_NEAR(image, pupil, 1e-9 * pupil);
    // At the mesh's shared vertices, the recovered irradiance differs far less between the
    // triangles meeting there than the triangles' own (constant-Jacobian) irradiance does.
    std::map<std::pair<double, double>, std::vector<std::pair<int, int>>> corners;
    for (size_t i = 0; i < beam.triangles().size(); ++i)
        for (int k = 0; k < 3; ++k)
            corners[{beam.triangles()[i].pupilMm[k].x, beam.triangles()[i].pupilMm[k].y}].push_back(
                {static_cast<int>(i), k});
    double jumpRecovered = 0.0, jumpOwn = 0.0;
    int shared = 0;
    for (const auto& [point, list] : corners)
        for (size_t m = 1; m < list.size(); ++m) {
            const BeamTriangle &a = beam.triangles()[list[0].first], &b = beam.triangles()[list[m].first];
            if (a.small || b.small) continue;
            const int ka = list[0].second, kb = list[m].second;
            const double ownA = a.throughput[ka] * a.pupilAreaMm2 / a.imageAreaPx2;
            const double ownB = b.throughput[kb] * b.pupilAreaMm2 / b.imageAreaPx2;
            jumpOwn += std::abs(ownA - ownB) / (ownA + ownB);
            jumpRecovered += std::abs(a.irradiance[ka] - b.irradiance[kb]) / (a.irradiance[ka] + b.irradiance[kb]);
            ++shared;
        }
    ASSERT_GT(shared, 100);
    // Measured: 0.046 against 0.124 at this level (the jumps fall as h² against h).
    EXPECT_LT(jumpRecovered, 0.5 * jumpOwn) << "mean jumps: recovered " << jumpRecovered / shared << ", own "
                                             << jumpOwn / shared;
}

TEST(GhostBeam, KeepsOnlyTheMaskedPartOfTheRegion) {
    // The same beam with the full mask and with only the mask's cells left of the region's middle:
    // the second's power is the first's part left of that line (its triangles clipped there).
    const RealBeam r = realBeam();
    const SpectralIndices indices = r.lens.indicesAt(550.0);
    const BundleTracer tracer(r.lens, indices, r.ghost->path.reflections);
    PupilRemeshOptions options;
    options.minLevel = 2;
    LivePupilRegion region = r.ghost->pupil;
    const GuideMask full(region);
    const GhostBeam whole = GhostBeam::build(tracer, r.report.grid, r.ghost->lattice, full, r.frame, options);
    // Cut the region (and so the mask, which grows it by one cell) at a cell boundary.
    const int cut = region.cellsA / 2;
    for (int j = 0; j < region.cellsB; ++j)
        for (int i = cut - 1; i < region.cellsA; ++i) region.live[static_cast<size_t>(j) * region.cellsA + i] = 0;
    const GuideMask half(region);
    const GhostBeam left = GhostBeam::build(tracer, r.report.grid, r.ghost->lattice, half, r.frame, options);
    double expected = 0.0;
    // The half mask's live cells end at the last column with any live cell: find that line.
    double edgeMm = -1e300;
    for (int j = 0; j < half.cellsB(); ++j)
        for (int i = 0; i < half.cellsA(); ++i)
            if (half.liveCell(i, j)) edgeMm = std::max(edgeMm, half.aMinMm() + (i + 1) * half.cellMm());
    for (const BeamTriangle& t : whole.triangles()) {
        // The triangle's pupil part with a < edgeMm, by clipping in the pupil (the map is affine).
        const double full = t.pupilAreaMm2 * (t.throughput[0] + t.throughput[1] + t.throughput[2]) / 3.0;
        double inside = 0.0;
        std::vector<glm::dvec3> poly = {{t.pupilMm[0], t.throughput[0]}, {t.pupilMm[1], t.throughput[1]},
                                        {t.pupilMm[2], t.throughput[2]}};
        std::vector<glm::dvec3> out;
        for (size_t k = 0; k < 3; ++k) {
            const glm::dvec3 p = poly[k], q = poly[(k + 1) % 3];
            const double dp = edgeMm - p.x, dq = edgeMm - q.x;
            if (dp >= 0.0) out.push_back(p);
            if ((dp >= 0.0) != (dq >= 0.0)) out.push_back(p + (dp / (dp - dq)) * (q - p));
        }
        for (size_t k = 1; k + 1 < out.size(); ++k) {
            const glm::dvec3 a = out[0], b = out[k], c = out[k + 1];
            inside += 0.5 * std::abs((b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y)) * (a.z + b.z + c.z) / 3.0;
        }
        expected += full > 0.0 ? inside : 0.0;
    }
    double got = 0.0;
    for (const BeamTriangle& t : left.triangles())
        got += t.pupilAreaMm2 * (t.throughput[0] + t.throughput[1] + t.throughput[2]) / 3.0;
    ASSERT_GT(expected, 0.0);
    EXPECT_NEAR(got, expected, 1e-9 * expected);
}

// What rasterise writes lies in the columns columnsInBand gives for the band, whatever the jitter
// (the per-ghost layers are zeroed, added and summed over those columns alone, Render.cpp): a real
// ghost's beam with its rim ringing at a few pixels' Fresnel scale, and small triangles whose
// splats reach beyond their image. The columns are tight enough to matter: narrower than the frame.
TEST(GhostBeam, ColumnsInBandHoldEverythingRasteriseWrites) {
    const RealBeam r = realBeam();
    GhostBeam ringed = beamOf(r, GuideMask(r.ghost->pupil));
    ASSERT_FALSE(ringed.empty());
    ringed.ring(3.0);
    ASSERT_FALSE(ringed.rim().empty());
    // Small triangles across a band's edge (row 32) and at the frame's right edge.
    const GhostBeam small = GhostBeam::fromTriangles(
        {triangle({100.2, 31.1}, {100.9, 31.6}, {100.4, 32.4}, 1.0, 2.0, 3.0, true),
         triangle({179.1, 70.2}, {179.8, 70.3}, {179.5, 70.9}, 2.0, 1.0, 1.0, true)},
        r.frame);
    const int w = r.frame.widthPx, h = r.frame.heightPx, bands = (h + 31) / 32;
    Rng rng(5, 31);
    int narrower = 0, written = 0;
    for (const GhostBeam* beam : {static_cast<const GhostBeam*>(&ringed), &small})
        for (int band = 0; band < bands; ++band) {
            int lo = w, hi = -1;
            beam->columnsInBand(band, lo, hi);
            narrower += lo <= hi && hi - lo + 1 < w;
            for (int n = 0; n < 200; ++n) {
                // The jitter's extremes as well as the tent's draws.
                const glm::dvec2 jitter = n < 4 ? glm::dvec2(n % 2 ? 1.0 : -1.0, n / 2 ? 1.0 : -1.0)
                                                : tentJitter(rng.uniform(), rng.uniform());
                std::vector<double> rows(static_cast<size_t>(w) * 32 * 3, 0.0);
                beam->rasterise(band, jitter, {1.0, 1.0, 1.0}, n, rows.data());
                for (int y = 0; y < 32; ++y)
                    for (int x = 0; x < w; ++x) {
                        const double* v = &rows[(static_cast<size_t>(y) * w + x) * 3];
                        if (v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0) continue;
                        ++written;
                        ASSERT_TRUE(x >= lo && x <= hi) << "band " << band << ", column " << x << " outside [" << lo
                                                        << ", " << hi << "], jitter " << jitter.x << ", " << jitter.y;
                    }
            }
        }
    EXPECT_GT(written, 1000);
    EXPECT_GE(narrower, 3);
    // A band the beam does not reach: the columns are left as they were.
    int lo = 7, hi = 9;
    small.columnsInBand(bands - 1, lo, hi);
    EXPECT_EQ(lo, 7);
    EXPECT_EQ(hi, 9);
}

TEST(GhostBeam, TwinsLandWithTheBeamsIrradiance) {
    // Twins of pupil points drawn uniformly over the mask, splatted with the tent and weighted by
    // their throughput × mask area, estimate the beam's image; the jittered raster averaged over
    // many jitters estimates it too. Compared in 10 × 10-pixel blocks with a z-test (Bonferroni).
    const RealBeam r = realBeam();
    const GuideMask mask(r.ghost->pupil);
    const GhostBeam beam = beamOf(r, mask);
    const int w = r.frame.widthPx, h = r.frame.heightPx, blocks = (w / 10) * (h / 10);
    auto block = [&](double x, double y) { return static_cast<int>(y / 10) * (w / 10) + static_cast<int>(x / 10); };
    constexpr int kRounds = 40, kTwinsPerRound = 20000, kJittersPerRound = 50;
    std::vector<double> twinSum(blocks, 0.0), twinSq(blocks, 0.0), rasterSum(blocks, 0.0), rasterSq(blocks, 0.0);
    double twinTotals[2] = {0.0, 0.0}, rasterTotals[2] = {0.0, 0.0};  // Σ and Σ² of the rounds' totals
    Rng rng(21, 4);
    const int bands = (h + 31) / 32;
    for (int round = 0; round < kRounds; ++round) {
        std::vector<double> twins(blocks, 0.0), rasters(blocks, 0.0);
        for (int n = 0; n < kTwinsPerRound; ++n) {
            BeamTwin twin;
            if (!beam.twin(mask.sample(rng.uniform(), rng.uniform(), rng.uniform()), &twin)) continue;
            const double weight = twin.throughput * mask.areaMm2() / kTwinsPerRound;
            const double fx = twin.pixel.x - 0.5, fy = twin.pixel.y - 0.5;
            const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
            for (int dy = 0; dy < 2; ++dy)
                for (int dx = 0; dx < 2; ++dx) {
                    const int x = x0 + dx, y = y0 + dy;
                    if (x < 0 || y < 0 || x >= w / 10 * 10 || y >= h / 10 * 10) continue;
                    twins[block(x, y)] += weight * (dx ? fx - x0 : 1 - (fx - x0)) * (dy ? fy - y0 : 1 - (fy - y0));
                }
        }
        for (int n = 0; n < kJittersPerRound; ++n) {
            const glm::dvec2 jitter = tentJitter(rng.uniform(), rng.uniform());
            for (int band = 0; band < bands; ++band) {
                std::vector<double> rows(static_cast<size_t>(w) * 32 * 3, 0.0);
                beam.rasterise(band, jitter, {0.0, 1.0, 0.0}, round * 1000 + n, rows.data());
                for (int y = band * 32; y < std::min(h / 10 * 10, band * 32 + 32); ++y)
                    for (int x = 0; x < w / 10 * 10; ++x)
                        rasters[block(x, y)] += rows[(static_cast<size_t>(y - band * 32) * w + x) * 3 + 1] / kJittersPerRound;
            }
        }
        double twinRound = 0.0, rasterRound = 0.0;
        for (int b = 0; b < blocks; ++b) {
            twinSum[b] += twins[b], twinSq[b] += twins[b] * twins[b];
            rasterSum[b] += rasters[b], rasterSq[b] += rasters[b] * rasters[b];
            twinRound += twins[b], rasterRound += rasters[b];
        }
        twinTotals[0] += twinRound, twinTotals[1] += twinRound * twinRound;
        rasterTotals[0] += rasterRound, rasterTotals[1] += rasterRound * rasterRound;
    }
    const double z = test::normalTwoSidedCritical(1e-4 / blocks);
    int lit = 0;
    double total = 0.0;
    for (int b = 0; b < blocks; ++b) total += rasterSum[b];
    for (int b = 0; b < blocks; ++b) {
        auto stats = [&](double sum, double sq) {
            const double mean = sum / kRounds;
            return std::pair{mean, std::max(0.0, sq / kRounds - mean * mean) / (kRounds - 1)};
        };
        const auto [tm, tv] = stats(twinSum[b], twinSq[b]);
        const auto [rm, rv] = stats(rasterSum[b], rasterSq[b]);
        lit += rm > 1e-3 * total / kRounds;
        EXPECT_LE(std::abs(tm - rm), z * std::sqrt(tv + rv) + 1e-12 * total) << "block " << b;
    }
    EXPECT_GT(lit, 5);
    // And in all, where a twin weight off by a small factor shows first: the rounds' totals.
    const double twinMean = twinTotals[0] / kRounds, rasterMean = rasterTotals[0] / kRounds;
    const double variance = (twinTotals[1] / kRounds - twinMean * twinMean) / (kRounds - 1) +
                            (rasterTotals[1] / kRounds - rasterMean * rasterMean) / (kRounds - 1);
    EXPECT_LE(std::abs(twinMean - rasterMean), test::normalTwoSidedCritical(1e-4) * std::sqrt(std::max(variance, 0.0)))
        << "twins " << twinMean << ", raster " << rasterMean;
}

}  // namespace
}  // namespace flare
