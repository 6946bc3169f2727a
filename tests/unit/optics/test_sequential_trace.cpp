// Exact sequential tracing: agreement with paraxial optics near the axis, reversibility, Fresnel
// weights, prescribed reflection sequences and failure statuses.
#include <cmath>
#include <numbers>
#include <random>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/optics/Glass.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/Paraxial.h"
#include "flare/optics/RealRays.h"
#include "flare/optics/SequentialTracer.h"

namespace flare {
namespace {

using test::loadLens;

double distanceToLine(const glm::dvec3& p, const Ray& line) {
    const glm::dvec3 v = p - line.originMm;
    return glm::length(v - glm::dot(v, line.direction) * line.direction);
}

TEST(SequentialTrace, NearAxisRealRaysMeetTheParaxialFocus) {
    for (const char* file : test::kShippedLenses) {
        const LensSystem lens = loadLens(file);
        const SpectralIndices idx = lens.indicesAt(kLineDNm);
        const ParaxialData para = analyseParaxial(lens, kLineDNm);
        const double zLast = lens.surface(lens.surfaceCount() - 1).vertexZMm;
        const double zStart = objectSpaceStartZMm(lens);
        // Longitudinal aberration grows as h²: at h = 1e-4 of the pupil radius it is below 1e-8 of
        // the focal length for these lenses (their third-order coefficients are of order 1).
        const double h = 1e-4 * 0.5 * para.entrancePupilDiameterMm;
        const Ray ray{{0.0, h, zStart}, {0.0, 0.0, 1.0}};
        TraceOptions options;
        options.clipApertures = false;
        const TraceResult result = traceForward(lens, idx, ray, options);
        ASSERT_TRUE(result.ok()) << file << " " << toString(result.status);
        const Ray& out = result.ray;
        const double crossingZ = out.originMm.z - out.originMm.y / out.direction.y * out.direction.z;
        EXPECT_NEAR(crossingZ - zLast, para.bflMm, 1e-8 * std::abs(para.eflMm)) << file;
        // Focal length from the exit slope: EFL = −h / tan(u').
        EXPECT_NEAR(-h / (out.direction.y / out.direction.z), para.eflMm, 1e-6 * std::abs(para.eflMm)) << file;
    }
}

TEST(SequentialTrace, SmallFieldChiefRayImageHeightIsEflTimesTangent) {
    for (const char* file : test::kShippedLenses) {
        const LensSystem lens = loadLens(file);
        const SpectralIndices idx = lens.indicesAt(kLineDNm);
        const ParaxialData para = analyseParaxial(lens, kLineDNm);
        const double theta = 1e-4;
        const std::optional<double> h = chiefRayImageHeightMm(lens, idx, theta);
        ASSERT_TRUE(h) << file;
        // Distortion is third order in θ: 1e-8 relative at θ = 1e-4.
        EXPECT_NEAR(*h / (para.eflMm * std::tan(theta)), 1.0, 1e-6) << file;
    }
}

TEST(SequentialTrace, ForwardThenBackwardReturnsToTheStart) {
    std::mt19937_64 rng(2024);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (const char* file : test::kShippedLenses) {
        const LensSystem lens = loadLens(file);
        const double maxFieldRad = 0.5 * std::min(analyseParaxial(lens, kLineDNm).paraxialFieldOfViewDeg, 60.0) *
                                   std::numbers::pi / 180.0;
        const double stopRadius = lens.iris().radiusMm();
        int tested = 0;
        for (double wavelength : {450.0, 550.0, 650.0}) {
            const SpectralIndices idx = lens.indicesAt(wavelength);
            for (int i = 0; i < 100; ++i) {
                // Rays aimed through the stop over the field, so that most of them pass.
                const std::optional<Ray> aimed = aimAtStop(lens, idx, maxFieldRad * u(rng),
                                                           0.9 * stopRadius * u(rng), 0.6 * stopRadius * u(rng));
                if (!aimed) continue;
                const Ray& ray = *aimed;
                const TraceResult forward = traceForward(lens, idx, ray);
                if (!forward.ok()) continue;
                ++tested;
                const Ray reversed{forward.ray.originMm, -forward.ray.direction};
                const TraceResult backward = traceBackward(lens, idx, reversed);
                ASSERT_TRUE(backward.ok()) << file << " " << toString(backward.status);
                EXPECT_NEAR(glm::dot(backward.ray.direction, -ray.direction), 1.0, 1e-12) << file;
                EXPECT_LT(distanceToLine(ray.originMm, backward.ray), 1e-9) << file;
                // Fresnel transmission is reciprocal.
                EXPECT_NEAR(backward.throughput, forward.throughput, 1e-12) << file;
            }
        }
        EXPECT_GT(tested, 100) << file;
    }
}

// A plane-parallel plate of index n: transmission (1 − R)² at normal incidence, and its one
// two-reflection ghost leaves parallel to the input with weight R²·(1 − R)²... — here both
// closed forms are checked.
TEST(SequentialTrace, PlaneParallelPlateWeightsAndGhost) {
    const std::string text = R"(name plate
focal_length_mm 1
surfaces
 stop  1    air     10
 inf   5    n=1.5   10
 inf   10   air     10
)";
    const LensPrescription p = parseLensText(text, "plate.lens");
    // The plate has no power: build with the explicit sensor distance.
    const LensSystem lens = LensSystem::build(p);
    const SpectralIndices idx = lens.indicesAt(550.0);
    const double R = 0.04;
    const Ray axial{{0.0, 0.0, -1.0}, {0.0, 0.0, 1.0}};
    const TraceResult direct = traceForward(lens, idx, axial);
    ASSERT_TRUE(direct.ok());
    EXPECT_NEAR(direct.throughput, (1.0 - R) * (1.0 - R), 1e-15);

