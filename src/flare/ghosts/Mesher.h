// The pupil mesher behind meshLiveRegion and remeshLiveRegion (PupilMesh.h), internal to the
// ghosts stage. One object meshes one path at one wavelength and direction; its state is the
// quadtree lattice of rays over the pupil window, followed through the path event by event.
//   MesherSearch.cpp     finding the live region: the lattice, tracing event by event, judging
//                        cells whose corner rays died (MarginModel), resolving thin regions,
//                        completing around live corners;
//   MesherTriangles.cpp  meshing it: the Fresnel weights, refinement for accuracy and along the
//                        edge, locating the edge between rays, triangles and the region bitmap.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include <glm/vec2.hpp>

#include "flare/ghosts/KeyIndex.h"
#include "flare/ghosts/MarginModel.h"
#include "flare/ghosts/PupilMesh.h"
#include "flare/optics/PacketTracer.h"

namespace flare::mesher {

constexpr int kKeyLevels = 20;  // lattice keys address points of every level up to this one
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Splits of a cell whose event margins are too few to judge it (4× finer).
constexpr int kBlindLevels = 2;
// Of a cell: a possible live part this small is not refined (see possiblyLive).
constexpr double kNegligibleArea = 0.1;
constexpr int kAccuracyRounds = 3;  // of refineForAccuracy
constexpr int kBoundaryRounds = 3;  // of refineBoundary
constexpr int kCompletionPasses = 2;  // of completeAroundLiveCorners after the search
constexpr int kMaxSplitDepth = 6;     // see processStep
constexpr long kMaxRegionCells = 128;  // across PupilMesh::region (see meshCells)

class Mesher {
public:
    // search: trace geometry only while searching (most rays die), and the vertices' rays again
    // with their weights at the end; else (remeshing, where most rays live) trace with weights.
    Mesher(const BundleTracer& tracer, const PupilGrid& grid, const PupilMeshOptions& options, bool search)
        : weighted_(tracer), tracer_(search ? tracer.geometryOnly() : tracer), grid_(grid), o_(options),
          lens_(tracer.lens()), search_(search) {
        o_.baseCells = std::clamp(o_.baseCells, 1, 1 << 7);
        o_.maxLevel = std::clamp(o_.maxLevel, 0, kKeyLevels - 8);
        tracerSteps_ = tracer.stepCount();
        steps_ = tracerSteps_ + (o_.requireOnSensor ? 1 : 0);
    }

    // The search from the base lattice, event by event, then the mesh.
    PupilMesh run();

    // Remeshing (see remeshLiveRegion): no search, cells given.
    PupilMesh remesh(const PupilLattice& lattice, const PupilRemeshOptions& options);

private:
    struct Sample {
        glm::dvec2 pupilMm{0.0};
        BundleRay state;
        int reached = 0;  // events applied
        int death = -1;   // the event that stopped it, −1 while alive
    };
    struct Cell {
        int level = 0;
        long i = 0, j = 0;  // lower-left corner on the level's lattice
        int corner[4] = {0, 0, 0, 0};  // sample ids, counter-clockwise from (i, j)
        int blindDepth = 0;  // splits in the cell's ancestry made without enough margins to judge
        bool blind = false;  // the last test had too few margins
        int slopeStep = -1;  // the event the cell was last judged at
        // Per event that killed a corner: the allowance of its margin model, per mm² (inherited
        // by the children of a split).
        struct Allowance {
            int event = -1;
            double perMm2 = 0.0;
        };
        Allowance allowances[4];
    };
    static constexpr long kCorner[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};

