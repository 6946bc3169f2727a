// The SIMD packet tracer against tracePath, bit for bit, on every instruction set that this
// processor runs and Highway compiled (AVX-512, AVX2, SSE4, the baseline): every shipped lens,
// the direct path and ghost paths, geometry only and with Fresnel/coating factors, rays that land
// and rays that fail in every way, and the cases its vector lanes hand to the scalar step
// (aspheres, far origins, the blades of a polygonal iris) as well as conics and a round iris.
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <hwy/targets.h>

#include "TestUtil.h"
#include "flare/ghosts/Ghosts.h"
#include "flare/optics/PacketTracer.h"

namespace flare {
namespace {

// Runs `body` once per instruction set that Highway compiled and this processor supports, with
// the dispatcher forced to it; the name goes into failure messages.
template <class Body>
void forEachTarget(Body body) {
    for (const std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
        hwy::SetSupportedTargetsForTest(target);
        ASSERT_STREQ(PacketTracer::targetName(), hwy::TargetName(target));
        body(std::string(hwy::TargetName(target)));
    }
    hwy::SetSupportedTargetsForTest(0);
}

// Counts of outcomes seen, so that a test shows it compared failures of each kind, not only hits.
struct Seen {
    long counts[7] = {};
    void add(TraceStatus s) { ++counts[static_cast<int>(s)]; }
    long operator[](TraceStatus s) const { return counts[static_cast<int>(s)]; }
};

// Every ray of `points` through `tracer` against tracePath with the same options, bit for bit.
void expectEqualsTracePath(const PacketTracer& tracer, const PupilGrid& grid, const std::vector<glm::dvec2>& points,
                           std::span<const int> reflections, bool fresnelWeights, const std::string& what, Seen* seen) {
    const LensSystem& lens = tracer.path().lens();
    const SpectralIndices indices = lens.indicesAt(tracer.path().wavelengthNm());
    std::vector<BundleLanding> landings(points.size());
    tracer.trace(grid, points, landings);
    SequentialPath path;
    path.reflections = reflections;
    TraceOptions options;
    options.fresnelWeights = fresnelWeights;
    for (size_t i = 0; i < points.size(); ++i) {
        const TraceResult r = tracePath(lens, indices, grid.ray(points[i].x, points[i].y), path, options);
        ASSERT_EQ(landings[i].status, r.status) << what << " ray " << i;
        ASSERT_EQ(landings[i].surface, r.surface) << what << " ray " << i;
        ASSERT_EQ(landings[i].throughput, r.throughput) << what << " ray " << i;
        if (seen) seen->add(r.status);
        if (!r.ok()) continue;
        ASSERT_EQ(landings[i].sensorMm.x, r.ray.originMm.x) << what << " ray " << i;
        ASSERT_EQ(landings[i].sensorMm.y, r.ray.originMm.y) << what << " ray " << i;
    }
}

TEST(PacketTracer, EqualsTracePathBitForBitOnEveryShippedLensAndInstructionSet) {
    forEachTarget([](const std::string& target) {
        Seen seen;
        for (const char* file : test::kShippedLenses) {
            const LensSystem lens = test::loadLens(file);
            const PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(9.0, 6.0));
            const SpectralIndices indices = lens.indicesAt(520.0);
            std::vector<GhostPath> paths = enumerateGhosts(lens, 2, true);
            // The direct path, then sequences no ray completes: out through the front, at the
            // sensor too early.
            paths.insert(paths.begin(), {GhostPath{}, GhostPath{{2}}, GhostPath{{3, 1, 0}}});
            const std::vector<glm::dvec2> points = test::pupilLattice(grid, 23);
            for (size_t p = 0; p < paths.size(); p += p < 3 ? 1 : 5) {  // every fifth ghost keeps it short
                const std::string what = target + " " + file + " " + paths[p].label();
                for (bool weights : {false, true}) {
                    const PacketTracer tracer(BundleTracer(lens, indices, paths[p].reflections, weights));
                    expectEqualsTracePath(tracer, grid, points, paths[p].reflections, weights, what, &seen);
                }
            }
        }
        EXPECT_GT(seen[TraceStatus::Ok], 1000) << target;
        for (TraceStatus s : {TraceStatus::Missed, TraceStatus::Vignetted, TraceStatus::BlockedByIris,
                              TraceStatus::TotalInternalReflection, TraceStatus::WrongExit})
            EXPECT_GT(seen[s], 0) << target << " " << toString(s);
    });
}

// With InterfaceTables, the factors come from the same lookups as BundleTracer's.
TEST(PacketTracer, WithTablesEqualsBundleTracerBitForBit) {
    const LensSystem lens = test::loadLens("lenses/double-gauss-50mm.lens");
    const SpectralIndices indices = lens.indicesAt(610.0);
    const InterfaceTables tables(lens, indices);
    const PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(4.0, -7.0));
    const std::vector<glm::dvec2> points = test::pupilLattice(grid, 41);
    forEachTarget([&](const std::string& target) {
        for (const GhostPath& ghost : {GhostPath{}, GhostPath{{4, 1}}, GhostPath{{11, 8}}, GhostPath{{9, 0}}}) {
            const BundleTracer bundle(lens, indices, ghost.reflections, true, &tables);
            const PacketTracer tracer(bundle);
            std::vector<BundleLanding> expected(points.size()), landings(points.size());
            bundle.trace(grid, points, expected);
            tracer.trace(grid, points, landings);
            for (size_t i = 0; i < points.size(); ++i) {
                ASSERT_EQ(landings[i].status, expected[i].status) << target << " " << ghost.label() << " ray " << i;
                ASSERT_EQ(landings[i].surface, expected[i].surface) << target << " " << ghost.label();
                ASSERT_EQ(landings[i].throughput, expected[i].throughput) << target << " " << ghost.label();
                ASSERT_EQ(landings[i].sensorMm.x, expected[i].sensorMm.x) << target << " " << ghost.label();
                ASSERT_EQ(landings[i].sensorMm.y, expected[i].sensorMm.y) << target << " " << ghost.label();
            }
        }
    });
}

