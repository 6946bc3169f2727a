// Paraxial analysis against independent ray-transfer matrices, thick-lens formulas and the
// focal lengths the prescriptions' sources publish.
#include <cmath>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/core/Error.h"
#include "flare/optics/Glass.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/Paraxial.h"

namespace flare {
namespace {

using test::loadLens;

// 2×2 ray-transfer matrices acting on (y, n·u): written here independently of Paraxial.cpp.
struct Matrix {
    double a, b, c, d;
    Matrix operator*(const Matrix& o) const {
        return {a * o.a + b * o.c, a * o.b + b * o.d, c * o.a + d * o.c, c * o.b + d * o.d};
    }
};
Matrix translation(double t, double n) { return {1.0, t / n, 0.0, 1.0}; }
Matrix refraction(double curvature, double n1, double n2) { return {1.0, 0.0, -(n2 - n1) * curvature, 1.0}; }

// System matrix from the first vertex to the last vertex.
Matrix systemMatrix(const LensSystem& lens, const SpectralIndices& idx) {
    Matrix m{1, 0, 0, 1};
    for (int k = 0; k < lens.surfaceCount(); ++k) {
        if (k > 0)
            m = translation(lens.surface(k).vertexZMm - lens.surface(k - 1).vertexZMm, idx.n[k]) * m;
        m = refraction(lens.surface(k).curvature(), idx.n[k], idx.n[k + 1]) * m;
    }
    return m;
}

TEST(Paraxial, PbrtDoubleGaussAtConstantIndices) {
    const LensSystem lens = loadLens("tests/data/dgauss.50mm.dat");
    const ParaxialData p = analyseParaxial(lens, kLineDNm);
    EXPECT_NEAR(p.eflMm, 50.36, 0.005);  // reference printed to 0.01 mm
    EXPECT_NEAR(p.bflMm, 36.11, 0.005);
}

TEST(Paraxial, AgreesWithRayTransferMatrices) {
    for (const char* file : test::kShippedLenses) {
        const LensSystem lens = loadLens(file);
        for (double wavelength : {450.0, kLineDNm, 650.0}) {
            const SpectralIndices idx = lens.indicesAt(wavelength);
            const Matrix m = systemMatrix(lens, idx);
            const double efl = -1.0 / m.c;
            const double bfl = -m.a / m.c;
            const ParaxialData p = analyseParaxial(lens, wavelength);
            EXPECT_NEAR(p.eflMm, efl, 1e-9 * std::abs(efl)) << file << " " << wavelength;
            EXPECT_NEAR(p.bflMm, bfl, 1e-9 * std::abs(efl)) << file << " " << wavelength;
            // Front focal point: a ray from it at distance s in front leaves parallel, C·s + D = 0.
            EXPECT_NEAR(p.frontFocalDistanceMm, -m.d / m.c, 1e-9 * std::abs(efl)) << file;
        }
    }
}

TEST(Paraxial, ThickLensFormulas) {
    const std::string text = R"(name thick
focal_length_mm 100
surfaces
 stop  0   air     10
 50    8   n=1.6   10
 -80   auto air    10
)";
    const LensSystem lens = LensSystem::build(parseLensText(text, "thick.lens"));
    const double n = 1.6, r1 = 50.0, r2 = -80.0, d = 8.0;
    const double power = (n - 1.0) * (1.0 / r1 - 1.0 / r2 + (n - 1.0) * d / (n * r1 * r2));
    const double f = 1.0 / power;
    const ParaxialData p = analyseParaxial(lens, kLineDNm);
    EXPECT_NEAR(p.eflMm, f, 1e-10 * f);
    EXPECT_NEAR(p.bflMm, f * (1.0 - (n - 1.0) * d / (n * r1)), 1e-10 * f);
    EXPECT_NEAR(p.frontFocalDistanceMm, f * (1.0 + (n - 1.0) * d / (n * r2)), 1e-10 * f);
    // Stop on the front vertex plane: the entrance pupil is the stop itself.
    EXPECT_NEAR(p.entrancePupilDiameterMm, 20.0, 1e-12);
    EXPECT_NEAR(p.entrancePupilZMm, 0.0, 1e-12);
    EXPECT_NEAR(p.totalTrackMm, d + p.bflMm, 1e-9);
}

TEST(Paraxial, EntrancePupilIsTheImageOfTheStop) {
    // A stop at depth t inside glass n behind a surface of curvature c: seen from air it is the
    // virtual image given by the Gaussian equation n2/s' − n1/s = (n2 − n1)c' in the reversed frame.
    const std::string text = R"(name pupil
focal_length_mm 100
surfaces
 40    10   n=1.5   12
 stop  5    n=1.5   6
 -60   auto air     12
)";
    const LensSystem lens = LensSystem::build(parseLensText(text, "pupil.lens"));
    const ParaxialData p = analyseParaxial(lens, kLineDNm);
    const double n = 1.5, c = 1.0 / 40.0, t = 10.0;
    // Reversed frame: c' = −c, object at s = −t in glass (n1 = n), image in air (n2 = 1).
    const double inv = (1.0 - n) * (-c) - n / t;  // refraction from glass into air, reversed frame
    const double sAir = 1.0 / inv;                   // negative: virtual, behind the vertex
    EXPECT_NEAR(p.entrancePupilZMm, -sAir, 1e-9);
    const double magnification = (sAir / 1.0) / (t / n);  // lateral magnification n1 s' / (n2 s)
    EXPECT_NEAR(p.entrancePupilDiameterMm, 12.0 * std::abs(magnification), 1e-9);
    EXPECT_NEAR(p.fNumber, p.eflMm / p.entrancePupilDiameterMm, 1e-12);
}

