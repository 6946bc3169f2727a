// Thin-film coatings: the quarter-wave closed form, energy balance, and the uncoated limit.
#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "flare/core/Error.h"
#include "flare/optics/Coating.h"
#include "flare/optics/Glass.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/SequentialTracer.h"

namespace flare {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

double quarterWaveReflectance(double n0, double n1, double n2) {
    const double a = n0 * n2 - n1 * n1, b = n0 * n2 + n1 * n1;
    return (a / b) * (a / b);
}

TEST(Coating, QuarterWaveMgF2OnBk7MatchesClosedForm) {
    const Coating mgf2 = Coating::magnesiumFluoride();
    const double n550 = catalogIndex(*findCatalogGlass("N-BK7"), 550.0);
    EXPECT_NEAR(thinFilmResponse(mgf2, 1.0, 1.0, n550, true, 550.0).reflectance(),
                quarterWaveReflectance(1.0, 1.38, n550), 1e-14);
    // The quoted ≈1.28 % uses the catalogue nd of N-BK7 as the substrate index.
    const double nd = findCatalogGlass("N-BK7")->nd;
    EXPECT_NEAR(thinFilmResponse(mgf2, 1.0, 1.0, nd, true, 550.0).reflectance(), 0.0128, 0.00005);
}

TEST(Coating, QuarterWaveClosedFormForOtherIndices) {
    for (const auto& [n1, n2] : {std::pair{1.38, 1.9}, std::pair{1.45, 1.6}, std::pair{2.1, 1.5}}) {
        const Coating c = Coating::quarterWave("q", n1, 600.0);
        EXPECT_NEAR(thinFilmResponse(c, 1.0, 1.0, n2, true, 600.0).reflectance(),
                    quarterWaveReflectance(1.0, n1, n2), 1e-14);
    }
}

TEST(Coating, EnergyBalanceAtAllAnglesWavelengthsAndSides) {
    const Coating stack{"stack", {{1.38, 99.6}, {2.05, 134.1}, {1.62, 84.9}}};
    for (const Coating& c : {Coating::magnesiumFluoride(), stack}) {
        for (double l : {400.0, 550.0, 700.0}) {
            for (int i = 0; i < 90; ++i) {
                for (bool fromAir : {true, false}) {
                    const FresnelTerms f = thinFilmResponse(c, std::cos(i * kDeg), 1.0, 1.6, fromAir, l);
                    if (f.totalInternalReflection) {
                        EXPECT_EQ(f.reflectance(), 1.0);
                        continue;
                    }
                    EXPECT_NEAR(f.rs + f.ts, 1.0, 1e-12) << c.name << " " << l << " " << i;
                    EXPECT_NEAR(f.rp + f.tp, 1.0, 1e-12) << c.name << " " << l << " " << i;
                }
            }
        }
    }
}

TEST(Coating, UncoatedAndZeroThicknessLimitsEqualFresnel) {
    const Coating empty{"none", {}};
    const Coating zero{"zero", {{1.38, 0.0}}};
    for (int i = 0; i < 90; i += 3) {
        const double cosI = std::cos(i * kDeg);
        const FresnelTerms bare = fresnelDielectric(cosI, 1.0, 1.7);
        for (const Coating& c : {empty, zero}) {
            const FresnelTerms f = thinFilmResponse(c, cosI, 1.0, 1.7, true, 550.0);
            EXPECT_NEAR(f.rs, bare.rs, 1e-13);
            EXPECT_NEAR(f.rp, bare.rp, 1e-13);
        }
    }
}

// At grazing incidence the p admittance n0 / cos θ0 is infinite: the response must stay finite
// (it was NaN for cos θ ≲ 10⁻⁸), also through a sequential trace reflected by a coated plate.
TEST(Coating, ResponseIsFiniteAtGrazingIncidence) {
    for (double cosThetaI : {0.0, 1e-10, 1e-9}) {
        const FresnelTerms t = thinFilmResponse(Coating::magnesiumFluoride(), cosThetaI, 1.0, 1.5, true, 550.0);
        EXPECT_TRUE(std::isfinite(t.rp) && std::isfinite(t.tp)) << "cos θ = " << cosThetaI << ": rp " << t.rp << ", tp " << t.tp;
    }
    const LensSystem lens = LensSystem::build(parseLensText(
        "name plate\nfocal_length_mm 1\ndefault_coating mgf2\nsurfaces\n inf 5 n=1.5 10\n inf 5 air 10\n stop 10 air 10\n", "plate.lens"));
    const glm::dvec3 d = glm::normalize(glm::dvec3(1.0, 0.0, 1e-10));
    const glm::dvec3 onPlate(1.0, 0.0, 0.0);
    const int reflections[] = {0};
    SequentialPath path;
    path.reflections = reflections;
    path.end = SequentialPath::End::ObjectSpace;
    const TraceResult r = tracePath(lens, lens.indicesAt(550.0), Ray{onPlate - (1.0 / d.z) * d, d}, path);
    EXPECT_TRUE(std::isfinite(r.throughput)) << toString(r.status) << " " << r.throughput;
}

TEST(Coating, SameReflectanceFromBothSidesOfALosslessStack) {
    const Coating c = Coating::magnesiumFluoride();
    // Angles related by Snell's law in the outer media.
    for (int i = 0; i < 60; i += 5) {
        const double sinAir = std::sin(i * kDeg);
        const double cosGlass = std::sqrt(1.0 - (sinAir / 1.6) * (sinAir / 1.6));
        const FresnelTerms fromAir = thinFilmResponse(c, std::cos(i * kDeg), 1.0, 1.6, true, 500.0);
        const FresnelTerms fromGlass = thinFilmResponse(c, cosGlass, 1.0, 1.6, false, 500.0);
        EXPECT_NEAR(fromAir.rs, fromGlass.rs, 1e-13);
        EXPECT_NEAR(fromAir.rp, fromGlass.rp, 1e-13);
    }
}

// An ideal coating: the given reflectance at every angle and polarisation from either side, the
// rest transmitted; beyond the critical angle the interface still reflects totally.
TEST(Coating, IdealFlatReflectanceAtEveryAngleAndSide) {
    const Coating ideal = Coating::idealFlat("i", 0.04);
    for (int i = 0; i < 90; i += 3) {
        for (bool fromAir : {true, false}) {
            const FresnelTerms f = thinFilmResponse(ideal, std::cos(i * kDeg), 1.0, 1.8, fromAir, 480.0);
            const double sinGlass = fromAir ? 0.0 : std::sin(i * kDeg);
            if (sinGlass * 1.8 >= 1.0) {
                EXPECT_TRUE(f.totalInternalReflection) << i;
                EXPECT_EQ(f.reflectance(), 1.0);
                continue;
            }
            EXPECT_EQ(f.rs, 0.04);
            EXPECT_EQ(f.rp, 0.04);
            EXPECT_EQ(f.transmittance(), 0.96);
            const double n0 = fromAir ? 1.0 : 1.8, n1 = fromAir ? 1.8 : 1.0;
            const double sinT = n0 * std::sin(i * kDeg) / n1;
            EXPECT_NEAR(f.cosThetaT, std::sqrt(1.0 - sinT * sinT), 1e-15);
        }
    }
}

TEST(Coating, IdealTableInterpolatesLinearlyAndHoldsItsEnds) {
    const IdealReflectance table{{450.0, 550.0, 650.0}, {0.02, 0.004, 0.012}};
    EXPECT_EQ(table.at(400.0), 0.02);
    EXPECT_EQ(table.at(450.0), 0.02);
    EXPECT_NEAR(table.at(500.0), 0.012, 1e-15);
    EXPECT_EQ(table.at(550.0), 0.004);
    EXPECT_NEAR(table.at(625.0), 0.010, 1e-15);
    EXPECT_EQ(table.at(700.0), 0.012);
    const Coating c{"t", {}, table};
    EXPECT_NEAR(thinFilmResponse(c, 0.7, 1.0, 1.6, true, 600.0).reflectance(), 0.008, 1e-15);
}

TEST(Coating, IdealCoatingsInLensFiles) {
    const LensPrescription p = parseLensText(R"(name ideal
focal_length_mm 100
coating flat ideal R=0.04
coating tab ideal 450:0.02 550:0.004 650:0.012
default_coating flat
surfaces
  50   5    N-BK7  10
 -50   5    air    10  coating=tab
 stop  auto air    8
)", "ideal.lens");
    const LensSystem lens = LensSystem::build(p);
    ASSERT_NE(lens.coating(0), nullptr);
    ASSERT_TRUE(lens.coating(0)->ideal.has_value());
    EXPECT_EQ(lens.coating(0)->ideal->at(700.0), 0.04);
    ASSERT_NE(lens.coating(1), nullptr);
    EXPECT_EQ(lens.coating(1)->ideal->at(500.0), 0.012);
    auto error = [](const std::string& line) {
        try {
            parseLensText("name x\nfocal_length_mm 100\n" + line + "\nsurfaces\n 50 5 N-BK7 10\n stop 1 air 8\n -50 auto air 10\n",
                          "bad.lens");
        } catch (const InputError& e) {
            EXPECT_EQ(e.line(), 3) << e.what();
            return std::string(e.problem());
        }
        ADD_FAILURE() << line;
        return std::string();
    };
    EXPECT_NE(error("coating c ideal R=1.2").find("[0, 1]"), std::string::npos);
    EXPECT_NE(error("coating c ideal 550:0.01 450:0.02").find("increase"), std::string::npos);
    EXPECT_NE(error("coating c ideal R=0.01 550:0.01").find("not both"), std::string::npos);
    EXPECT_NE(error("coating c ideal 0.04").find("wavelength_nm:R"), std::string::npos);
}

// The photon tracer refracts without the film's phase wherever its draw lies above
// thinFilmReflectanceBound, so the bound must hold everywhere: over single layers of low and high
// index and of many thicknesses, on glasses from 1.45 to 1.95, from both sides, at every angle
// below total internal reflection and at every visible wavelength. And it must be tight, not just
// true: at normal incidence, where s and p coincide, the largest reflectance over the layer's
// thickness reaches it.
TEST(Coating, ReflectanceBoundHoldsForEverySingleLayerAndIsReached) {
    long checked = 0;
    double closest = 1.0;  // the smallest relative gap between the bound and a reflectance
    for (double filmIndex : {1.23, 1.38, 1.63, 2.1}) {
        for (double thicknessNm : {40.0, 99.6, 137.0, 260.0, 611.0}) {
            const Coating c{"c", {{filmIndex, thicknessNm}}, {}};
            for (double glass : {1.45, 1.52, 1.7, 1.95})
                for (bool fromAir : {true, false})
                    for (int a = 0; a <= 180; ++a) {
                        const double cosI = a == 180 ? 1.0 : std::cos((a * 0.5) * kDeg);
                        const double bound = thinFilmReflectanceBound(c, cosI, 1.0, glass, fromAir);
                        for (double l = 380.0; l <= 780.0; l += 25.0) {
                            const FresnelTerms f = thinFilmResponse(c, cosI, 1.0, glass, fromAir, l);
                            if (f.totalInternalReflection) {
                                EXPECT_EQ(bound, 1.0);
                                continue;
                            }
                            ++checked;
                            ASSERT_LE(f.reflectance(), bound * (1.0 + 1e-13))
                                << "n " << filmIndex << " d " << thicknessNm << " glass " << glass << " from air "
                                << fromAir << " angle " << a * 0.5 << " λ " << l;
                            if (bound < 1.0) closest = std::min(closest, (bound - f.reflectance()) / bound);
                        }
                    }
        }
    }
    EXPECT_GT(checked, 100000);
    // Reached at normal incidence: the thickness that puts the reflections in phase.
    for (double filmIndex : {1.23, 1.38, 2.1}) {
        const double bound = thinFilmReflectanceBound(Coating{"c", {{filmIndex, 100.0}}, {}}, 1.0, 1.0, 1.52, true);
        double largest = 0.0;
        for (double d = 0.0; d <= 400.0; d += 0.01)
            largest = std::max(largest, thinFilmResponse(Coating{"c", {{filmIndex, d}}, {}}, 1.0, 1.0, 1.52, true, 550.0).reflectance());
        EXPECT_NEAR(largest, bound, 1e-9 * bound) << filmIndex;
    }
    EXPECT_LT(closest, 1e-3);  // and approached on this grid too (within 0.1 %)
    // No bound where there is none to give.
    EXPECT_EQ(thinFilmReflectanceBound(Coating{"c", {{1.38, 100.0}, {2.1, 60.0}}, {}}, 0.9, 1.0, 1.52, true), 1.0);
    EXPECT_EQ(thinFilmReflectanceBound(Coating::idealFlat("i", 0.01), 0.9, 1.0, 1.52, true), 1.0);
    EXPECT_EQ(thinFilmReflectanceBound(Coating::magnesiumFluoride(), 0.0, 1.0, 1.52, true), 1.0);
}

}  // namespace
}  // namespace flare