// Conics without polynomial terms (the zoom's aspheres with their terms removed) take the vector
// lanes' conic normal; a round iris is decided in the lanes alone.
TEST(PacketTracer, ConicsAndARoundIrisEqualTracePath) {
    LensPrescription prescription = loadLensFile(test::sourcePath("lenses/zoom-24-70mm.lens"));
    int conics = 0;
    for (PrescriptionRow& row : prescription.rows) {
        row.asphere = {};
        conics += row.conic != 0.0;
    }
    ASSERT_GE(conics, 3);
    prescription.iris.blades = 0;
    const LensSystem lens = LensSystem::build(prescription);
    const SpectralIndices indices = lens.indicesAt(480.0);
    const PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(-12.0, 5.0));
    const std::vector<glm::dvec2> points = test::pupilLattice(grid, 37);
    forEachTarget([&](const std::string& target) {
        Seen seen;
        for (const GhostPath& ghost : {GhostPath{}, GhostPath{{28, 3}}, GhostPath{{13, 6}}, GhostPath{{22, 21}}}) {
            const PacketTracer tracer(BundleTracer(lens, indices, ghost.reflections, true));
            expectEqualsTracePath(tracer, grid, points, ghost.reflections, true, target + " " + ghost.label(), &seen);
        }
        EXPECT_GT(seen[TraceStatus::Ok], 50) << target;
        EXPECT_GT(seen[TraceStatus::BlockedByIris], 0) << target;
    });
}

// Rays starting far in front of the lens (a long back-off) meet the first surface from beyond
// kConicFarOrigin radii: the lanes hand them to intersectConicFromAfar's scalar path.
TEST(PacketTracer, FarOriginsEqualTracePath) {
    const LensSystem lens = test::loadLens("lenses/double-gauss-50mm.lens");
    const SpectralIndices indices = lens.indicesAt(550.0);
    PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(2.0, 1.0));
    grid.backOffMm += 400.0;
    ASSERT_GT(grid.backOffMm, kConicFarOrigin * std::abs(lens.surface(0).radiusMm) * 2.0);
    const std::vector<glm::dvec2> points = test::pupilLattice(grid, 19);
    forEachTarget([&](const std::string& target) {
        Seen seen;
        const PacketTracer tracer(BundleTracer(lens, indices, {}, true));
        expectEqualsTracePath(tracer, grid, points, {}, true, target, &seen);
        EXPECT_GT(seen[TraceStatus::Ok], 20) << target;
    });
}

