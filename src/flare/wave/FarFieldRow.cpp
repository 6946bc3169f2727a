// FarFieldRow.h's row, compiled once per instruction set: foreach_target.h includes this file again
// for each target Highway builds (HWY_TARGET_INCLUDE), each time with that target's HWY_NAMESPACE;
// the dispatch table and the plain functions that use it are defined once, at the end (HWY_ONCE).
#include "flare/wave/FarFieldRow.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "flare/wave/FarFieldRow.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace flare {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// smoothstep(t) = t²(3 − 2t) of t clamped to [0, 1], as Starburst.cpp's: std::clamp's two
// comparisons (a −0 kept as it is: its square is +0 either way).
template <class V>
HWY_INLINE V Smoothstep(V t) {
    const hn::DFromV<V> d;
    const V zero = hn::Zero(d), one = hn::Set(d, 1.0);
    t = hn::IfThenElse(hn::Lt(t, zero), zero, hn::IfThenElse(hn::Lt(one, t), one, t));
    return hn::Mul(hn::Mul(t, t), hn::Sub(hn::Set(d, 3.0), hn::Mul(hn::Set(d, 2.0), t)));
}

// The scalar loop's per-pixel arithmetic (addFarRowScalar below), lane by lane: glm::dot as
// x·x' + y·y', glm::length as the square root of that, each product and sum in the order the
// scalar expression has it. Lanes whose spike share is not the narrow fan's averaged tail, and
// the halo and the corners, go to FarRowTerms one pixel at a time (their values taken out of the
// registers and put back), so each pixel's additions keep the scalar order.
void AddFarRow(const detail::FarRow& row) {
    const hn::ScalableTag<double> d;
    using V = hn::Vec<decltype(d)>;
    constexpr size_t kMaxLanes = HWY_MAX_BYTES / sizeof(double);
    const int lanes = static_cast<int>(hn::Lanes(d));
    HWY_ALIGN double laneX[kMaxLanes], laneY[kMaxLanes], laneZ[kMaxLanes], laneTaper[kMaxLanes];
    HWY_ALIGN double laneScalar[kMaxLanes];

    const V zero = hn::Zero(d), half = hn::Set(d, 0.5), quarter = hn::Set(d, 0.25), one = hn::Set(d, 1.0);
    const V six = hn::Set(d, 6.0), twentyFour = hn::Set(d, 24.0), fifth = hn::Set(d, 0.2);
    const V laneOffsets = hn::Iota(d, 0.0);
    const double dyScalar = row.pixelY - row.centreY;
    const V dy = hn::Set(d, dyScalar), dy2 = hn::Mul(dy, dy);
    const V centreX = hn::Set(d, row.centreX);
    const detail::FarTaperRing* tapers = row.tapers;
    double rowY = 0.0;

    for (int x0 = 0; x0 < row.width; x0 += lanes) {
        const int inRow = std::min(lanes, row.width - x0);
        const V px = hn::Add(hn::Add(hn::Set(d, static_cast<double>(x0)), laneOffsets), half);
        const V dx = hn::Sub(px, centreX);
        const V r2 = hn::Add(hn::Mul(dx, dx), dy2);
        V taper = zero;
        if (row.taperCount == 1) {
            taper = Smoothstep(hn::Div(hn::Sub(hn::Sqrt(r2), hn::Set(d, tapers[0].startPx)), hn::Set(d, tapers[0].widthPx)));
        } else {
            for (size_t k = 0; k < row.taperCount; ++k) {
                const detail::FarTaperRing& t = tapers[k];
                const V ax = hn::Sub(px, hn::Set(d, t.centreX));
                const V ay = hn::Set(d, row.pixelY - t.centreY);
                const V length = hn::Sqrt(hn::Add(hn::Mul(ax, ax), hn::Mul(ay, ay)));
                const V ring = Smoothstep(hn::Div(hn::Sub(length, hn::Set(d, t.startPx)), hn::Set(d, t.widthPx)));
                taper = hn::Add(taper, hn::Mul(hn::Set(d, t.weight), ring));
            }
        }
        const auto active = hn::And(hn::FirstN(d, static_cast<size_t>(inRow)), hn::Gt(taper, zero));
        if (hn::AllFalse(d, active)) continue;
        const V inverseR4 = hn::Div(one, hn::Mul(r2, r2));
        V valueX = zero, valueY = zero, valueZ = zero;
        for (size_t s = 0; s < row.spikeCount; ++s) {
            const detail::FarSpike& spike = row.spikes[s];
            const double fanWidthScalar = spike.fanToRad - spike.fanFromRad;
            const V fanWidth = hn::Set(d, fanWidthScalar);
            const V along = hn::Add(hn::Mul(dx, hn::Set(d, spike.directionX)), hn::Set(d, dyScalar * spike.directionY));
            const V t = hn::Add(hn::Mul(dx, hn::Set(d, spike.transverseX)), hn::Set(d, dyScalar * spike.transverseY));
            const V tA = hn::Sub(t, hn::Mul(along, hn::Set(d, spike.fanFromRad)));
            const V tB = hn::Sub(t, hn::Mul(along, hn::Set(d, spike.fanToRad)));
            const V nearest = hn::Sub(hn::Min(hn::Abs(tA), hn::Abs(tB)), half);
            const auto beyondBand = hn::Or(hn::Gt(hn::Min(tA, tB), hn::Set(d, spike.bandHiPx)),
                                           hn::Lt(hn::Max(tA, tB), hn::Set(d, spike.bandLoPx)));
            const V alongFan = hn::Mul(along, fanWidth);
            auto narrowTail = hn::And(beyondBand, hn::Gt(nearest, hn::Set(d, detail::kAveragedTailWidths * spike.widestPx)));
            narrowTail = hn::And(narrowTail, hn::Lt(hn::Abs(alongFan), hn::Mul(fifth, nearest)));
            narrowTail = hn::And(narrowTail, active);
            if (!hn::AllFalse(d, narrowTail)) {
                // The averaged tail's mean over the fan by its midpoint and curvature term
                // (Starburst.cpp's fannedTailShape, inlined there in this order).
                const V mid = hn::Mul(half, hn::Add(tA, tB));
                const V y2 = hn::Mul(mid, mid);
                const V inverse = hn::Div(one, hn::Sub(y2, quarter));
                const V spread2 = hn::Mul(hn::Mul(hn::Mul(along, along), fanWidth), fanWidth);
                const V curvature = hn::Mul(hn::Mul(hn::Mul(hn::Mul(hn::Add(hn::Mul(six, y2), half), inverse), inverse), inverse), spread2);
                const V shape = hn::Add(inverse, hn::Div(curvature, twentyFour));
                const V share = hn::Mul(hn::Mul(hn::Mul(along, along), inverseR4), shape);
                valueX = hn::IfThenElse(narrowTail, hn::Add(valueX, hn::Mul(hn::Set(d, spike.tailScale.x), share)), valueX);
                valueY = hn::IfThenElse(narrowTail, hn::Add(valueY, hn::Mul(hn::Set(d, spike.tailScale.y), share)), valueY);
                valueZ = hn::IfThenElse(narrowTail, hn::Add(valueZ, hn::Mul(hn::Set(d, spike.tailScale.z), share)), valueZ);
            }
            const auto others = hn::AndNot(narrowTail, active);
            if (hn::AllFalse(d, others)) continue;
            // The other lanes' share from the profiles or the wide fan's closed form, in scalar code.
            hn::Store(valueX, d, laneX);
            hn::Store(valueY, d, laneY);
            hn::Store(valueZ, d, laneZ);
            hn::Store(hn::IfThenElseZero(others, one), d, laneScalar);
            for (int k = 0; k < inRow; ++k) {
                if (laneScalar[k] == 0.0) continue;
                glm::dvec3 value(laneX[k], laneY[k], laneZ[k]);
                row.terms->spikeShare(x0 + k, s, value);
                laneX[k] = value.x, laneY[k] = value.y, laneZ[k] = value.z;
            }
            valueX = hn::Load(d, laneX);
            valueY = hn::Load(d, laneY);
            valueZ = hn::Load(d, laneZ);
        }
        hn::Store(valueX, d, laneX);
        hn::Store(valueY, d, laneY);
        hn::Store(valueZ, d, laneZ);
        hn::Store(hn::IfThenElseZero(active, taper), d, laneTaper);
        // Column by column: the halo and the corners, the taper, the row's Y in the scalar order.
        for (int k = 0; k < inRow; ++k) {
            if (!(laneTaper[k] > 0.0)) continue;
            glm::dvec3 value(laneX[k], laneY[k], laneZ[k]);
            row.terms->haloAndCorners(x0 + k, value);
            const glm::dvec3 v = laneTaper[k] * value;
            float* q = row.xyz + 3 * static_cast<size_t>(x0 + k);
            for (int c = 0; c < 3; ++c) q[c] += static_cast<float>(v[c]);
            rowY += v.y;
        }
    }
    *row.rowY += rowY;
}

