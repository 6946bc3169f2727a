// Photon emission: the sun's directions are uniform over its cone (χ²) and its power per unit area
// is unbiased; a point light delivers I·Ω through a square of the pupil plane (exact solid angle,
// midpoint rule with a derived error bound); a disk light draws uniform points of the disk (χ²)
// and delivers the Lambertian form-factor power; and the emission square covers every ray through
// the front clear aperture of the shipped lenses.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/core/Random.h"
#include "flare/optics/Surface.h"
#include "flare/photons/LightSampler.h"

namespace flare {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDegToRad = kPi / 180.0;
constexpr double kMm2PerM2 = 1e6;

const LensSystem& doubleGauss() {
    static const LensSystem lens = test::loadLens("lenses/double-gauss-50mm.lens");
    return lens;
}

LightSpec sun(double fieldXDeg, double fieldYDeg, double angularDiameterDeg, double power = 1000.0) {
    LightSpec light;
    light.type = LightSpec::Type::Directional;
    light.fieldXDeg = fieldXDeg;
    light.fieldYDeg = fieldYDeg;
    light.angularDiameterDeg = angularDiameterDeg;
    light.power = power;
    return light;
}

LightSpec pointLight(const glm::dvec3& positionMm, double intensity) {
    LightSpec light;
    light.type = LightSpec::Type::Point;
    light.positionMm = positionMm;
    light.power = intensity;
    return light;
}

LightSpec diskLight(const glm::dvec3& positionMm, double radiusMm, double intensity) {
    LightSpec light = pointLight(positionMm, intensity);
    light.type = LightSpec::Type::Disk;
    light.radiusMm = radiusMm;
    return light;
}

// Where the line of a ray crosses the pupil plane, in the plane's (a, b) millimetres.
glm::dvec2 crossing(const PupilGrid& grid, const glm::dvec3& originMm, const glm::dvec3& direction) {
    const double t = glm::dot(grid.centreMm - originMm, grid.direction) / glm::dot(direction, grid.direction);
    const glm::dvec3 p = originMm + t * direction - grid.centreMm;
    return {glm::dot(p, grid.e1), glm::dot(p, grid.e2)};
}

// A unit vector ⟂ n and the third axis: a basis for angles around n, independent of the sampler's.
void basisAround(const glm::dvec3& n, glm::dvec3* u, glm::dvec3* v) {
    *u = glm::normalize(glm::cross(n, std::abs(n.y) < 0.9 ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1)));
    *v = glm::cross(n, *u);
}

double angleIn2Pi(double y, double x) {
    const double phi = std::atan2(y, x);
    return phi < 0.0 ? phi + 2.0 * kPi : phi;
}

int binOf(double fraction, int bins) { return std::clamp(static_cast<int>(fraction * bins), 0, bins - 1); }

// χ² of a table of counts against a uniform expectation, with its critical value: no parameter
// is fitted, so cells − 1 degrees of freedom; reject at p = 1e-4.
void expectUniform(const std::vector<long>& counts, long samples, const std::string& what) {
    const std::vector<double> expected(counts.size(), static_cast<double>(samples) / counts.size());
    const int dof = static_cast<int>(counts.size()) - 1;
    EXPECT_LT(test::pearsonChiSquared(counts, expected), test::chiSquaredUpperCritical(dof, 1e-4))
        << what << " (" << counts.size() << " cells)";
}

