// The inner loop of a beam rim's ringing (BeamRim::rasterise): one film row's pixels near one rim
// segment, several pixels at a time in the lanes of SIMD registers, compiled once per instruction
// set (Google Highway's foreach_target) and run on the widest the processor has.
//
// The rim's pixels cost several times a triangle's (a division, a square root and a table lookup
// each), and a large defocused ghost has a long rim. Every operation is the scalar loop's, in its
// order (BeamRimRow.cpp is compiled with -ffp-contract=off: no fused multiply-adds, which baseline
// x86-64 code never has), and a pixel the scalar loop skips is left untouched, so the film gets
// the same bits either way (test_beam_rows.cpp compares them).
#pragma once

#include <cstddef>

#include <glm/vec3.hpp>

#include "flare/render/BeamRim.h"

namespace flare::detail {

// One row of one segment: the pixel centres (column + 0.5 + jitterX, y) for column in
// [first, last], `row` pointing at column `first`'s xyz.
struct RimRowSpan {
    double y = 0.0;        // the row's centre + the jitter
    double jitterX = 0.0;
    int first = 0, last = -1;
    double reach = 0.0;    // FresnelEdgeExcess::kReach × w, in pixels
    double inverseScale = 0.0;  // 1 / w
    double* row = nullptr;      // column `first`'s xyz (addRimRows)
};

// A segment's rows, each as addRimRow with its span's `row`: one call, so that the segment's
// constants are set up once rather than once per row.
void addRimRows(const BeamRim::Segment& s, const RimRowSpan* spans, size_t count, const glm::dvec3& scale);

// Adds the segment's ringing times `scale` over the span (BeamRim::rasterise's per-pixel tests and
// value).
void addRimRow(const BeamRim::Segment& s, const RimRowSpan& span, const glm::dvec3& scale, double* row);

// The same, one pixel at a time: the scalar reference (tests, and the instruction-set check).
void addRimRowScalar(const BeamRim::Segment& s, const RimRowSpan& span, const glm::dvec3& scale, double* row);

// The instruction set addRimRow runs on (for reports and tests).
const char* rimRowTargetName();

}  // namespace flare::detail
