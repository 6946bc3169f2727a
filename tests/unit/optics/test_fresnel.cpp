// Fresnel equations and Snell's law against closed-form and catalogue values.
#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "flare/optics/Fresnel.h"
#include "flare/optics/Glass.h"

namespace flare {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
// The reference values are printed to 5 significant digits: half a unit in the last place.
constexpr double kPrintedDigits = 0.5e-5;

double nBk7() { return findCatalogGlass("N-BK7")->nd; }

TEST(Fresnel, NormalIncidenceFourPercentAtIndexOnePointFive) {
    const FresnelTerms f = fresnelDielectric(1.0, 1.0, 1.5);
    EXPECT_NEAR(f.rs, 0.04, 1e-15);
    EXPECT_NEAR(f.rp, 0.04, 1e-15);
    EXPECT_NEAR(f.reflectance(), 0.04, 1e-15);
}

TEST(Fresnel, AirToBk7At45DegreesMatchesReference) {
    const FresnelTerms f = fresnelDielectric(std::cos(45.0 * kDeg), 1.0, nBk7());
    EXPECT_NEAR(f.rs, 0.09598, kPrintedDigits);
    EXPECT_NEAR(f.rp, 0.00921, kPrintedDigits);
    EXPECT_NEAR(f.reflectance(), 0.05260, kPrintedDigits);
}

TEST(Fresnel, EnergyIsConservedPerPolarisationFromBothSides) {
    for (double n2 : {1.2, 1.5168, 1.9}) {
        for (int i = 0; i <= 90; ++i) {
            const double cosI = std::cos(i * kDeg);
            for (const auto& [a, b] : {std::pair{1.0, n2}, std::pair{n2, 1.0}}) {
                const FresnelTerms f = fresnelDielectric(cosI, a, b);
                EXPECT_NEAR(f.rs + f.ts, 1.0, 1e-12) << "angle " << i << " n " << a << "->" << b;
                EXPECT_NEAR(f.rp + f.tp, 1.0, 1e-12) << "angle " << i << " n " << a << "->" << b;
            }
        }
    }
}

TEST(Fresnel, TotalInternalReflectionAboveCriticalAngleOfBk7) {
    const double critical = std::asin(1.0 / nBk7()) / kDeg;
    EXPECT_NEAR(critical, 41.25, 0.005);  // printed to 0.01°
    const FresnelTerms below = fresnelDielectric(std::cos((critical - 0.01) * kDeg), nBk7(), 1.0);
    EXPECT_FALSE(below.totalInternalReflection);
    EXPECT_LT(below.reflectance(), 1.0);
    const FresnelTerms above = fresnelDielectric(std::cos((critical + 0.01) * kDeg), nBk7(), 1.0);
    EXPECT_TRUE(above.totalInternalReflection);
    EXPECT_EQ(above.reflectance(), 1.0);
    EXPECT_EQ(above.transmittance(), 0.0);
    glm::dvec3 refracted;
    const glm::dvec3 d(std::sin((critical + 0.01) * kDeg), 0.0, std::cos((critical + 0.01) * kDeg));
    EXPECT_FALSE(refract(d, {0.0, 0.0, 1.0}, nBk7(), 1.0, &refracted));
}

TEST(Fresnel, BrewsterAngleHasNoPReflection) {
    const double brewster = std::atan(nBk7());
    EXPECT_NEAR(brewster / kDeg, 56.60, 0.005);
    EXPECT_NEAR(fresnelDielectric(std::cos(brewster), 1.0, nBk7()).rp, 0.0, 1e-15);
}

TEST(Snell, RefractedDirectionObeysSnellAndStaysInPlane) {
    const double n1 = 1.0, n2 = 1.7;
    for (int i = 0; i < 89; i += 7) {
        const double theta = i * kDeg;
        const glm::dvec3 d(std::sin(theta) * 0.6, std::sin(theta) * 0.8, std::cos(theta));
        const glm::dvec3 normal = glm::normalize(glm::dvec3(0.0, 0.0, -1.0));
        glm::dvec3 t;
        ASSERT_TRUE(refract(d, normal, n1, n2, &t));
        EXPECT_NEAR(glm::length(t), 1.0, 1e-14);
        const double sinI = glm::length(glm::cross(d, normal));
        const double sinT = glm::length(glm::cross(t, normal));
        EXPECT_NEAR(n1 * sinI, n2 * sinT, 1e-14);
        EXPECT_NEAR(glm::dot(glm::cross(d, normal), t), 0.0, 1e-14);  // coplanar
        EXPECT_GT(t.z, 0.0);
    }
}

TEST(Reflect, MirrorsAboutNormal) {
    const glm::dvec3 d = glm::normalize(glm::dvec3(0.3, -0.2, 1.0));
    const glm::dvec3 r = reflect(d, {0.0, 0.0, 1.0});
    EXPECT_DOUBLE_EQ(r.x, d.x);
    EXPECT_DOUBLE_EQ(r.y, d.y);
    EXPECT_DOUBLE_EQ(r.z, -d.z);
}

}  // namespace
}  // namespace flare
