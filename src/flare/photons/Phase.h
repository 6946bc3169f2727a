// Phase functions and scattering lobes of the scattering effects: Henyey–Greenstein for bulk
// scattering in glass and for dust, a Phong lobe for glossy housing paint, and GGX microfacet
// normals for grease. Samplers are pure functions of their uniform numbers.
#pragma once

#include <glm/vec3.hpp>

namespace flare {

// Henyey–Greenstein density over the sphere, per steradian, of scattering by the angle whose
// cosine is cosTheta (measured from the incident direction); g in (−1, 1) is the mean cosine.
double henyeyGreensteinPdf(double cosTheta, double g);
// Cosine of the scattering angle drawn from Henyey–Greenstein by inverting its CDF.
double sampleHenyeyGreensteinCos(double g, double u);
// A direction scattered from `direction` with Henyey–Greenstein, azimuth uniform.
glm::dvec3 sampleHenyeyGreenstein(const glm::dvec3& direction, double g, double u1, double u2);

// Cosine-weighted direction about the unit vector n (density cosθ/π).
glm::dvec3 sampleCosineHemisphere(const glm::dvec3& n, double u1, double u2);
// A direction in the lobe cos^exponent about the unit axis (density (e+1)/(2π) cos^e).
glm::dvec3 samplePowerCosine(const glm::dvec3& axis, double exponent, double u1, double u2);

// A paint's scattering lobe: the share `diffuse` Lambertian about the unit normal n (towards the
// photon) and the share `glossy` in the power-cosine lobe about the unit mirror direction, as the
// photon tracer samples them; per steradian, towards the unit direction w (0 into the paint).
// This is f·cosθ, the density of the analog walk's scattered direction (absorption included).
double paintLobeDensity(const glm::dvec3& n, const glm::dvec3& mirror, double diffuse, double glossy,
                        double exponent, const glm::dvec3& w);

// The density per steradian, seen from x, of the direction towards a point y drawn uniformly on a
// flat area of `areaMm2` facing +z (the sensor, for the tracer's connections): distance² / (area ·
// cos θ), θ between the direction and +z; 0 if y is not ahead of x in z.
double flatAreaDirectionPdf(const glm::dvec3& x, const glm::dvec3& y, double areaMm2);

// A microfacet normal drawn from the GGX (Trowbridge–Reitz) distribution of roughness alpha about
// the macro normal n, with density D(m)·(m·n).
glm::dvec3 sampleGgxNormal(const glm::dvec3& n, double alpha, double u1, double u2);

// The unit direction at polar angle acos(cosTheta) and azimuth phi about the unit axis.
glm::dvec3 directionAround(const glm::dvec3& axis, double cosTheta, double phi);

// An orthonormal frame (t1, t2, n) about a unit vector n.
void orthonormalFrame(const glm::dvec3& n, glm::dvec3* t1, glm::dvec3* t2);

}  // namespace flare
