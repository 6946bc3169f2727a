#include "flare/render/BeamShare.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <utility>

#include <tbb/parallel_for.h>

#include "flare/render/BeamStrategy.h"
#include "flare/render/BeamVariance.h"

namespace flare::renderer {

std::vector<double> waterFillRates(const std::vector<double>& strength, const std::vector<double>& floor, double budget) {
    if (strength.size() != floor.size()) throw std::invalid_argument("waterFillRates: one floor per strength");
    if (!std::isfinite(budget) || budget < 0.0) throw std::invalid_argument("waterFillRates: the budget is negative or not finite");
    for (size_t p = 0; p < strength.size(); ++p)
        if (!std::isfinite(strength[p]) || strength[p] < 0.0 || !std::isfinite(floor[p]) || floor[p] < 0.0)
            throw std::invalid_argument("waterFillRates: a strength or floor is negative or not finite");
    std::vector<double> rate = floor;
    // Σ_p max(f_p, λ s_p) grows piecewise linearly in λ, with a break at each path's λ_p = f_p / s_p
    // (below it the path sits on its floor). Walk the breaks in order: with the paths whose break
    // lies below λ free, Σ = (floors of the others) + λ (strengths of the free ones).
    std::vector<size_t> order;
    for (size_t p = 0; p < strength.size(); ++p)
        if (strength[p] > 0.0) order.push_back(p);
    if (order.empty()) return rate;
    auto lambdaOf = [&](size_t p) { return floor[p] / strength[p]; };
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return lambdaOf(a) < lambdaOf(b); });
    double floorsHeld = std::accumulate(floor.begin(), floor.end(), 0.0);
    if (floorsHeld >= budget) return rate;
    double freeStrength = 0.0;
    double lambda = 0.0;
    for (size_t i = 0; i < order.size(); ++i) {
        // Free path order[i]: its floor leaves the held sum, its strength joins the free one.
        floorsHeld -= floor[order[i]];
        freeStrength += strength[order[i]];
        lambda = (budget - floorsHeld) / freeStrength;
        // The solution lies in this segment if λ does not pass the next break.
        if (i + 1 == order.size() || lambda <= lambdaOf(order[i + 1])) break;
    }
    for (size_t p : order) rate[p] = std::max(floor[p], lambda * strength[p]);
    return rate;
}

void shareBeamsByVariance(const LensSystem& lens, const RenderOptions& options, const PhotonTracer& tracer,
                          std::vector<LightState>& lights) {
    std::vector<std::pair<int, int>> paths;  // (light, slot) of every beam-rendered path
    double budget = 0.0;
    std::vector<bool> lightsWithBeams(lights.size(), false);
    for (size_t l = 0; l < lights.size(); ++l) {
        for (int slot = 1; slot < lights[l].slots; ++slot)
            if (lights[l].strategy[slot] == PathStrategy::Beams) paths.push_back({static_cast<int>(l), slot}), lightsWithBeams[l] = true;
        if (lightsWithBeams[l]) budget += lights[l].beamsPerPass;
    }
    // One light: its budget is fixed, and within it the central probe's shares stay (on the default
    // scene the sampled probes' shares, mixed as below, cost a pass more: docs/BENCHMARKS.md).
    if (std::count(lightsWithBeams.begin(), lightsWithBeams.end(), true) < 2) return;
    std::vector<BeamPathVariance> probed(paths.size());
    tbb::parallel_for(size_t{0}, paths.size(), size_t{1}, [&](size_t p) {
        const auto [l, slot] = paths[p];
        probed[p] = probeBeamVariance(lens, options, tracer, lights[static_cast<size_t>(l)], l, slot, options.beamVarianceProbes);
    });
    std::vector<double> strength(paths.size()), floor(paths.size());
    std::vector<std::vector<double>> floors;
    for (const LightState& light : lights) floors.push_back(beamRateFloors(light, light.beamSpectralPower, light.beamsPerPass));
    for (size_t p = 0; p < paths.size(); ++p) {
        const BeamPathVariance& v = probed[p];
        strength[p] = v.costRays > 0.0 ? std::sqrt(v.variancePerBeam / v.costRays) : 0.0;
        floor[p] = floors[static_cast<size_t>(paths[p].first)][static_cast<size_t>(paths[p].second)];
    }
    const std::vector<double> sampled = waterFillRates(strength, floor, budget);
    // Each light's beams are what the sampled probes give it (they see how far the light's extent
    // moves its ghosts: the central probe cannot). Within the light, each path gets the larger of
    // the two predictors' rates, the central probe's scaled to the light's beams, then all scaled
    // back to them: at least half what either predictor asks (docs/BENCHMARKS.md, "eleventh part":
    // the sampled probes' variance counts the colour of a single-wavelength beam, which the
    // sequences' stratified wavelengths integrate far faster than 1 / n, and on the default scene
    // took beams from a large smooth ghost that needed them; the central probe missed the focused
    // ghosts of a disk light).
    std::vector<double> sampledTotal(lights.size(), 0.0), centralTotal(lights.size(), 0.0), mixedTotal(lights.size(), 0.0);
    for (size_t p = 0; p < paths.size(); ++p) {
        const size_t l = static_cast<size_t>(paths[p].first);
        sampledTotal[l] += sampled[p];
        centralTotal[l] += lights[l].beamRate[static_cast<size_t>(paths[p].second)];
    }
    std::vector<double> mixed(paths.size());
    for (size_t p = 0; p < paths.size(); ++p) {
        const size_t l = static_cast<size_t>(paths[p].first);
        const double central = lights[l].beamRate[static_cast<size_t>(paths[p].second)] * sampledTotal[l] / centralTotal[l];
        mixed[p] = std::max(sampled[p], central);
        mixedTotal[l] += mixed[p];
    }
    for (size_t p = 0; p < paths.size(); ++p) {
        const size_t l = static_cast<size_t>(paths[p].first);
        lights[l].beamRate[static_cast<size_t>(paths[p].second)] = std::max(floor[p], mixed[p] * sampledTotal[l] / mixedTotal[l]);
    }
}

}  // namespace flare::renderer
