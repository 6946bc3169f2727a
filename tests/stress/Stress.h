// Numerical-stability stress runs over random valid lenses (RandomLens.h): sequential tracing,
// non-sequential photon tracing and the final renderer, fed with the rays that break naive code
// (exactly on the axis, grazing, at element edges, at the critical angle). Each run returns counts
// and a list of failures, every failure with what is needed to reproduce it (the lens text, the
// ray in hexadecimal floating point, the wavelength and the random stream).
//
// The same runners serve the short version in the default suite (tests/stress/test_stress.cpp,
// seconds) and the long one labelled `stress` (tests/stress/stress_main.cpp, minutes).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace flare::stress {

struct StressConfig {
    std::uint64_t seed = 1;
    int lenses = 40;          // lenses drawn (valid or not)
    int raysPerLens = 64;     // sequential rays per lens (every kind in turn)
    int photonsPerLens = 256; // photon-tracer photons per lens
    int renderEvery = 8;      // a tiny render for every n-th valid lens (0: none)
    int renderPasses = 2;
    int maxLights = 3;        // lights per rendered scene: 1 … maxLights
    std::string reproducerDir;  // where failures are written as replayable files ("" = nowhere)
    // Also write the findings that are not failures (photons stopped at the event limit, ...):
    // the long run keeps them to study; the default suite writes nothing it need not.
    bool findingReproducers = false;
    // Real lenses instead of random ones (e.g. the lens library): lens i is lensFiles[i % size],
    // built at its first zoom position.
    std::vector<std::string> lensFiles;
};

// Named tolerances (see docs/robustness.md for their derivation).
// Round trip forward → reversed: error ≤ kReversalSafety · m · ε · (S + κ), where m is the number
// of surface events, ε the double epsilon, S the largest coordinate on the path and κ the
// amplification of a perturbation of the reversed ray, measured by finite differences.
inline constexpr double kReversalSafety = 64.0;
// Beyond the critical angle by more than this (rad), a ray must be totally reflected; below it by
// more than this, it must refract.
inline constexpr double kCriticalAngleMarginRad = 1e-9;
// Photons the tracer may lose (fate Lost) per photon traced: none were seen; one in 10⁵ is allowed
// so that a single rounding accident on a random lens does not fail the suite, and each is
// reported with a reproducer.
inline constexpr double kMaxLostFraction = 1e-5;

struct StressReport {
    long lensesTried = 0, lensesRejected = 0, lensesBuilt = 0;
    std::map<std::string, long> rejections;  // first words of the builder's message → count
    // Sequential tracing.
    long rays = 0, raysOk = 0;
    std::map<std::string, long> statuses;
    long reversalsCompared = 0, reversalsNotReturned = 0, reversalsIllConditioned = 0, reversalsNotSequential = 0;
    double worstReversalRatio = 0.0;  // max error / (m ε (S + κ)), to compare with kReversalSafety
    long criticalRays = 0, criticalTir = 0;
    // Photon tracing.
    long photons = 0, arrivals = 0;
    std::map<std::string, long> fates;
    std::map<std::string, long> findings;  // Lost and EventLimit photons by kind of ray and lens
    // Renders.
    long renders = 0, renderPhotons = 0;
    std::vector<std::string> failures;  // each names the check and a reproducer

    std::string summary() const;
};

StressReport runSequentialStress(const StressConfig& config);
StressReport runPhotonStress(const StressConfig& config);
StressReport runRenderStress(const StressConfig& config);

// Re-runs one failure written to reproducerDir; returns what it found ("" if all is well now).
std::string replay(const std::string& path);

}  // namespace flare::stress
