// Ray–surface intersection for planes, spheres, conics and even aspheres.
#include <cmath>
#include <random>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "flare/optics/Surface.h"

namespace flare {
namespace {

Surface sphere(double radius, double semiAperture, double z = 0.0) {
    Surface s;
    s.radiusMm = radius;
    s.semiApertureMm = semiAperture;
    s.vertexZMm = z;
    return s;
}

// The hit point lies on the surface: |z − z_vertex − sag(r)| small.
double residual(const Surface& s, const glm::dvec3& p) {
    double sag = 0.0;
    EXPECT_TRUE(s.sagMm(p.x * p.x + p.y * p.y, &sag));
    return std::abs(p.z - s.vertexZMm - sag);
}

TEST(Surface, PlaneHit) {
    Surface s = sphere(0.0, 10.0, 5.0);
    const Ray ray{{1.0, 2.0, -3.0}, glm::normalize(glm::dvec3(0.1, 0.0, 1.0))};
    const SurfaceHit hit = intersect(s, ray);
    ASSERT_EQ(hit.status, HitStatus::Hit);
    EXPECT_NEAR(ray.at(hit.tMm).z, 5.0, 1e-14);
}

TEST(Surface, SphereHitsVertexSideFromBothDirections) {
    for (double radius : {25.0, -25.0}) {
        Surface s = sphere(radius, 10.0, 3.0);
        for (double dz : {1.0, -1.0}) {
            const Ray ray{{2.0, -1.0, dz > 0 ? -20.0 : 30.0}, {0.0, 0.0, dz}};
            const SurfaceHit hit = intersect(s, ray);
            ASSERT_EQ(hit.status, HitStatus::Hit);
            const glm::dvec3 p = ray.at(hit.tMm);
            EXPECT_LT(residual(s, p), 1e-12);
            EXPECT_LT(std::abs(p.z - 3.0), 1.0);  // near the vertex, not the far cap
        }
    }
}

TEST(Surface, NearlyFlatSphereHasNoCancellation) {
    Surface s = sphere(1e9, 10.0);
    const Ray ray{{5.0, 0.0, -1.0}, {0.0, 0.0, 1.0}};
    const SurfaceHit hit = intersect(s, ray);
    ASSERT_EQ(hit.status, HitStatus::Hit);
    // R − √(R² − r²) would lose every digit here; the stable form is limited only by the ulp of
    // the ray parameter t ≈ 1 (2.2e-16), not by the 1e-8 mm sag.
    EXPECT_NEAR(ray.at(hit.tMm).z, 25.0 / (2.0 * 1e9), 1e-15);
}

// From a far origin the quadratic's discriminant b² − a c cancels: solved as given, this hit (an
// origin 2·10⁵ mm away, nearly parallel to the vertex plane, on an R = 2.5 mm sphere) missed the
// surface by 8·10⁻⁷ mm. Solved from the ray's point nearest the vertex it lies on the surface to
// rounding (the residual is then ~4·10⁻¹⁴ mm, mostly the rounding of the hit point o + t d itself).
TEST(Surface, HitFromAFarOriginLiesOnTheSurface) {
    const Surface s = sphere(2.5257321427787489, 0.87773556188973056);
    const glm::dvec3 d(-0x1.eb0785f6a29bfp-1, -0x1.221022b0103e3p-2, 0x1.6df0dc5089dc3p-18);
    const Ray ray{{0x1.7340054c3d8bbp+17, 0x1.b69e272541b66p+15, -0x1.00005b7c37142p+0}, d};
    const SurfaceHit hit = intersect(s, ray);
    ASSERT_EQ(hit.status, HitStatus::Hit);
    EXPECT_LT(residual(s, ray.at(hit.tMm)), 1e-12) << "the hit point is off the surface";
}

TEST(Surface, ParaboloidMatchesClosedForm) {
    Surface s = sphere(20.0, 15.0);
    s.conic = -1.0;  // z = r² / (2R)
    for (double x : {0.0, 3.0, 9.0, 14.0}) {
        const Ray ray{{x, 0.0, -5.0}, {0.0, 0.0, 1.0}};
        const SurfaceHit hit = intersect(s, ray);
        ASSERT_EQ(hit.status, HitStatus::Hit);
        EXPECT_NEAR(ray.at(hit.tMm).z, x * x / 40.0, 1e-12);
    }
}

TEST(Surface, AsphereNewtonConvergesOntoTheSurfaceAndNormalIsGradient) {
    Surface s = sphere(30.0, 12.0, 2.0);
    s.conic = -0.7;
    s.asphere = {2e-5, -3e-8, 1e-10, 0, 0, 0, 0};
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int i = 0; i < 1000; ++i) {
        const glm::dvec3 origin(8.0 * u(rng), 8.0 * u(rng), -10.0);
        const glm::dvec3 dir = glm::normalize(glm::dvec3(0.2 * u(rng), 0.2 * u(rng), 1.0));
        const Ray ray{origin, dir};
        const SurfaceHit hit = intersect(s, ray);
        ASSERT_EQ(hit.status, HitStatus::Hit);
        const glm::dvec3 p = ray.at(hit.tMm);
        EXPECT_LT(residual(s, p), 1e-10);
        // Normal ⟂ to the surface: compare with a finite-difference tangent.
        const double h = 1e-5;
        double z1 = 0.0, z2 = 0.0;
        s.sagMm((p.x + h) * (p.x + h) + p.y * p.y, &z1);
        s.sagMm((p.x - h) * (p.x - h) + p.y * p.y, &z2);
        const glm::dvec3 tangent = glm::normalize(glm::dvec3(2.0 * h, 0.0, z1 - z2));
        EXPECT_NEAR(glm::dot(tangent, s.normalAt(p)), 0.0, 1e-7);
    }
}

TEST(Surface, MissesAndNewtonFailureReturnStatusNotThrow) {
    Surface s = sphere(5.0, 4.0);
    EXPECT_EQ(intersect(s, Ray{{10.0, 0.0, -5.0}, {0.0, 0.0, 1.0}}).status, HitStatus::Miss);
    // A wildly divergent polynomial: the sag is defined but Newton cannot settle.
    Surface wild = sphere(5.0, 4.0);
    wild.asphere = {0, 0, 0, 0, 0, 0, 1e3};
    const SurfaceHit hit = intersect(wild, Ray{{3.0, 0.0, -5.0}, glm::normalize(glm::dvec3(1.0, 0.0, 0.01))});
    EXPECT_NE(hit.status, HitStatus::Hit);
    // Ray travelling away from the surface.
    EXPECT_EQ(intersect(s, Ray{{0.0, 0.0, -5.0}, {0.0, 0.0, -1.0}}).status, HitStatus::Miss);
}

}  // namespace
}  // namespace flare
