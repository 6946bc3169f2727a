#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <glm/mat2x2.hpp>

#include "flare/optics/Iris.h"
#include "flare/wave/ApertureTransform.h"
#include "flare/wave/DiffractionPsf.h"
#include "flare/wave/PupilOutline.h"

using namespace flare;

namespace {

constexpr double kPi = std::numbers::pi;

std::vector<SpectralSample> monochromatic(double wavelengthNm) { return {{wavelengthNm, glm::dvec3(1.0)}}; }

// An ideal lens of focal length f: a direction change α moves the image by f·α; pixels of `pixelMm`.
glm::dmat2 idealLens(double focalMm, double pixelMm) { return glm::dmat2(focalMm / pixelMm); }

}  // namespace

TEST(ApertureTransform, CircleMatchesTheAiryAmplitude) {
    const double r = 1.5;
    const ApertureTransform circle(circleOutline(r, 2048));
    EXPECT_NEAR(circle.areaMm2(), kPi * r * r, 1e-5 * kPi * r * r);
    for (double kr : {0.5, 2.0, 3.8317, 7.0, 12.0}) {
        const double k = kr / r;
        const double airy = 2.0 * kPi * r * r * std::cyl_bessel_j(1.0, kr) / kr;
        EXPECT_NEAR(circle.transform({k * 0.6, k * 0.8}).real(), airy, 1e-4 * kPi * r * r) << kr;
    }
    // The circle has no straight edge: all of it is the smooth halo, ρ = r in every direction.
    EXPECT_TRUE(circle.spikeEdges().empty());
    for (double beta : {0.0, 1.0, 2.5, -2.0}) EXPECT_NEAR(circle.smoothDensityMmPerRad(beta), r, 0.01 * r);
}

TEST(ApertureTransform, SquareMatchesItsSeparableTransform) {
    const double s = 2.0;
    const ApertureTransform square({{-1, -1}, {1, -1}, {1, 1}, {-1, 1}});
    ASSERT_EQ(square.spikeEdges().size(), 4u);
    auto sinc = [](double x) { return x == 0.0 ? 1.0 : std::sin(x) / x; };
    for (const glm::dvec2 k : {glm::dvec2(0.3, 0.0), glm::dvec2(2.0, 5.0), glm::dvec2(-7.0, 0.4)}) {
        const double exact = s * s * sinc(k.x * s / 2) * sinc(k.y * s / 2);
        EXPECT_NEAR(square.transform(k).real(), exact, 1e-12);
        EXPECT_NEAR(square.transform(k).imag(), 0.0, 1e-12);
    }
}

// The Airy pattern: first zero at 1.22 λN, 83.8 % of the energy inside it (1 − J0² − J1² at the
// zero), on pixels of λN/20.
TEST(DiffractionPsf, CircularApertureGivesTheAiryPattern) {
    const double lambdaNm = 550.0, radius = 1.0, focal = 100.0;
    const double fNumber = focal / (2.0 * radius);
    const double pixel = lambdaNm * 1e-6 * fNumber / 20.0;
    const ApertureTransform circle(circleOutline(radius, 2048));
    DiffractionPsf psf(circle, monochromatic(lambdaNm), idealLens(focal, pixel));
    const int half = static_cast<int>(std::ceil(psf.coherentRadiusPx())) + 4;
    const std::vector<float> image = psf.window(half);
    const int side = 2 * half + 1;
    auto at = [&](int x, int y) { return image[3 * (static_cast<size_t>(y + half) * side + (x + half)) + 1]; };
    int zero = 0;
    float lowest = 1e30f;
    for (int x = 18; x <= 30; ++x)
        if (at(x, 0) < lowest) lowest = at(x, 0), zero = x;
    EXPECT_NEAR(zero, 1.22 * 20.0, 1.0);
    double inside = 0.0;
    const double ring = 1.2197 * 20.0;
    for (int y = -half; y <= half; ++y)
        for (int x = -half; x <= half; ++x)
            if (x * x + y * y <= ring * ring) inside += at(x, y);
    const double j0 = std::cyl_bessel_j(0.0, 3.8317), j1 = std::cyl_bessel_j(1.0, 3.8317);
    EXPECT_NEAR(inside, 1.0 - j0 * j0 - j1 * j1, 0.004);
    EXPECT_LT(psf.parsevalError(), 0.01);
}

