// The bundle tracer against tracePath (bit for bit), its step-by-step form against its whole-path
// form, its margins against the clipping tests, and the tabulated interface factors against
// interfaceResponse.
#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/ghosts/Ghosts.h"
#include "flare/optics/BundleTracer.h"

namespace flare {
namespace {

TEST(BundleTracer, EqualsTracePathBitForBitOnEveryShippedLens) {
    for (const char* file : test::kShippedLenses) {
        const LensSystem lens = test::loadLens(file);
        const PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(9.0, 6.0));
        const SpectralIndices indices = lens.indicesAt(520.0);
        std::vector<GhostPath> paths = enumerateGhosts(lens, 2, true);
        paths.insert(paths.begin(), GhostPath{});  // the direct path
        const std::vector<glm::dvec2> points = test::pupilLattice(grid, 20);
        long ok = 0;
        for (size_t p = 0; p < paths.size(); p += 3) {  // every third path keeps the test short
            const BundleTracer tracer(lens, indices, paths[p].reflections);
            std::vector<BundleLanding> landings(points.size());
            tracer.trace(grid, points, landings);
            SequentialPath path;
            path.reflections = paths[p].reflections;
            for (size_t i = 0; i < points.size(); ++i) {
                const TraceResult r = tracePath(lens, indices, grid.ray(points[i].x, points[i].y), path);
                ASSERT_EQ(landings[i].status, r.status) << file << " " << paths[p].label() << " ray " << i;
                ASSERT_EQ(landings[i].surface, r.surface) << file << " " << paths[p].label();
                ASSERT_EQ(landings[i].throughput, r.throughput) << file << " " << paths[p].label();
                if (!r.ok()) continue;
                ++ok;
                ASSERT_EQ(landings[i].sensorMm.x, r.ray.originMm.x) << file << " " << paths[p].label();
                ASSERT_EQ(landings[i].sensorMm.y, r.ray.originMm.y) << file << " " << paths[p].label();
            }
        }
        EXPECT_GT(ok, 20) << file;  // the comparison saw surviving rays, not only failures
    }
}

TEST(BundleTracer, StepByStepEqualsTheWholePathAndMarginsAgreeWithTheTests) {
    const LensSystem lens = test::loadLens("lenses/zoom-24-70mm.lens");
    const PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(11.0, 8.0));
    const SpectralIndices indices = lens.indicesAt(550.0);
    const std::vector<glm::dvec2> points = test::pupilLattice(grid, 48);
    for (const GhostPath& ghost : {GhostPath{{28, 3}}, GhostPath{{13, 6}}, GhostPath{{22, 21}}, GhostPath{}}) {
        const BundleTracer tracer(lens, indices, ghost.reflections);
        std::vector<BundleLanding> whole(points.size());
        tracer.trace(grid, points, whole);
        for (size_t i = 0; i < points.size(); ++i) {
            BundleRay ray{grid.ray(points[i].x, points[i].y), 1.0};
            StepOutcome outcome;
            int step = 0;
            for (; step < tracer.stepCount(); ++step) {
                tracer.advance(step, std::span<BundleRay>(&ray, 1), std::span<StepOutcome>(&outcome, 1), true);
                // A margin says on which side of its constraint the ray is, as the test did.
                if (!std::isnan(outcome.margin) && std::abs(outcome.margin) > 1e-12)
                    ASSERT_EQ(outcome.margin <= 0.0, outcome.alive) << ghost.label() << " ray " << i << " step " << step;
                if (!outcome.alive) break;
            }
            if (outcome.alive) {
                ASSERT_TRUE(whole[i].ok()) << ghost.label();
                EXPECT_EQ(ray.ray.originMm.x, whole[i].sensorMm.x);
                EXPECT_EQ(ray.ray.originMm.y, whole[i].sensorMm.y);
                EXPECT_EQ(ray.throughput, whole[i].throughput);
            } else {
                EXPECT_EQ(outcome.failure, whole[i].status) << ghost.label() << " ray " << i;
                EXPECT_EQ(tracer.stepSurface(step), whole[i].surface) << ghost.label() << " ray " << i;
            }
        }
    }
}