    const double theta = 10.0 * std::numbers::pi / 180.0;
    const Ray tilted{{0.0, 0.0, -1.0}, {std::sin(theta), 0.0, std::cos(theta)}};
    const int reflections[] = {2, 1};  // rear face, then front face (0-based, stop is 0)
    SequentialPath ghostPath;
    ghostPath.reflections = reflections;
    const TraceResult ghost = tracePath(lens, idx, tilted, ghostPath);
    ASSERT_TRUE(ghost.ok()) << toString(ghost.status);
    EXPECT_NEAR(glm::dot(ghost.ray.direction, tilted.direction), 1.0, 1e-14);
    // Lateral shift relative to the direct ray: 2·d·tan(θ_glass) along x.
    const TraceResult straight = traceForward(lens, idx, tilted);
    const double sinGlass = std::sin(theta) / 1.5;
    const double shift = 2.0 * 5.0 * sinGlass / std::sqrt(1.0 - sinGlass * sinGlass);
    EXPECT_NEAR(ghost.ray.originMm.x - straight.ray.originMm.x, shift, 1e-12);
    const FresnelTerms in = fresnelDielectric(std::cos(theta), 1.0, 1.5);
    const FresnelTerms inside = fresnelDielectric(std::sqrt(1.0 - sinGlass * sinGlass), 1.5, 1.0);
    EXPECT_NEAR(ghost.throughput,
                in.transmittance() * inside.reflectance() * inside.reflectance() * inside.transmittance(), 1e-15);
}

TEST(SequentialTrace, FailuresReturnAStatusAndZeroWeight) {
    const LensSystem lens = loadLens("lenses/double-gauss-50mm.lens");
    const SpectralIndices idx = lens.indicesAt(kLineDNm);
    const double zStart = objectSpaceStartZMm(lens);
    // Outside the first clear aperture.
    TraceResult r = traceForward(lens, idx, Ray{{0.0, 13.0, zStart}, {0.0, 0.0, 1.0}});
    EXPECT_EQ(r.status, TraceStatus::Vignetted);
    EXPECT_EQ(r.surface, 0);
    EXPECT_EQ(r.throughput, 0.0);
    // Through the front glass but outside the stopped-down iris.
    const LensSystem stopped = LensSystem::build(loadLensFile(test::sourcePath("lenses/double-gauss-50mm.lens")),
                                                 LensState{"", {}, 16.0});
    r = traceForward(stopped, idx, Ray{{0.0, 5.0, zStart}, {0.0, 0.0, 1.0}});
    EXPECT_EQ(r.status, TraceStatus::BlockedByIris);
    EXPECT_EQ(r.surface, stopped.stopIndex());
    // A ray that misses everything (travelling away).
    r = traceForward(lens, idx, Ray{{0.0, 0.0, zStart}, {0.0, 0.0, -1.0}});
    EXPECT_FALSE(r.ok());
    // A path that asks to end at the sensor but reflects an odd number of times ends wrongly.
    const int one[] = {3};
    SequentialPath odd;
    odd.reflections = one;
    r = tracePath(lens, idx, Ray{{0.0, 1.0, zStart}, {0.0, 0.0, 1.0}}, odd);
    EXPECT_FALSE(r.ok());
}

TEST(SequentialTrace, TotalInternalReflectionIsAStatus) {
    const std::string text = R"(name tir
focal_length_mm 1
surfaces
 stop  1    air     10
 inf   5    n=1.5   10
 inf   10   air     10
)";
    const LensSystem lens = LensSystem::build(parseLensText(text, "tir.lens"));
    const SpectralIndices idx = lens.indicesAt(550.0);
    // Start inside the glass at 60° (beyond the 41.8° critical angle) heading for the rear face.
    SequentialPath path;
    path.start = 1;
    const double a = 60.0 * std::numbers::pi / 180.0;
    const TraceResult r = tracePath(lens, idx, Ray{{0.0, 0.0, 2.0}, {std::sin(a), 0.0, std::cos(a)}}, path);
    EXPECT_EQ(r.status, TraceStatus::TotalInternalReflection);
    EXPECT_EQ(r.surface, 2);
}

}  // namespace
}  // namespace flare