namespace {

// The PSF's energy per pixel on a ring of radius r (px) around the point image, at `samples`
// directions (the pixel cell centred there).
std::vector<double> ringProfile(const DiffractionPsf& psf, double radiusPx, int samples) {
    std::vector<double> ring(samples);
    for (int i = 0; i < samples; ++i) {
        const double phi = 2.0 * kPi * i / samples;
        ring[i] = psf.cellEnergy({radiusPx * std::cos(phi), radiusPx * std::sin(phi)}, 0.5).y;
    }
    return ring;
}

// Directions (rad) of the ring's spikes: its local maxima above a tenth of the highest, those
// within a degree of each other (a spike's sinc² side lobes) counted once, at the highest.
std::vector<double> spikeDirections(const std::vector<double>& ring) {
    const double highest = *std::max_element(ring.begin(), ring.end());
    const int n = static_cast<int>(ring.size());
    std::vector<std::pair<double, double>> peaks;  // (direction, value)
    for (int i = 0; i < n; ++i)
        if (ring[i] > 0.1 * highest && ring[i] >= ring[(i + n - 1) % n] && ring[i] > ring[(i + 1) % n])
            peaks.push_back({2.0 * kPi * i / n, ring[i]});
    std::vector<std::pair<double, double>> merged;
    for (const auto& p : peaks) {
        if (!merged.empty() && p.first - merged.back().first < kPi / 180.0) {
            if (p.second > merged.back().second) merged.back() = p;
            continue;
        }
        merged.push_back(p);
    }
    if (merged.size() > 1 && merged.front().first + 2.0 * kPi - merged.back().first < kPi / 180.0) {
        if (merged.back().second > merged.front().second) merged.front() = merged.back();
        merged.pop_back();
    }
    std::vector<double> directions;
    for (const auto& p : merged) directions.push_back(p.first);
    return directions;
}

double angularDistance(double a, double b) {
    const double d = std::fmod(std::abs(a - b), kPi);  // a spike is a line: φ and φ + π alike
    return std::min(d, kPi - d);
}

}  // namespace

// N blades: 2N spikes for odd N, N for even N (opposite edges are parallel), each perpendicular to
// a blade edge; rotating the iris rotates the star.
TEST(DiffractionPsf, PolygonIrisGivesTwoNSpikesForOddNAndNForEvenN) {
    const double focal = 50.0, pixel = 0.01;
    for (int blades : {5, 6, 7, 8}) {
        for (double rotationDeg : {0.0, 11.0}) {
            const Iris iris(blades, rotationDeg * kPi / 180.0, 0.0, 3.0);
            const ApertureTransform aperture(irisOutline(iris));
            ASSERT_EQ(aperture.spikeEdges().size(), static_cast<size_t>(blades));
            DiffractionPsf psf(aperture, monochromatic(550.0), idealLens(focal, pixel));
            psf.window(static_cast<int>(psf.coherentRadiusPx()) + 4);
            const std::vector<double> peaks = spikeDirections(ringProfile(psf, 400.0, 7200));
            EXPECT_EQ(peaks.size(), static_cast<size_t>(blades % 2 ? 2 * blades : blades)) << blades;
            // Each peak lies along the normal of an edge: the edges' mid-normals are at
            // rotation + (k + ½)·2π/N (Iris.h: the rotation is the first vertex's angle).
            for (double phi : peaks) {
                double nearest = 1e9;
                for (int k = 0; k < blades; ++k)
                    nearest = std::min(nearest, angularDistance(phi, rotationDeg * kPi / 180.0 + (k + 0.5) * 2.0 * kPi / blades));
                EXPECT_LT(nearest, 2.0 * 2.0 * kPi / 7200) << blades << " blades, peak at " << phi;
            }
        }
    }
}