TEST(LightSampler, SunDirectionsAreUniformOverItsConeAndItsPowerIsUnbiased) {
    for (const double diameterDeg : {0.53, 10.0}) {
        const LightSpec light = sun(10.0, -5.0, diameterDeg, 800.0);
        const LightSampler sampler(light, doubleGauss());
        const PupilGrid& grid = sampler.grid();
        EXPECT_NEAR(glm::length(grid.direction - light.travelDirection()), 0.0, 1e-12);
        const double half = sampler.emissionHalfSizeMm();
        // 1 − cos(half angle), without cancellation; the equal-solid-angle bins are equal steps of
        // 1 − cosθ, and ⟨cosθ⟩ over the cone is 1 − (1 − cos θmax)/2.
        const double halfAngle = 0.5 * diameterDeg * kDegToRad;
        const double oneMinusCosMax = 2.0 * std::pow(std::sin(0.5 * halfAngle), 2);
        const double meanCosine = 1.0 - 0.5 * oneMinusCosMax;

        const int thetaBins = 10, phiBins = 16;
        const long n = 160000;  // 1000 per joint cell
        std::vector<long> joint(thetaBins * phiBins, 0), theta(thetaBins, 0), phi(phiBins, 0);
        double sum = 0.0, sumSquares = 0.0;
        Rng rng(31, static_cast<std::uint64_t>(diameterDeg * 100));
        for (long i = 0; i < n; ++i) {
            const double a = (2.0 * rng.uniform() - 1.0) * half, b = (2.0 * rng.uniform() - 1.0) * half;
            const double u1 = rng.uniform(), u2 = rng.uniform();
            const EmittedRay e = sampler.rayThrough(a, b, u1, u2);
            const glm::dvec3& d = e.ray.direction;
            ASSERT_NEAR(glm::length(d), 1.0, 1e-12);
            const glm::dvec2 ab = crossing(grid, e.ray.originMm, d);
            ASSERT_NEAR(ab.x, a, 1e-9 * (1.0 + half));
            ASSERT_NEAR(ab.y, b, 1e-9 * (1.0 + half));
            // 1 − cosθ = |d − d0|² / 2 for unit vectors (no cancellation at 0.27°).
            const double oneMinusCos = 0.5 * glm::dot(d - grid.direction, d - grid.direction);
            ASSERT_LE(oneMinusCos, oneMinusCosMax * (1.0 + 1e-6)) << "outside the sun's disk";
            const int t = binOf(oneMinusCos / oneMinusCosMax, thetaBins);
            const int p = binOf(angleIn2Pi(glm::dot(d, grid.e2), glm::dot(d, grid.e1)) / (2.0 * kPi), phiBins);
            ++joint[t * phiBins + p];
            ++theta[t];
            ++phi[p];
            // The documented per-ray weight, E cosθ / ⟨cosθ⟩ per mm² of the plane.
            const double weight = e.powerPerMm2 / (light.power / kMm2PerM2);
            ASSERT_NEAR(weight, (1.0 - oneMinusCos) / meanCosine, 1e-9);
            sum += weight;
            sumSquares += weight * weight;
        }
        const std::string what = "sun " + std::to_string(diameterDeg) + "°";
        expectUniform(joint, n, what + ", (1 − cosθ, φ)");
        expectUniform(theta, n, what + ", 1 − cosθ");
        expectUniform(phi, n, what + ", φ");
        // E[cosθ / ⟨cosθ⟩] = 1 exactly, so the mean power per mm² is E / 10⁶ (W/m² → W/mm²).
        // Bound: z · standard error, z two-sided at p = 1e-4 (3.89).
        const double mean = sum / n, standardError = std::sqrt((sumSquares / n - mean * mean) / (n - 1));
        EXPECT_NEAR(mean, 1.0, test::normalTwoSidedCritical(1e-4) * standardError) << what;
        EXPECT_GT(standardError, 0.0);
    }

    // A perfectly collimated light: every ray along the central direction with exactly E.
    const LightSampler parallel(sun(10.0, -5.0, 0.0, 800.0), doubleGauss());
    for (const double u : {0.0, 0.3, 0.999}) {
        const EmittedRay e = parallel.rayThrough(1.5, -2.0, u, 1.0 - u);
        EXPECT_NEAR(glm::length(e.ray.direction - parallel.grid().direction), 0.0, 1e-15);
        EXPECT_DOUBLE_EQ(e.powerPerMm2, 800.0 / kMm2PerM2);
    }
}

// Solid angle of the rectangle [x1, x2] × [y1, y2] on a plane at distance d from a point, the
// coordinates measured from the foot of the perpendicular: the corner function
// F(x, y) = atan(x y / (d √(x² + y² + d²))) is the solid angle of [0, x] × [0, y].
double rectangleSolidAngle(double x1, double x2, double y1, double y2, double d) {
    auto F = [d](double x, double y) { return std::atan(x * y / (d * std::sqrt(x * x + y * y + d * d))); };
    return F(x2, y2) - F(x1, y2) - F(x2, y1) + F(x1, y1);
}

