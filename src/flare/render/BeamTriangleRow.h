// The inner loop of a beam triangle's rasterisation (GhostBeam::rasterise): one film row's span of
// pixels, the irradiance plane e = rowValue + gx · (column + 0.5) times the beam's XYZ scale added
// to each pixel's three values, several values at a time in the lanes of SIMD registers (Google
// Highway's foreach_target, run-time dispatch to the widest instruction set the processor has).
//
// The row's values are interleaved (x, y, z per pixel), so a register holds the values of a few
// pixels and channels as they lie in memory: each lane computes its pixel's e and its channel's
// product with exactly the scalar loop's operations (BeamTriangleRow.cpp is compiled with
// -ffp-contract=off), and the span's last register writes only its own lanes. The film gets the
// same bits as from the scalar loop (test_beam_rows.cpp compares them).
#pragma once

#include <cstddef>

#include <glm/vec3.hpp>

namespace flare::detail {

// One row of a triangle: the plane's value at x = 0 on the row, its columns [first, last], and
// `row` pointing at column `first`'s x.
struct TriangleRowSpan {
    double rowValue = 0.0;
    int first = 0, last = -1;
    double* row = nullptr;
};

// The rows of one triangle (one slope gx, one scale), each as addTriangleRow: one call, so that
// the lanes' set-up is paid once per triangle rather than once per row.
void addTriangleRows(const TriangleRowSpan* spans, size_t count, double gx, const glm::dvec3& scale);

// Adds (rowValue + gx · (column + 0.5)) · scale to the xyz of columns [first, last], `row`
// pointing at column `first`'s x.
void addTriangleRow(double rowValue, double gx, int first, int last, const glm::dvec3& scale, double* row);

// The same, one pixel at a time: the scalar reference (tests).
void addTriangleRowScalar(double rowValue, double gx, int first, int last, const glm::dvec3& scale, double* row);

// The instruction set addTriangleRow runs on (tests).
const char* triangleRowTargetName();

}  // namespace flare::detail