// Curved blades (on the circumscribed circle) have no straight edge: no spikes, a halo.
TEST(DiffractionPsf, FullyCurvedBladesGiveNoSpikes) {
    const Iris iris(6, 0.0, 1.0, 3.0);
    const ApertureTransform aperture(irisOutline(iris));
    EXPECT_TRUE(aperture.spikeEdges().empty());
    DiffractionPsf psf(aperture, monochromatic(550.0), idealLens(50.0, 0.01));
    psf.window(static_cast<int>(psf.coherentRadiusPx()) + 4);
    // A halo: the ring varies by less than a factor 3 (the spikes of straight blades stand 10⁴
    // times above their surroundings).
    const std::vector<double> ring = ringProfile(psf, 400.0, 3600);
    EXPECT_LT(*std::max_element(ring.begin(), ring.end()), 3.0 * *std::min_element(ring.begin(), ring.end()));
}

// The pattern scales linearly with λ and with the f-number: the radius holding half the energy.
TEST(DiffractionPsf, ScalesLinearlyWithWavelengthAndFNumber) {
    auto halfEnergyRadius = [](double lambdaNm, double irisRadiusMm) {
        const ApertureTransform aperture(irisOutline(Iris(7, 0.0, 0.0, irisRadiusMm)));
        DiffractionPsf psf(aperture, monochromatic(lambdaNm), idealLens(100.0, 0.5e-3));
        const int half = static_cast<int>(psf.coherentRadiusPx()) + 4;
        const std::vector<float> image = psf.window(half);
        const int side = 2 * half + 1;
        std::vector<double> byRadius(half + 2, 0.0);
        for (int y = -half; y <= half; ++y)
            for (int x = -half; x <= half; ++x) {
                const double r = std::hypot(x, y);
                if (r <= half) byRadius[static_cast<int>(r)] += image[3 * (static_cast<size_t>(y + half) * side + x + half) + 1];
            }
        double sum = 0.0;
        for (int r = 0; r <= half; ++r) {
            if (sum + byRadius[r] >= 0.5) return r + (0.5 - sum) / byRadius[r];
            sum += byRadius[r];
        }
        return -1.0;
    };
    const double base = halfEnergyRadius(450.0, 2.0);
    EXPECT_NEAR(halfEnergyRadius(650.0, 2.0) / base, 650.0 / 450.0, 0.02);
    EXPECT_NEAR(halfEnergyRadius(450.0, 1.0) / base, 2.0, 0.04);  // half the pupil: twice the f-number
}

