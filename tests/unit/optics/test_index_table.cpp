// The photon tracer's table of refractive indices against the glasses' dispersion formulas: exact
// at its 1-nm samples, within the stated interpolation error between them, clamped outside its
// range, and fill() writing exactly at()'s values into the lens's media and nothing else.
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/optics/IndexTable.h"

namespace flare {
namespace {

TEST(IndexTable, EqualsTheDispersionFormulasAtItsSamplesAndIsCloseBetween) {
    for (const char* file : test::kShippedLenses) {
        const LensSystem lens = test::loadLens(file);
        const IndexTable table(lens);
        const int media = lens.surfaceCount() + 1;
        // Linear interpolation between samples h = 1 nm apart errs by at most h²/8 · max |n''|
        // over the interval. n'' per medium from the formulas' second differences at the samples
        // (n'' varies by a few per cent over a nanometre: a tenth more is allowed), plus rounding.
        std::vector<double> curvature(media, 0.0), largest(media, 0.0);
        for (double nm = 379.0; nm <= 781.0; nm += 1.0) {
            const SpectralIndices a = lens.indicesAt(nm - 1.0), b = lens.indicesAt(nm), c = lens.indicesAt(nm + 1.0);
            for (int m = 0; m < media; ++m) curvature[m] = std::max(curvature[m], std::abs(a.n[m] - 2.0 * b.n[m] + c.n[m]));
        }
        for (double nm = 380.0; nm <= 780.0; nm += 0.037) {
            const SpectralIndices exact = lens.indicesAt(nm);
            const SpectralIndices tabled = table.at(nm);
            ASSERT_EQ(tabled.wavelengthNm, nm);
            for (int m = 0; m < media; ++m) largest[m] = std::max(largest[m], std::abs(tabled.n[m] - exact.n[m]));
        }
        double worst = 0.0;
        for (int m = 0; m < media; ++m) {
            EXPECT_LE(largest[m], 1.1 * curvature[m] / 8.0 + 1e-14) << file << " medium " << m;
            worst = std::max(worst, largest[m]);
        }
        // What that is for these glasses: up to about 2e-6 in n (a ray's angle moves by that much
        // relative, well under a micrometre on the sensor).
        EXPECT_LT(worst, 3e-6) << file;
        for (const double nm : {400.0, 555.0, 700.0}) {
            const SpectralIndices exact = lens.indicesAt(nm);
            const SpectralIndices tabled = table.at(nm);
            for (int m = 0; m < media; ++m) EXPECT_EQ(tabled.n[m], exact.n[m]) << file << " at " << nm << " nm";
        }
    }
}

TEST(IndexTable, ClampsOutsideItsRange) {
    const LensSystem lens = test::loadLens("lenses/double-gauss-50mm.lens");
    const IndexTable table(lens, 360.0, 830.0);
    const SpectralIndices below = table.at(200.0), first = table.at(360.0);
    const SpectralIndices above = table.at(1200.0), last = table.at(830.0);
    for (int m = 0; m <= lens.surfaceCount(); ++m) {
        EXPECT_EQ(below.n[m], first.n[m]);
        EXPECT_EQ(above.n[m], last.n[m]);
    }
}

TEST(IndexTable, FillWritesTheLensMediaOnly) {
    const LensSystem lens = test::loadLens("lenses/zoom-24-70mm.lens");
    const IndexTable table(lens);
    const int media = lens.surfaceCount() + 1;
    ASSERT_LT(media, kMaxSurfaces + 1);
    const double sentinel = -12345.0;
    SpectralIndices out;
    out.n.fill(sentinel);
    for (const double nm : {431.7, 587.5618, 702.2}) {
        table.fill(nm, out);
        const SpectralIndices expected = table.at(nm);
        EXPECT_EQ(out.wavelengthNm, nm);
        for (int m = 0; m < media; ++m) EXPECT_EQ(out.n[m], expected.n[m]) << m;
        for (int m = media; m <= kMaxSurfaces; ++m) EXPECT_EQ(out.n[m], sentinel) << m;
    }
}

}  // namespace
}  // namespace flare
