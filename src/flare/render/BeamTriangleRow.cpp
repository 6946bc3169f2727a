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

void AddTriangleRow(double rowValue, double gx, int first, int last, const glm::dvec3& scale, double* row) {
    if (last < first) return;
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
    const V value = hn::Set(d, rowValue), slope = hn::Set(d, gx), half = hn::Set(d, 0.5);
    const size_t values = static_cast<size_t>(last - first + 1) * 3;
    for (size_t start = 0, column = static_cast<size_t>(first); start < values; start += 3 * lanes, column += lanes) {
        // The group's first column, exact as a double, and each lane's: column + its pixel, exact.
        const V base = hn::Set(d, static_cast<double>(column));
        for (size_t r = 0; r < 3; ++r) {
            const size_t offset = start + r * lanes;
            if (offset >= values) break;
            // e = rowValue + gx · (column + 0.5), then e · scale added: the scalar loop's order.
            const V e = hn::Add(value, hn::Mul(slope, hn::Add(hn::Add(base, pixels[r]), half)));
            const V product = hn::Mul(e, scales[r]);
            double* q = row + offset;
            if (values - offset >= lanes) {
                hn::StoreU(hn::Add(hn::LoadU(d, q), product), d, q);
            } else {
                const auto inside = hn::FirstN(d, values - offset);
                hn::BlendedStore(hn::Add(hn::MaskedLoad(inside, d, q), product), inside, d, q);
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

HWY_EXPORT(AddTriangleRow);
HWY_EXPORT(TriangleRowTargetName);

namespace detail {

void addTriangleRow(double rowValue, double gx, int first, int last, const glm::dvec3& scale, double* row) {
    HWY_DYNAMIC_DISPATCH(AddTriangleRow)(rowValue, gx, first, last, scale, row);
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