    double cellMm(int level) const {
        return o_.windowSizeMm / static_cast<double>(static_cast<long>(o_.baseCells) << level);
    }
    static std::uint64_t key(long i, long j, int level) {
        const int shift = kKeyLevels - level;
        return (static_cast<std::uint64_t>(i) << shift) | (static_cast<std::uint64_t>(j) << shift << 32);
    }
    int newSample(const glm::dvec2& pupilMm);
    int sampleAt(long i, long j, int level);
    const Sample* find(long i, long j, int level) const {
        if (i < 0 || j < 0) return nullptr;
        const int id = index_.find(key(i, j, level));
        return id < 0 ? nullptr : &samples_[id];
    }
    double margin(int id, int step) const { return margins_[static_cast<size_t>(id) * steps_ + step]; }
    bool alive(int id) const { return samples_[id].death < 0; }

    Cell makeCell(int level, long i, long j);
    static std::vector<int> cornersOf(const std::vector<Cell>& cells);

    // The set of cells in active_, as leaves of the quadtree (and their ancestors), to tell whether
    // a cell overlaps one already there.
    static std::uint64_t cellKey(int level, long i, long j) { return key(i, j, level) | static_cast<std::uint64_t>(level) << 60; }
    void addCell(int level, long i, long j);
    // Whether a cell overlaps one added: itself, an ancestor or a descendant (or lies outside the
    // window).
    bool covered(int level, long i, long j) const;
    void dropDead();
    // Adds the cells (of the same level) around every live corner that are not covered yet: the
    // region's part in them, next to the corner, is otherwise lost (the search drops such cells
    // as negligible one by one; together they hold a few tenths of a percent of the region), and
    // a region that has moved (another wavelength) is followed. Repeated while new live corners
    // appear, at most `passes` times.
    void completeAroundLiveCorners(int passes);

    // Applies events up to `step` (inclusive) to the given samples that are still alive: event by
    // event over all of them, so that each event's batch is as large as possible.
    void bringTo(const std::vector<int>& candidates, int step);

    // The sample ids of the 4 × 4 lattice points around a cell (its corners in the middle),
    // row after row from (i − 1, j − 1); −1 where there is none.
    using Block = std::array<int, 16>;
    Block blockOf(const Cell& c) const;

    // The margin of `event` around a cell, from the lattice points around it (its block) that
    // reached the event (MarginModel).
    MarginModel modelEvent(const Cell& c, const Block& block, int event) const;

    // Whether a cell whose four corner rays are all dead may hold surviving rays. Each event that
    // killed a corner was met by rays around the cell that passed the events before it, so its
    // margin is smooth there: inside the cell it stays within a plane fitted around the cell plus
    // an allowance, the curvature term (|∂²m/∂u²| + |∂²m/∂v²|)/8 from the largest second
    // difference around the cell (times a safety factor) and the plane's residual at the corners.
    // The cell may hold survivors only where every such event's plane is below its allowance:
    // the cell square is clipped by one half-plane per event. A region between the corners (an
    // island, or a strip between two events that each killed other corners) is thus kept and
    // refined, and an empty cell next to an edge already found is dropped, unless the left-over
    // strip is a negligible sliver (the bulge of a curved edge between two lattice points, of
    // order h²/8ρ for an edge of radius ρ), which would be refined down to the finest level.
    // Where too few rays around the cell reached an event to judge it (the region there is thin),
    // the cell is split a few levels without judgement.
    bool possiblyLive(Cell& c, const Block& block, int step) const;

    // The four children of a cell, which inherit its judgement state.
    std::vector<Cell> split(const Cell& c);

    // Whether refinement may start more rays (PupilMeshOptions::maxRays). Asked before each split,
    // so that the rays started stay within the budget plus one cell's; a refinement refused for
    // want of budget marks the mesh unresolved.
    bool budgetLeft() {
        if (static_cast<long>(samples_.size()) < o_.maxRays) return true;
        truncated_ = true;
        return false;
    }

    // After event `step`: cells with a surviving corner stay; the others are split where the
    // event's margin allows survivors inside, else dropped.
    void processStep(int step);

    // Splits the coarsest cells until the surviving rays number at least `points` and span at
    // least `across` cells of the coarsest level.
    void resolve(int step, int points, int across);

