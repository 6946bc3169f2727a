// The starburst's far field against an independent Fraunhofer computation. A stop-in-front singlet
// (the pupil is the iris itself, traced exactly: 720 outline directions include the blades'
// corners) at f/22 images an on-axis point into one pixel; its starburst is compared with the
// exact transform of the traced pupil outline, computed here from the polygon's edges (not with
// ApertureTransform), integrated over each pixel (box pixels).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <numbers>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "flare/optics/LensFile.h"
#include "flare/optics/LensSystem.h"
#include "flare/wave/PupilOutline.h"
#include "flare/wave/Starburst.h"

namespace flare {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kSide = 1025;  // odd: the on-axis image lands on the centre of the centre pixel
constexpr int kCentre = kSide / 2;
constexpr double kWavelengthNm = 550.0;

LensSystem singlet(int blades, double rotationDeg, double fNumber) {
    const std::string text = "name singlet\nfocal_length_mm 100\niris blades=" + std::to_string(blades) +
                             " rotation_deg=" + std::to_string(rotationDeg) +
                             " curvature=0\nsensor width_mm=10.25 height_mm=10.25\nsurfaces\n"
                             " stop 2 air 10\n 60 6 N-BK7 12\n -200 auto air 12\n";
    LensState state;
    state.fNumber = fNumber;
    return LensSystem::build(parseLensText(text, "singlet.lens"), state);
}

// A point light `fieldRad` above the axis (a tilt about the x axis keeps the iris's mirror
// symmetry, so one pair of spikes stays exactly along the pixel rows).
glm::dvec3 lightDirection(double fieldRad) { return {0.0, std::sin(fieldRad), std::cos(fieldRad)}; }

StarburstLight pointLight(double fieldRad) {
    return {"point", lightDirection(fieldRad), {{kWavelengthNm, glm::dvec3(1.0)}}};
}

PupilOutline traceOutline(const LensSystem& lens, double fieldRad) {
    PupilOutlineOptions options;
    options.widthPx = kSide;
    options.heightPx = kSide;
    return tracePupilOutline(lens, lightDirection(fieldRad), options);
}

// The direct image: unit energy in the pixel (x, y), or split between it and the pixel below
// (the image's centroid then lies on the boundary between two rows).
std::vector<float> directImage(int x, int y, bool betweenRows) {
    std::vector<float> xyz(static_cast<size_t>(kSide) * kSide * 3, 0.0f);
    auto put = [&](int px, int py, float v) {
        for (int c = 0; c < 3; ++c) xyz[3 * (static_cast<size_t>(py) * kSide + px) + c] = v;
    };
    if (betweenRows) {
        put(x, y, 0.5f);
        put(x, y + 1, 0.5f);
    } else {
        put(x, y, 1.0f);
    }
    return xyz;
}

// Independent exact Fraunhofer transform of a polygon, F(k) = ∫_A exp(−i k·x) d²x, by a fan of
// triangles (0, a, b) from the centroid. By the Hermite–Genocchi formula the integral of e^{−ix}
// over a triangle, in barycentric form, is a second divided difference:
//   ∫_T e^{−ik·x} d²x = −(a × b) · h[0, −k·a, −k·b],   h(x) = e^{ix},
// closed form at every k (no sampling grid), with (a × b) signed so the fan covers the polygon.
std::complex<double> dividedExp(double x0, double x1, double x2) {
    const std::complex<double> i(0.0, 1.0);
    auto first = [&](double a, double b) {  // h[a, b] = (e^{ib} − e^{ia})/(b − a), by its series when close
        const double d = b - a;
        if (std::abs(d) < 1e-4) return std::exp(i * a) * (i + i * i * d / 2.0 + i * i * i * d * d / 6.0);
        return (std::exp(i * b) - std::exp(i * a)) / d;
    };
    const double spread = std::max({x0, x1, x2}) - std::min({x0, x1, x2});
    if (spread < 1e-5) return -0.5 * std::exp(i * (x0 + x1 + x2) / 3.0);  // h''(x̄)/2, to spread²
    // a and c the farthest apart (the divisor), b between in the recursion.
    double a = x0, b = x1, c = x2;
    if (std::abs(x1 - x0) >= std::abs(x2 - x0) && std::abs(x1 - x0) >= std::abs(x2 - x1)) std::swap(b, c);
    else if (std::abs(x2 - x1) > std::abs(x2 - x0)) std::swap(a, b);
    return (first(b, c) - first(a, b)) / (c - a);
}

struct ExactPolygon {
    std::vector<glm::dvec2> vertices;  // counter-clockwise, centroid at the origin
    double area = 0.0;