TEST(LightSampler, PointLightDeliversIntensityTimesSolidAngleThroughASquare) {
    // Check the corner formula against the centred closed form Ω = 4 arcsin(sin α sin β).
    const double alpha = std::atan(30.0 / 100.0), beta = std::atan(20.0 / 100.0);
    EXPECT_NEAR(rectangleSolidAngle(-30, 30, -20, 20, 100), 4.0 * std::asin(std::sin(alpha) * std::sin(beta)), 1e-14);

    const double intensity = 2.5;  // W/sr
    for (const glm::dvec3 position : {glm::dvec3(0, 0, -100), glm::dvec3(40, -25, -150), glm::dvec3(-60, 10, -80)}) {
        const LightSampler sampler(pointLight(position, intensity), doubleGauss());
        const PupilGrid& grid = sampler.grid();
        // The source's distance to the plane and the foot of its perpendicular, in (a, b).
        const double d = glm::dot(grid.centreMm - position, grid.direction);
        const glm::dvec2 foot = crossing(grid, position, grid.direction);
        // The square [−s, s]² of the plane, s = 0.4 d: wide enough that cos θ' and 1/r² vary.
        const double s = 0.4 * d;
        const int cells = 400;
        const double h = 2.0 * s / cells;
        double integral = 0.0;
        for (int j = 0; j < cells; ++j)
            for (int i = 0; i < cells; ++i) {
                const double a = -s + (i + 0.5) * h, b = -s + (j + 0.5) * h;
                const EmittedRay e = sampler.rayThrough(a, b, 0.5, 0.5);
                integral += e.powerPerMm2;
                if (i % 37 == 0 && j % 41 == 0) {
                    // From the light, starting on its way (in front of the lens).
                    EXPECT_EQ(e.sourceMm, position);
                    EXPECT_LT(glm::length(glm::cross(e.ray.originMm - position, e.ray.direction)), 1e-9 * d);
                    EXPECT_GE(glm::dot(e.ray.originMm - position, e.ray.direction), 0.0);
                    const glm::dvec2 ab = crossing(grid, e.ray.originMm, e.ray.direction);
                    EXPECT_NEAR(ab.x, a, 1e-9 * d);
                    EXPECT_NEAR(ab.y, b, 1e-9 * d);
                }
            }
        integral *= h * h;
        const double expected = intensity * rectangleSolidAngle(-s - foot.x, s - foot.x, -s - foot.y, s - foot.y, d);
        // Midpoint rule on the integrand f = I d / (x² + y² + d²)^{3/2}: per cell the error is
        // h⁴/24 (f_xx(ξ) + f_yy(η)), so |error| ≤ A h²/24 (max|f_xx| + max|f_yy|), and
        // |f_xx| ≤ 3 I d ρ^{-5/2} + 15 I d x² ρ^{-7/2} ≤ (3 + 15 X²/d²) I/d⁴ with X the largest |x|.
        // (≈ 1e-7 relative here; a wrong power of cos θ' would be off by several percent.) Plus
        // 1e-12 relative for the rounding of 160 000 sums.
        const double X = s + std::abs(foot.x), Y = s + std::abs(foot.y);
        const double bound = 4.0 * s * s * h * h / 24.0 * ((3.0 + 15.0 * X * X / (d * d)) + (3.0 + 15.0 * Y * Y / (d * d))) *
                             intensity / std::pow(d, 4);
        EXPECT_NEAR(integral, expected, bound + 1e-12 * expected) << "light at " << position.x << ", " << position.y << ", " << position.z;
    }
}