    PupilVertex vertexOf(int id) const {
        const Sample& s = samples_[id];
        return {s.pupilMm, {s.state.ray.originMm.x, s.state.ray.originMm.y}, s.state.throughput};
    }

    // The edge of the live region on the segment from a live sample (t = 0) to a dead one (t = 1).
    struct Crossing {
        int live = 0, dead = 0;
        double tLo = 0.0, tHi = 1.0;  // bracket: live at tLo, dead at tHi
        int lo = 0, hi = 0;           // the samples there
        int previousLive = -1;        // the live sample before lo, for extrapolation
        double tPrevious = 0.0;
        double estimate = 0.5;        // where the edge lies
        bool bisect = false;
        PupilVertex vertex;
    };

    glm::dvec2 along(const Crossing& c, double t) const {
        return samples_[c.live].pupilMm + t * (samples_[c.dead].pupilMm - samples_[c.live].pupilMm);
    }

    // The zero of the margin of the event that killed `hi`, interpolated between lo and hi.
    bool interpolate(Crossing& c) const;

    // Places each crossing's edge point: margins interpolated, probed, bisected where undefined.
    void locate(std::vector<Crossing>& crossings);

    // The search traced geometry only; the live corner rays are traced again with the Fresnel and
    // coating factors (the same rays: the factors do not change their geometry), and every ray
    // from here on is traced with them.
    void weighLive();

    // Interior cells integrate the throughput by linear interpolation over two triangles, whose
    // error is about h²/12 (|∂²T/∂u²| + |∂²T/∂v²|) per unit area (h the cell size). Estimated from
    // the throughput's second differences along the lattice, it decides which cells to split:
    // those whose share of the estimated error exceeds their share of the budget (a fraction of
    // the ghost's power), until the estimate fits the budget.
    void refineForAccuracy(int lastEvent);

    // The edge of the region is meshed as a chord across each cell it cuts, between the two edge
    // points. A curved edge bulges away from its chord by an area of about c²·α/12 (c the chord,
    // α the angle the edge turns through along it); α is estimated from the angles between a
    // chord and its neighbours at its ends, so corners of the region (where two edges meet) show
    // as large turns. Cells whose estimated bulge (times the throughput) exceeds their share
    // of a fraction of the region's power are split. Returns whether any was.
    template <typename EdgeKey>
    bool refineBoundary(const std::vector<Crossing>& crossings, const KeyIndex& edgeIndex,
                        const EdgeKey& edgeKey);

    // The mesh of the cells found: lattice recorded, weights traced, cells refined for accuracy
    // and along the edge, edge points located, each cell's live part triangulated, and the
    // region's bitmap.
    void meshCells(PupilMesh* mesh);

    // The path in SIMD packets (bit for bit BundleTracer's, so the mesh is the same on every
    // instruction set): with its factors, and geometry only when searching (the search needs no
    // Fresnel factors).
    const PacketTracer weighted_;
    const PacketTracer tracer_;
    const PacketTracer* stepping_ = &tracer_;  // the tracer new rays are followed with
    const PupilGrid& grid_;
    PupilMeshOptions o_;
    const LensSystem& lens_;
    bool search_ = true;
    int tracerSteps_ = 0, steps_ = 0;
    bool truncated_ = false;  // a refinement was refused for want of budget (PupilMesh::resolved)
    KeyIndex index_;
    KeyIndex leaves_, holders_;  // for covered()
    std::vector<Sample> samples_;
    std::vector<double> margins_;  // samples × events
    std::vector<Cell> active_;
    std::vector<int> stamps_;  // for bringTo's de-duplication
    int stamp_ = 0;
    std::vector<BundleRay> rays_;  // scratch for bringTo
    std::vector<int> owners_;
    std::vector<PacketTracer::End> ends_;
    std::vector<double*> marginRows_;
};

}  // namespace flare::mesher