    explicit ExactPolygon(std::vector<glm::dvec2> v) {
        double twice = 0.0;
        glm::dvec2 moment{0.0};
        for (size_t i = 0; i < v.size(); ++i) {
            const glm::dvec2 a = v[i], b = v[(i + 1) % v.size()];
            const double c = a.x * b.y - a.y * b.x;
            twice += c;
            moment += c * (a + b);
        }
        if (twice < 0.0) std::reverse(v.begin(), v.end());
        const glm::dvec2 centroid = moment / (3.0 * twice);
        for (glm::dvec2& p : v) p -= centroid;
        area = 0.5 * std::abs(twice);
        // The traced outline has 720 vertices, most of them on the blades' straight edges (to the
        // tracer's 1e-6 mm): those within 1e-5 mm of their neighbours' chord are dropped, which
        // moves the outline by less than λ/50 and leaves the corners.
        for (bool dropped = true; dropped && v.size() > 3;) {
            dropped = false;
            for (size_t i = 0; i < v.size() && v.size() > 3; ++i) {
                const glm::dvec2 a = v[(i + v.size() - 1) % v.size()], b = v[(i + 1) % v.size()];
                const glm::dvec2 chord = b - a, p = v[i] - a;
                if (std::abs(chord.x * p.y - chord.y * p.x) / glm::length(chord) < 1e-5) {
                    v.erase(v.begin() + static_cast<std::ptrdiff_t>(i));
                    dropped = true;
                }
            }
        }
        vertices = std::move(v);
    }

    // Σ over the fan of triangles (0, a, b) of −(a × b) h[0, −k·a, −k·b].
    std::complex<double> transform(const glm::dvec2& k) const {
        std::complex<double> sum = 0.0;
        for (size_t i = 0; i < vertices.size(); ++i) {
            const glm::dvec2 a = vertices[i], b = vertices[(i + 1) % vertices.size()];
            const double twiceArea = a.x * b.y - a.y * b.x;  // signed: a fan from the centroid
            sum += twiceArea * dividedExp(0.0, -glm::dot(k, a), -glm::dot(k, b));
        }
        return -sum;
    }
};

struct Reference {
    ExactPolygon pupil;
    glm::dmat2 radPerPx;
    double pixelSolidAngle;
};

Reference reference(const LensSystem& lens) {
    const PupilOutline outline = traceOutline(lens, 0.0);
    EXPECT_TRUE(outline.found);
    const glm::dmat2 radPerPx = glm::inverse(outline.pxPerRad);
    return {ExactPolygon(outline.outlineMm), radPerPx, std::abs(glm::determinant(radPerPx))};
}

// A deterministic uniform number in [0, 1) for (pixel, sample) (splitmix64).
double uniform(uint64_t key) {
    key += 0x9e3779b97f4a7c15ull;
    key = (key ^ (key >> 30)) * 0xbf58476d1ce4e5b9ull;
    key = (key ^ (key >> 27)) * 0x94d049bb133111ebull;
    return static_cast<double>((key ^ (key >> 31)) >> 11) * 0x1.0p-53;
}

// Energy of the pixel at `offset` (px from the point image), from s × s jittered points of it
// (one in each cell of an s × s grid): unbiased, and summed over a ring of N pixels its relative
// statistical error is about c/√(N s²), c ≲ 1 the fringes' contrast.
double referencePixel(const Reference& ref, const glm::dvec2& offset, int s, uint64_t pixel) {
    const double lambda = kWavelengthNm * 1e-6;
    double sum = 0.0;
    for (int j = 0; j < s; ++j)
        for (int i = 0; i < s; ++i) {
            const uint64_t key = (pixel * 64 + j * s + i) * 2;
            const glm::dvec2 within{(i + uniform(key)) / s - 0.5, (j + uniform(key + 1)) / s - 0.5};
            const glm::dvec2 k = (2.0 * kPi / lambda) * (ref.radPerPx * (offset + within));
            sum += std::norm(ref.pupil.transform(k));
        }
    return sum / (s * s) * ref.pixelSolidAngle / (lambda * lambda * ref.pupil.area);
}

double lineAngleDistance(double a, double b) {
    const double d = std::fmod(std::abs(a - b), kPi);
    return std::min(d, kPi - d);
}

const double kRings[4] = {20.0, 60.0, 200.0, 500.0};
const int kSamplesPerSide[3] = {4, 2, 1};
// Off axis the image sits up to 27 px low: rings to 400 px. The bounds are half-integers, as the
// spikes' half-width below: a horizontal spike's pixels (centres at integer offsets) then cover
// exactly [20.5, 60.5] and |t| ≤ 5.5, as an oblique one's do on average (with integer bounds its
// innermost pixel, the brightest, would stand half a pixel inside: +3.5 % in the true pattern).
const double kSpikeRings[4] = {20.5, 60.5, 200.5, 400.5};

}  // namespace

