// How the pupil mesher judges a cell whose four corner rays all died (Mesher::possiblyLive): the
// margin of each event that killed a corner is modelled around the cell as a plane fitted to the
// 4 × 4 lattice points around it, plus an allowance for what the plane misses (curvature, fit
// residual); the cell square, clipped by one half-plane per event, is where surviving rays may
// lie, and a negligible area means none do.
#pragma once

#include <glm/vec2.hpp>

namespace flare {

// One event's margin around a cell, in cell units (the cell is [0, 1]², u and v from its lower
// corner): m ≈ p0 + px·u + py·v, within `allowance`.
struct MarginModel {
    bool judged = false;  // enough points reached the event, with margins, to fit the plane
    int reached = 0;      // points of the block that reached the event (set by the caller)
    double p0 = 0.0, px = 0.0, py = 0.0, allowance = 0.0;
    double curvaturePerMm2 = 0.0;  // the largest second difference around the cell, per mm²
};

// Fits the plane by least squares to block[row][column], the margins of the 4 × 4 lattice points
// from (−1, −1) to (2, 2) in cell units (NaN where a point has none), for cells `cellMm` wide;
// the allowance is the plane's largest residual at the cell's own corners. Not judged with fewer
// than three margins or collinear points.
MarginModel fitMarginModel(const double block[4][4], double cellMm);

// A convex polygon in cell units: the cell square clipped by at most four half-planes.
struct CellPolygon {
    glm::dvec2 p[8];
    int size = 0;
};
// The part of a convex polygon where p0 + px·u + py·v ≤ 0.
CellPolygon clipBelow(const CellPolygon& polygon, double p0, double px, double py);
double polygonArea(const CellPolygon& polygon);

}  // namespace flare