// Pupil points that are not finite, far outside the lens, or on the edge of an aperture: every
// lane ends as tracePath's does, and nothing non-finite reaches a landing that is ok.
TEST(PacketTracer, NonFiniteFarAndEdgeRaysEqualTracePath) {
    const LensSystem lens = test::loadLens("lenses/wide-angle-28mm.lens");
    const SpectralIndices indices = lens.indicesAt(550.0);
    const InterfaceTables tables(lens, indices);
    const PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(0.0, 0.0));
    const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
    const double edge = lens.surface(0).semiApertureMm;
    std::vector<glm::dvec2> points = {{nan, 0.0}, {0.0, nan}, {inf, 0.0}, {-inf, inf}, {1e300, -1e300},
                                      {1e154, 0.0}, {0.0, 0.0}, {-0.0, -0.0}, {edge, 0.0}, {0.0, -edge},
                                      {std::nextafter(edge, 0.0), 0.0}, {std::nextafter(edge, 2 * edge), 0.0},
                                      {edge * 0.6, edge * 0.8}, {1e-300, -1e-300}};
    forEachTarget([&](const std::string& target) {
        for (const GhostPath& ghost : {GhostPath{}, GhostPath{{5, 2}}}) {
            expectEqualsTracePath(PacketTracer(BundleTracer(lens, indices, ghost.reflections, true)), grid, points,
                                  ghost.reflections, true, target + " " + ghost.label(), nullptr);
            const BundleTracer bundle(lens, indices, ghost.reflections, true, &tables);
            std::vector<BundleLanding> expected(points.size()), landings(points.size());
            bundle.trace(grid, points, expected);
            PacketTracer(bundle).trace(grid, points, landings);
            for (size_t i = 0; i < points.size(); ++i) {
                ASSERT_EQ(landings[i].status, expected[i].status) << target << " point " << i;
                ASSERT_EQ(landings[i].throughput, expected[i].throughput) << target << " point " << i;
                if (landings[i].ok()) ASSERT_TRUE(std::isfinite(landings[i].sensorMm.x + landings[i].sensorMm.y));
            }
        }
    });
}

// Rays at wavelengths of their own (the final render's guided photons) against tracePath with
// each ray's indices, bit for bit: every shipped lens (the zoom's aspheres, the fisheye, polygonal
// irises), direct and ghost paths, paths no ray completes, with and without factors; a tracer
// built at one wavelength traces rays of any. Far origins (left to the scalar code at a conic,
// so traced again by tracePath) in the last case.
TEST(PacketTracer, RaysAtTheirOwnWavelengthsEqualTracePath) {
    forEachTarget([](const std::string& target) {
        Seen seen;
        for (const char* file : test::kShippedLenses) {
            const LensSystem lens = test::loadLens(file);
            for (const double backOffMm : {0.0, 400.0}) {
                PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(9.0, 6.0));
                grid.backOffMm += backOffMm;
                const std::vector<glm::dvec2> points = test::pupilLattice(grid, backOffMm > 0.0 ? 11 : 23);
                std::vector<Ray> rays;
                std::vector<SpectralIndices> indices;
                for (size_t i = 0; i < points.size(); ++i) {
                    rays.push_back(grid.ray(points[i].x, points[i].y));
                    indices.push_back(lens.indicesAt(380.0 + std::fmod(37.3 * static_cast<double>(i), 400.0)));
                }
                std::vector<const SpectralIndices*> pointers;
                for (const SpectralIndices& n : indices) pointers.push_back(&n);
                std::vector<GhostPath> paths = enumerateGhosts(lens, 2, true);
                paths.insert(paths.begin(), {GhostPath{}, GhostPath{{2}}, GhostPath{{3, 1, 0}}});
                for (size_t p = 0; p < paths.size(); p += p < 3 ? 1 : 7) {
                    for (bool weights : {false, true}) {
                        const std::string what = target + " " + file + " " + paths[p].label() + (weights ? " weighted" : "") +
                                                 (backOffMm > 0.0 ? " far" : "");
                        const PacketTracer tracer(BundleTracer(lens, lens.indicesAt(587.56), paths[p].reflections, weights));
                        std::vector<BundleLanding> landings(rays.size());
                        tracer.trace(rays, pointers, landings);
                        SequentialPath path;
                        path.reflections = paths[p].reflections;
                        TraceOptions options;
                        options.fresnelWeights = weights;
                        for (size_t i = 0; i < rays.size(); ++i) {
                            const TraceResult r = tracePath(lens, indices[i], rays[i], path, options);
                            ASSERT_EQ(landings[i].status, r.status) << what << " ray " << i;
                            ASSERT_EQ(landings[i].surface, r.surface) << what << " ray " << i;
                            ASSERT_EQ(landings[i].throughput, r.throughput) << what << " ray " << i;
                            seen.add(r.status);
                            if (!r.ok()) continue;
                            ASSERT_EQ(landings[i].sensorMm.x, r.ray.originMm.x) << what << " ray " << i;
                            ASSERT_EQ(landings[i].sensorMm.y, r.ray.originMm.y) << what << " ray " << i;
                        }
                    }
                }
            }
        }
        EXPECT_GT(seen[TraceStatus::Ok], 1000) << target;
        for (TraceStatus s : {TraceStatus::Missed, TraceStatus::Vignetted, TraceStatus::BlockedByIris,
                              TraceStatus::TotalInternalReflection, TraceStatus::WrongExit})
            EXPECT_GT(seen[s], 0) << target << " " << toString(s);
    });
}