// The normalised PSF integrates to 1: the window's pixels plus the asymptote's energy outside it,
// computed for a larger window after the normalisation was fixed on a smaller one, to 1e-3 (the
// asymptote's own accuracy at the window's edge); and before normalisation the model's energy is
// within 2 % of Parseval's 1 (the asymptote of a curved outline is good to about 1/(kρ), some per
// cent where it takes over from the exact core; measured 1.3 % here, 0.09 % on the default scene).
TEST(DiffractionPsf, IntegratesToOne) {
    const ApertureTransform aperture(irisOutline(Iris(6, 0.2, 0.3, 2.5)));
    std::vector<SpectralSample> spectrum;
    for (int i = 0; i < 16; ++i) spectrum.push_back({420.0 + 20.0 * i, glm::dvec3(1.0, 0.5 + 0.03 * i, 1.0 - 0.05 * i)});
    DiffractionPsf psf(aperture, spectrum, glm::dmat2(2000.0, 300.0, -150.0, 2200.0));
    const int half = static_cast<int>(psf.coherentRadiusPx()) + 4;
    psf.window(half);
    EXPECT_LT(psf.parsevalError(), 0.02);
    const int larger = 3 * half;
    const std::vector<float> image = psf.window(larger);
    glm::dvec3 inside{0.0};
    for (size_t i = 0; i < image.size(); i += 3) inside += glm::dvec3(image[i], image[i + 1], image[i + 2]);
    // Outside the larger window: the spikes' and halo's analytic tails (normalised).
    glm::dvec3 outside{0.0};
    for (const DiffractionPsf::Spike& s : psf.spikes())
        outside += 2.0 * s.lineDensity / ((larger + 0.5) / std::max(std::abs(s.directionPx.x), std::abs(s.directionPx.y)));
    for (int i = 0; i < 1440; ++i) {
        const double phi = 2.0 * kPi * (i + 0.5) / 1440;
        const glm::dvec2 u{std::cos(phi), std::sin(phi)};
        outside += psf.smoothPerPixel(u) / ((larger + 0.5) / std::max(std::abs(u.x), std::abs(u.y))) * (2.0 * kPi / 1440);
    }
    // The corners' interference falls as 1/r⁴ per pixel: R²/2 times its value at the edge R.
    for (int i = 0; i < 8 * 1440; ++i) {
        const double phi = 2.0 * kPi * (i + 0.5) / (8 * 1440);
        const glm::dvec2 u{std::cos(phi), std::sin(phi)};
        const double exitR = (larger + 0.5) / std::max(std::abs(u.x), std::abs(u.y));
        outside += psf.cornerPerPixel(exitR * u) * exitR * exitR / 2.0 * (2.0 * kPi / (8 * 1440));
    }
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(inside[c] + outside[c], 1.0, 1e-3) << c;
}

// The exact core integrates each pixel (box pixels): the Airy pattern's peak pixel against its
// box integral (2-D Gauss–Legendre on 48 × 48 nodes of the analytic [2 J1(x)/x]²), for pixels of a
// third, a fifth and a tenth of λN (sampling them at 2 × 2 or 1 × 1 points overstated them by
// 1.1 %, 1.7 % and 0.4 %). The 2048-gon's area is the circle's to 2e-6; what remains is the exact
// core's table interpolation (bicubic on eight samples per fringe, h = 2π/(8D)): F = 2J1(x)/x
// has a quartic term x⁴/192 that the cubic misses by ~(hR)⁴/192 ≈ 1e-4 per axis, so |F|² in two
// axes by up to 4e-4 (measured: −3.9e-4 at five pixels per λN). Tolerance 1e-3.
TEST(DiffractionPsf, ExactCoreIntegratesEachPixel) {
    const double lambdaNm = 550.0, radius = 1.0, focal = 100.0;
    const double lambda = lambdaNm * 1e-6, fNumber = focal / (2.0 * radius);
    const ApertureTransform circle(circleOutline(radius, 2048));
    // Gauss–Legendre nodes on [−1, 1] by Newton on P_n.
    const int nodes = 48;
    std::vector<double> x(nodes), w(nodes);
    for (int i = 0; i < nodes; ++i) {
        double z = std::cos(kPi * (i + 0.75) / (nodes + 0.5)), dp = 0.0;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1.0, p1 = z;
            for (int k = 2; k <= nodes; ++k) {
                const double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
                p0 = p1, p1 = p2;
            }
            dp = nodes * (z * p1 - p0) / (z * z - 1.0);
            const double step = p1 / dp;
            z -= step;
            if (std::abs(step) < 1e-15) break;
        }
        x[i] = z, w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
    }
    for (double pixelsPerLambdaN : {3.0, 5.0, 10.0}) {
        const double pixel = lambda * fNumber / pixelsPerLambdaN;
        DiffractionPsf psf(circle, monochromatic(lambdaNm), idealLens(focal, pixel));
        // I(α) = A/λ² [2 J1(x)/x]², x = 2πR|α|/λ; the pixel spans ±pixel/(2f) in α.
        const double area = kPi * radius * radius, half = 0.5 * pixel / focal;
        double exact = 0.0;
        for (int i = 0; i < nodes; ++i)
            for (int j = 0; j < nodes; ++j) {
                const double xr = 2.0 * kPi * radius / lambda * half * std::hypot(x[i], x[j]);
                const double airy = xr < 1e-8 ? 1.0 : 2.0 * std::cyl_bessel_j(1.0, xr) / xr;
                exact += w[i] * w[j] * airy * airy;
            }
        exact *= area / (lambda * lambda) * half * half;
        EXPECT_NEAR(psf.cellEnergy({0.0, 0.0}, 0.5).y / exact, 1.0, 1e-3) << pixelsPerLambdaN << " px per λN";
    }
}

