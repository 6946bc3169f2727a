// The live region of one ghost path at one wavelength, found and meshed on the pupil grid: the
// rays of a directional light that survive the path (and, for the analysis, land on the sensor),
// as triangles carrying each corner's sensor position and throughput. The ghost analysis
// integrates power and footprint over the triangles; the preview rasterises their images.
//
// Finding: a lattice of rays over a square window is followed through the path one event at a
// time (BundleTracer::advance), and its cells are refined (split in four) where needed. After each
// event, a cell whose four corner rays are all dead is kept (and split) only if survivors may lie
// inside it: each event that killed a corner has a constraint (StepOutcome::margin: ≤ 0 exactly
// where rays pass; smooth there, because every ray evaluated at an event survived the events
// before), modelled around the cell by a plane fitted to the margins of nearby rays plus an
// allowance for its curvature; the cell is kept if the part of it where every such model allows
// ≤ 0 is not negligible (see possiblyLive in PupilMesh.cpp). Live regions smaller than the
// lattice spacing, or thin ones between two events, are thus found instead of falling between
// rays; a region that some event shrinks to a few rays is refined at once, so that it stays
// resolved for the events after it. At the end the region is refined until it spans enough cells
// and holds enough live rays, the cells around live corners are added, and cells are split where
// estimates of the integration error (interior curvature of the throughput, bulge of the edge
// from its chords) exceed their share of a tolerance.
//
// Meshing (marching squares): a cell with four live corners gives two triangles; a cell cut by the
// region's edge gives the polygon of its live part, whose vertices on the cell's sides are placed
// where the margin of the event that killed the dead end interpolates to zero, then checked with
// probe rays just inside (bisection where the margin is undefined, e.g. a missed surface). The
// polygons' area is then exact to second order in the cell size, where counting live cell
// centres (the midpoint rule) is only first-order accurate along the edge.
//
// Budget: every refinement stops at PupilMeshOptions::maxRays rays started (a region folded along
// many events would otherwise be refined without end), and the mesh reports that it is unresolved.
//
// Known limit: a region that is a thin ring along a fold of the path (rays meeting a surface at a
// stationary height), narrower than the lattice around it, can be found only in part.
#pragma once

#include <vector>

#include <glm/vec2.hpp>

#include "flare/ghosts/GhostAnalysis.h"
#include "flare/optics/BundleTracer.h"

namespace flare {

struct PupilMeshOptions {
    glm::dvec2 windowMinMm{0.0};  // the square searched, on the pupil plane
    double windowSizeMm = 0.0;
    int baseCells = 16;        // lattice cells across the window at the first level
    int minCellsAcross = 16;   // at the end, refine until the live region spans this many cells...
    int minLivePoints = 150;   // ...and holds this many live lattice points
    int minPassingPoints = 32; // after each event, keep at least this many surviving rays
    int maxLevel = 12;         // a region smaller than window / (baseCells · 2^maxLevel) may be lost
    bool requireOnSensor = true;  // live = lands inside the sensor rectangle (the analysis)
    double slopeSafety = 1.5;  // on the margin models' allowances when dropping cells
    int bisections = 6;        // where no margin can place an edge vertex
    // The work and memory per path (see kMaxRaysPerPath): refinement of every kind stops once
    // this many rays have been started, and the mesh is built from the cells found so far
    // (PupilMesh::resolved = false). Locating the edge may start as many again (see locate).
    long maxRays = kMaxRaysPerPath;
    // Cells are split where the estimated error of the interior integration (linear interpolation
    // of the throughput) exceeds this fraction of the region's power in all.
    double interiorTolerance = 0.002;
    // Cells cut by the region's edge are split where the edge's estimated bulge from its chords
    // exceeds this fraction of the region's power in all (see refineBoundary in PupilMesh.cpp).
    double boundaryTolerance = 0.002;
};

struct PupilVertex {
    glm::dvec2 pupilMm{0.0};
    glm::dvec2 sensorMm{0.0};
    double throughput = 0.0;
};

struct PupilTriangle {
    PupilVertex v[3];
    double pupilAreaMm2 = 0.0;
    // Power this triangle carries, per unit incident irradiance: area × mean corner throughput.
    double power() const { return pupilAreaMm2 * (v[0].throughput + v[1].throughput + v[2].throughput) / 3.0; }
};

struct PupilMesh {
    std::vector<PupilTriangle> triangles;
    // The cells covering the cells with live corners: of the coarsest final lattice level, or
    // coarser where the region's bounding box would span more than 128 of them (so that a region
    // of scattered fine cells does not make a bitmap of gigabytes).
    LivePupilRegion region;
    PupilLattice lattice;  // the cells holding live rays, before the refinements for accuracy
    int level = 0;             // of region's cells
    long tracedRays = 0;       // rays started (most end early)
    // False when the ray budget (maxRays) ran out while cells were still to be split: the region
    // may then be found only in part, and the power's error may exceed the tolerances.
    bool resolved = true;

    bool empty() const { return triangles.empty(); }
};

PupilMesh meshLiveRegion(const BundleTracer& tracer, const PupilGrid& grid, const PupilMeshOptions& options);

struct PupilRemeshOptions {
    int minLevel = 0;            // split coarser cells down to this level first
    int maxGrowth = 8;           // passes adding the cells around live corners not covered yet
    bool requireOnSensor = true;
    int bisections = 6;
    double interiorTolerance = 0.002;  // as PupilMeshOptions
    double boundaryTolerance = 0.002;
    long maxRays = kMaxRaysPerPath;
};

// The live region meshed on the cells of an earlier search (another wavelength, a finer level),
// without searching again: the cells, split to options.minLevel, are traced, and the cells around
// their live corners are added as long as new live corners appear (the region moves a little
// with the wavelength). Thin parts of the region keep the fine cells the search found for them.
// Then the same refinements for accuracy as meshLiveRegion.
PupilMesh remeshLiveRegion(const BundleTracer& tracer, const PupilGrid& grid, const PupilLattice& lattice,
                           const PupilRemeshOptions& options);

}  // namespace flare
