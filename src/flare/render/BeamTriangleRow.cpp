// BeamTriangleRow.h's row, compiled once per instruction set: foreach_target.h includes this file
// again for each target Highway builds (HWY_TARGET_INCLUDE), each time with that target's
// HWY_NAMESPACE; the dispatch table and the plain functions that use it are defined once, at the
// end (HWY_ONCE).
#include "flare/render/BeamTriangleRow.h"

#include <algorithm>
#include <cstddef>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "flare/render/BeamTriangleRow.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace flare {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// N lanes hold N consecutive values of the row; three registers, 3N values, hold N whole pixels.
// Register r's lane L holds value rN + L: pixel (rN + L) / 3 of the N, channel (rN + L) mod 3.
struct LanePattern {
    static constexpr size_t kMaxLanes = HWY_MAX_BYTES / sizeof(double);
    HWY_ALIGN double pixel[3][kMaxLanes];
    HWY_ALIGN double channel[3][kMaxLanes];
    explicit LanePattern(size_t lanes) {
        for (size_t r = 0; r < 3; ++r)
            for (size_t lane = 0; lane < lanes; ++lane) {
                pixel[r][lane] = static_cast<double>((r * lanes + lane) / 3);
                channel[r][lane] = static_cast<double>((r * lanes + lane) % 3);
            }
    }
};

// The spans of one triangle share its slope and the beam's scale: the lane pattern, the scale per
// lane and the slope are set up once for all of them (a triangle's rows average about 8 pixels, so
// setting them up per row cost about as much as the row itself).
void AddTriangleRows(const detail::TriangleRowSpan* spans, size_t count, double gx, const glm::dvec3& scale) {
    const hn::ScalableTag<double> d;
    using V = hn::Vec<decltype(d)>;
    const size_t lanes = hn::Lanes(d);
    static const LanePattern pattern(lanes);  // one per instruction set
    V pixels[3], scales[3];
    const V zero = hn::Zero(d), one = hn::Set(d, 1.0);
    const V x = hn::Set(d, scale.x), y = hn::Set(d, scale.y), z = hn::Set(d, scale.z);
    for (size_t r = 0; r < 3; ++r) {
        pixels[r] = hn::Load(d, pattern.pixel[r]);
        const V channel = hn::Load(d, pattern.channel[r]);
        scales[r] = hn::IfThenElse(hn::Eq(channel, zero), x, hn::IfThenElse(hn::Eq(channel, one), y, z));
    }
    const V slope = hn::Set(d, gx), half = hn::Set(d, 0.5);
    for (size_t n = 0; n < count; ++n) {
        const detail::TriangleRowSpan& span = spans[n];
        if (span.last < span.first) continue;
        const V value = hn::Set(d, span.rowValue);
        const size_t values = static_cast<size_t>(span.last - span.first + 1) * 3;
        for (size_t start = 0, column = static_cast<size_t>(span.first); start < values; start += 3 * lanes, column += lanes) {
            // The group's first column, exact as a double, and each lane's: column + its pixel, exact.
            const V base = hn::Set(d, static_cast<double>(column));
            for (size_t r = 0; r < 3; ++r) {
                const size_t offset = start + r * lanes;
                if (offset >= values) break;
                // e = rowValue + gx · (column + 0.5), then e · scale added: the scalar loop's order.
                const V e = hn::Add(value, hn::Mul(slope, hn::Add(hn::Add(base, pixels[r]), half)));
                const V product = hn::Mul(e, scales[r]);
                double* q = span.row + offset;
                if (values - offset >= lanes) {
                    hn::StoreU(hn::Add(hn::LoadU(d, q), product), d, q);
                } else {
#if HWY_TARGET <= HWY_AVX2
                    const auto inside = hn::FirstN(d, values - offset);
                    hn::BlendedStore(hn::Add(hn::MaskedLoad(inside, d, q), product), inside, d, q);
#else
                    // The span's last values through an aligned copy: before AVX2, Highway's
                    // MaskedLoad is an aligned load of the whole register (a fault where a pixel's
                    // values start off a 16-byte boundary, as every other pixel's do).
                    HWY_ALIGN double tail[LanePattern::kMaxLanes] = {};
                    const size_t left = values - offset;
                    std::copy(q, q + left, tail);
                    hn::Store(hn::Add(hn::Load(d, tail), product), d, tail);
                    std::copy(tail, tail + left, q);
#endif
                }
            }
        }
    }
}

const char* TriangleRowTargetName() { return hwy::TargetName(HWY_TARGET); }

}  // namespace HWY_NAMESPACE
}  // namespace flare
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace flare {

HWY_EXPORT(AddTriangleRows);
HWY_EXPORT(TriangleRowTargetName);

namespace detail {

void addTriangleRows(const TriangleRowSpan* spans, size_t count, double gx, const glm::dvec3& scale) {
    HWY_DYNAMIC_DISPATCH(AddTriangleRows)(spans, count, gx, scale);
}

void addTriangleRow(double rowValue, double gx, int first, int last, const glm::dvec3& scale, double* row) {
    const TriangleRowSpan span{rowValue, first, last, row};
    addTriangleRows(&span, 1, gx, scale);
}

void addTriangleRowScalar(double rowValue, double gx, int first, int last, const glm::dvec3& scale, double* row) {
    double* q = row;
    for (int column = first; column <= last; ++column, q += 3) {
        const double e = rowValue + gx * (column + 0.5);
        q[0] += e * scale.x;
        q[1] += e * scale.y;
        q[2] += e * scale.z;
    }
}

const char* triangleRowTargetName() { return HWY_DYNAMIC_DISPATCH(TriangleRowTargetName)(); }

}  // namespace detail
}  // namespace flare
#endif  // HWY_ONCE