// The fringe-averaged asymptote against the exact transform of an irregular pentagon, averaged
// over patches many fringes wide: between the spikes (where the edges alone give a fraction of
// the truth: their interference at the corners is half of it for a square) and across one edge's
// spike, at |u| = |k·t|L/2 from 0.3 to 6 (inside the corners' exact zone and beyond it).
TEST(ApertureTransform, AsymptoteIsTheFringeAverageOfThePolygonsTransform) {
    const std::vector<glm::dvec2> outline{{1.0, 0.0}, {0.4, 0.9}, {-0.8, 0.7}, {-0.9, -0.5}, {0.3, -1.0}};
    const ApertureTransform pentagon(outline);
    ASSERT_EQ(pentagon.spikeEdges().size(), 5u);
    ASSERT_EQ(pentagon.corners().size(), 5u);
    // Deterministic patch samples: a Halton sequence over radius × angle (or × transverse u).
    auto halton = [](int i, int base) {
        double f = 1.0, r = 0.0;
        for (; i > 0; i /= base) f /= base, r += f * (i % base);
        return r;
    };
    auto patchMean = [&](auto&& kOf, auto&& valueOf) {
        double sum = 0.0;
        const int samples = 40000;
        for (int i = 1; i <= samples; ++i) sum += valueOf(kOf(halton(i, 2), halton(i, 3)));
        return sum / samples;
    };
    auto exact = [&](const glm::dvec2& k) { return std::norm(pentagon.transform(k)) * std::pow(glm::dot(k, k), 2); };
    auto model = [&](const glm::dvec2& k) { return pentagon.incoherentIntensity(k) * std::pow(glm::dot(k, k), 2); };
    for (double phi : {0.3, 1.0, 2.0, 2.9, 4.0, 5.5}) {
        // r in [1000, 1200], angle ±0.01: hundreds of fringes in r (the spikes are ≥ 0.1 rad away).
        auto kOf = [&](double a, double b) {
            const double r = 1000.0 * (1.0 + 0.2 * a), p = phi + 0.02 * (b - 0.5);
            return glm::dvec2(r * std::cos(p), r * std::sin(p));
        };
        EXPECT_NEAR(patchMean(kOf, exact) / patchMean(kOf, model), 1.0, 0.01) << "direction " << phi;
    }
    const ApertureEdge& e = pentagon.spikeEdges()[2];
    for (double u : {0.3, 1.0, 2.0, 3.5, 6.0, -2.0, 14.0}) {
        auto kOf = [&](double a, double) { return 1000.0 * (1.0 + 0.2 * a) * e.normal + (2.0 * u / e.lengthMm) * e.tangent; };
        EXPECT_NEAR(patchMean(kOf, exact) / patchMean(kOf, model), 1.0, 0.01) << "u = " << u;
    }
}

