// Shared helpers for the unit tests: paths into the source tree, lens loading, running the CLI,
// and critical values of the χ² and normal distributions for statistical tests.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "flare/optics/LensFile.h"
#include "flare/optics/LensSystem.h"
#include "flare/optics/PupilGrid.h"

namespace flare::test {

// The scratch root of this test process, <tmp>/flare_tests-<pid>: ctest runs tests in parallel,
// one process each, and tests that share a helper writing fixed file names must not overwrite
// each other's files. A global test environment (ScratchCleanup.cpp) removes it when the process's
// tests end, so a run leaves the temporary directory as it found it.
inline std::filesystem::path scratchRoot() {
    return std::filesystem::temp_directory_path() / ("flare_tests-" + std::to_string(::getpid()));
}

// A scratch directory `name` under this process's scratch root, created if needed.
inline std::filesystem::path processTempDir(const std::string& name) {
    const auto dir = scratchRoot() / name;
    std::filesystem::create_directories(dir);
    return dir;
}

// A fresh, empty folder `name` under the process's scratch folder `area` (removed with it).
inline std::filesystem::path freshDir(const std::string& area, const std::string& name) {
    const std::filesystem::path dir = processTempDir(area) / name;
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return dir;
}

// A small, quick scene written into `dir` (the default sun through the double Gauss at 96 × 64
// pixels, three preview wavelengths, no diffraction); returns its path.
inline std::string writeTinyScene(const std::filesystem::path& dir) {
    const std::string path = (dir / "tiny.json").string();
    std::ofstream(path) << R"({"lens": "double-gauss-50mm", "f_number": 4,
        "sensor": {"resolution": [96, 64]},
        "lights": [{"type": "directional", "field_deg": [11, 8], "angular_diameter_deg": 0.53}],
        "render": {"preview_wavelengths": 3, "diffraction": false}})";
    return path;
}

inline std::string sourcePath(const std::string& relative) {
    return std::string(FLARE_SOURCE_DIR) + "/" + relative;
}

inline LensSystem loadLens(const std::string& relative, const LensState& state = {}) {
    return LensSystem::build(loadLensFile(sourcePath(relative)), state);
}

// Runs the built `flare` binary with `arguments` (stdout and stderr together); the exit code is −1
// if it did not exit normally.
struct CliRun {
    int exitCode;
    std::string out;
};
inline CliRun runCli(const std::string& arguments) {
    const std::string command = std::string(FLARE_CLI_PATH) + " " + arguments + " 2>&1";
    FILE* pipe = popen(command.c_str(), "r");
    if (!pipe) return {-1, "popen failed"};
    std::string out;
    std::array<char, 4096> buffer{};
    while (size_t n = fread(buffer.data(), 1, buffer.size(), pipe)) out.append(buffer.data(), n);
    const int status = pclose(pipe);
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

// Every lens shipped in lenses/.
// An n × n lattice of pupil points over the whole grid (cell centres), so that traced rays meet
// every kind of failure; an odd n leaves a partial SIMD vector at the end of a batch.
inline std::vector<glm::dvec2> pupilLattice(const PupilGrid& grid, int n) {
    std::vector<glm::dvec2> points;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
            points.push_back({-grid.halfSizeMm + (i + 0.5) * 2.0 * grid.halfSizeMm / n,
                              -grid.halfSizeMm + (j + 0.5) * 2.0 * grid.halfSizeMm / n});
    return points;
}

inline const char* const kShippedLenses[] = {
    "lenses/double-gauss-50mm.lens", "lenses/wide-angle-28mm.lens", "lenses/telephoto-180mm.lens",
    "lenses/fisheye-16mm.lens",      "lenses/zoom-24-70mm.lens",
};

// ---- Statistics for sampler tests ----------------------------------------------------------------
// Regularized incomplete gamma functions P(s, x) and Q(s, x) = 1 − P(s, x): the series for
// x < s + 1 and the continued fraction (modified Lentz) otherwise, as in Numerical Recipes §6.2;
// relative accuracy ~1e-14.
inline double regularizedGammaQ(double s, double x) {
    if (!(x > 0.0)) return 1.0;
    const double logPrefactor = -x + s * std::log(x) - std::lgamma(s);
    const double eps = 1e-16, tiny = 1e-300;
    if (x < s + 1.0) {
        double term = 1.0 / s, sum = term;
        for (int n = 1; n < 100000 && std::abs(term) > std::abs(sum) * eps; ++n) {
            term *= x / (s + n);
            sum += term;
        }
        return 1.0 - sum * std::exp(logPrefactor);
    }
    double b = x + 1.0 - s, c = 1.0 / tiny, d = 1.0 / b, h = d;
    for (int i = 1; i < 100000; ++i) {
        const double an = -i * (i - s);
        b += 2.0;
        d = an * d + b;
        if (std::abs(d) < tiny) d = tiny;
        c = b + an / c;
        if (std::abs(c) < tiny) c = tiny;
        d = 1.0 / d;
        const double delta = d * c;
        h *= delta;
        if (std::abs(delta - 1.0) < eps) break;
    }
    return std::exp(logPrefactor) * h;
}

// P(χ²_k > x).
inline double chiSquaredSurvival(int k, double x) { return regularizedGammaQ(0.5 * k, 0.5 * x); }

// x with P(χ²_k > x) = alpha (upper critical value), by bisection on the monotone survival function.
inline double chiSquaredUpperCritical(int k, double alpha) {
    double lo = 0.0, hi = k + 10.0;
    while (chiSquaredSurvival(k, hi) > alpha) hi *= 2.0;
    for (int i = 0; i < 200; ++i) {
        const double mid = 0.5 * (lo + hi);
        (chiSquaredSurvival(k, mid) > alpha ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

// x with P(χ²_k < x) = alpha (lower critical value).
inline double chiSquaredLowerCritical(int k, double alpha) { return chiSquaredUpperCritical(k, 1.0 - alpha); }

// z with P(|Z| > z) = alpha for a standard normal Z, by bisection on erfc.
inline double normalTwoSidedCritical(double alpha) {
    double lo = 0.0, hi = 40.0;
    for (int i = 0; i < 200; ++i) {
        const double mid = 0.5 * (lo + hi);
        (std::erfc(mid / std::sqrt(2.0)) > alpha ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

// Pearson's statistic Σ (observed − expected)² / expected.
inline double pearsonChiSquared(const std::vector<long>& observed, const std::vector<double>& expected) {
    double chi2 = 0.0;
    for (size_t i = 0; i < observed.size(); ++i) {
        const double d = static_cast<double>(observed[i]) - expected[i];
        chi2 += d * d / expected[i];
    }
    return chi2;
}

}  // namespace flare::test
