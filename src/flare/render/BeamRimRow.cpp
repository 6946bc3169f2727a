// BeamRimRow.h's row, compiled once per instruction set: foreach_target.h includes this file again
// for each target Highway builds (HWY_TARGET_INCLUDE), each time with that target's HWY_NAMESPACE;
// the dispatch table and the plain functions that use it are defined once, at the end (HWY_ONCE).
#include "flare/render/BeamRimRow.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include <glm/geometric.hpp>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "flare/render/BeamRimRow.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "flare/core/FresnelIntegrals.h"

HWY_BEFORE_NAMESPACE();
namespace flare {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// The scalar loop's per-pixel arithmetic (addRimRowScalar below), lane by lane: glm::dot as
// x·x' + y·y', the cross product as a.x·b.y − a.y·b.x, std::clamp as its two comparisons.
// A segment's rows in one call: the segment's and the row's constants are set in registers once
// (about thirty broadcasts, as much as a short row's own work).
void AddRimRows(const BeamRim::Segment& s, const detail::RimRowSpan* spans, size_t count, const glm::dvec3& scale) {
    const hn::ScalableTag<double> d;
    const hn::RebindToSigned<decltype(d)> di;
    constexpr size_t kMaxLanes = HWY_MAX_BYTES / sizeof(double);
    const int lanes = static_cast<int>(hn::Lanes(d));
    using V = hn::Vec<decltype(d)>;
    const FresnelEdgeExcess& excess = FresnelEdgeExcess::instance();
    const double* table = excess.table();
    const V zero = hn::Zero(d), one = hn::Set(d, 1.0);
    const V kReach = hn::Set(d, FresnelEdgeExcess::kReach);
    const V samplesPerUnit = hn::Set(d, static_cast<double>(FresnelEdgeExcess::samplesPerUnit()));
    const V offset = hn::Set(d, excess.offset());
    const V ax = hn::Set(d, s.a.x), bx = hn::Set(d, s.b.x), length = hn::Set(d, s.length);
    const V inwardX = hn::Set(d, s.inward.x), inwardY = hn::Set(d, s.inward.y);
    const V alongX = hn::Set(d, s.along.x), alongY = hn::Set(d, s.along.y);
    const V bisectorAX = hn::Set(d, s.bisectorA.x), bisectorAY = hn::Set(d, s.bisectorA.y);
    const V bisectorBX = hn::Set(d, s.bisectorB.x), bisectorBY = hn::Set(d, s.bisectorB.y);
    const V sideA = hn::Set(d, s.sideA), sideB = hn::Set(d, s.sideB);
    const V irradianceA = hn::Set(d, s.irradianceA), irradianceB = hn::Set(d, s.irradianceB);
    const V scaleX = hn::Set(d, scale.x), scaleY = hn::Set(d, scale.y), scaleZ = hn::Set(d, scale.z);
    const V half = hn::Set(d, 0.5);
    const V laneOffsets = hn::Iota(d, 0.0);
    HWY_ALIGN double values[kMaxLanes];
    HWY_ALIGN double keep[kMaxLanes];
    for (size_t n = 0; n < count; ++n) {
        const detail::RimRowSpan& span = spans[n];
        const V reach = hn::Set(d, span.reach), inverseScale = hn::Set(d, span.inverseScale);
        const V jitterX = hn::Set(d, span.jitterX);
        // The row's y terms are the same in every lane.
        const V fromAY = hn::Set(d, span.y - s.a.y), fromBY = hn::Set(d, span.y - s.b.y);
        const V acrossY = hn::Mul(fromAY, inwardY), alongYTerm = hn::Mul(fromAY, alongY);
        const V crossAY = hn::Mul(bisectorAX, fromAY), crossBY = hn::Mul(bisectorBX, fromBY);
        for (int column = span.first; column <= span.last; column += lanes) {
            const int inSpan = std::min(lanes, span.last - column + 1);
            // column + 0.5 + jitter, column exact as a double.
            const V px = hn::Add(hn::Add(hn::Add(hn::Set(d, static_cast<double>(column)), laneOffsets), half), jitterX);
            const V fromAX = hn::Sub(px, ax);
            const V across = hn::Add(hn::Mul(fromAX, inwardX), acrossY);
            auto kept = hn::And(hn::FirstN(d, static_cast<size_t>(inSpan)), hn::Lt(hn::Abs(across), reach));
            // On the wedge's side of either bisector: not (cross·side < 0) and not (cross·side ≤ 0).
            const V crossA = hn::Sub(crossAY, hn::Mul(bisectorAY, fromAX));
            const V crossB = hn::Sub(crossBY, hn::Mul(bisectorBY, hn::Sub(px, bx)));
            kept = hn::AndNot(hn::Lt(hn::Mul(crossA, sideA), zero), kept);
            kept = hn::AndNot(hn::Le(hn::Mul(crossB, sideB), zero), kept);
            // (Most of a row's lanes lie in the wedge's bounding box but outside the wedge.)
            if (hn::AllFalse(d, kept)) continue;
            const V alongPx = hn::Add(hn::Mul(fromAX, alongX), alongYTerm);
            const V ratio = hn::Div(alongPx, length);
            const V t = hn::IfThenElse(hn::Lt(ratio, zero), zero, hn::IfThenElse(hn::Lt(one, ratio), one, ratio));
            const V beyond = hn::Sub(alongPx, hn::Mul(t, length));
            const V u = hn::Mul(hn::CopySign(hn::Sqrt(hn::Add(hn::Mul(across, across), hn::Mul(beyond, beyond))), across),
                                inverseScale);
            kept = hn::And(kept, hn::Lt(hn::Abs(u), kReach));
            // FresnelEdgeExcess::operator(): lanes left out read the table's first entries.
            const V x = hn::IfThenElseZero(kept, hn::Mul(hn::Add(u, kReach), samplesPerUnit));
            const auto index = hn::ConvertTo(di, x);  // truncation, as static_cast<int> (x ≥ 0)
            const V fraction = hn::Sub(x, hn::ConvertTo(d, index));
            const V below = hn::GatherIndex(d, table, index);
            const V above = hn::GatherIndex(d, table + 1, index);
            const V step = hn::IfThenElseZero(hn::Gt(u, zero), one);
            const V ringing =
                hn::Add(hn::Sub(hn::Add(hn::Mul(hn::Sub(one, fraction), below), hn::Mul(fraction, above)), step), offset);
            const V value = hn::Mul(hn::Add(hn::Mul(hn::Sub(one, t), irradianceA), hn::Mul(t, irradianceB)), ringing);
            double* q = span.row + static_cast<std::ptrdiff_t>(column - span.first) * 3;
            if (inSpan == lanes) {
                // A whole register of pixels: their x, y and z apart, each added where kept and left
                // as it is elsewhere (a skipped pixel keeps even a −0).
                V px3, py3, pz3;
                hn::LoadInterleaved3(d, q, px3, py3, pz3);
                px3 = hn::IfThenElse(kept, hn::Add(px3, hn::Mul(value, scaleX)), px3);
                py3 = hn::IfThenElse(kept, hn::Add(py3, hn::Mul(value, scaleY)), py3);
                pz3 = hn::IfThenElse(kept, hn::Add(pz3, hn::Mul(value, scaleZ)), pz3);
                hn::StoreInterleaved3(px3, py3, pz3, d, q);
                continue;
            }
            hn::Store(value, d, values);
            hn::Store(hn::IfThenElseZero(kept, one), d, keep);
            for (int k = 0; k < inSpan; ++k, q += 3) {
                if (keep[k] == 0.0) continue;  // untouched, as the scalar loop leaves it
                q[0] += values[k] * scale.x;
                q[1] += values[k] * scale.y;
                q[2] += values[k] * scale.z;
            }
        }
    }
}

const char* RimRowTargetName() { return hwy::TargetName(HWY_TARGET); }

}  // namespace HWY_NAMESPACE
}  // namespace flare
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace flare {

HWY_EXPORT(AddRimRows);
HWY_EXPORT(RimRowTargetName);

namespace detail {

void addRimRows(const BeamRim::Segment& s, const RimRowSpan* spans, size_t count, const glm::dvec3& scale) {
    HWY_DYNAMIC_DISPATCH(AddRimRows)(s, spans, count, scale);
}

void addRimRow(const BeamRim::Segment& s, const RimRowSpan& span, const glm::dvec3& scale, double* row) {
    RimRowSpan one = span;
    one.row = row;
    addRimRows(s, &one, 1, scale);
}

void addRimRowScalar(const BeamRim::Segment& s, const RimRowSpan& span, const glm::dvec3& scale, double* row) {
    const FresnelEdgeExcess& excess = FresnelEdgeExcess::instance();
    auto cross = [](const glm::dvec2& a, const glm::dvec2& b) { return a.x * b.y - a.y * b.x; };
    double* q = row;
    for (int column = span.first; column <= span.last; ++column, q += 3) {
        const glm::dvec2 p(column + 0.5 + span.jitterX, span.y);
        const glm::dvec2 fromA = p - s.a;
        const double across = glm::dot(fromA, s.inward);
        if (!(std::abs(across) < span.reach)) continue;
        if (cross(s.bisectorA, fromA) * s.sideA < 0.0 || cross(s.bisectorB, p - s.b) * s.sideB <= 0.0) continue;
        // The distance to the segment (to its end beyond it, in the fan of a corner: the rim's
        // mesh vertices carry small placement errors, and the distance to a line through two
        // close ones would swing with them), signed by the side.
        const double alongPx = glm::dot(fromA, s.along);
        const double t = std::clamp(alongPx / s.length, 0.0, 1.0);
        const double beyond = alongPx - t * s.length;
        const double u = std::copysign(std::sqrt(across * across + beyond * beyond), across) * span.inverseScale;
        if (!(std::abs(u) < FresnelEdgeExcess::kReach)) continue;
        const double value = ((1.0 - t) * s.irradianceA + t * s.irradianceB) * excess(u);
        q[0] += value * scale.x;
        q[1] += value * scale.y;
        q[2] += value * scale.z;
    }
}

const char* rimRowTargetName() { return HWY_DYNAMIC_DISPATCH(RimRowTargetName)(); }

}  // namespace detail
}  // namespace flare
#endif  // HWY_ONCE
