#include "flare/optics/SpectralReflectance.h"

#include <algorithm>
#include <cmath>

#include <tbb/parallel_for.h>

#include "flare/optics/Coating.h"
#include "flare/optics/SequentialTracer.h"

namespace flare {

namespace {
// The exact response's zones (where the bilinear table's error would exceed its bound): grazing
// incidence, and the stretch of cosines above the critical angle.
constexpr double kExactBelowCosine = 0.03;
constexpr double kExactAboveCritical = 0.15;
}  // namespace

SpectralReflectance::SpectralReflectance(const LensSystem& lens, double fromNm, double toNm, double stepNm,
                                         int cosIntervals)
    : lens_(&lens), fromNm_(fromNm), stepNm_(stepNm),
      // The served intervals and a node beyond either end, so that every served interval has the
      // four nodes of its spline.
      nodes_(std::max(1, static_cast<int>(std::ceil((toNm - fromNm) / stepNm - 1e-9))) + 3),
      cosIntervals_(std::max(cosIntervals, 1)) {
    const int surfaces = lens.surfaceCount();
    values_.assign(static_cast<size_t>(surfaces) * 2 * nodes_ * (cosIntervals_ + 1), 0.0f);
    zones_.assign(static_cast<size_t>(surfaces) * 2 * nodes_, Node{});
    const double h = 1.0 / cosIntervals_;
    tbb::parallel_for(0, nodes_, [&](int j) {
        const double wavelengthNm = fromNm_ + stepNm_ * (j - 1);
        const SpectralIndices indices = lens.indicesAt(wavelengthNm);
        for (int k = 0; k < surfaces; ++k) {
            if (lens.surface(k).isStop) continue;
            // An ideal coating's response is cheap and may have kinks at any wavelength: exact.
            const Coating* coating = lens.coating(k);
            const bool ideal = coating && coating->ideal.has_value();
            for (int direction : {-1, 1}) {
                const double n1 = direction > 0 ? indices.n[k] : indices.n[k + 1];
                const double n2 = direction > 0 ? indices.n[k + 1] : indices.n[k];
                Node& zone = zones_[(static_cast<size_t>(k) * 2 + (direction > 0 ? 1 : 0)) * nodes_ + j];
                // Total internal reflection below cos = √(1 − (n2/n1)²), where the response has
                // a square-root edge whose curvature a linear interpolant misses for about 0.1
                // above it: exact from two intervals below it to kExactAboveCritical above.
                if (n1 > n2) {
                    const double critical = std::sqrt(1.0 - (n2 / n1) * (n2 / n1));
                    zone.exactFrom = critical - 2.0 * h;
                    zone.exactTo = critical + kExactAboveCritical;
                }
                if (ideal) {
                    zone.exactFrom = 0.0;
                    zone.exactTo = 1.0;
                    continue;
                }
                float* values = const_cast<float*>(row(k, direction, j));
                for (int i = 0; i <= cosIntervals_; ++i) {
                    const FresnelTerms r = interfaceResponse(lens, indices, k, direction, i * h);
                    values[i] = static_cast<float>(r.totalInternalReflection ? 1.0 : r.reflectance());
                }
            }
        }
    });
}

double SpectralReflectance::reflectance(int surface, int direction, double wavelengthNm, const SpectralIndices& indices,
                                        double cosThetaI) const {
    const double c = std::clamp(cosThetaI, 0.0, 1.0);
    const double x = (wavelengthNm - fromNm_) / stepNm_ + 1.0;  // in nodes
    auto exact = [&] {
        const FresnelTerms r = interfaceResponse(*lens_, indices, surface, direction, c);
        return r.totalInternalReflection ? 1.0 : r.reflectance();
    };
    if (!(wavelengthNm >= fromNm() && wavelengthNm <= toNm())) return exact();
    const int j = std::clamp(static_cast<int>(x), 1, nodes_ - 3);
    const Node& lo = node(surface, direction, j);
    const Node& hi = node(surface, direction, j + 1);
    // The critical angle moves with the wavelength: exact wherever either node is.
    if (c >= std::min(lo.exactFrom, hi.exactFrom) && c <= std::max(lo.exactTo, hi.exactTo)) return exact();
    // At grazing incidence R falls from 1 with a slope of tens per unit cosine.
    if (c < kExactBelowCosine) return exact();
    const double w = x - j;
    const double y = c * cosIntervals_;
    const int i = std::min(static_cast<int>(y), cosIntervals_ - 1);
    const double u = y - i;
    // Catmull-Rom in λ and in cos θ (in the last interval of cos θ, a parabola).
    auto spline = [](double t, double p0, double p1, double p2, double p3) {
        return p1 + 0.5 * t * (p2 - p0 + t * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + t * (3.0 * (p1 - p2) + p3 - p0)));
    };
    auto along = [&](int node) {
        const float* v = row(surface, direction, node);
        if (i == 0) return v[0] + u * (v[1] - v[0]);  // (in the grazing zone)
        if (i == cosIntervals_ - 1)  // the parabola through the last three nodes
            return v[i] + u * (v[i + 1] - v[i]) + 0.5 * u * (u - 1.0) * (v[i + 1] - 2.0 * v[i] + v[i - 1]);
        return spline(u, v[i - 1], v[i], v[i + 1], v[i + 2]);
    };
    return spline(w, along(j - 1), along(j), along(j + 1), along(j + 2));
}

}  // namespace flare