const char* FarRowTargetName() { return hwy::TargetName(HWY_TARGET); }

}  // namespace HWY_NAMESPACE
}  // namespace flare
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace flare {

HWY_EXPORT(AddFarRow);
HWY_EXPORT(FarRowTargetName);

namespace detail {

void addFarRow(const FarRow& row) { HWY_DYNAMIC_DISPATCH(AddFarRow)(row); }

namespace {
double smoothstep(double t) {
    t = std::clamp(t, 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}
}  // namespace

void addFarRowScalar(const FarRow& row) {
    const double dy = row.pixelY - row.centreY;
    double rowY = 0.0;
    for (int x = 0; x < row.width; ++x) {
        const double dx = x + 0.5 - row.centreX;
        const double r2 = dx * dx + dy * dy;
        double taper = 0.0;
        if (row.taperCount == 1) {
            taper = smoothstep((std::sqrt(r2) - row.tapers[0].startPx) / row.tapers[0].widthPx);
        } else {  // the cluster's lights' tapers, each about its own crop, by their energy
            for (size_t k = 0; k < row.taperCount; ++k) {
                const FarTaperRing& t = row.tapers[k];
                const double ax = x + 0.5 - t.centreX, ay = row.pixelY - t.centreY;
                taper += t.weight * smoothstep((std::sqrt(ax * ax + ay * ay) - t.startPx) / t.widthPx);
            }
        }
        if (!(taper > 0.0)) continue;
        const double inverseR4 = 1.0 / (r2 * r2);
        glm::dvec3 value(0.0);
        for (size_t s = 0; s < row.spikeCount; ++s) {
            const FarSpike& spike = row.spikes[s];
            const double fanWidth = spike.fanToRad - spike.fanFromRad;
            // The envelope (k·n)²/|k|⁴: 1/r² along the line, falling to 0 across it.
            const double along = dx * spike.directionX + dy * spike.directionY;
            const double t = dx * spike.transverseX + dy * spike.transverseY;
            const double tA = t - along * spike.fanFromRad, tB = t - along * spike.fanToRad;
            const double nearest = std::min(std::abs(tA), std::abs(tB)) - 0.5;
            const bool beyondBand = std::min(tA, tB) > spike.bandHiPx || std::max(tA, tB) < spike.bandLoPx;
            // Wholly beyond the band and four widths (most of the frame), a narrow fan: the
            // averaged tail's mean over it by its midpoint and curvature term.
            if (beyondBand && nearest > kAveragedTailWidths * spike.widestPx && std::abs(along * fanWidth) < 0.2 * nearest) {
                const double mid = 0.5 * (tA + tB), y2 = mid * mid, inverse = 1.0 / (y2 - 0.25);
                const double spread2 = along * along * fanWidth * fanWidth;
                const double shape = inverse + (6.0 * y2 + 0.5) * inverse * inverse * inverse * spread2 / 24.0;
                value += spike.tailScale * (along * along * inverseR4 * shape);
                continue;
            }
            row.terms->spikeShare(x, s, value);
        }
        row.terms->haloAndCorners(x, value);
        const glm::dvec3 v = taper * value;
        float* q = row.xyz + 3 * static_cast<size_t>(x);
        for (int c = 0; c < 3; ++c) q[c] += static_cast<float>(v[c]);
        rowY += v.y;
    }
    *row.rowY += rowY;
}

const char* farRowTargetName() { return HWY_DYNAMIC_DISPATCH(FarRowTargetName)(); }

}  // namespace detail
}  // namespace flare
#endif  // HWY_ONCE