TEST(Paraxial, ShippedLensesMatchTheirPublishedFocalLengths) {
    for (const char* file : test::kShippedLenses) {
        const LensPrescription prescription = loadLensFile(test::sourcePath(file));
        if (prescription.zoomPositions.empty()) {
            ASSERT_TRUE(prescription.focalLengthMm) << file;
            const LensSystem lens = LensSystem::build(prescription);
            const double efl = analyseParaxial(lens, kLineDNm).eflMm;
            EXPECT_NEAR(efl / *prescription.focalLengthMm, 1.0, 0.005) << file << ": EFL " << efl;
        } else {
            for (const ZoomPosition& z : prescription.zoomPositions) {
                const LensSystem lens = LensSystem::build(prescription, LensState{z.name, {}, {}});
                const double efl = analyseParaxial(lens, kLineDNm).eflMm;
                EXPECT_NEAR(efl / z.focalLengthMm, 1.0, 0.005) << file << " at " << z.name << ": EFL " << efl;
            }
        }
    }
}

// A focal length asked of a zoom is reached: the gaps run linearly between the bracketing positions
// and the weight is solved for the paraxial EFL (LensState::zoom). Before, the gaps were
// interpolated in the positions' stated focal lengths and `--zoom 100` on the Nikon 70-200 gave an
// EFL of 95.27 mm.
TEST(Paraxial, ZoomReachesTheFocalLengthAskedFor) {
    auto efl = [](const LensPrescription& p, const std::string& zoom) {
        return analyseParaxial(LensSystem::build(p, {zoom, {}, {}}), kLineDNm).eflMm;
    };
    const LensPrescription p = loadLensFile(test::sourcePath("lenses/zoom-24-70mm.lens"));
    ASSERT_GE(p.zoomPositions.size(), 3u);
    const double wide = efl(p, p.zoomPositions.front().name), tele = efl(p, p.zoomPositions.back().name);
    // Anywhere between the positions' EFLs, the asked value to the solver's tolerance (50 bits of
    // the weight: the EFL's own rounding dominates; 1e-9 relative is far inside the 1e-6 asked).
    for (int i = 0; i <= 20; ++i) {
        const double f = wide + (tele - wide) * i / 20.0;
        char text[64];
        std::snprintf(text, sizeof text, "%.17g", f);
        EXPECT_NEAR(efl(p, text) / f, 1.0, 1e-9) << f;
    }
    // Asking a position's own EFL gives that position's gaps (the same surfaces, so the same EFL).
    const ZoomPosition& mid = p.zoomPositions[1];
    char midText[64];
    std::snprintf(midText, sizeof midText, "%.17g", efl(p, mid.name));
    EXPECT_DOUBLE_EQ(efl(p, midText), efl(p, mid.name));
    // Outside the positions' EFLs: an error naming them, not an extrapolation.
    EXPECT_THROW(LensSystem::build(p, {"500", {}, {}}), InputError);
    EXPECT_THROW(LensSystem::build(p, {"ultrawide", {}, {}}), InputError);
    try {
        LensSystem::build(p, {"20", {}, {}});
        ADD_FAILURE() << "20 mm is below the wide end";
    } catch (const InputError& e) {
        EXPECT_NE(e.problem().find("outside the lens's range"), std::string::npos) << e.what();
        EXPECT_NE(e.problem().find("wide"), std::string::npos) << e.what();
    }
    // The issue's case: the Nikon AF-S 70-200 f/2.8G VR II from the library at 100 mm.
    const LensPrescription nikon =
        loadLensFile(test::sourcePath("lenses/library/nikon/nikon-af-s-nikkor-70-200mm-f2.8g-ed-vr-ii.lens"));
    EXPECT_NEAR(efl(nikon, "100") / 100.0, 1.0, 1e-6);
    EXPECT_NEAR(efl(nikon, "135") / 135.0, 1.0, 1e-6);
    EXPECT_NEAR(efl(nikon, "190") / 190.0, 1.0, 1e-6);
}

