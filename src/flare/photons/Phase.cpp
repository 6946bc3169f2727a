#include "flare/photons/Phase.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>

namespace flare {

namespace {
constexpr double kPi = std::numbers::pi;

}  // namespace

glm::dvec3 directionAround(const glm::dvec3& n, double cosTheta, double phi) {
    glm::dvec3 t1, t2;
    orthonormalFrame(n, &t1, &t2);
    const double sinTheta = std::sqrt(std::max(0.0, 1.0 - cosTheta * cosTheta));
    return glm::normalize(sinTheta * std::cos(phi) * t1 + sinTheta * std::sin(phi) * t2 + cosTheta * n);
}

void orthonormalFrame(const glm::dvec3& n, glm::dvec3* t1, glm::dvec3* t2) {
    const glm::dvec3 helper = std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
    *t1 = glm::normalize(glm::cross(helper, n));
    *t2 = glm::cross(n, *t1);
}

double henyeyGreensteinPdf(double cosTheta, double g) {
    const double denominator = 1.0 + g * g - 2.0 * g * cosTheta;
    return (1.0 - g * g) / (4.0 * kPi * denominator * std::sqrt(denominator));
}

double sampleHenyeyGreensteinCos(double g, double u) {
    if (std::abs(g) < 1e-4) return 1.0 - 2.0 * u;  // isotropic (the formula below divides by g)
    const double s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    return std::clamp((1.0 + g * g - s * s) / (2.0 * g), -1.0, 1.0);
}

glm::dvec3 sampleHenyeyGreenstein(const glm::dvec3& direction, double g, double u1, double u2) {
    return directionAround(direction, sampleHenyeyGreensteinCos(g, u1), 2.0 * kPi * u2);
}

glm::dvec3 sampleCosineHemisphere(const glm::dvec3& n, double u1, double u2) {
    return directionAround(n, std::sqrt(std::max(0.0, 1.0 - u1)), 2.0 * kPi * u2);
}

glm::dvec3 samplePowerCosine(const glm::dvec3& axis, double exponent, double u1, double u2) {
    return directionAround(axis, std::pow(1.0 - u1, 1.0 / (exponent + 1.0)), 2.0 * kPi * u2);
}

double paintLobeDensity(const glm::dvec3& n, const glm::dvec3& mirror, double diffuse, double glossy,
                        double exponent, const glm::dvec3& w) {
    const double cosTheta = glm::dot(n, w);
    if (!(cosTheta > 0.0)) return 0.0;
    double density = diffuse * cosTheta / kPi;
    if (const double cosAlpha = glm::dot(mirror, w); glossy > 0.0 && cosAlpha > 0.0)
        density += glossy * (exponent + 1.0) / (2.0 * kPi) * std::pow(cosAlpha, exponent);
    return density;
}

double flatAreaDirectionPdf(const glm::dvec3& x, const glm::dvec3& y, double areaMm2) {
    const glm::dvec3 d = y - x;
    const double distance2 = glm::dot(d, d);
    if (!(d.z > 0.0) || !(areaMm2 > 0.0)) return 0.0;
    const double cosTheta = d.z / std::sqrt(distance2);
    return distance2 / (areaMm2 * cosTheta);
}

glm::dvec3 sampleGgxNormal(const glm::dvec3& n, double alpha, double u1, double u2) {
    // tan²θ = α² u / (1 − u) inverts the CDF of D(m)(m·n) for GGX.
    const double tan2 = alpha * alpha * u1 / std::max(1.0 - u1, 1e-300);
    return directionAround(n, 1.0 / std::sqrt(1.0 + tan2), 2.0 * kPi * u2);
}

}  // namespace flare
