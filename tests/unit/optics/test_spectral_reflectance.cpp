// The photon tracer's reflectance table against the exact coating response: its interpolation
// error over every interface of every shipped lens (single-layer MgF2), a four-layer stack with
// fast spectral ripples, uncoated glass and an ideal coating; the exact zones (the critical angle,
// outside the tabulated wavelengths); and photons traced with the table against photons traced
// with the exact response.
#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/core/Random.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/SequentialTracer.h"
#include "flare/optics/SpectralReflectance.h"
#include "flare/photons/PhotonTracer.h"

namespace flare {
namespace {

double exactReflectance(const LensSystem& lens, int k, int direction, double wavelengthNm, double c) {
    const FresnelTerms r = interfaceResponse(lens, lens.indicesAt(wavelengthNm), k, direction, c);
    return r.totalInternalReflection ? 1.0 : r.reflectance();
}

struct ErrorSeen {
    double absolute = 0.0, relative = 0.0;  // relative to max(R, 1e-3)
    long samples = 0;
};

// Random interfaces, directions, wavelengths in the table and cosines.
ErrorSeen measure(const LensSystem& lens, const SpectralReflectance& table, int samples, std::uint64_t seed) {
    Rng rng(seed, 1);
    ErrorSeen e;
    for (int n = 0; n < samples; ++n) {
        const int k = std::min(lens.surfaceCount() - 1, static_cast<int>(rng.uniform() * lens.surfaceCount()));
        if (lens.surface(k).isStop) continue;
        const int direction = rng.uniform() < 0.5 ? -1 : 1;
        const double wavelengthNm = table.fromNm() + rng.uniform() * (table.toNm() - table.fromNm());
        const double c = rng.uniform();
        const double exact = exactReflectance(lens, k, direction, wavelengthNm, c);
        const double tabled = table.reflectance(k, direction, wavelengthNm, lens.indicesAt(wavelengthNm), c);
        const double error = std::abs(tabled - exact);
        e.absolute = std::max(e.absolute, error);
        e.relative = std::max(e.relative, error / std::max(exact, 1e-3));
        ++e.samples;
    }
    return e;
}

LensSystem lensWithCoating(const std::string& coatingLine) {
    return LensSystem::build(parseLensText("name coated\nfocal_length_mm 100\n" + coatingLine +
                                               "\nsurfaces\n  60 6 N-SF6 12\n -45 3 N-BK7 12\n -200 4 air 12\n"
                                               " stop 5 air 7\n -30 3 N-LAK9 10\n -80 auto air 10\n",
                                           "coated.lens"));
}

// A four-layer broadband anti-reflection stack (layer index:thickness nm from the air side).
constexpr const char* kStack = "coating bbar stack 1.38:99.6 2.10:114.5 1.62:84.9 2.10:30.0\ndefault_coating bbar";

// The stated bound. Measured worst cases (printed; 40 000 random interfaces, wavelengths and
// cosines each): shipped lenses 6e-6 absolute and 1e-4 relative, the four-layer stack 1.8e-5 and
// 4e-4, uncoated glass 4e-7 and 5e-6. The splines are needed: a first, bilinear version on the
// same grid (exact only to 0.05 above the critical angle) erred by 8.5e-4 absolute at grazing
// incidence and by 1.2 % relative just above the critical angle; and a grid 8× coarser
// (ACoarseTableFailsTheBound) breaks the bound.
constexpr double kMaxAbsoluteError = 2e-5, kMaxRelativeError = 1e-3;

TEST(SpectralReflectance, MatchesTheExactResponseOnEveryShippedLens) {
    for (const char* file : test::kShippedLenses) {
        const LensSystem lens = test::loadLens(file);
        const SpectralReflectance table(lens, SpectralReflectance::Tabulate::All);
        const ErrorSeen e = measure(lens, table, 40000, 3);
        std::printf("%s: max error %.2g absolute, %.2g relative (%ld samples)\n", file, e.absolute, e.relative, e.samples);
        EXPECT_GT(e.samples, 30000);
        EXPECT_LT(e.absolute, kMaxAbsoluteError) << file;
        EXPECT_LT(e.relative, kMaxRelativeError) << file;
    }
}

TEST(SpectralReflectance, MatchesAMultilayerStackUncoatedGlassAndAnIdealCoating) {
    for (const char* coating : {kStack,
                                "default_coating none", "coating flat ideal 400:0.02 550:0.004 700:0.012\ndefault_coating flat"}) {
        const LensSystem lens = lensWithCoating(coating);
        const SpectralReflectance table(lens, SpectralReflectance::Tabulate::All);
        const ErrorSeen e = measure(lens, table, 40000, 5);
        std::printf("%s: max error %.2g absolute, %.2g relative\n", coating, e.absolute, e.relative);
        EXPECT_LT(e.absolute, kMaxAbsoluteError) << coating;
        EXPECT_LT(e.relative, kMaxRelativeError) << coating;
    }
}

// Near the critical angle and outside the tabulated wavelengths the answer is the exact one.
TEST(SpectralReflectance, ExactNearTheCriticalAngleAndOutsideTheTable) {
    const LensSystem lens = test::loadLens("lenses/double-gauss-50mm.lens");
    const SpectralReflectance table(lens, SpectralReflectance::Tabulate::All, 400.0, 700.0);
    int checked = 0;
    for (int k = 0; k < lens.surfaceCount(); ++k) {
        if (lens.surface(k).isStop) continue;
        for (int direction : {-1, 1}) {
            for (double wavelengthNm : {380.0, 712.5, 1000.0}) {
                const SpectralIndices indices = lens.indicesAt(wavelengthNm);
                for (double c : {0.0, 0.3, 0.77, 1.0})
                    EXPECT_EQ(table.reflectance(k, direction, wavelengthNm, indices, c),
                              exactReflectance(lens, k, direction, wavelengthNm, c));
            }
            const double wavelengthNm = 523.0;
            const SpectralIndices indices = lens.indicesAt(wavelengthNm);
            const double n1 = direction > 0 ? indices.n[k] : indices.n[k + 1];
            const double n2 = direction > 0 ? indices.n[k + 1] : indices.n[k];
            if (n1 <= n2) continue;
            const double critical = std::sqrt(1.0 - (n2 / n1) * (n2 / n1));
            for (double c : {critical - 1e-4, critical, critical + 1e-6, critical + 0.01}) {
                EXPECT_EQ(table.reflectance(k, direction, wavelengthNm, indices, c),
                          exactReflectance(lens, k, direction, wavelengthNm, c));
                ++checked;
            }
        }
    }
    EXPECT_GT(checked, 20);
}

// The bound is not vacuous: a table 8× coarser in cos θ breaks it on uncoated glass.
TEST(SpectralReflectance, ACoarseTableFailsTheBound) {
    const LensSystem lens = lensWithCoating("default_coating none");
    const SpectralReflectance coarse(lens, SpectralReflectance::Tabulate::All, 360.0, 830.0, 40.0, 32);
    const ErrorSeen e = measure(lens, coarse, 40000, 7);
    EXPECT_GT(e.relative, kMaxRelativeError);
}

// Only multilayer-coated interfaces get a table by default; a lens without any keeps none.
TEST(SpectralReflectance, TablesOnlyMultilayerInterfaces) {
    const LensSystem single = test::loadLens("lenses/double-gauss-50mm.lens");
    EXPECT_EQ(SpectralReflectance(single).tabulatedInterfaces(), 0);
    PhotonTracer tracer(single, InteriorMaterials{});
    tracer.tabulateReflectance();
    EXPECT_FALSE(tracer.tabulatesReflectance());
    const LensSystem stack = lensWithCoating(kStack);
    EXPECT_EQ(SpectralReflectance(stack).tabulatedInterfaces(), 2 * 4);  // four air-glass surfaces, both ways
}

// Photons through a lens with a four-layer stack, with the table and with the exact response:
// each fate's count agrees within binomial statistics (a table off by 10 % in reflectance would
// not).
TEST(SpectralReflectance, PhotonFatesAgreeWithTheExactResponse) {
    const LensSystem lens = lensWithCoating(kStack);
    InteriorMaterials materials;
    PhotonTracer exact(lens, materials), tabled(lens, materials);
    tabled.tabulateReflectance();
    ASSERT_TRUE(tabled.tabulatesReflectance());
    const glm::dvec3 direction = directionFromFieldDeg(8.0, 5.0);
    constexpr int kPhotons = 200000;
    std::map<int, long> counts[2];
    long reflected[2] = {};  // photons that reflected at least once
    for (int which = 0; which < 2; ++which) {
        Rng rng(11, static_cast<std::uint64_t>(which) + 1);
        const PhotonTracer& tracer = which == 0 ? exact : tabled;
        for (int i = 0; i < kPhotons; ++i) {
            const double wavelengthNm = 400.0 + 300.0 * rng.uniform();
            const double r = 0.9 * lens.surface(0).semiApertureMm * std::sqrt(rng.uniform());
            const double phi = 2.0 * M_PI * rng.uniform();
            Ray ray{{r * std::cos(phi), r * std::sin(phi), lens.surface(0).vertexZMm - 10.0}, direction};
            ray.originMm -= direction * 10.0;
            PhotonHistory history;
            tracer.trace(lens.indicesAt(wavelengthNm), ray, rng, history);
            ++counts[which][static_cast<int>(history.fate)];
            reflected[which] += history.reflections > 0;
        }
    }
    for (const auto& [fate, n0] : counts[0]) {
        const double n1 = static_cast<double>(counts[1][fate]);
        const double p = (n0 + n1) / (2.0 * kPhotons);
        const double sigma = std::sqrt(2.0 * kPhotons * p * (1.0 - p));
        EXPECT_LE(std::abs(n1 - n0), 5.0 * sigma + 1.0) << "fate " << fate;
    }
    EXPECT_GT(reflected[0], 1000);
    const double p = (reflected[0] + reflected[1]) / (2.0 * kPhotons);
    EXPECT_LE(std::abs(reflected[1] - reflected[0]), 5.0 * std::sqrt(2.0 * kPhotons * p * (1.0 - p)));
}

}  // namespace
}  // namespace flare