// A fast lens on large pixels: f/2.8 at 50 mm on 47 µm pixels (the dusty double Gauss's 768 px
// frame) puts 0.03 px in a fringe, the whole exact core (ten fringes) inside the centre pixel.
// The pixel's sub-cells (at most maxSubsamples = 24 a side) were then wider than the peak, and
// their 2 × 2 Gauss nodes misjudged its energy (the model's total 1.19 in Z on that scene); the
// sub-cells that reach the core are now split to half a fringe. The Airy pattern's centre
// pixel, 30 λN wide, against its exact energy: the encircled energy 1 − J0² − J1² of the
// inscribed circle plus, by symmetry, the eight half-corners' wedges between it and the square.
// The model is exact to 7 fringes (0.23 px) and beyond it the fringe average of the curved
// outline, good to 1/(kρ) = 1/(7π) = 4.5 % of the energy beyond (2/(π kρ) = 2.9 %): 1.3e-3.
// Tolerance 2e-3 (measured: −4.3e-4). Before the split the pixel held 1.088.
TEST(DiffractionPsf, FringesMuchFinerThanAPixelKeepTheCentrePixelsEnergy) {
    const double lambdaNm = 550.0, radius = 1.0, focal = 100.0;
    const double lambdaN = lambdaNm * 1e-6 * focal / (2.0 * radius);
    const double pixel = 30.0 * lambdaN;
    const ApertureTransform circle(circleOutline(radius, 2048));
    const DiffractionPsf psf(circle, monochromatic(lambdaNm), idealLens(focal, pixel));
    ASSERT_LT(psf.coherentRadiusPx(), 0.5);
    // Encircled energy within r pixels (u = π r / (λN) in pixels of 30 λN).
    auto encircled = [](double rPx) {
        const double u = kPi * rPx * 30.0;
        const double j0 = std::cyl_bessel_j(0.0, u), j1 = std::cyl_bessel_j(1.0, u);
        return 1.0 - j0 * j0 - j1 * j1;
    };
    double corners = 0.0;
    const int steps = 20000;  // the wedge's far end crosses ~6 fringes over π/4: ample
    for (int i = 0; i < steps; ++i) {
        const double phi = 0.25 * kPi * (i + 0.5) / steps;
        corners += (encircled(0.5 / std::cos(phi)) - encircled(0.5)) * (0.25 * kPi / steps);
    }
    const double exact = encircled(0.5) + 8.0 * corners / (2.0 * kPi);
    EXPECT_NEAR(psf.cellEnergy({0.0, 0.0}, 0.5).y, exact, 2e-3);
}

// The same on a pupil like the dusty double Gauss's (six curved blades at f/2.8 on 47 µm pixels,
// a spectrum over 400–700 nm): the model's total energy before normalisation is within the
// model's stated 2 % of Parseval's 1 (it was 16 % off in X), and within 1e-3 of the same pupil's
// on pixels a sixteenth the size (0.5 px per fringe, where 24 sub-cells a side reach a quarter
// fringe with no second split): the pixel size changes only the quadrature (measured: 2.1–3.0e-4).
TEST(DiffractionPsf, ModelEnergyOnPixelsManyFringesWideIsParsevals) {
    const double focal = 50.0, pixel = 36.0 / 768.0;
    const ApertureTransform aperture(irisOutline(Iris(6, 0.2, 0.3, focal / 2.8 / 2.0)));
    std::vector<SpectralSample> spectrum;
    for (int i = 0; i < 16; ++i) spectrum.push_back({400.0 + 20.0 * i, glm::dvec3(1.0 - 0.05 * i, 0.5 + 0.03 * i, 1.0)});
    DiffractionPsf coarse(aperture, spectrum, idealLens(focal, pixel));
    coarse.window(32);
    EXPECT_LT(coarse.parsevalError(), 0.02);
    DiffractionPsf fine(aperture, spectrum, idealLens(focal, pixel / 16.0));
    fine.window(static_cast<int>(std::ceil(fine.coherentRadiusPx())) + 4);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(coarse.parsevalTotal()[c], fine.parsevalTotal()[c], 1e-3) << c;
}