TEST(LightSampler, DiskLightSamplesAreUniformOverTheDisk) {
    for (const LightSpec& light : {diskLight({0, 0, -300}, 40.0, 1.0), diskLight({150, 80, -500}, 25.0, 1.0)}) {
        const LightSampler sampler(light, doubleGauss());
        const glm::dvec3 n = light.diskNormal();
        glm::dvec3 u, v;
        basisAround(n, &u, &v);
        const double half = sampler.emissionHalfSizeMm();
        // Equal-area rings (equal steps of ρ²/R²) × equal sectors: 96 cells of 1000 expected.
        const int rings = 8, sectors = 12;
        const long samples = 96000;
        std::vector<long> joint(rings * sectors, 0), ring(rings, 0), sector(sectors, 0);
        Rng rng(32, static_cast<std::uint64_t>(light.radiusMm));
        for (long i = 0; i < samples; ++i) {
            const double a = (2.0 * rng.uniform() - 1.0) * half, b = (2.0 * rng.uniform() - 1.0) * half;
            const EmittedRay e = sampler.rayThrough(a, b, rng.uniform(), rng.uniform());
            // The ray comes from the sampled point of the disk and passes through (a, b).
            const glm::dvec3 offset = e.sourceMm - light.positionMm;
            ASSERT_LT(glm::length(glm::cross(e.ray.originMm - e.sourceMm, e.ray.direction)), 1e-9 * glm::length(light.positionMm));
            ASSERT_NEAR(glm::dot(offset, n), 0.0, 1e-9 * glm::length(light.positionMm)) << "off the disk's plane";
            const double rho2 = glm::dot(offset, offset) / (light.radiusMm * light.radiusMm);
            ASSERT_LE(rho2, 1.0 + 1e-9) << "outside the disk";
            const glm::dvec2 ab = crossing(sampler.grid(), e.ray.originMm, e.ray.direction);
            ASSERT_NEAR(ab.x, a, 1e-9 * glm::length(light.positionMm));
            ASSERT_NEAR(ab.y, b, 1e-9 * glm::length(light.positionMm));
            ASSERT_GT(e.powerPerMm2, 0.0);
            const int r = binOf(rho2, rings);
            const int s = binOf(angleIn2Pi(glm::dot(offset, v), glm::dot(offset, u)) / (2.0 * kPi), sectors);
            ++joint[r * sectors + s];
            ++ring[r];
            ++sector[s];
        }
        const std::string what = "disk at z " + std::to_string(light.positionMm.z);
        expectUniform(joint, samples, what + ", rings × sectors");
        expectUniform(ring, samples, what + ", rings");
        expectUniform(sector, samples, what + ", sectors");
    }
}

// Coaxial parallel disks (source radius r1, receiver radius r2, distance L): view factor
// F12 = ½ (S − √(S² − 4 (r2/r1)²)), S = 1 + (1 + R2²)/R1², Ri = ri/L (Incropera, Table 13.2).
double coaxialDiskViewFactor(double r1, double r2, double L) {
    const double R1 = r1 / L, R2 = r2 / L, S = 1.0 + (1.0 + R2 * R2) / (R1 * R1);
    return 0.5 * (S - std::sqrt(S * S - 4.0 * (r2 / r1) * (r2 / r1)));
}

TEST(LightSampler, DiskLightDeliversTheLambertianFormFactorPower) {
    // A Lambertian disk of radiance L and radius R has on-axis intensity I0 = L π R² and sends
    // π L · π R² · F12 = π I0 F12 through a coaxial disk. The receiver is a disk of radius ρ0 on the
    // pupil plane (parallel to the source, centred on its axis); Monte Carlo over uniform points of
    // it and uniform disk points (the sampler's u1, u2): mean of powerPerMm2 · π ρ0².
    const double intensity = 3.0, R = 60.0, rho0 = 40.0;
    for (const glm::dvec3 position : {glm::dvec3(0, 0, -150), glm::dvec3(90, -60, -120)}) {
        const LightSampler sampler(diskLight(position, R, intensity), doubleGauss());
        const PupilGrid& grid = sampler.grid();
        const double d = glm::dot(grid.centreMm - position, grid.direction);
        const glm::dvec2 foot = crossing(grid, position, grid.direction);
        const long n = 200000;
        Rng rng(33, static_cast<std::uint64_t>(-position.z));
        double sum = 0.0, sumSquares = 0.0;
        for (long i = 0; i < n; ++i) {
            const double r = rho0 * std::sqrt(rng.uniform()), phi = 2.0 * kPi * rng.uniform();
            const EmittedRay e = sampler.rayThrough(foot.x + r * std::cos(phi), foot.y + r * std::sin(phi), rng.uniform(), rng.uniform());
            const double x = e.powerPerMm2 * kPi * rho0 * rho0;
            sum += x;
            sumSquares += x * x;
        }
        const double mean = sum / n, standardError = std::sqrt((sumSquares / n - mean * mean) / (n - 1));
        const double expected = kPi * intensity * coaxialDiskViewFactor(R, rho0, d);
        // z · standard error, z two-sided at p = 1e-4.
        const double tolerance = test::normalTwoSidedCritical(1e-4) * standardError;
        EXPECT_NEAR(mean, expected, tolerance) << "disk at " << position.x << ", " << position.y << ", " << position.z;
        // The test can tell the disk from a point of the same intensity (I0 · Ω of the receiver):
        // at this distance the two differ by many standard errors.
        const double pointLike = intensity * 2.0 * kPi * (1.0 - d / std::sqrt(d * d + rho0 * rho0));
        EXPECT_GT(std::abs(pointLike - expected), 10.0 * tolerance);
    }
}