// Rays at their own wavelengths that are not finite, far outside the lens or on an aperture's
// edge end as tracePath ends them, and nothing non-finite reaches a landing that is ok.
TEST(PacketTracer, NonFiniteRaysAtTheirOwnWavelengthsEqualTracePath) {
    const LensSystem lens = test::loadLens("lenses/wide-angle-28mm.lens");
    const PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(3.0, -2.0));
    const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
    const double edge = lens.surface(0).semiApertureMm;
    std::vector<Ray> rays;
    for (const glm::dvec2& p : std::vector<glm::dvec2>{{0.0, 0.0}, {edge, 0.0}, {std::nextafter(edge, 2 * edge), 0.0},
                                                       {1e154, 0.0}, {edge * 0.6, edge * 0.7}, {1e-300, -1e-300}})
        rays.push_back(grid.ray(p.x, p.y));
    const Ray good = grid.ray(0.3 * edge, -0.2 * edge);
    for (const glm::dvec3& origin : {glm::dvec3(nan, 0.0, good.originMm.z), glm::dvec3(0.0, inf, good.originMm.z),
                                     glm::dvec3(0.0, 0.0, -inf), glm::dvec3(1e300, -1e300, good.originMm.z)})
        rays.push_back({origin, good.direction});
    for (const glm::dvec3& direction : {glm::dvec3(nan, 0.0, 1.0), glm::dvec3(0.0, 0.0, 0.0), glm::dvec3(0.0, 0.0, -1.0),
                                        glm::dvec3(inf, 0.0, 1.0), glm::dvec3(0.0, 1.0, 0.0)})
        rays.push_back({good.originMm, direction});
    std::vector<SpectralIndices> indices;
    std::vector<const SpectralIndices*> pointers;
    for (size_t i = 0; i < rays.size(); ++i) indices.push_back(lens.indicesAt(400.0 + 23.0 * static_cast<double>(i)));
    for (const SpectralIndices& n : indices) pointers.push_back(&n);
    forEachTarget([&](const std::string& target) {
        for (const GhostPath& ghost : {GhostPath{}, GhostPath{{5, 2}}}) {
            const PacketTracer tracer(BundleTracer(lens, lens.indicesAt(550.0), ghost.reflections, true));
            std::vector<BundleLanding> landings(rays.size());
            tracer.trace(rays, pointers, landings);
            SequentialPath path;
            path.reflections = ghost.reflections;
            for (size_t i = 0; i < rays.size(); ++i) {
                const TraceResult r = tracePath(lens, indices[i], rays[i], path);
                ASSERT_EQ(landings[i].status, r.status) << target << " " << ghost.label() << " ray " << i;
                ASSERT_EQ(landings[i].surface, r.surface) << target << " ray " << i;
                ASSERT_EQ(landings[i].throughput, r.throughput) << target << " ray " << i;
                if (landings[i].ok()) ASSERT_TRUE(std::isfinite(landings[i].sensorMm.x + landings[i].sensorMm.y));
            }
        }
    });
}