namespace flare {
namespace {

TEST(RealFieldOfView, ChiefRayAtHalfTheFieldLandsOnTheSensorCorner) {
    for (const char* file : {"lenses/double-gauss-50mm.lens", "lenses/wide-angle-28mm.lens"}) {
        const LensSystem lens = loadLens(file);
        const RealFieldOfView fov = realFieldOfView(lens, kLineDNm);
        ASSERT_EQ(fov.kind, RealFieldOfView::Kind::Reached) << file;
        const double half = 0.5 * fov.fullAngleDeg * std::numbers::pi / 180.0;
        const std::optional<double> h = chiefRayImageHeightMm(lens, lens.indicesAt(kLineDNm), half);
        ASSERT_TRUE(h) << file;
        // Bisection to 2^-40 of a 0.5° bracket: the height is exact to far below a micrometre.
        EXPECT_NEAR(std::abs(*h), lens.sensorHalfDiagonalMm(), 1e-6) << file;
        // Rectilinear lenses: the real field is within a few percent of the paraxial one.
        EXPECT_NEAR(fov.fullAngleDeg / analyseParaxial(lens, kLineDNm).paraxialFieldOfViewDeg, 1.0, 0.05) << file;
    }
}

TEST(RealFieldOfView, FullFrameFisheyeCoversMoreThan180Degrees) {
    const LensSystem lens = loadLens("lenses/fisheye-16mm.lens");
    const RealFieldOfView fov = realFieldOfView(lens, kLineDNm);
    ASSERT_EQ(fov.kind, RealFieldOfView::Kind::Beyond180);
    EXPECT_LT(fov.maxFieldImageHeightMm, lens.sensorHalfDiagonalMm());
    // A rectilinear lens of this focal length would need an infinite image height; the fisheye
    // keeps the 90° chief ray near 2f·sin(45°) (equisolid angle), within 10 %.
    EXPECT_NEAR(fov.maxFieldImageHeightMm / (2.0 * 15.67 * std::sin(std::numbers::pi / 4)), 1.0, 0.1);
}

}  // namespace
}  // namespace flare