// The front surface's point at polar coordinates (ρ, φ) of its clear aperture.
glm::dvec3 frontPoint(const Surface& first, double rho, double phi) {
    double sag = 0.0;
    EXPECT_TRUE(first.sagMm(rho * rho, &sag));
    return {rho * std::cos(phi), rho * std::sin(phi), first.vertexZMm + sag};
}

TEST(LightSampler, EmissionDiskCoversEveryRayThroughTheFrontAperture) {
    std::vector<LightSpec> lights = {sun(20.0, 0.0, 0.53), sun(14.0, 14.0, 0.53), sun(20.0, 0.0, 10.0), sun(0.0, 0.0, 0.53),
                                     sun(0.0, -20.0, 0.53)};
    lights.push_back(pointLight(180.0 * glm::dvec3(std::sin(30 * kDegToRad), 0.0, -std::cos(30 * kDegToRad)), 1.0));
    lights.push_back(diskLight({0.0, 50.0, -250.0}, 40.0, 1.0));
    for (const char* file : test::kShippedLenses) {
        const LensSystem lens = test::loadLens(file);
        const Surface& first = lens.surface(0);
        // Points of the front clear aperture: its rim, densely, and random interior points.
        std::vector<glm::dvec3> points;
        for (int k = 0; k < 360; ++k) points.push_back(frontPoint(first, first.semiApertureMm, 2.0 * kPi * k / 360.0));
        Rng rng(34, 0);
        for (int k = 0; k < 1000; ++k)
            points.push_back(frontPoint(first, first.semiApertureMm * std::sqrt(rng.uniform()), 2.0 * kPi * rng.uniform()));
        for (size_t l = 0; l < lights.size(); ++l) {
            const LightSpec& light = lights[l];
            const LightSampler sampler(light, lens);
            const PupilGrid& grid = sampler.grid();
            const double half = sampler.emissionHalfSizeMm();
            const std::string what = std::string(file) + ", light " + std::to_string(l);
            EXPECT_GE(half, grid.halfSizeMm) << what;
            // The light's extreme rays: the sampler's own, at u1 → 1 (the rim of the sun's cone or
            // of the disk) for 16 azimuths, plus the centre (u1 = 0).
            std::vector<std::pair<double, double>> extremes{{0.0, 0.0}};
            for (int k = 0; k < 16; ++k) extremes.emplace_back(1.0 - 0x1.0p-53, k / 16.0);
            int outside = 0, outsideGrid = 0, behind = 0;
            double worst = 0.0;
            for (const glm::dvec3& p : points)
                for (const auto& [u1, u2] : extremes) {
                    glm::dvec3 direction, source;
                    if (light.type == LightSpec::Type::Directional) {
                        direction = sampler.rayThrough(0.0, 0.0, u1, u2).ray.direction;
                    } else {
                        source = sampler.rayThrough(0.0, 0.0, u1, u2).sourceMm;
                        direction = glm::normalize(p - source);
                    }
                    const glm::dvec2 ab = crossing(grid, p, direction);
                    const double extent = std::hypot(ab.x, ab.y);
                    worst = std::max(worst, extent / half);
                    outside += extent > half;
                    // The grid's own square covers the rays along the central direction.
                    if (light.type == LightSpec::Type::Directional && u1 == 0.0) outsideGrid += extent > grid.halfSizeMm;
                    // The emitted ray through that point must start in front of the glass and
                    // meet the front surface first at p.
                    const EmittedRay e = sampler.rayThrough(ab.x, ab.y, u1, u2);
                    const SurfaceHit hit = intersect(first, e.ray);
                    const bool reachesP = hit.status == HitStatus::Hit && glm::length(e.ray.at(hit.tMm) - p) < 1e-6 &&
                                          glm::dot(p - e.ray.originMm, e.ray.direction) > 0.0;
                    behind += !reachesP;
                }
            EXPECT_EQ(outside, 0) << what << ": rays into the aperture cross the plane outside the emission disk (worst at "
                                  << worst << " × the half size " << half << " mm)";
            EXPECT_EQ(outsideGrid, 0) << what << ": central-direction rays outside the grid square";
            EXPECT_EQ(behind, 0) << what << ": emitted rays that do not reach the front surface where they should";
        }
    }
}

}  // namespace
}  // namespace flare
