// Spectra and colour: the CIE tables against their published check sums and chromaticities, the
// Planckian locus against published tables, Planck's law against the Stefan–Boltzmann and Wien
// constants, the Rec.709 matrix against IEC 61966-2-1, the preview quadrature's convergence and
// the photon wavelength sampler's distribution and weights.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <random>
#include <type_traits>
#include <vector>

#include <glm/common.hpp>
#include <glm/exponential.hpp>
#include <gtest/gtest.h>

#include "flare/core/Spectrum.h"

namespace flare {
namespace {

constexpr double kEpsilon = std::numeric_limits<double>::epsilon();
// CODATA 2018 second radiation constant c2 = hc/k (exact), m·K.
constexpr double kC2Codata = 6.62607015e-34 * 299792458.0 / 1.380649e-23;

// Reference tables state the c2 they used; Planck's law depends on c2/T only, so a black body
// computed with c2_used at T is ours at T·c2_codata/c2_used.
Spectrum blackbodyWithC2(double temperatureK, double c2UsedMK) {
    return Spectrum::blackbody(temperatureK * kC2Codata / c2UsedMK);
}

// Chromaticity by plain summation of the table at a fixed step (the CIE 15 practice that the
// published reference values come from: 5 nm over 380–780 or 360–830 nm).
glm::dvec2 summedChromaticity(const Spectrum& s, double fromNm, double toNm, double stepNm) {
    glm::dvec3 xyz(0.0);
    for (double l = fromNm; l <= toNm + 1e-9; l += stepNm) xyz += s.value(l) * cieXyzBar(l);
    return xyChromaticity(xyz);
}

// How far our integral (1 nm table, 360–830 nm) is from the summation methods in use for
// published chromaticities; a published value can only be expected to agree within this plus
// its printing precision.
glm::dvec2 methodSpread(const Spectrum& s) {
    const glm::dvec2 ours = xyChromaticity(spectrumXyz(s));
    glm::dvec2 spread(0.0);
    for (const auto& [lo, hi] : {std::pair{380.0, 780.0}, std::pair{360.0, 830.0}}) {
        const glm::dvec2 other = summedChromaticity(s, lo, hi, 5.0);
        spread = glm::max(spread, glm::abs(ours - other));
    }
    return spread;
}

glm::dvec2 toUv1960(const glm::dvec2& xy) {
    const double d = -2.0 * xy.x + 12.0 * xy.y + 3.0;
    return {4.0 * xy.x / d, 6.0 * xy.y / d};
}

TEST(CieTable, ColumnSumsMatchThePublishedCheckSums) {
    // Check sums of the CIE 1 nm 1931 table (CIE / CVRL), printed to 12 decimals. Summing 471
    // doubles of magnitude ≤ 107 adds at most 471 ulp(107) of rounding.
    const double reference[3] = {106.865469489595, 106.856917101172, 106.892251278636};
    const double tolerance = 0.5e-12 + 471 * (std::nextafter(107.0, 108.0) - 107.0);
    glm::dvec3 sum(0.0);
    for (int nm = 360; nm <= 830; ++nm) sum += cieXyzBar(nm);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(sum[c], reference[c], tolerance) << "column " << c;
}

TEST(CieTable, FiveNanometreSamplesMatchCie15TableT4Sums) {
    // CIE 15:2004 Table T.4 prints the 5 nm table (380–780 nm) to 6 decimals with column sums
    // 21.371524, 21.371327, 21.371540. Our samples carry 7 significant digits: rounding each of
    // the 81 to 6 decimals moves a sum by at most 81 × 0.5e-6, plus half a unit of the sum.
    const double reference[3] = {21.371524, 21.371327, 21.371540};
    const double tolerance = 81 * 0.5e-6 + 0.5e-6;
    glm::dvec3 sum(0.0);
    for (int nm = 380; nm <= 780; nm += 5) sum += cieXyzBar(nm);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(sum[c], reference[c], tolerance) << "column " << c;
}

TEST(CieTable, EqualEnergyIsWhiteToThePrecisionOfTheTables) {
    // The CIE scaled the 1931 functions to equal areas; the 1 nm table, an interpolation of the
    // 5 nm one, keeps that to the relative spread of its published check sums (3.3e-4).
    const double sums[3] = {106.865469489595, 106.856917101172, 106.892251278636};
    const double mean = (sums[0] + sums[1] + sums[2]) / 3.0;
    const double spread = (*std::max_element(sums, sums + 3) - *std::min_element(sums, sums + 3)) / mean;
    const glm::dvec3 xyz = spectrumXyz(Spectrum::equalEnergy());
    EXPECT_NEAR(xyz.x / xyz.y, 1.0, spread);
    EXPECT_NEAR(xyz.z / xyz.y, 1.0, spread);
    EXPECT_NEAR(xyz.x / xyz.z, 1.0, spread);
    // |x − 1/3| = |2X − Y − Z| / 3(X + Y + Z) ≤ (2/9)·(max − min)/mean.
    const glm::dvec2 xy = xyChromaticity(xyz);
    EXPECT_NEAR(xy.x, 1.0 / 3.0, 2.0 / 9.0 * spread);
    EXPECT_NEAR(xy.y, 1.0 / 3.0, 2.0 / 9.0 * spread);
}

TEST(CieTable, LuminosityPeaksAt555NmWithValueOne) {
    double bestNm = 0.0, best = -1.0;
    for (int i = 0; i <= 47000; ++i) {  // 360–830 nm in 0.01 nm steps
        const double nm = 360.0 + i / 100.0;
        if (cieXyzBar(nm).y > best) best = cieXyzBar(nm).y, bestNm = nm;
    }
    EXPECT_EQ(bestNm, 555.0);
    EXPECT_EQ(best, 1.0);
    EXPECT_EQ(cieXyzBar(359.9), glm::dvec3(0.0));
    EXPECT_EQ(cieXyzBar(830.1), glm::dvec3(0.0));
}

TEST(Chromaticity, D65MatchesItsPublishedWhitePoint) {
    const Spectrum d65 = Spectrum::d65();
    const glm::dvec2 xy = xyChromaticity(spectrumXyz(d65));
    // sRGB / Rec.709 white, printed to 4 decimals.
    EXPECT_NEAR(xy.x, 0.3127, 0.5e-4);
    EXPECT_NEAR(xy.y, 0.3290, 0.5e-4);
    // CIE 15:2004 Table T.3, printed to 5 decimals.
    const glm::dvec2 spread = methodSpread(d65);
    EXPECT_NEAR(xy.x, 0.31272, 0.5e-5 + spread.x);
    EXPECT_NEAR(xy.y, 0.32903, 0.5e-5 + spread.y);
}

TEST(Chromaticity, IlluminantAIsABlackbodyAtItsPublishedChromaticity) {
    // CIE 15:2004: illuminant A is Planck's law with c2 = 1.435e-2 m·K at 2848 K (the 2856 K of
    // the modern temperature scale); Table T.3 gives x = 0.44757, y = 0.40745.
    const Spectrum a = blackbodyWithC2(2848.0, 1.435e-2);
    const glm::dvec2 xy = xyChromaticity(spectrumXyz(a));
    const glm::dvec2 spread = methodSpread(a);
    EXPECT_NEAR(xy.x, 0.44757, 0.5e-5 + spread.x);
    EXPECT_NEAR(xy.y, 0.40745, 0.5e-5 + spread.y);
}

TEST(Chromaticity, BlackbodiesLieOnThePublishedPlanckianLocus) {
    // Robertson (1968), J. Opt. Soc. Am. 58, 1528 / Wyszecki & Stiles, Color Science (1982),
    // Table 1(3.11): CIE 1960 (u, v) of the Planckian locus, c2 = 1.4388e-2 m·K, 5 decimals.
    struct LocusPoint {
        double mired, u, v;
    };
    const LocusPoint table[] = {{100, 0.19032, 0.29326}, {200, 0.21142, 0.32312},
                                {250, 0.22511, 0.33439}, {300, 0.24010, 0.34308},
                                {400, 0.27218, 0.35407}, {500, 0.30505, 0.35907},
                                {600, 0.33724, 0.36051}};
    for (const LocusPoint& p : table) {
        const Spectrum bb = blackbodyWithC2(1e6 / p.mired, 1.4388e-2);
        const glm::dvec2 xy = xyChromaticity(spectrumXyz(bb));
        const glm::dvec2 uv = toUv1960(xy);
        // The spread in (u, v) of the methods' (x, y), mapped through the same transform.
        const glm::dvec2 spreadXy = methodSpread(bb);
        const glm::dvec2 spread = glm::abs(toUv1960(xy + spreadXy) - uv) +
                                  glm::abs(toUv1960(xy - spreadXy) - uv);
        EXPECT_NEAR(uv.x, p.u, 0.5e-5 + spread.x) << p.mired << " mired";
        EXPECT_NEAR(uv.y, p.v, 0.5e-5 + spread.y) << p.mired << " mired";
    }
}

TEST(Planck, IntegratesToStefanBoltzmann) {
    // π ∫ B_λ dλ = σT⁴ with σ = 5.670374419e-8 W·m⁻²·K⁻⁴ (CODATA 2018, from the exact h, c, k;
    // printed to 10 digits). Simpson's rule in ln λ over 10 nm – 10 mm, where the tails hold
    // < 1e-12 of the power at 5778 K; the quadrature error is bounded by the change when the
    // step is halved.
    const double temperatureK = 5778.0;
    auto integrate = [&](int n) {
        const double a = std::log(10.0), b = std::log(1e7), h = (b - a) / n;
        double sum = 0.0;
        for (int i = 0; i <= n; ++i) {
            const double l = std::exp(a + i * h);
            const double w = (i == 0 || i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0);
            sum += w * planckRadiance(l, temperatureK) * l;  // dλ = λ d(ln λ)
        }
        return sum * h / 3.0;
    };
    const double fine = integrate(20000), coarse = integrate(10000);
    const double sigma = 5.670374419e-8;
    const double expected = sigma * std::pow(temperatureK, 4) / std::numbers::pi;
    EXPECT_NEAR(fine / expected, 1.0, std::abs(fine - coarse) / expected + 0.5e-9 / 5.670374419 + 1e-12);
}

TEST(Planck, PeaksAtWiensDisplacement) {
    // λ_max = b/T with b = 2.897771955e-3 m·K (CODATA 2018). A smooth maximum is located from
    // function values to no better than √ε relative; golden-section search to that resolution.
    const double temperatureK = 5778.0;
    const double expected = 2.897771955e-3 / temperatureK * 1e9;
    double lo = 300.0, hi = 700.0;
    const double phi = (std::sqrt(5.0) - 1.0) / 2.0;
    while (hi - lo > expected * std::sqrt(kEpsilon)) {
        const double a = hi - phi * (hi - lo), b = lo + phi * (hi - lo);
        if (planckRadiance(a, temperatureK) < planckRadiance(b, temperatureK))
            lo = a;
        else
            hi = b;
    }
    EXPECT_NEAR(0.5 * (lo + hi), expected, 2.0 * expected * std::sqrt(kEpsilon));
}

TEST(Spectrum, RelativeToTheValueAt560Nm) {
    EXPECT_TRUE(std::is_trivially_copyable_v<Spectrum>);
    EXPECT_EQ(Spectrum::d65().value(560.0), 1.0);
    EXPECT_EQ(Spectrum::equalEnergy().value(420.0), 1.0);
    EXPECT_NEAR(Spectrum::d65().value(302.5), 0.01 * (0.0341 + 1.6643) / 2.0, 1e-15);
    EXPECT_EQ(Spectrum::d65().value(299.0), 0.0);
    for (double t : {1000.0, 2856.0, 6500.0, 20000.0}) {
        const Spectrum bb = Spectrum::blackbody(t);
        EXPECT_NEAR(bb.value(560.0), 1.0, 4 * kEpsilon);
        for (double l : {380.0, 455.5, 700.0}) {
            // Two routes through pow and exp: a few ulps each.
            const double ratio = planckRadiance(l, t) / planckRadiance(560.0, t);
            EXPECT_NEAR(bb.value(l) / ratio, 1.0, 32 * kEpsilon) << t << " K at " << l;
        }
    }
    // No overflow for a cold body far into the blue.
    EXPECT_GT(Spectrum::blackbody(300.0).value(360.0), 0.0);
    EXPECT_TRUE(std::isfinite(Spectrum::blackbody(300.0).value(360.0)));
}

TEST(Spectrum, Describe) {
    EXPECT_EQ(Spectrum::blackbody(5778.0).describe(), "blackbody 5778 K");
    EXPECT_EQ(Spectrum::d65().describe(), "CIE D65");
    EXPECT_EQ(Spectrum::equalEnergy().describe(), "equal energy (CIE E)");
}

TEST(Rec709, D65WhiteMapsToUnitRgb) {
    const glm::dvec3 white(kD65WhiteXy[0] / kD65WhiteXy[1], 1.0,
                           (1.0 - kD65WhiteXy[0] - kD65WhiteXy[1]) / kD65WhiteXy[1]);
    const glm::dvec3 rgb = xyzToLinearSrgb(white);
    // A well-conditioned 3×3 inverse and one product: within a few ulps.
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(rgb[c], 1.0, 8 * kEpsilon);
}

TEST(Rec709, MatrixRoundsToTheStandardsPrintedMatrix) {
    // IEC 61966-2-1 prints RGB → XYZ to 4 decimals. (Its XYZ → RGB matrix is the inverse of the
    // rounded matrix, so only the forward one is compared.)
    const double printed[3][3] = {{0.4124, 0.3576, 0.1805}, {0.2126, 0.7152, 0.0722},
                                  {0.0193, 0.1192, 0.9505}};
    for (int col = 0; col < 3; ++col) {
        glm::dvec3 unit(0.0);
        unit[col] = 1.0;
        const glm::dvec3 xyz = linearSrgbToXyz(unit);
        for (int row = 0; row < 3; ++row) EXPECT_NEAR(xyz[row], printed[row][col], 0.5e-4);
        const glm::dvec3 back = xyzToLinearSrgb(xyz);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(back[c], unit[c], 8 * kEpsilon);
    }
}

TEST(SpectralQuadrature, WeightsCarryTheLightsColourWithUnitLuminance) {
    for (const Spectrum& s : {Spectrum::d65(), Spectrum::blackbody(3200.0), Spectrum::equalEnergy()}) {
        const glm::dvec3 visible = spectrumXyz(s, kVisibleMinNm, kVisibleMaxNm);
        for (int count : {1, 3, 5, 16, 64}) {
            const std::vector<SpectralSample> samples = spectralQuadrature(s, count);
            ASSERT_EQ(samples.size(), static_cast<size_t>(count));
            EXPECT_NEAR(samples.front().wavelengthNm, kVisibleMinNm + 200.0 / count, 1e-12);
            glm::dvec3 sum(0.0);
            for (const SpectralSample& q : samples) sum += q.xyzWeight;
            // Sums of `count` positive terms: count ulps.
            EXPECT_NEAR(sum.y, 1.0, count * kEpsilon);
            // The bands' integrals add up to the whole band's. Exact (to rounding) for the
            // tabulated spectra; a black body's integrals carry Simpson's error, different for
            // different splits, and is left to the convergence test below.
            if (s.kind() == Spectrum::Kind::Blackbody) continue;
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(sum[c], visible[c] / visible.y, 4 * count * kEpsilon) << s.describe();
        }
    }
}

TEST(SpectralQuadrature, ConvergesToTheFineIntegralForASmoothTransmittance) {
    // A coating-like transmittance T(λ) = 0.6 + 0.4 cos(2π(λ − 380)/P). With f = S·cmf / ∫S·ȳ,
    // band width w and L = 400 nm, the rule Σ T(λᵢ) ∫_band f has error at most
    //   max|T'|·max|f'|·L·w²/12 + max|T''|·w²/8·∫f
    // (Taylor-expand T about each midpoint; the first-order term integrates against f − f(mid)).
    const double periodNm = 160.0, k = 2.0 * std::numbers::pi / periodNm;
    auto transmittance = [&](double l) { return 0.6 + 0.4 * std::cos(k * (l - kVisibleMinNm)); };
    const double maxT1 = 0.4 * k, maxT2 = 0.4 * k * k;
    const double length = kVisibleMaxNm - kVisibleMinNm;

    const Spectrum s = Spectrum::d65();
    const double luminance = spectrumXyz(s, kVisibleMinNm, kVisibleMaxNm).y;
    auto f = [&](double l) { return s.value(l) * cieXyzBar(l) / luminance; };
    // Reference: Simpson on 0.05 nm steps (the integrand is smooth between the 1 nm knots,
    // which fall on the grid).
    glm::dvec3 reference(0.0), integralF(0.0), maxSlope(0.0);
    const double h = 0.05;
    for (int i = 0; i < static_cast<int>(length / h + 0.5); ++i) {
        const double a = kVisibleMinNm + i * h, b = a + h, m = a + h / 2;
        reference += h / 6 * (transmittance(a) * f(a) + 4.0 * transmittance(m) * f(m) +
                              transmittance(b) * f(b));
        integralF += h / 6 * (f(a) + 4.0 * f(m) + f(b));
        maxSlope = glm::max(maxSlope, glm::abs(f(b) - f(a)) / h);
    }
    double previousError = std::numeric_limits<double>::infinity();
    for (int count : {5, 10, 20, 40, 80, 160}) {
        glm::dvec3 sum(0.0);
        for (const SpectralSample& q : spectralQuadrature(s, count))
            sum += transmittance(q.wavelengthNm) * q.xyzWeight;
        const double w = length / count;
        double error = 0.0;
        for (int c = 0; c < 3; ++c) {
            const double bound = maxT1 * maxSlope[c] * length * w * w / 12.0 +
                                 maxT2 * w * w / 8.0 * integralF[c];
            EXPECT_LE(std::abs(sum[c] - reference[c]), bound) << count << " wavelengths, c " << c;
            error = std::max(error, std::abs(sum[c] - reference[c]));
        }
        EXPECT_LT(error, previousError) << count;
        previousError = error;
    }
}

// Uniform doubles in [0, 1) from the top 53 bits: the same sequence on every platform.
struct UniformSource {
    std::mt19937_64 engine{20240607};
    double operator()() { return static_cast<double>(engine() >> 11) * 0x1.0p-53; }
};

// Upper α quantile of the standard normal, by bisection on erfc (monotone).
double normalUpperQuantile(double alpha) {
    double lo = 0.0, hi = 40.0;
    for (int i = 0; i < 200; ++i) {
        const double mid = 0.5 * (lo + hi);
        (0.5 * std::erfc(mid / std::numbers::sqrt2) > alpha ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

// Upper α quantile of χ² with k degrees of freedom (Wilson–Hilferty cube-root normal
// approximation).
double chiSquaredUpperQuantile(int k, double alpha) {
    const double c = 2.0 / (9.0 * k);
    return k * std::pow(1.0 - c + normalUpperQuantile(alpha) * std::sqrt(c), 3);
}

TEST(WavelengthSampler, DensityIsNormalisedAndReportedConsistently) {
    const WavelengthSampler sampler(Spectrum::d65());
    double total = 0.0;
    for (int nm = 360; nm < 830; ++nm) total += sampler.pdf(nm + 0.5);
    EXPECT_NEAR(total, 1.0, 470 * kEpsilon);
    EXPECT_EQ(sampler.pdf(359.0), 0.0);
    EXPECT_EQ(sampler.pdf(831.0), 0.0);
    UniformSource uniform;
    double previous = 0.0;
    for (int i = 0; i <= 1000; ++i) {
        const double u = i == 1000 ? 1.0 : i / 1000.0;
        double pdf = -1.0;
        const double l = sampler.sample(u, &pdf);
        EXPECT_GE(l, previous);  // the inverse CDF is monotone
        EXPECT_GE(l, kCieMinNm);
        EXPECT_LE(l, kCieMaxNm);
        EXPECT_GT(pdf, 0.0);
        EXPECT_EQ(pdf, sampler.pdf(l)) << "u " << u;
        previous = l;
        const double again = sampler.sample(uniform(), &pdf);
        EXPECT_EQ(pdf, sampler.pdf(again));
    }
}

// The search for u's bin starts from a guide (one entry per 1/512 of u): at the guide's cell
// edges, a hair below them and on a dense grid, with an importance that empties whole ranges of
// bins, every sample lies in a bin of non-zero density, reports that density, and the inverse
// CDF is monotone.
TEST(WavelengthSampler, GuidedSearchFindsTheBinOfEveryU) {
    std::vector<double> importance(static_cast<size_t>(kCieMaxNm - kCieMinNm), 1.0);
    for (int nm = 500; nm < 600; ++nm) importance[nm - 360] = 0.0;
    for (int nm = 700; nm < 701; ++nm) importance[nm - 360] = 0.0;
    const WavelengthSampler sampler(Spectrum::blackbody(5778.0), importance);
    std::vector<double> us;
    for (int k = 0; k <= 512; ++k) {
        us.push_back(std::nextafter(k / 512.0, 0.0));
        us.push_back(k / 512.0);
    }
    for (int i = 0; i <= 20000; ++i) us.push_back(i / 20000.0);
    std::sort(us.begin(), us.end());
    double previous = 0.0;
    for (double u : us) {
        double pdf = -1.0;
        const double l = sampler.sample(u, &pdf);
        EXPECT_GT(pdf, 0.0) << "u " << u;
        EXPECT_EQ(pdf, sampler.pdf(l)) << "u " << u;
        EXPECT_FALSE(l >= 500.0 && l < 600.0) << "u " << u << " gave " << l;
        EXPECT_GE(l, previous) << "u " << u;
        previous = l;
    }
}

TEST(WavelengthSampler, SamplesFollowTheTabulatedDensity) {
    for (const Spectrum& s : {Spectrum::d65(), Spectrum::blackbody(3000.0)}) {
        const WavelengthSampler sampler(s);
        // 50 equal-width bins over 360–830 nm (9.4 nm: their edges cut through the 1 nm cells,
        // so the position within a cell is tested too). A bin's probability is the exact integral
        // of the piecewise-constant tabulated density. Bins expecting fewer than 5 samples (the
        // tails) are merged into their neighbour, the usual condition for the χ² approximation.
        const int n = 200000;
        const double width = (kCieMaxNm - kCieMinNm) / 50;
        auto probabilityBetween = [&](double a, double b) {
            double p = 0.0;
            for (int nm = static_cast<int>(a); nm < b && nm < 830; ++nm)
                p += sampler.pdf(nm + 0.5) * (std::min(b, nm + 1.0) - std::max(a, double(nm)));
            return p;
        };
        std::vector<double> edges{kCieMinNm}, probability;
        for (int k = 1; k <= 50; ++k) {
            const double edge = k == 50 ? kCieMaxNm : kCieMinNm + k * width;
            const double p = probabilityBetween(edges.back(), edge);
            if (!probability.empty() && n * probability.back() < 5.0) {
                probability.back() += p;  // grow the starved bin
                edges.back() = edge;
            } else {
                probability.push_back(p);
                edges.push_back(edge);
            }
        }
        if (n * probability.back() < 5.0) {  // a starved last bin joins the one before
            probability[probability.size() - 2] += probability.back();
            probability.pop_back();
            edges.erase(edges.end() - 2);
        }
        const int bins = static_cast<int>(probability.size());
        ASSERT_GE(bins, 30);

        std::vector<int> observed(bins, 0);
        UniformSource uniform;
        glm::dvec3 mean(0.0), meanSquare(0.0);
        for (int i = 0; i < n; ++i) {
            double pdf = 0.0;
            const double l = sampler.sample(uniform(), &pdf);
            const int bin = static_cast<int>(std::upper_bound(edges.begin(), edges.end(), l) -
                                             edges.begin()) - 1;
            ++observed[std::clamp(bin, 0, bins - 1)];
            const glm::dvec3 w = sampler.xyzWeight(l, pdf);
            mean += w;
            meanSquare += w * w;
        }
        double chi2 = 0.0;
        for (int b = 0; b < bins; ++b) {
            const double expected = n * probability[b];
            chi2 += (observed[b] - expected) * (observed[b] - expected) / expected;
        }
        // No parameter is fitted: bins − 1 degrees of freedom; reject at the 1e-3 level.
        EXPECT_LT(chi2, chiSquaredUpperQuantile(bins - 1, 1e-3)) << s.describe();

        // E[weight] is the light's XYZ at unit luminance over the sampler's 360–830 nm; the
        // quadrature covers 380–780 nm, and the exact difference is added to 4 standard errors.
        mean /= n;
        meanSquare /= n;
        const glm::dvec3 standardError = glm::sqrt((meanSquare - mean * mean) / (n - 1.0));
        glm::dvec3 quadrature(0.0);
        for (const SpectralSample& q : spectralQuadrature(s, 5)) quadrature += q.xyzWeight;
        const glm::dvec3 full = spectrumXyz(s);
        const glm::dvec3 rangeDifference = glm::abs(full / full.y - quadrature);
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(mean[c], quadrature[c], 4.0 * standardError[c] + rangeDifference[c])
                << s.describe() << " component " << c;
    }
}

}  // namespace
}  // namespace flare
