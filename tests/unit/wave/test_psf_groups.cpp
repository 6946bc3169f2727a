// Lights sharing a diffraction PSF (PsfGroups.h, StarburstOptions::psfGroupTolerance) against each
// light with its own. Point lights (one pixel each) at nearby field angles through the double
// Gauss at f/8 on a small, fine sensor: their starburst is, to the model, each light's energy times
// its PSF, so giving light l its group founder's PSF P_f changes the image by
// Σ_l E_l (P_f − P_l) shifted to l's pixel, whose L2 norm is at most Σ_l E_l ||P_f − P_l||₂
// (Young's inequality; the triangle inequality over the lights), and whose sum at most
// Σ_l E_l ||P_f − P_l||₁. The PSFs' differences are computed here from DiffractionPsf's windows
// over every offset the frame can hold, not through the starburst's near/far split.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <set>
#include <vector>

#include <glm/geometric.hpp>

#include "flare/optics/LensFile.h"
#include "flare/optics/LensSystem.h"
#include "flare/wave/ApertureTransform.h"
#include "flare/wave/DiffractionPsf.h"
#include "flare/wave/PsfGroups.h"
#include "flare/wave/PupilOutline.h"
#include "flare/wave/Starburst.h"

namespace flare {
namespace {

constexpr int kWidth = 160, kHeight = 120;
constexpr double kPi = std::numbers::pi;

LensSystem doubleGauss() {
    LensPrescription p = loadLens("double-gauss-50mm");
    // 16 × 12 mm over 160 × 120 px: 100 µm pixels, the field ±9° across.
    p.sensor.widthMm = 16.0;
    p.sensor.heightMm = 12.0;
    LensState state;
    state.fNumber = 4.0;
    return LensSystem::build(p, state);
}

glm::dvec3 direction(double xDeg, double yDeg) {
    const double x = std::tan(xDeg * kPi / 180.0), y = std::tan(yDeg * kPi / 180.0);
    return glm::normalize(glm::dvec3(x, y, 1.0));
}

struct Case {
    std::vector<StarburstLight> lights;
    std::vector<PupilOutline> outlines;
    std::vector<float> direct;
    std::vector<double> energy;
};

// White point lights at the given field angles, each one pixel of the direct image where its
// beam lands, with energies 1, 2, 3, ...
Case pointLights(const LensSystem& lens, const std::vector<glm::dvec2>& fieldDeg) {
    Case c;
    c.direct.assign(3 * static_cast<size_t>(kWidth) * kHeight, 0.0f);
    PupilOutlineOptions options;
    options.widthPx = kWidth;
    options.heightPx = kHeight;
    std::vector<SpectralSample> white;
    for (int i = 0; i < 8; ++i) white.push_back({420.0 + 40.0 * i, glm::dvec3(1.0)});
    for (size_t l = 0; l < fieldDeg.size(); ++l) {
        const glm::dvec3 d = direction(fieldDeg[l].x, fieldDeg[l].y);
        c.lights.push_back({"light" + std::to_string(l), d, white});
        c.outlines.push_back(tracePupilOutline(lens, d, options));
        EXPECT_TRUE(c.outlines.back().found);
        const int x = static_cast<int>(std::floor(c.outlines.back().imagePx.x));
        const int y = static_cast<int>(std::floor(c.outlines.back().imagePx.y));
        EXPECT_TRUE(x >= 0 && y >= 0 && x < kWidth && y < kHeight) << l;
        c.energy.push_back(1.0 + l);
        for (int k = 0; k < 3; ++k) c.direct[3 * (static_cast<size_t>(y) * kWidth + x) + k] = static_cast<float>(1.0 + l);
    }
    return c;
}

// The Y channel's PSF over every offset the frame can hold (half-sizes kWidth).
std::vector<double> psfY(const Case& c, size_t l) {
    const ApertureTransform aperture(c.outlines[l].outlineMm);
    DiffractionPsf psf(aperture, c.lights[l].spectrum, c.outlines[l].pxPerRad);
    const std::vector<float> xyz = psf.window(kWidth);
    std::vector<double> y(xyz.size() / 3);
    for (size_t i = 0; i < y.size(); ++i) y[i] = xyz[3 * i + 1];
    return y;
}

struct Norms {
    double l1 = 0.0, l2 = 0.0;
};
Norms difference(const std::vector<double>& a, const std::vector<double>& b) {
    Norms n;
    for (size_t i = 0; i < a.size(); ++i) {
        n.l1 += std::abs(a[i] - b[i]);
        n.l2 += (a[i] - b[i]) * (a[i] - b[i]);
    }
    n.l2 = std::sqrt(n.l2);
    return n;
}

// The Y channel's L2 difference of two starbursts, relative to the light diffraction moves (the
// reference less the direct image: `flare composite`'s starburst layer), and their sums.
struct Comparison {
    double relL2 = 0.0, absL2 = 0.0, sumDifference = 0.0, sum = 0.0;
};
Comparison compare(const StarburstImage& a, const StarburstImage& reference, const std::vector<float>& direct) {
    Comparison c;
    double ref2 = 0.0;
    for (size_t i = 1; i < a.xyz.size(); i += 3) {
        const double d = double(a.xyz[i]) - reference.xyz[i];
        c.absL2 += d * d;
        ref2 += (double(reference.xyz[i]) - direct[i]) * (double(reference.xyz[i]) - direct[i]);
        c.sumDifference += d;
        c.sum += reference.xyz[i];
    }
    c.absL2 = std::sqrt(c.absL2);
    c.relL2 = c.absL2 / std::sqrt(ref2);
    return c;
}

StarburstImage starburst(const LensSystem& lens, const Case& c, double tolerance) {
    StarburstOptions options;
    options.psfGroupTolerance = tolerance;
    return renderStarburst(lens, c.direct, kWidth, kHeight, c.lights, options);
}

// Four lights within 1.3° of each other and of the axis: grouped at the composite's default
// tolerance, within the bounds the PSFs' own differences give.
const std::vector<glm::dvec2> kFields = {{4.0, 0.0}, {4.3, 0.3}, {3.6, -0.2}, {4.2, -0.5}};
constexpr double kTolerance = 0.05;

TEST(PsfGroups, SharedPsfsStayWithinTheBoundOfTheirPsfsDifference) {
    const LensSystem lens = doubleGauss();
    const Case c = pointLights(lens, kFields);
    const StarburstImage exact = starburst(lens, c, 0.0);
    const StarburstImage grouped = starburst(lens, c, kTolerance);
    std::set<int> psfs;
    double boundL2 = 0.0, boundL1 = 0.0, energy = 0.0;
    for (size_t l = 0; l < c.lights.size(); ++l) {
        ASSERT_TRUE(grouped.lights[l].diffracted) << l;
        EXPECT_EQ(exact.lights[l].psfLight, static_cast<int>(l));
        const int f = grouped.lights[l].psfLight;
        psfs.insert(f);
        energy += c.energy[l];
        if (f == static_cast<int>(l)) continue;
        // The pupils' difference is at most the tolerance, and bounds the PSFs' (PsfGroups.h).
        const double delta = grouped.lights[l].psfDifference;
        EXPECT_LE(delta, kTolerance);
        const Norms n = difference(psfY(c, static_cast<size_t>(f)), psfY(c, l));
        EXPECT_LE(n.l1, 2.0 * std::sqrt(delta)) << l;
        boundL2 += c.energy[l] * n.l2;
        boundL1 += c.energy[l] * n.l1;
    }
    // Sharing happened (else this test would test nothing), and not all in one.
    EXPECT_LT(psfs.size(), c.lights.size());
    const Comparison d = compare(grouped, exact, c.direct);
    // The starburst is the PSF by its near window and its far asymptote (the same model, split
    // at the taper): 10 % of slack on the bound, and float rounding.
    EXPECT_LE(d.absL2, 1.1 * boundL2 + 1e-6 * energy) << "relative L2 " << d.relL2;
    EXPECT_LE(std::abs(d.sumDifference), boundL1 + 1e-5 * energy);
    EXPECT_LT(d.relL2, 0.01);
}

// Too coarse a tolerance groups lights whose PSFs differ: a light far across the field given the
// cluster's PSF shows in the image, many times the cluster's own grouping error.
TEST(PsfGroups, TooCoarseAToleranceShowsInTheImage) {
    const LensSystem lens = doubleGauss();
    std::vector<glm::dvec2> fields = kFields;
    fields.push_back({-8.0, 5.0});  // far across the field: its pupil vignetted
    const Case c = pointLights(lens, fields);
    const double farDelta = psfShapeDifference(psfShape(c.outlines.back(), c.lights.back().spectrum),
                                               psfShape(c.outlines[0], c.lights[0].spectrum));
    const StarburstImage exact = starburst(lens, c, 0.0);
    // Below the far light's difference: the cluster shares one PSF, the far light has its own.
    const StarburstImage fineImage = starburst(lens, c, 0.5 * farDelta);
    EXPECT_EQ(fineImage.lights.back().psfLight, static_cast<int>(fields.size()) - 1);
    EXPECT_EQ(fineImage.lights[1].psfLight, 0);
    const Comparison fine = compare(fineImage, exact, c.direct);
    // Above it: the far light takes the cluster's PSF.
    const StarburstImage coarseImage = starburst(lens, c, 2.0 * farDelta);
    for (const StarburstLightReport& r : coarseImage.lights) EXPECT_EQ(r.psfLight, 0);
    const Comparison coarse = compare(coarseImage, exact, c.direct);
    EXPECT_GT(coarse.relL2, 3.0 * fine.relL2);
}

// Tolerance 0 gives every light its own PSF, as the starburst did before groups; so does a
// tolerance below every pair's difference, bit for bit.
TEST(PsfGroups, NoGroupIsTheOwnPsfBitForBit) {
    const LensSystem lens = doubleGauss();
    const Case c = pointLights(lens, kFields);
    const StarburstImage exact = starburst(lens, c, 0.0);
    const StarburstImage tiny = starburst(lens, c, 1e-12);
    for (size_t l = 0; l < c.lights.size(); ++l) EXPECT_EQ(tiny.lights[l].psfLight, static_cast<int>(l));
    EXPECT_EQ(exact.xyz, tiny.xyz);
}

// The difference measure: zero for the same pupil, the mapping and the wavelength count.
TEST(PsfGroups, DifferenceSeesShapeMappingAndWavelength) {
    PupilOutline square;
    square.found = true;
    square.pxPerRad = glm::dmat2(1000.0);
    for (int i = 0; i < 400; ++i) {  // a 2 mm square's outline, counter-clockwise
        const double t = i / 100.0;
        const int side = i / 100;
        const double u = t - side;
        const glm::dvec2 corners[4] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
        square.outlineMm.push_back(corners[side] + u * (corners[(side + 1) % 4] - corners[side]));
    }
    const std::vector<SpectralSample> green = {{550.0, glm::dvec3(1.0)}};
    const PsfShape a = psfShape(square, green);
    EXPECT_NEAR(psfShapeDifference(a, a), 0.0, 1e-12);
    // Shifted: the same pattern.
    PupilOutline shifted = square;
    for (glm::dvec2& p : shifted.outlineMm) p += glm::dvec2(0.3, -0.2);
    EXPECT_NEAR(psfShapeDifference(psfShape(shifted, green), a), 0.0, 1e-9);
    // Stretched by 1 % along one axis (by the pupil, or by the mapping): area difference ≈ 1 %.
    PupilOutline stretched = square;
    for (glm::dvec2& p : stretched.outlineMm) p.x *= 1.01;
    EXPECT_NEAR(psfShapeDifference(psfShape(stretched, green), a), 0.01, 1e-3);
    PupilOutline mapped = square;
    mapped.pxPerRad = glm::dmat2(1000.0 / 1.01, 0.0, 0.0, 1000.0);  // columns: the x scale
    EXPECT_NEAR(psfShapeDifference(psfShape(mapped, green), a), 0.01, 1e-3);
    // 1 % longer wavelength: the pattern 1 % larger both ways, Q/λ 1 % smaller: about 2 %.
    const std::vector<SpectralSample> longer = {{555.5, glm::dvec3(1.0)}};
    EXPECT_NEAR(psfShapeDifference(psfShape(square, longer), a), 0.0199, 1e-3);
    // Not found: never grouped.
    EXPECT_TRUE(std::isinf(psfShapeDifference(PsfShape{}, a)));
    const std::vector<int> groups = groupByPsf({a, PsfShape{}, a}, 0.5);
    EXPECT_EQ(groups, (std::vector<int>{0, 1, 0}));
}

}  // namespace
}  // namespace flare