// The exact transform used below: a unit square against its separable sinc, and Parseval's
// energy of a hexagon on a coarse grid (the check that the reference is a transform at all).
TEST(StarburstFarField, ReferenceTransformIsExact) {
    const ExactPolygon square({{-1, -1}, {1, -1}, {1, 1}, {-1, 1}});
    auto sinc = [](double x) { return x == 0.0 ? 1.0 : std::sin(x) / x; };
    for (const glm::dvec2 k : {glm::dvec2(0.0, 0.0), glm::dvec2(0.3, 0.0), glm::dvec2(2.0, 5.0), glm::dvec2(-7.0, 0.4),
                               glm::dvec2(1e-7, 3.0)}) {
        const std::complex<double> f = square.transform(k);
        EXPECT_NEAR(f.real(), 4.0 * sinc(k.x) * sinc(k.y), 1e-9) << k.x << " " << k.y;
        EXPECT_NEAR(f.imag(), 0.0, 1e-9);
    }
    // A triangle off the origin: the phase of its centroid's shift and its area.
    const ExactPolygon triangle({{0, 0}, {2, 0}, {0, 1}});
    EXPECT_NEAR(std::abs(triangle.transform({0.0, 0.0})), 1.0, 1e-12);
    // Against brute-force quadrature of the triangle at one frequency.
    const glm::dvec2 k{1.3, -2.1};
    std::complex<double> brute = 0.0;
    const int n = 2000;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const glm::dvec2 x{2.0 * (i + 0.5) / n, (j + 0.5) / n};
            if (x.x / 2.0 + x.y > 1.0) continue;
            const glm::dvec2 c = x - glm::dvec2(2.0 / 3.0, 1.0 / 3.0);
            brute += std::exp(std::complex<double>(0.0, -glm::dot(k, c)));
        }
    brute *= 2.0 / (double(n) * n);
    EXPECT_NEAR(std::abs(triangle.transform(k) - brute), 0.0, 2e-3);
}

// A 6-blade iris rotated 30°: spikes along 0°, 60° and 120°, one pair along the pixel row through
// the image. Every spike carries the same energy in each ring (to 2 %), and the image centred
// between two rows (the horizontal spikes then run along a row boundary) agrees with it. On axis
// and slightly off it: there the traced spike is horizontal to ~1e-9 rad (not exactly), which
// cut the pair off beyond the near window (its pixel range overflowed an int).
TEST(StarburstFarField, SpikeAlongThePixelRowKeepsItsEnergy) {
    const LensSystem lens = singlet(6, 30.0, 22.0);
    for (const double fieldRad : {0.0, 0.001, 0.003}) {
        const PupilOutline outline = traceOutline(lens, fieldRad);
        ASSERT_TRUE(outline.found);
        const int px = static_cast<int>(std::floor(outline.imagePx.x)), py = static_cast<int>(std::floor(outline.imagePx.y));
        auto spikeEnergies = [&](bool betweenRows) {
            const StarburstImage image =
                renderStarburst(lens, directImage(px, py, betweenRows), kSide, kSide, {pointLight(fieldRad)});
            EXPECT_TRUE(image.lights.at(0).diffracted) << image.lights.at(0).why;
            const glm::dvec2 centre{px + 0.5, py + (betweenRows ? 1.0 : 0.5)};
            // [ring][half-line]: the pixels within 5.5 px of each of the six half-lines.
            std::vector<std::vector<double>> energy(3, std::vector<double>(6, 0.0));
            for (int y = 0; y < kSide; ++y)
                for (int x = 0; x < kSide; ++x) {
                    const glm::dvec2 o = glm::dvec2(x + 0.5, y + 0.5) - centre;
                    const double r = glm::length(o);
                    int ring = -1;
                    for (int i = 0; i < 3; ++i)
                        if (r >= kSpikeRings[i] && r < kSpikeRings[i + 1]) ring = i;
                    if (ring < 0) continue;
                    for (int s = 0; s < 6; ++s) {
                        const glm::dvec2 d{std::cos(s * kPi / 3.0), std::sin(s * kPi / 3.0)};
                        if (glm::dot(o, d) > 0.0 && std::abs(d.x * o.y - d.y * o.x) < 5.5)
                            energy[ring][s] += image.xyz[3 * (static_cast<size_t>(y) * kSide + x) + 1];
                    }
                }
            return std::pair(energy, image.lights.at(0).outsideFrameShare);
        };
        const auto [onRow, outsideOnRow] = spikeEnergies(false);
        const auto [betweenRows, outsideBetween] = spikeEnergies(true);
        for (int ring = 0; ring < 3; ++ring) {
            double mean = 0.0;
            for (double e : onRow[ring]) mean += e / 6.0;
            for (int s = 0; s < 6; ++s) {
                EXPECT_NEAR(onRow[ring][s] / mean, 1.0, 0.02)
                    << "field " << fieldRad << " rad, ring " << ring << ", spike at " << 60 * s << "°";
                EXPECT_NEAR(betweenRows[ring][s] / onRow[ring][s], 1.0, 0.02)
                    << "field " << fieldRad << " rad, ring " << ring << ", spike at " << 60 * s << "°";
            }
        }
        // The light leaving the frame does not depend on where the image sits within its pixel.
        EXPECT_NEAR(outsideOnRow, outsideBetween, 0.02 * outsideBetween) << "field " << fieldRad;
    }
}