// The tables interpolate smooth functions of the incidence cosine with cubic Hermite polynomials
// on 1/1024 intervals; their slopes come from central differences. Away from the critical angle
// (handled exactly) that leaves errors around 1e-9 relative, and at most ~1e-5 relative where a
// factor is tiny or steep (a reflectance near 1e-3 at normal incidence, the last interval before
// the exact zone). 1e-4 bounds them with margin; a throughput is a product of ~50 factors, so its
// error stays below 1e-3 relative, far below anything the preview or the analysis resolve.
TEST(BundleTracer, InterfaceTablesAgreeWithInterfaceResponse) {
    for (const char* file : test::kShippedLenses) {
        const LensSystem lens = test::loadLens(file);
        for (double wavelengthNm : {420.0, 550.0, 680.0}) {
            const SpectralIndices indices = lens.indicesAt(wavelengthNm);
            const InterfaceTables tables(lens, indices);
            std::mt19937_64 random(7);
            std::uniform_real_distribution<double> uniform(0.0, 1.0);
            for (int k = 0; k < lens.surfaceCount(); ++k) {
                if (lens.surface(k).isStop) continue;
                for (int direction : {-1, 1})
                    for (int n = 0; n < 400; ++n) {
                        const double c = n < 21 ? n / 20.0 : uniform(random);
                        const FresnelTerms exact = interfaceResponse(lens, indices, k, direction, c);
                        EXPECT_NEAR(tables.reflectance(k, direction, c), exact.reflectance(),
                                    1e-4 * exact.reflectance() + 1e-15)
                            << file << " surface " << k << " cos " << c;
                        EXPECT_NEAR(tables.transmittance(k, direction, c), exact.transmittance(),
                                    1e-4 * exact.transmittance() + 1e-15)
                            << file << " surface " << k << " cos " << c;
                    }
            }
        }
    }
}

// Coarse tables, as the final render's beams build them for one wavelength each: 128 intervals.
// Measured worst relative errors over the shipped lenses (2000 random cosines per surface and
// direction, three wavelengths): 2.8e-4 for a reflectance (a tiny one near normal incidence, on
// the zoom), 2.2e-5 for a transmittance. The bound, 1e-3, leaves margin for other coatings; a
// ghost's throughput then moves by at most a few 1e-3, below its mesh's interpolation error.
TEST(BundleTracer, CoarseInterfaceTablesAgreeWithInterfaceResponse) {
    for (const char* file : test::kShippedLenses) {
        const LensSystem lens = test::loadLens(file);
        for (double wavelengthNm : {420.0, 550.0, 680.0}) {
            const SpectralIndices indices = lens.indicesAt(wavelengthNm);
            const InterfaceTables tables(lens, indices, 128);
            std::mt19937_64 random(11);
            std::uniform_real_distribution<double> uniform(0.0, 1.0);
            for (int k = 0; k < lens.surfaceCount(); ++k) {
                if (lens.surface(k).isStop) continue;
                for (int direction : {-1, 1})
                    for (int n = 0; n < 400; ++n) {
                        const double c = n < 21 ? n / 20.0 : uniform(random);
                        const FresnelTerms exact = interfaceResponse(lens, indices, k, direction, c);
                        EXPECT_NEAR(tables.reflectance(k, direction, c), exact.reflectance(),
                                    1e-3 * exact.reflectance() + 1e-15)
                            << file << " surface " << k << " cos " << c;
                        EXPECT_NEAR(tables.transmittance(k, direction, c), exact.transmittance(),
                                    1e-3 * exact.transmittance() + 1e-15)
                            << file << " surface " << k << " cos " << c;
                    }
            }
        }
    }
}

// The beams' tables take their slopes from the tabulated values (fourth-order differences; the
// response's own differences at the ends and near total internal reflection's edge): one response
// per point instead of three. They must add little to the tables' own error: at most a tenth of
// the coarse bound above, 1e-4 relative, between the two kinds of slopes (measured: 8.5e-6 on the
// shipped lenses), and the 1e-3 bound against the exact response still holds.
TEST(BundleTracer, CoarseTablesWithSlopesFromValuesAgreeWithInterfaceResponse) {
    double largest = 0.0;
    for (const char* file : test::kShippedLenses) {
        const LensSystem lens = test::loadLens(file);
        for (double wavelengthNm : {420.0, 550.0, 680.0}) {
            const SpectralIndices indices = lens.indicesAt(wavelengthNm);
            const InterfaceTables responseSlopes(lens, indices, 128), valueSlopes(lens, indices, 128, {}, true);
            std::mt19937_64 random(13);
            std::uniform_real_distribution<double> uniform(0.0, 1.0);
            for (int k = 0; k < lens.surfaceCount(); ++k) {
                if (lens.surface(k).isStop) continue;
                for (int direction : {-1, 1})
                    for (int n = 0; n < 1000; ++n) {
                        const double c = n < 21 ? n / 20.0 : uniform(random);
                        const FresnelTerms exact = interfaceResponse(lens, indices, k, direction, c);
                        const double r = valueSlopes.reflectance(k, direction, c), t = valueSlopes.transmittance(k, direction, c);
                        EXPECT_NEAR(r, exact.reflectance(), 1e-3 * exact.reflectance() + 1e-15) << file << " " << k << " " << c;
                        EXPECT_NEAR(t, exact.transmittance(), 1e-3 * exact.transmittance() + 1e-15) << file << " " << k << " " << c;
                        EXPECT_NEAR(r, responseSlopes.reflectance(k, direction, c), 1e-4 * exact.reflectance() + 1e-15)
                            << file << " " << k << " " << c;
                        EXPECT_NEAR(t, responseSlopes.transmittance(k, direction, c), 1e-4 * exact.transmittance() + 1e-15)
                            << file << " " << k << " " << c;
                        if (exact.reflectance() > 0.0)
                            largest = std::max(largest, std::abs(r / responseSlopes.reflectance(k, direction, c) - 1.0));
                    }
            }
        }
    }
    EXPECT_GT(largest, 0.0) << "the two kinds of slopes gave the same tables: is the option used?";
}

