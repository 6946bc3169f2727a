// The built-in glass catalogue reproduces every glass's printed nd and Vd; (nd, Vd) glasses
// reproduce their own nd and Vd exactly.
#include <cmath>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "flare/optics/Glass.h"

namespace flare {
namespace {

// Catalogues print nd to 5 decimals and Vd to 2: a formula consistent with the printed values lies
// within half a unit in the last place (plus rounding noise of the double computation).
constexpr double kNdHalfUnit = 0.5e-5 + 1e-12;
constexpr double kVdHalfUnit = 0.005 + 1e-9;

double abbe(const CatalogGlass& g) {
    const double nd = catalogIndex(g, kLineDNm);
    return (nd - 1.0) / (catalogIndex(g, kLineFNm) - catalogIndex(g, kLineCNm));
}

TEST(GlassCatalog, HasAtLeastThirtyGlassesFromSchottOharaHoya) {
    EXPECT_GE(glassCatalog().size(), 30u);
    std::set<std::string> makers, names;
    for (const CatalogGlass& g : glassCatalog()) {
        makers.insert(g.maker);
        EXPECT_TRUE(names.insert(g.name).second) << "duplicate " << g.name;
    }
    EXPECT_TRUE(makers.count("Schott"));
    EXPECT_TRUE(makers.count("Ohara"));
    EXPECT_TRUE(makers.count("Hoya"));
}

TEST(GlassCatalog, DispersionFormulasReproducePrintedNdAndVd) {
    for (const CatalogGlass& g : glassCatalog()) {
        EXPECT_NEAR(catalogIndex(g, kLineDNm), g.nd, kNdHalfUnit) << g.name;
        EXPECT_NEAR(abbe(g), g.vd, kVdHalfUnit) << g.name;
    }
}

TEST(GlassCatalog, ReferenceSellmeierValues) {
    const CatalogGlass* bk7 = findCatalogGlass("n-bk7");
    ASSERT_NE(bk7, nullptr);
    EXPECT_EQ(bk7->coefficients[0], 1.03961212);
    EXPECT_EQ(bk7->coefficients[5], 103.560653);
    EXPECT_NEAR(catalogIndex(*bk7, kLineDNm), 1.51680, kNdHalfUnit);
    EXPECT_EQ(findCatalogGlass("no-such-glass"), nullptr);
}

TEST(GlassCatalog, NormalDispersion) {
    for (const CatalogGlass& g : glassCatalog()) {
        double previous = catalogIndex(g, 380.0);
        for (double l = 390.0; l <= 780.0; l += 10.0) {
            const double n = catalogIndex(g, l);
            EXPECT_LT(n, previous) << g.name << " at " << l;
            previous = n;
        }
    }
}

TEST(Medium, AbbeMatchedGlassReproducesItsNdAndVdExactly) {
    for (const auto& [nd, vd] : {std::pair{1.670, 47.1}, std::pair{1.5168, 64.17}, std::pair{1.92286, 20.9},
                                 std::pair{1.497, 81.6}, std::pair{1.80610, 40.9}}) {
        const Medium m = Medium::abbe(nd, vd);
        const double n = m.indexAt(kLineDNm);
        EXPECT_NEAR(n, nd, 1e-12);
        EXPECT_NEAR((n - 1.0) / (m.indexAt(kLineFNm) - m.indexAt(kLineCNm)), vd, 1e-9);
        ASSERT_NE(m.baseGlass(), nullptr);
    }
}

TEST(Medium, CauchyGlassReproducesItsNdAndVdAndFollowsOneOverLambdaSquared) {
    for (const auto& [nd, vd] : {std::pair{1.670, 47.1}, std::pair{1.5168, 64.17}, std::pair{1.92286, 20.9}}) {
        const Medium m = Medium::cauchy(nd, vd);
        EXPECT_EQ(m.kind(), Medium::Kind::Cauchy);
        EXPECT_EQ(m.baseGlass(), nullptr);
        const double n = m.indexAt(kLineDNm);
        EXPECT_NEAR(n, nd, 1e-12);
        EXPECT_NEAR((n - 1.0) / (m.indexAt(kLineFNm) - m.indexAt(kLineCNm)), vd, 1e-9);
        // Two terms: n(λ) − A is exactly B/λ², so the index differences scale as 1/λ² differences.
        const double r = (m.indexAt(400.0) - m.indexAt(700.0)) / (m.indexAt(500.0) - m.indexAt(700.0));
        EXPECT_NEAR(r, (1.0 / (400.0 * 400.0) - 1.0 / (700.0 * 700.0)) / (1.0 / (500.0 * 500.0) - 1.0 / (700.0 * 700.0)), 1e-9);
    }
    // Near a real glass, the two models part by ~1e-3 at the ends of the visible: N-BK7 at 400 nm.
    const Medium cauchy = Medium::cauchy(1.51680, 64.17), abbe = Medium::abbe(1.51680, 64.17);
    EXPECT_LT(std::abs(cauchy.indexAt(400.0) - abbe.indexAt(400.0)), 2e-3);
    EXPECT_GT(std::abs(cauchy.indexAt(400.0) - abbe.indexAt(400.0)), 1e-5);
}

TEST(Medium, AbbeMatchingPicksTheCatalogueGlassWithThoseValues) {
    const Medium m = Medium::abbe(1.51680, 64.17);
    EXPECT_STREQ(m.baseGlass()->name, "N-BK7");
    // Away from d, the matched glass follows N-BK7's dispersion curve.
    EXPECT_NEAR(m.indexAt(400.0), catalogIndex(*findCatalogGlass("N-BK7"), 400.0), 2e-5);
}

TEST(Medium, AirAndConstant) {
    EXPECT_EQ(Medium::air().indexAt(450.0), 1.0);
    EXPECT_EQ(Medium::constant(1.67).indexAt(450.0), 1.67);
    EXPECT_TRUE(std::isinf(Medium::constant(1.67).vd()));
}

}  // namespace
}  // namespace flare
