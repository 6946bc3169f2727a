// Numerical-stability stress over random valid lenses (tests/stress/Stress.h): no NaN or infinity
// in sequential traces, photon histories, render layers or tallies; forward-then-reversed rays
// return to their start; rays beyond the critical angle are totally reflected; every photon ends
// in exactly one fate and none is lost. Compiled twice: into flare_tests (a short run, seconds,
// in the default suite) and, with FLARE_STRESS_FULL, into flare_stress (ctest label `stress`,
// minutes). Environment overrides: FLARE_STRESS_SEED, FLARE_STRESS_LENSES, FLARE_STRESS_OUT (where
// reproducers of failures are written; replay one with `flare_stress --replay FILE`).
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>

#include <gtest/gtest.h>

#include "Stress.h"

#ifndef FLARE_STRESS_FULL
#define FLARE_STRESS_FULL 0
#endif

namespace flare::stress {
namespace {

StressConfig config() {
    StressConfig c;
    if (FLARE_STRESS_FULL) {
        c.lenses = 4000;
        c.raysPerLens = 512;
        c.photonsPerLens = 2000;
        c.renderEvery = 10;
    } else {
        c.lenses = 40;
        c.raysPerLens = 64;
        c.photonsPerLens = 200;
        c.renderEvery = 16;
        c.maxLights = 1;
    }
    if (const char* seed = std::getenv("FLARE_STRESS_SEED")) c.seed = std::strtoull(seed, nullptr, 10);
    if (const char* lenses = std::getenv("FLARE_STRESS_LENSES")) c.lenses = std::atoi(lenses);
    const char* out = std::getenv("FLARE_STRESS_OUT");
    c.reproducerDir = out ? out : (std::filesystem::temp_directory_path() / "flare_stress").string();
    c.findingReproducers = FLARE_STRESS_FULL || out != nullptr;
    return c;
}

void expectClean(const StressReport& report, const char* what) {
    std::cout << "---- " << what << " ----\n" << report.summary();
    EXPECT_TRUE(report.failures.empty()) << report.summary();
    // The generator must keep producing mostly valid lenses, or the run tests little.
    EXPECT_GE(report.lensesBuilt, report.lensesTried * 3 / 4) << report.summary();
}

TEST(Stress, SequentialTracesStayFiniteAndReversible) {
    const StressReport report = runSequentialStress(config());
    expectClean(report, "sequential tracing");
    EXPECT_GT(report.reversalsCompared, 0);
    EXPECT_GT(report.criticalTir, 0);
}

TEST(Stress, PhotonTracerEndsEveryPhotonInOneFate) {
    const StressReport report = runPhotonStress(config());
    expectClean(report, "photon tracing");
    long total = 0;
    for (const auto& [fate, count] : report.fates) total += count;
    EXPECT_EQ(total, report.photons);
}

TEST(Stress, RenderLayersAndTalliesStayFinite) {
    const StressReport report = runRenderStress(config());
    expectClean(report, "renders");
    EXPECT_GT(report.renders, 0);
}

}  // namespace
}  // namespace flare::stress