TEST(BundleTracer, TablesChangeOnlyTheThroughput) {
    const LensSystem lens = test::loadLens("lenses/zoom-24-70mm.lens");
    const PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(11.0, 8.0));
    const SpectralIndices indices = lens.indicesAt(550.0);
    const InterfaceTables tables(lens, indices);
    const std::vector<glm::dvec2> points = test::pupilLattice(grid, 64);
    int ok = 0;
    for (const GhostPath& ghost : {GhostPath{{28, 3}}, GhostPath{{26, 24}}, GhostPath{}}) {
        const BundleTracer exact(lens, indices, ghost.reflections), tabled(lens, indices, ghost.reflections, true, &tables);
        std::vector<BundleLanding> a(points.size()), b(points.size());
        exact.trace(grid, points, a);
        tabled.trace(grid, points, b);
        for (size_t i = 0; i < points.size(); ++i) {
            ASSERT_EQ(a[i].status, b[i].status);
            if (!a[i].ok()) continue;
            ++ok;
            EXPECT_EQ(a[i].sensorMm, b[i].sensorMm);
            EXPECT_NEAR(b[i].throughput / a[i].throughput, 1.0, 1e-3) << ghost.label();  // see above
        }
    }
    EXPECT_GT(ok, 100);
}

// Tables of a path's own interfaces only (what a beam builds): the path traces with them to the
// same bits as with the whole lens's tables, and an interface left out falls back to the exact
// response.
TEST(BundleTracer, TablesOfThePathsInterfacesOnlyGiveTheSameBits) {
    const LensSystem lens = test::loadLens("lenses/double-gauss-50mm.lens");
    const PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(6.0, -4.0));
    const SpectralIndices indices = lens.indicesAt(505.0);
    const InterfaceTables all(lens, indices, 64);
    const std::vector<glm::dvec2> points = test::pupilLattice(grid, 48);
    int ok = 0;
    for (const GhostPath& ghost : {GhostPath{{9, 2}}, GhostPath{{11, 10}}, GhostPath{}}) {
        const std::vector<InterfaceTables::Interface> interfaces = BundleTracer(lens, indices, ghost.reflections).interfaces();
        // The direct path meets every surface once forwards; a ghost meets the surfaces between its
        // reflections both ways.
        const int refracting = lens.surfaceCount() - 1;  // all but the stop
        if (ghost.reflections.empty()) EXPECT_EQ(static_cast<int>(interfaces.size()), refracting);
        else EXPECT_GT(static_cast<int>(interfaces.size()), refracting);
        const InterfaceTables own(lens, indices, 64, interfaces);
        const BundleTracer withAll(lens, indices, ghost.reflections, true, &all);
        const BundleTracer withOwn(lens, indices, ghost.reflections, true, &own);
        std::vector<BundleLanding> a(points.size()), b(points.size());
        withAll.trace(grid, points, a);
        withOwn.trace(grid, points, b);
        for (size_t i = 0; i < points.size(); ++i) {
            ASSERT_EQ(a[i].status, b[i].status);
            ASSERT_EQ(a[i].throughput, b[i].throughput) << ghost.label();
            ok += a[i].ok();
        }
    }
    EXPECT_GT(ok, 100);
    // The direct path meets no interface backwards: a table of its interfaces leaves surface 1
    // backwards out, and answers it exactly.
    const InterfaceTables direct(lens, indices, 64, BundleTracer(lens, indices, {}).interfaces());
    for (double c : {0.2, 0.7, 0.95})
        EXPECT_EQ(direct.reflectance(1, -1, c), interfaceResponse(lens, indices, 1, -1, c).reflectance());
}

}  // namespace
}  // namespace flare
