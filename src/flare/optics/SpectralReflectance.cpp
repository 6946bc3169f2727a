#include "flare/optics/SpectralReflectance.h"

#include <algorithm>
#include <cmath>

#include <tbb/parallel_for.h>

#include "flare/optics/Coating.h"
#include "flare/optics/SequentialTracer.h"

namespace flare {

namespace {
// The exact response's zones (where the table's error would exceed its bound): grazing
// incidence, and the stretch of cosines above the critical angle (at 0.03 the spline errs by
// 3e-5 there).
constexpr double kExactBelowCosine = 0.03;
constexpr double kExactAboveCritical = 0.15;
}  // namespace

SpectralReflectance::SpectralReflectance(const LensSystem& lens, Tabulate which, double fromNm, double toNm,
                                         double stepNm, int cosIntervals)
    : lens_(&lens), fromNm_(fromNm), stepNm_(stepNm),
      // The served intervals and a node beyond either end, so that every served interval has the
      // four nodes of its spline.
      nodes_(std::max(1, static_cast<int>(std::ceil((toNm - fromNm) / stepNm - 1e-9))) + 3),
      cosIntervals_(std::max(cosIntervals, 1)) {
    const int surfaces = lens.surfaceCount();
    slots_.assign(static_cast<size_t>(surfaces) * 2, -1);
    struct Job {
        int surface, direction;
    };
    std::vector<Job> jobs;
    for (int k = 0; k < surfaces; ++k) {
        if (lens.surface(k).isStop) continue;
        const Coating* coating = lens.coating(k);
        const bool ideal = coating && coating->ideal.has_value();
        const bool multilayer = coating && coating->layers.size() >= 2;
        if (ideal || (which == Tabulate::Multilayer && !multilayer)) continue;
        for (int direction : {-1, 1}) {
            slots_[static_cast<size_t>(k) * 2 + (direction > 0 ? 1 : 0)] = static_cast<int>(jobs.size());
            jobs.push_back({k, direction});
        }
    }
    tabulated_ = static_cast<int>(jobs.size());
    interfaces_.resize(jobs.size());
    for (Interface& t : interfaces_) {
        t.values.assign(static_cast<size_t>(nodes_) * (cosIntervals_ + 1), 0.0f);
        t.exactFrom.assign(nodes_, 2.0);
        t.exactTo.assign(nodes_, -1.0);
    }
    const double h = 1.0 / cosIntervals_;
    tbb::parallel_for(0, nodes_, [&](int j) {
        const SpectralIndices indices = lens.indicesAt(fromNm_ + stepNm_ * (j - 1));
        for (size_t n = 0; n < jobs.size(); ++n) {
            const int k = jobs[n].surface, direction = jobs[n].direction;
            Interface& t = interfaces_[n];
            const double n1 = direction > 0 ? indices.n[k] : indices.n[k + 1];
            const double n2 = direction > 0 ? indices.n[k + 1] : indices.n[k];
            // Total internal reflection below cos = √(1 − (n2/n1)²), where the response has a
            // square-root edge: exact from two intervals below it to kExactAboveCritical above.
            if (n1 > n2) {
                const double critical = std::sqrt(1.0 - (n2 / n1) * (n2 / n1));
                t.exactFrom[j] = critical - 2.0 * h;
                t.exactTo[j] = critical + kExactAboveCritical;
            }
            float* values = t.values.data() + static_cast<size_t>(j) * (cosIntervals_ + 1);
            for (int i = 0; i <= cosIntervals_; ++i) {
                const FresnelTerms r = interfaceResponse(lens, indices, k, direction, i * h);
                values[i] = static_cast<float>(r.totalInternalReflection ? 1.0 : r.reflectance());
            }
        }
    });
}

double SpectralReflectance::reflectance(int surface, int direction, double wavelengthNm, const SpectralIndices& indices,
                                        double cosThetaI) const {
    const double c = std::clamp(cosThetaI, 0.0, 1.0);
    const int s = slot(surface, direction);
    auto exact = [&] {
        const FresnelTerms r = interfaceResponse(*lens_, indices, surface, direction, c);
        return r.totalInternalReflection ? 1.0 : r.reflectance();
    };
    if (s < 0 || !(wavelengthNm >= fromNm() && wavelengthNm <= toNm()) || c < kExactBelowCosine) return exact();
    const Interface& t = interfaces_[s];
    const double x = (wavelengthNm - fromNm_) / stepNm_ + 1.0;  // in nodes
    const int j = std::clamp(static_cast<int>(x), 1, nodes_ - 3);
    // The critical angle moves with the wavelength: exact wherever either neighbouring node is.
    if (c >= std::min(t.exactFrom[j], t.exactFrom[j + 1]) && c <= std::max(t.exactTo[j], t.exactTo[j + 1]))
        return exact();
    const double w = x - j;
    const double y = c * cosIntervals_;
    const int i = std::min(static_cast<int>(y), cosIntervals_ - 1);
    const double u = y - i;
    // Catmull-Rom in λ and in cos θ (in the last interval of cos θ, the parabola through its
    // last three nodes; in the first, which only a coarse table reaches outside the grazing zone,
    // a line).
    auto spline = [](double t, double p0, double p1, double p2, double p3) {
        return p1 + 0.5 * t * (p2 - p0 + t * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + t * (3.0 * (p1 - p2) + p3 - p0)));
    };
    auto along = [&](int node) {
        const float* v = t.values.data() + static_cast<size_t>(node) * (cosIntervals_ + 1);
        if (i == 0) return v[0] + u * (v[1] - v[0]);
        if (i == cosIntervals_ - 1)
            return v[i] + u * (v[i + 1] - v[i]) + 0.5 * u * (u - 1.0) * (v[i + 1] - 2.0 * v[i] + v[i - 1]);
        return spline(u, v[i - 1], v[i], v[i + 1], v[i + 2]);
    };
    return spline(w, along(j - 1), along(j), along(j + 1), along(j + 2));
}

}  // namespace flare