TEST(Paraxial, FocusSolvePutsTheSensorAtTheImageOfTheObject) {
    const LensPrescription p = loadLensFile(test::sourcePath("lenses/double-gauss-50mm.lens"));
    const LensSystem infinity = LensSystem::build(p);
    for (double distance : {500.0, 1000.0, 5000.0}) {
        const LensSystem near = LensSystem::build(p, {"", distance, {}});
        const SpectralIndices idx = near.indicesAt(kLineDNm);
        // Independent: image distance from the system matrix and an object at `distance`.
        const Matrix m = systemMatrix(near, idx) * translation(distance, 1.0);
        const double image = -m.b / m.d;  // y' = 0 for any slope: A·0 + B·u → solve after translation
        EXPECT_NEAR(near.sensorZMm() - near.surface(near.surfaceCount() - 1).vertexZMm, image, 1e-9);
        EXPECT_GT(near.sensorZMm(), infinity.sensorZMm());
        EXPECT_GT(analyseParaxial(near, kLineDNm).workingFNumber, analyseParaxial(infinity, kLineDNm).workingFNumber);
    }
}

TEST(Paraxial, FNumberSettingStopsDownTheIris) {
    const LensPrescription p = loadLensFile(test::sourcePath("lenses/double-gauss-50mm.lens"));
    for (double n : {2.8, 4.0, 8.0, 16.0}) {
        const LensSystem lens = LensSystem::build(p, {"", {}, n});
        EXPECT_NEAR(analyseParaxial(lens, kLineDNm).fNumber, n, 1e-9 * n);
    }
    EXPECT_THROW(LensSystem::build(p, {"", {}, 1.2}), InputError);
}

TEST(Paraxial, NormalDispersionGivesLongerFocalLengthInRedForASinglet) {
    const std::string text = R"(name singlet
focal_length_mm 100
surfaces
 stop  2    air    10
 60    6    N-BK7  12
 -200  auto air    12
)";
    const LensSystem lens = LensSystem::build(parseLensText(text, "singlet.lens"));
    EXPECT_LT(analyseParaxial(lens, kLineFNm).eflMm, analyseParaxial(lens, kLineDNm).eflMm);
    EXPECT_LT(analyseParaxial(lens, kLineDNm).eflMm, analyseParaxial(lens, kLineCNm).eflMm);
}

}  // namespace
}  // namespace flare