// Between the spikes (more than 10° from every spike line), the starburst's energy per ring is the
// exact transform's to 5 % (the reference: 4 × 4, 2 × 2 and 1 jittered point per pixel in the
// rings of about 6700, 76000 and 440000 pixels: statistical errors of about 0.3 %, 0.2 % and
// 0.15 %), and no pixel there is exactly zero.
TEST(StarburstFarField, LightBetweenTheSpikesFollowsTheExactTransform) {
    const LensSystem lens = singlet(6, 30.0, 22.0);
    const StarburstImage image = renderStarburst(lens, directImage(kCentre, kCentre, false), kSide, kSide, {pointLight(0.0)});
    ASSERT_TRUE(image.lights.at(0).diffracted) << image.lights.at(0).why;
    const Reference ref = reference(lens);
    EXPECT_EQ(ref.pupil.vertices.size(), 6u);  // the hexagon, its corners traced exactly
    // The corners' term is negative near some spikes; the pixels' sums are not.
    int negative = 0;
    for (const float v : image.xyz) negative += v < 0.0f;
    EXPECT_EQ(negative, 0);
    const glm::dvec2 centre{kCentre + 0.5, kCentre + 0.5};
    double rendered[3] = {0, 0, 0}, exact[3] = {0, 0, 0};
    int zeros[3] = {0, 0, 0}, counted[3] = {0, 0, 0};
    for (int y = 0; y < kSide; ++y)
        for (int x = 0; x < kSide; ++x) {
            const glm::dvec2 o = glm::dvec2(x + 0.5, y + 0.5) - centre;
            const double r = glm::length(o);
            int ring = -1;
            for (int i = 0; i < 3; ++i)
                if (r >= kRings[i] && r < kRings[i + 1]) ring = i;
            if (ring < 0) continue;
            const double phi = std::atan2(o.y, o.x);
            bool nearSpike = false;
            for (int s = 0; s < 3; ++s) nearSpike = nearSpike || lineAngleDistance(phi, s * kPi / 3.0) < 10.0 * kPi / 180.0;
            if (nearSpike) continue;
            const float v = image.xyz[3 * (static_cast<size_t>(y) * kSide + x) + 1];
            rendered[ring] += v;
            zeros[ring] += v == 0.0f;
            ++counted[ring];
            exact[ring] += referencePixel(ref, o, kSamplesPerSide[ring], static_cast<uint64_t>(y) * kSide + x);
        }
    for (int ring = 0; ring < 3; ++ring) {
        EXPECT_NEAR(rendered[ring] / exact[ring], 1.0, 0.05) << "ring " << kRings[ring] << "-" << kRings[ring + 1] << " px";
        EXPECT_EQ(zeros[ring], 0) << "of " << counted[ring] << " pixels in ring " << ring;
    }
}

}  // namespace flare
