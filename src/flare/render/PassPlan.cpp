#include "flare/render/PassPlan.h"

#include <algorithm>
#include <cmath>

namespace flare::renderer {

PlanSplit choosePassSplit(const std::vector<PlanTarget>& targets, double beamCost, double photonCost,
                          double minScale, double maxScale) {
    const PlanSplit nominal;
    if (!(beamCost > 0.0) || !(photonCost > 0.0) || !std::isfinite(beamCost) || !std::isfinite(photonCost))
        return nominal;
    bool measured = false;
    for (const PlanTarget& t : targets) {
        if (!(t.beamVariance >= 0.0) || !(t.photonVariance >= 0.0) || !(t.normTimesTarget2 > 0.0) ||
            !std::isfinite(t.beamVariance + t.photonVariance + t.accumulated + t.normTimesTarget2))
            return nominal;
        measured = measured || t.beamVariance + t.photonVariance > 0.0;
    }
    if (!measured) return nominal;
    // The split as f, the beams' share of the pass's cost: β = f·C / C_b, π = (1 − f)·C / C_p.
    const double cost = beamCost + photonCost;
    const double lo = std::max(minScale * beamCost / cost, 1.0 - maxScale * photonCost / cost);
    const double hi = std::min(maxScale * beamCost / cost, 1.0 - minScale * photonCost / cost);
    if (!(lo <= hi)) return nominal;
    auto split = [&](double f) { return PlanSplit{f * cost / beamCost, (1.0 - f) * cost / photonCost}; };
    auto worst = [&](double f) {
        const PlanSplit s = split(f);
        double largest = 0.0;
        for (const PlanTarget& t : targets)
            largest = std::max(largest, (t.accumulated + t.beamVariance / s.beamScale + t.photonVariance / s.photonScale) /
                                            t.normTimesTarget2);
        return largest;
    };
    // Golden-section search of a convex function on [lo, hi]: a fixed number of steps (the
    // interval shrinks by 0.618 each: 10⁻¹⁷ of it after 80), so the answer is a function of the
    // inputs alone.
    const double ratio = (std::sqrt(5.0) - 1.0) / 2.0;
    double a = lo, b = hi;
    double x1 = b - ratio * (b - a), x2 = a + ratio * (b - a);
    double f1 = worst(x1), f2 = worst(x2);
    for (int step = 0; step < 80; ++step) {
        if (f1 <= f2) {
            b = x2, x2 = x1, f2 = f1;
            x1 = b - ratio * (b - a), f1 = worst(x1);
        } else {
            a = x1, x1 = x2, f1 = f2;
            x2 = a + ratio * (b - a), f2 = worst(x2);
        }
    }
    // (The ends too: the optimum may be a bound, which the interior points only approach.)
    double best = 0.5 * (a + b), bestValue = worst(best);
    for (double f : {lo, hi})
        if (worst(f) < bestValue) best = f, bestValue = worst(f);
    return split(best);
}

}  // namespace flare::renderer