// The PSF is point-symmetric for any pupil (|F(−k)|² = |F(k)|² for a real pupil function; the
// asymptote's spikes, corners and halo are even in α), so window() evaluates half the cells and
// mirrors them. Checked on pupils with no symmetry of their own (an irregular pentagon; a circle
// cut by an off-centre chord: spikes, corners and a halo), through a sheared pixel map, on cells
// of the exact core, the blend and the asymptote: each cell against its mirror image within
// 1e-9 relative (double rounding of the sums is ~1e-14; the exact core's table values at k and −k
// are conjugate to rounding, ~1e-14 of the peak), and the window's mirrored half against cells
// evaluated there directly, to float precision.
TEST(DiffractionPsf, IsPointSymmetricSoTheWindowMirrorsHalfItsCells) {
    std::vector<glm::dvec2> cut;
    for (const glm::dvec2& p : circleOutline(1.6, 720)) cut.push_back({std::min(p.x, 0.9), p.y + 0.1 * p.x});
    const std::vector<std::vector<glm::dvec2>> outlines = {
        {{-1.8, -1.0}, {1.5, -1.4}, {2.0, 0.6}, {0.3, 1.9}, {-1.2, 1.2}}, cut};
    std::vector<SpectralSample> spectrum;
    for (int i = 0; i < 8; ++i) spectrum.push_back({430.0 + 40.0 * i, glm::dvec3(1.0, 0.4 + 0.1 * i, 1.0 - 0.1 * i)});
    for (size_t o = 0; o < outlines.size(); ++o) {
        const ApertureTransform aperture(outlines[o]);
        DiffractionPsf psf(aperture, spectrum, glm::dmat2(900.0, 140.0, -60.0, 1100.0));
        const int half = static_cast<int>(std::ceil(psf.coherentRadiusPx())) + 12;
        const glm::dvec3 peak = psf.cellEnergy({0.0, 0.0}, 0.5);
        int checked = 0;
        for (int y = 1; y <= half; ++y)
            for (int x = -half; x <= half; x += 2) {
                const glm::dvec3 a = psf.cellEnergy({x, y}, 0.5), b = psf.cellEnergy({-x, -y}, 0.5);
                for (int c = 0; c < 3; ++c)
                    EXPECT_NEAR(a[c], b[c], 1e-9 * (std::abs(a[c]) + std::abs(b[c])) + 1e-12 * peak[c])
                        << o << " (" << x << ", " << y << ") " << c;
                ++checked;
            }
        EXPECT_GT(checked, 100);
        const std::vector<float> window = psf.window(half);
        const glm::dvec3 norm = 1.0 / psf.parsevalTotal();
        const int side = 2 * half + 1;
        for (int y = 1; y <= half; y += 2)  // the mirrored rows, below the centre's
            for (int x = -half; x <= half; x += 3) {
                const glm::dvec3 direct = psf.cellEnergy({x, y}, 0.5) * norm;
                for (int c = 0; c < 3; ++c)
                    EXPECT_NEAR(window[3 * (static_cast<size_t>(y + half) * side + (x + half)) + c], direct[c],
                                2e-7 * std::abs(direct[c]) + 1e-12)
                        << o << " (" << x << ", " << y << ") " << c;
            }
    }
}

// The exact core's table holds F on half its grid, the rest conjugated: F(−k) = F̄(k) for a real
// pupil, and ApertureTransform::transform gives exactly that (each edge's term at −k is the
// negated conjugate of its term at k), so the mirrored table is the computed one bit for bit.
TEST(ApertureTransform, TransformAtMinusKIsTheConjugateBitForBit) {
    std::vector<glm::dvec2> cut;
    for (const glm::dvec2& p : circleOutline(1.6, 720)) cut.push_back({std::min(p.x, 0.9), p.y + 0.1 * p.x});
    const ApertureTransform aperture(cut);
    for (int i = 0; i < 200; ++i) {
        const glm::dvec2 k{std::cos(0.37 * i) * (0.1 + 0.3 * i), std::sin(0.53 * i) * (0.2 + 0.25 * i)};
        const std::complex<double> a = aperture.transform(k), b = aperture.transform(-k);
        EXPECT_EQ(a.real(), b.real()) << i;
        EXPECT_EQ(a.imag(), -b.imag()) << i;
    }
}