// What BundleTracer::advance does to rays over steps first..last, one step at a time: each ray's
// state after the last step (if it went through), where and why it ended, and its margin at each
// step it entered (NaN elsewhere).
struct StepByStep {
    std::vector<BundleRay> rays;
    std::vector<PacketTracer::End> ends;
    std::vector<std::vector<double>> margins;
};

StepByStep stepByStep(const BundleTracer& bundle, std::vector<BundleRay> rays, int first, int last, bool margins) {
    StepByStep out;
    out.ends.resize(rays.size());
    out.margins.assign(rays.size(), std::vector<double>(bundle.stepCount(), std::numeric_limits<double>::quiet_NaN()));
    std::vector<size_t> owner(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) owner[i] = i;
    out.rays = rays;
    for (int step = first; step <= last && !rays.empty(); ++step) {
        std::vector<StepOutcome> outcomes(rays.size());
        bundle.advance(step, rays, outcomes, margins);
        size_t kept = 0;
        for (size_t i = 0; i < rays.size(); ++i) {
            if (margins) out.margins[owner[i]][step] = outcomes[i].margin;
            if (!outcomes[i].alive) {
                out.ends[owner[i]] = {step, outcomes[i].failure};
                continue;
            }
            out.rays[owner[i]] = rays[i];
            rays[kept] = rays[i];
            owner[kept++] = owner[i];
        }
        rays.resize(kept);
        owner.resize(kept);
    }
    return out;
}

