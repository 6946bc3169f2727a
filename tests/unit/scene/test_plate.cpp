// The pieces of `flare composite`: the smooth spectrum of a colour, the plate's colour spaces, the
// pixel → field-angle mapping through a real lens, and the grouping of source pixels.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>
#include <glm/matrix.hpp>

#include "TestUtil.h"
#include "flare/core/Error.h"
#include "flare/core/SmoothSpectrum.h"
#include "flare/core/Spectrum.h"
#include "flare/optics/RealRays.h"
#include "flare/scene/PlateColourSpace.h"
#include "flare/scene/PlateLights.h"
#include "flare/scene/PlateSources.h"
#include "flare/scene/Scene.h"
#include "flare/scene/SceneJson.h"

namespace flare {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// Grey is D65 itself, to within what separates the CIE's tabulated D65 (integrated with the
// 1931 observer: x, y = 0.31272, 0.32903) from the rounded white point of Rec.709 (0.3127, 0.3290):
// the sigmoid stays within 0.1 % of ½ across the visible band.
TEST(SmoothSpectrum, GreyIsD65Itself) {
    const SmoothSpectrumFit fit = fitSmoothSpectrum(linearSrgbToXyz(glm::dvec3(3.0)));
    EXPECT_LT(fit.chromaticityError, 1e-6);
    for (double nm = 380.0; nm <= 780.0; nm += 5.0)
        EXPECT_NEAR(smoothSpectrumShape(fit.coefficients, nm), 0.5, 5e-4) << nm;
}

// The fitted spectrum's chromaticity, integrated independently (spectrumXyz, Simpson on the CIE
// table's knots, not the fit's own sums), is the colour asked for, for saturated colours too; and
// the spectrum is non-negative and smooth (no spike: its largest step between neighbouring
// nanometres is small against its peak).
TEST(SmoothSpectrum, ReproducesTheColourOfRec709Colours) {
    const glm::dvec3 colours[] = {
        {1.0, 0.52, 0.13},  // sodium street lamp
        {1.0, 0.15, 0.55},  // pink neon
        {0.1, 0.9, 1.0},    // cyan neon
        {0.9, 0.05, 0.05},  // near the red primary
        {0.05, 0.9, 0.05},  // near the green primary
        {0.05, 0.05, 0.9},  // near the blue primary
        {1.0, 0.93, 0.82},  // warm white LED
    };
    for (const glm::dvec3& rgb : colours) {
        const glm::dvec3 xyz = linearSrgbToXyz(rgb);
        const SmoothSpectrumFit fit = fitSmoothSpectrum(xyz);
        const Spectrum s = Spectrum::smooth(fit.coefficients);
        const glm::dvec2 want = xyChromaticity(xyz), got = xyChromaticity(spectrumXyz(s));
        EXPECT_LT(std::hypot(want.x - got.x, want.y - got.y), 1e-4) << rgb.x << " " << rgb.y << " " << rgb.z;
        double peak = 0.0, largestStep = 0.0;
        for (double nm = 380.0; nm <= 780.0; nm += 1.0) {
            ASSERT_GE(s.value(nm), 0.0);
            peak = std::max(peak, s.value(nm));
            largestStep = std::max(largestStep, std::abs(s.value(nm + 1.0) - s.value(nm)));
        }
        // D65's own table steps by up to ~4 % of its peak per nm (its 5 nm knots); a smooth factor adds little.
        EXPECT_LT(largestStep, 0.1 * peak) << rgb.x << " " << rgb.y << " " << rgb.z;
    }
}

// ACEScg's matrix to XYZ from its published primaries, against the Academy's published matrix
// (S-2014-004, AP1 → XYZ, printed to 10 decimals).
TEST(PlateColourSpace, AcesCgMatchesThePublishedMatrix) {
    const PlateColourSpace s = resolveColourSpace("ACEScg");
    const double published[3][3] = {{0.6624541811, 0.1340042065, 0.1561876870},
                                     {0.2722287168, 0.6740817658, 0.0536895174},
                                     {-0.0055746495, 0.0040607335, 1.0103391003}};
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(s.toXyz[c][r], published[r][c], 1e-6) << r << "," << c;
    EXPECT_EQ(resolveColourSpace("lin_ap1").name, "ACEScg");
    EXPECT_EQ(knownColourSpaceName(s.chromaticities), "ACEScg");
    // Chromaticities derived back from a matrix are the primaries.
    const PlateColourSpace back = colourSpaceFromMatrix(s.toXyz, "x", "test");
    for (int i = 0; i < 8; ++i) EXPECT_NEAR(back.chromaticities[i], s.chromaticities[i], 1e-12);
    EXPECT_THROW(resolveColourSpace("ACEScgg-nonsense"), InputError);
}

// The field angle of the sensor's corner is the lens's real half field of view, which
// realFieldOfView finds by its own search (continuation and bisection on the chief ray); and the
// chief ray at the field of any pixel lands on that pixel (to 1e-6 px): the wide angle's
// distortion is the lens's own.
TEST(PlateFieldMap, InvertsTheRealChiefRayHeight) {
    LensSystem lens = test::loadLens("lenses/wide-angle-28mm.lens");
    const int w = 1536, h = 1024;
    const PlateFieldMap map(lens, w, h);
    const RealFieldOfView fov = realFieldOfView(lens, 550.0);
    ASSERT_EQ(fov.kind, RealFieldOfView::Kind::Reached);
    EXPECT_NEAR(map.fieldAngleRad(lens.sensorHalfDiagonalMm()) / kDeg, 0.5 * fov.fullAngleDeg, 1e-6);
    const SpectralIndices indices = lens.indicesAt(550.0);
    for (const glm::dvec2 px : {glm::dvec2(800.5, 500.5), glm::dvec2(1500.5, 40.5), glm::dvec2(3.5, 1020.5), glm::dvec2(768.0, 512.0)}) {
        const glm::dvec2 field = map.fieldDeg(px);
        const double tx = std::tan(field.x * kDeg), ty = std::tan(field.y * kDeg);
        const double theta = std::atan(std::hypot(tx, ty));
        const std::optional<double> height = chiefRayImageHeightMm(lens, indices, theta);
        ASSERT_TRUE(height);
        const double r = std::hypot(tx, ty);
        const glm::dvec2 mm = r > 0.0 ? std::abs(*height) * glm::dvec2(tx, ty) / r : glm::dvec2(0.0);
        const glm::dvec2 back = map.pixelOf(mm);
        EXPECT_NEAR(back.x, px.x, 1e-6);
        EXPECT_NEAR(back.y, px.y, 1e-6);
        // Barrel distortion: the real field differs from the paraxial (tan θ = r / f) off axis.
        if (glm::length(px - glm::dvec2(w / 2.0, h / 2.0)) > 600.0)
            EXPECT_GT(std::abs(theta - std::atan(glm::length(map.pictureMm(px)) / 28.0)), 1e-3);
    }
}

Plate blankPlate(int w, int h) {
    Plate p;
    p.width = w;
    p.height = h;
    p.rgb.assign(3 * static_cast<size_t>(w) * h, 0.0f);
    p.space = resolveColourSpace("linear Rec.709");
    return p;
}

void setPixel(Plate& p, int x, int y, const glm::dvec3& rgb) {
    for (int k = 0; k < 3; ++k) p.rgb[3 * (static_cast<size_t>(y) * p.width + x) + k] = static_cast<float>(rgb[k]);
}

// Two blobs give two groups; cutting a 10 × 6 blob into 4 px cells gives 3 × 2 cells whose sums
// add up to the blob's; the centroid is luminance-weighted; 8-neighbours join, a gap splits.
TEST(PlateSources, GroupsAndCellsAddUp) {
    Plate p = blankPlate(200, 150);  // 63 source pixels: under 0.5 % of the frame
    glm::dvec3 sum(0.0);
    for (int y = 10; y < 16; ++y)
        for (int x = 20; x < 30; ++x) {
            setPixel(p, x, y, glm::dvec3(1.0 + x, 2.0, 0.5 * y));
            sum += p.space.toXyz * p.pixel(x, y);
        }
    setPixel(p, 50, 40, glm::dvec3(100.0));
    setPixel(p, 51, 41, glm::dvec3(100.0));  // diagonal neighbour: the same group
    setPixel(p, 53, 41, glm::dvec3(300.0));  // a gap of one pixel: another group
    const PlateSources s = findPlateSources(p, 0.5, 4);
    EXPECT_EQ(s.groups, 3);
    EXPECT_EQ(s.sourcePixels, 63);
    ASSERT_EQ(s.cells.size(), 6u + 1u + 1u);
    glm::dvec3 cellSum(0.0);
    for (int i = 0; i < 6; ++i) {
        EXPECT_EQ(s.cells[i].group, 0);
        cellSum += s.cells[i].xyzSum;
    }
    EXPECT_NEAR(glm::length(cellSum - sum), 0.0, 1e-9 * glm::length(sum));
    EXPECT_EQ(s.cells[6].pixelCount, 2);
    EXPECT_NEAR(s.cells[6].centroidPx.x, 51.0, 1e-12);
    EXPECT_NEAR(s.cells[7].centroidPx.x, 53.5, 1e-12);
    // The automatic threshold on this frame: 1e-3 of the brightest beats the (zero) percentile.
    const PlateSources automatic = findPlateSources(p, std::nullopt, 4);
    EXPECT_NEAR(automatic.threshold, 1e-3 * 300.0, 1e-9);
    EXPECT_EQ(automatic.groups, 3);
}

// The scene format's { "rgb": [r, g, b] } spectrum: read, written back by sceneToJson to the bit,
// and its errors (a black colour, two kinds at once) name the line and key.
TEST(SceneRgbSpectrum, ReadsWritesAndRefuses) {
    const std::string text = R"({"lens": "double-gauss-50mm",
        "lights": [{"type": "directional", "field_deg": [3, -2.25], "angular_diameter_deg": 0.1,
                    "spectrum": {"rgb": [1.0, 0.15, 0.55]}, "power": 12.5}]})";
    const Scene scene = parseSceneText(text, "rgb.json", "");
    ASSERT_EQ(scene.lights[0].spectrum.kind, SpectrumSpec::Kind::Rgb);
    EXPECT_EQ(scene.lights[0].spectrum.rgb, glm::dvec3(1.0, 0.15, 0.55));
    const Scene again = parseSceneText(sceneToJson(scene).dump(), "again.json", "");
    EXPECT_EQ(again.lights[0].spectrum.rgb, scene.lights[0].spectrum.rgb);
    EXPECT_EQ(again.lights[0].fieldYDeg, -2.25);
    EXPECT_EQ(again.lights[0].power, 12.5);
    EXPECT_EQ(toSpectrum(again.lights[0].spectrum).kind(), Spectrum::Kind::Smooth);
    for (const char* bad : {R"({"rgb": [0, 0, 0]})", R"({"rgb": [1, 1, 1], "blackbody_k": 3000})", R"({"rgb": [1, 1]})"}) {
        const std::string t = std::string(R"({"lens": "double-gauss-50mm", "lights": [{"type": "directional",
            "field_deg": [0, 0], "spectrum": )") + bad + "}]}";
        try {
            parseSceneText(t, "bad.json", "");
            ADD_FAILURE() << bad;
        } catch (const InputError& e) {
            EXPECT_EQ(e.line(), 2) << e.what();
            EXPECT_NE(std::string(e.what()).find("lights[0].spectrum"), std::string::npos) << e.what();
        }
    }
}

}  // namespace
}  // namespace flare
