// Time against error for the final render: the guided hybrid against naive photon tracing (the
// seed thesis's method) on the ghost layer, measured in one run on one machine.
//
// A reference comes from two independent guided renders (different seeds) averaged; their
// difference estimates the reference's own error, which is removed in quadrature from every
// measured error (E_true² ≈ E_measured² − E_ref²). Each method then runs pass after pass; after
// geometrically spaced passes the relative L2 error of its ghost layer against the reference is
// recorded with the wall time so far (including the ghost analysis, which both modes run).
// A method that does not reach the target within its time budget is extrapolated from its last
// point with the Monte Carlo law error ∝ time^(−1/2), and the output says so.
//
//   flare_render_error [--quick] [--csv FILE] [--field X,Y] [--resolution W,H]
//                      [--reference-photons N] [--naive-seconds S] [--target E]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "flare/ImageCompare.h"
#include "flare/Render.h"
#include "flare/Spectrum.h"

using namespace flare;

namespace {

double seconds(std::chrono::steady_clock::time_point since) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

ImageLayer toRgb(const std::vector<float>& xyz, int w, int h) {
    ImageLayer layer{"", w, h, std::vector<float>(xyz.size())};
    for (size_t i = 0; i < xyz.size(); i += 3) {
        const glm::dvec3 rgb = xyzToLinearSrgb({xyz[i], xyz[i + 1], xyz[i + 2]});
        for (int c = 0; c < 3; ++c) layer.rgb[i + c] = static_cast<float>(rgb[c]);
    }
    return layer;
}

RenderOptions optionsFor(const Scene& scene, const LensSystem& lens, RenderOptions::Mode mode, std::uint64_t seed) {
    RenderOptions o;
    o.mode = mode;
    o.seed = seed;
    o.analysis.order = scene.render.ghostOrder;
    o.film.widthPx = scene.sensor.widthPx;
    o.film.heightPx = scene.sensor.heightPx;
    o.film.widthMm = lens.sensor().widthMm;
    o.film.heightMm = lens.sensor().heightMm;
    return o;
}

struct Point {
    double seconds;
    std::int64_t photons;
    double measured, corrected;
};

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"time against error: guided vs naive photon tracing on the ghost layer"};
    bool quick = false;
    std::string csv, lens = "double-gauss-50mm";
    std::vector<double> field{15.0, 0.0};
    std::vector<int> resolution{192, 128};
    long long referencePhotons = 0;
    double naiveSeconds = 0.0, target = 0.05;
    app.add_flag("--quick", quick, "smaller reference and budgets (about a minute)");
    app.add_option("--csv", csv, "write every measured point to this CSV file");
    app.add_option("--lens", lens, "lens (shipped name or file)");
    app.add_option("--field", field, "sun position, field angles in degrees")->expected(2);
    app.add_option("--resolution", resolution, "image size in pixels")->expected(2);
    app.add_option("--reference-photons", referencePhotons, "photons per reference half");
    app.add_option("--naive-seconds", naiveSeconds, "time budget of the naive method");
    app.add_option("--target", target, "relative L2 error to reach");
    CLI11_PARSE(app, argc, argv);
    if (referencePhotons <= 0) referencePhotons = quick ? 4'000'000 : 24'000'000;
    if (naiveSeconds <= 0.0) naiveSeconds = quick ? 20.0 : 120.0;

    const std::string sceneText = R"({ "lens": ")" + lens + R"(", "f_number": 4.0,
  "sensor": { "resolution": [)" + std::to_string(resolution[0]) + "," + std::to_string(resolution[1]) + R"(] },
  "lights": [ { "type": "directional", "name": "sun", "field_deg": [)" +
                                  std::to_string(field[0]) + "," + std::to_string(field[1]) + R"(],
                "angular_diameter_deg": 0.53, "spectrum": { "blackbody_k": 5778 } } ] })";
    const Scene scene = parseSceneText(sceneText, "benchmark scene", "");
    const LensSystem system = buildSceneLens(scene);
    const int w = scene.sensor.widthPx, h = scene.sensor.heightPx;
    std::printf("# lens %s, sun at field (%g, %g) deg, %dx%d px, ghost layer, target rel. L2 %.3g\n",
                system.name().c_str(), field[0], field[1], w, h, target);

    // Reference: two guided halves.
    std::vector<ImageLayer> halves;
    for (std::uint64_t seed : {1001u, 1002u}) {
        const auto start = std::chrono::steady_clock::now();
        Renderer r(system, scene, optionsFor(scene, system, RenderOptions::Mode::Guided, seed));
        while (r.statistics().photons < referencePhotons) r.runPass();
        halves.push_back(toRgb(r.layerXyz(kLayerGhost), w, h));
        std::printf("# reference half (seed %llu): %lld photons, %.1f s\n", static_cast<unsigned long long>(seed),
                    static_cast<long long>(r.statistics().photons), seconds(start));
    }
    ImageLayer reference = halves[0];
    for (size_t i = 0; i < reference.rgb.size(); ++i) reference.rgb[i] = 0.5f * (halves[0].rgb[i] + halves[1].rgb[i]);
    // ‖A − B‖ ≈ √2 E_half ‖ref‖ and the mean of the halves has E_half / √2 = ‖A − B‖ / (2 ‖ref‖).
    const double referenceError = 0.5 * compareImages(halves[0], halves[1]).relL2.value_or(0.0);
    std::printf("# reference error (from the halves' difference): %.4f\n", referenceError);

    std::FILE* out = csv.empty() ? nullptr : std::fopen(csv.c_str(), "w");
    if (out) std::fprintf(out, "method,seconds,photons,rel_l2_measured,rel_l2\n");
    double timeToTarget[2] = {0.0, 0.0};
    bool extrapolated[2] = {false, false};
    const char* names[2] = {"guided", "naive"};
    for (int m = 0; m < 2; ++m) {
        const auto mode = m == 0 ? RenderOptions::Mode::Guided : RenderOptions::Mode::Naive;
        const double budget = m == 0 ? 4.0 * naiveSeconds : naiveSeconds;
        const auto start = std::chrono::steady_clock::now();
        Renderer r(system, scene, optionsFor(scene, system, mode, 1));
        std::vector<Point> points;
        int nextMeasure = 1;
        while (true) {
            r.runPass();
            if (r.statistics().passes < nextMeasure) continue;
            nextMeasure = std::max(nextMeasure + 1, static_cast<int>(nextMeasure * 1.4));
            const double t = seconds(start);
            const std::optional<double> e = compareImages(toRgb(r.layerXyz(kLayerGhost), w, h), reference).relL2;
            const double measured = e.value_or(1.0);
            const double corrected = std::sqrt(std::max(0.0, measured * measured - referenceError * referenceError));
            points.push_back({t, r.statistics().photons, measured, corrected});
            std::printf("%s,%.3f,%lld,%.5f,%.5f\n", names[m], t, static_cast<long long>(r.statistics().photons), measured,
                        corrected);
            if (out) std::fprintf(out, "%s,%.4f,%lld,%.6f,%.6f\n", names[m], t, static_cast<long long>(r.statistics().photons),
                                  measured, corrected);
            std::fflush(stdout);
            if (corrected <= target || t > budget) break;
        }
        const Point& last = points.back();
        if (last.corrected <= target) {
            // Interpolate the crossing on log–log axes between the last two points.
            if (points.size() >= 2) {
                const Point& prev = points[points.size() - 2];
                const double s = std::log(last.corrected / prev.corrected) / std::log(last.seconds / prev.seconds);
                timeToTarget[m] = prev.seconds * std::exp(std::log(target / prev.corrected) / s);
            } else {
                timeToTarget[m] = last.seconds;
            }
        } else {
            timeToTarget[m] = last.seconds * std::pow(last.corrected / target, 2.0);
            extrapolated[m] = true;
        }
    }
    if (out) std::fclose(out);
    std::printf("# time to %.3g rel. L2 on the ghost layer: guided %.3g s, naive %.3g s%s; speed-up %.0fx\n", target,
                timeToTarget[0], timeToTarget[1], extrapolated[1] ? " (extrapolated as t^-1/2 from its last point)" : "",
                timeToTarget[1] / timeToTarget[0]);
    return 0;
}