// The pupil mesher's stepping: PacketTracer::advance over a range of steps (the rays kept in the
// lanes), and one step per call, equal to BundleTracer::advance step by step to the last bit:
// every ray's end (step and status), state and margins (NaN where it has none), with and without
// margins, on a round and a polygonal iris, with and without tables, starting at the first step
// and later, for batches that are not a multiple of the vector length.
TEST(PacketTracer, AdvanceEqualsBundleTracerStepByStep) {
    struct Case {
        const char* file;
        bool roundIris;
    };
    long compared[2] = {}, marginsSeen = 0, nanSeen = 0, ended = 0;
    for (const Case& c : {Case{"lenses/double-gauss-50mm.lens", false}, Case{"lenses/double-gauss-50mm.lens", true},
                          Case{"lenses/zoom-24-70mm.lens", false}, Case{"lenses/fisheye-16mm.lens", false}}) {
        LensPrescription prescription = loadLensFile(test::sourcePath(c.file));
        if (c.roundIris) prescription.iris.blades = 0;
        const LensSystem lens = LensSystem::build(prescription);
        const SpectralIndices indices = lens.indicesAt(530.0);
        const InterfaceTables tables(lens, indices);
        const PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(7.0, -3.0));
        const std::vector<glm::dvec2> points = test::pupilLattice(grid, 29);
        std::vector<GhostPath> paths = enumerateGhosts(lens, 2, true);
        paths.insert(paths.begin(), GhostPath{});
        forEachTarget([&](const std::string& target) {
            for (size_t p = 0; p < paths.size(); p += p == 0 ? 1 : 7) {
                for (int variant = 0; variant < 3; ++variant) {
                    const BundleTracer bundle(lens, indices, paths[p].reflections, variant > 0,
                                              variant == 2 ? &tables : nullptr);
                    const PacketTracer packets(bundle);
                    const int last = bundle.stepCount() - 1;
                    for (bool margins : {false, true}) {
                        std::vector<BundleRay> start;
                        for (const glm::dvec2& q : points) start.push_back({grid.ray(q.x, q.y), 1.0});
                        start.resize(start.size() - 3);  // not a multiple of any vector length
                        for (int first : {0, 1}) {
                            std::vector<BundleRay> rays = start;
                            if (first == 1) {  // the rays that went through step 0
                                const StepByStep zero = stepByStep(bundle, start, 0, 0, false);
                                rays.clear();
                                for (size_t i = 0; i < start.size(); ++i)
                                    if (zero.ends[i].step < 0) rays.push_back(zero.rays[i]);
                            }
                            const StepByStep want = stepByStep(bundle, rays, first, last, margins);
                            for (bool oneCall : {true, false}) {
                                const std::string what = target + " " + c.file + (c.roundIris ? " round " : " ") +
                                                         paths[p].label() + " variant " + std::to_string(variant) +
                                                         (margins ? " margins" : "") + " from " + std::to_string(first) +
                                                         (oneCall ? " in one call" : " a step per call");
                                std::vector<BundleRay> got = rays;
                                std::vector<PacketTracer::End> ends(rays.size());
                                std::vector<std::vector<double>> marginTable(
                                    rays.size(), std::vector<double>(bundle.stepCount(), std::numeric_limits<double>::quiet_NaN()));
                                std::vector<double*> rows;
                                for (auto& row : marginTable) rows.push_back(row.data());
                                if (oneCall) {
                                    packets.advance(first, last, got, ends, margins ? rows : std::vector<double*>{});
                                } else {
                                    // The going rays only, one step per call (as the mesher does while rays join).
                                    std::vector<size_t> owner;
                                    for (size_t i = 0; i < rays.size(); ++i) owner.push_back(i);
                                    for (int step = first; step <= last && !owner.empty(); ++step) {
                                        std::vector<BundleRay> batch;
                                        std::vector<double*> batchRows;
                                        for (size_t i : owner) batch.push_back(got[i]), batchRows.push_back(rows[i]);
                                        std::vector<PacketTracer::End> batchEnds(batch.size());
                                        packets.advance(step, step, batch, batchEnds, margins ? batchRows : std::vector<double*>{});
                                        std::vector<size_t> going;
                                        for (size_t k = 0; k < owner.size(); ++k) {
                                            ends[owner[k]] = batchEnds[k];
                                            if (batchEnds[k].step >= 0) continue;
                                            got[owner[k]] = batch[k];
                                            going.push_back(owner[k]);
                                        }
                                        owner = going;
                                    }
                                }
                                for (size_t i = 0; i < rays.size(); ++i) {
                                    ASSERT_EQ(ends[i].step, want.ends[i].step) << what << " ray " << i;
                                    ASSERT_EQ(ends[i].status, want.ends[i].status) << what << " ray " << i;
                                    for (int step = first; step <= last; ++step) {
                                        const double m = marginTable[i][step], w = want.margins[i][step];
                                        ASSERT_EQ(std::isnan(m), std::isnan(w)) << what << " ray " << i << " step " << step;
                                        if (!std::isnan(w)) ASSERT_EQ(m, w) << what << " ray " << i << " step " << step;
                                        marginsSeen += !std::isnan(w) && w != -1.0;
                                        nanSeen += margins && std::isnan(w) && (ends[i].step < 0 || step <= ends[i].step);
                                    }
                                    ++compared[margins];
                                    if (ends[i].step >= 0) {
                                        ++ended;
                                        continue;
                                    }
                                    ASSERT_EQ(got[i].throughput, want.rays[i].throughput) << what << " ray " << i;
                                    for (int k = 0; k < 3; ++k) {
                                        ASSERT_EQ(got[i].ray.originMm[k], want.rays[i].ray.originMm[k]) << what << " ray " << i;
                                        ASSERT_EQ(got[i].ray.direction[k], want.rays[i].ray.direction[k]) << what << " ray " << i;
                                    }
                                }
                            }
                        }
                    }
                }
            }
        });
    }
    EXPECT_GT(compared[0], 10000);
    EXPECT_GT(compared[1], 10000);
    EXPECT_GT(marginsSeen, 10000);
    EXPECT_GT(nanSeen, 100);
    EXPECT_GT(ended, 10000);
}

}  // namespace
}  // namespace flare
