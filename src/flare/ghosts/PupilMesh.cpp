#include "flare/ghosts/PupilMesh.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <array>
#include <utility>

#include <glm/common.hpp>

namespace flare {

namespace {

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

// Lattice keys to indices: open addressing with linear probing, faster than std::unordered_map
// for the mesher's many small lookups (the 4 × 4 blocks around each cell judged).
class KeyIndex {
public:
    KeyIndex() : keys_(64, kEmpty), values_(64, -1) {}
    // The value stored under key, or -1.
    int find(std::uint64_t key) const {
        for (size_t slot = hash(key);; slot = (slot + 1) & (keys_.size() - 1)) {
            if (keys_[slot] == key) return values_[slot];
            if (keys_[slot] == kEmpty) return -1;
        }
    }
    // Stores value under key unless the key is there; returns the stored value and whether it
    // was inserted.
    std::pair<int, bool> emplace(std::uint64_t key, int value) {
        if (2 * (size_ + 1) > keys_.size()) grow();
        for (size_t slot = hash(key);; slot = (slot + 1) & (keys_.size() - 1)) {
            if (keys_[slot] == key) return {values_[slot], false};
            if (keys_[slot] == kEmpty) {
                keys_[slot] = key;
                values_[slot] = value;
                ++size_;
                return {value, true};
            }
        }
    }
    bool contains(std::uint64_t key) const { return find(key) >= 0; }
    bool empty() const { return size_ == 0; }

private:
    static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  // no lattice or edge key
    // Fibonacci hashing: the product's top bits depend on all of the key's bits.
    size_t hash(std::uint64_t key) const { return static_cast<size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_); }
    void grow() {
        std::vector<std::uint64_t> keys(keys_.size() * 2, kEmpty);
        std::vector<int> values(keys.size(), -1);
        keys.swap(keys_);
        values.swap(values_);
        size_ = 0;
        --shift_;
        for (size_t k = 0; k < keys.size(); ++k)
            if (keys[k] != kEmpty) emplace(keys[k], values[k]);
    }
    std::vector<std::uint64_t> keys_;
    std::vector<int> values_;
    size_t size_ = 0;
    int shift_ = 64 - 6;  // 64 − log2(capacity)
};

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

    PupilMesh run() {
        PupilMesh mesh;
        const long n0 = o_.baseCells;
        for (long j = 0; j < n0; ++j)
            for (long i = 0; i < n0; ++i) active_.push_back(makeCell(0, i, j));
        for (int k = 0; k < steps_ && !active_.empty(); ++k) {
            bringTo(cornersOf(active_), k);
            processStep(k);
            const bool last = k == steps_ - 1;
            resolve(k, last ? o_.minLivePoints : o_.minPassingPoints, last ? o_.minCellsAcross : 0);
        }
        mesh.tracedRays = static_cast<long>(samples_.size());
        mesh.resolved = !truncated_;
        if (active_.empty()) return mesh;
        completeAroundLiveCorners(kCompletionPasses);
        meshCells(&mesh);
        mesh.tracedRays = static_cast<long>(samples_.size());
        mesh.resolved = !truncated_;
        return mesh;
    }

    // Remeshing (see remeshLiveRegion): no search, cells given.
    PupilMesh remesh(const PupilLattice& lattice, const PupilRemeshOptions& options) {
        PupilMesh mesh;
        for (const PupilLattice::Leaf& leaf : lattice.leaves) {
            if (leaf.level >= options.minLevel) {
                addCell(leaf.level, leaf.i, leaf.j);
                continue;
            }
            const int shift = std::min(options.minLevel, o_.maxLevel) - leaf.level;
            for (long dj = 0; dj < (1L << shift); ++dj)
                for (long di = 0; di < (1L << shift); ++di)
                    if (budgetLeft()) addCell(leaf.level + shift, (leaf.i << shift) + di, (leaf.j << shift) + dj);
        }
        bringTo(cornersOf(active_), steps_ - 1);
        dropDead();
        // At this wavelength the region has moved a little: follow it through live corners.
        completeAroundLiveCorners(options.maxGrowth);
        mesh.tracedRays = static_cast<long>(samples_.size());
        mesh.resolved = !truncated_;
        if (active_.empty()) return mesh;
        o_.bisections = options.bisections;
        meshCells(&mesh);
        mesh.tracedRays = static_cast<long>(samples_.size());
        mesh.resolved = !truncated_;
        return mesh;
    }

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
    int newSample(const glm::dvec2& pupilMm) {
        Sample s;
        s.pupilMm = pupilMm;
        s.state = {grid_.ray(pupilMm.x, pupilMm.y), 1.0};
        samples_.push_back(s);
        margins_.resize(samples_.size() * static_cast<size_t>(steps_), kNaN);
        return static_cast<int>(samples_.size() - 1);
    }
    int sampleAt(long i, long j, int level) {
        const auto [id, inserted] = index_.emplace(key(i, j, level), static_cast<int>(samples_.size()));
        if (inserted) {
            const double h = cellMm(level);
            newSample(o_.windowMinMm + glm::dvec2(static_cast<double>(i) * h, static_cast<double>(j) * h));
        }
        return id;
    }
    const Sample* find(long i, long j, int level) const {
        if (i < 0 || j < 0) return nullptr;
        const int id = index_.find(key(i, j, level));
        return id < 0 ? nullptr : &samples_[id];
    }
    double margin(int id, int step) const { return margins_[static_cast<size_t>(id) * steps_ + step]; }
    bool alive(int id) const { return samples_[id].death < 0; }

    Cell makeCell(int level, long i, long j) {
        Cell c;
        c.level = level;
        c.i = i;
        c.j = j;
        for (int k = 0; k < 4; ++k) c.corner[k] = sampleAt(i + kCorner[k][0], j + kCorner[k][1], level);
        return c;
    }
    static std::vector<int> cornersOf(const std::vector<Cell>& cells) {
        std::vector<int> ids;
        ids.reserve(cells.size() * 4);
        for (const Cell& c : cells) ids.insert(ids.end(), c.corner, c.corner + 4);
        return ids;
    }

    // The set of cells in active_, as leaves of the quadtree (and their ancestors), to tell whether
    // a cell overlaps one already there.
    static std::uint64_t cellKey(int level, long i, long j) { return key(i, j, level) | static_cast<std::uint64_t>(level) << 60; }
    void addCell(int level, long i, long j) {
        leaves_.emplace(cellKey(level, i, j), 1);
        for (int l = level - 1; l >= 0; --l) holders_.emplace(cellKey(l, i >> (level - l), j >> (level - l)), 1);
        active_.push_back(makeCell(level, i, j));
    }
    // Whether a cell overlaps one added: itself, an ancestor or a descendant (or lies outside the
    // window).
    bool covered(int level, long i, long j) const {
        if (i < 0 || j < 0) return true;
        const long last = static_cast<long>(o_.baseCells) << level;
        if (i >= last || j >= last) return true;
        if (holders_.contains(cellKey(level, i, j))) return true;
        for (int l = level; l >= 0; --l)
            if (leaves_.contains(cellKey(l, i >> (level - l), j >> (level - l)))) return true;
        return false;
    }
    void dropDead() {
        std::erase_if(active_, [&](const Cell& c) {
            return !(alive(c.corner[0]) || alive(c.corner[1]) || alive(c.corner[2]) || alive(c.corner[3]));
        });
    }
    // Adds the cells (of the same level) around every live corner that are not covered yet: the
    // region's part in them, next to the corner, is otherwise lost (the search drops such cells
    // as negligible one by one; together they hold a few tenths of a percent of the region), and
    // a region that has moved (another wavelength) is followed. Repeated while new live corners
    // appear, at most `passes` times.
    void completeAroundLiveCorners(int passes) {
        if (leaves_.empty())
            for (const Cell& c : active_) {
                leaves_.emplace(cellKey(c.level, c.i, c.j), 1);
                for (int l = c.level - 1; l >= 0; --l)
                    holders_.emplace(cellKey(l, c.i >> (c.level - l), c.j >> (c.level - l)), 1);
            }
        std::vector<Cell> fresh = active_;
        for (int pass = 0; pass < passes && !fresh.empty() && budgetLeft(); ++pass) {
            const size_t before = active_.size();
            for (const Cell& c : fresh)
                for (int k = 0; k < 4; ++k) {
                    if (!alive(c.corner[k])) continue;
                    const long ci = c.i + kCorner[k][0], cj = c.j + kCorner[k][1];  // the corner
                    for (long dj = -1; dj <= 0; ++dj)
                        for (long di = -1; di <= 0; ++di)
                            if (!covered(c.level, ci + di, cj + dj) && budgetLeft()) addCell(c.level, ci + di, cj + dj);
                }
            if (active_.size() == before) break;
            std::vector<Cell> added(active_.begin() + static_cast<std::ptrdiff_t>(before), active_.end());
            bringTo(cornersOf(added), steps_ - 1);
            std::erase_if(added, [&](const Cell& c) {
                return !(alive(c.corner[0]) || alive(c.corner[1]) || alive(c.corner[2]) || alive(c.corner[3]));
            });
            active_.resize(before);
            active_.insert(active_.end(), added.begin(), added.end());
            fresh = std::move(added);
        }
    }

    // Applies events up to `step` (inclusive) to the given samples that are still alive: event by
    // event over all of them, so that each event's batch is as large as possible.
    void bringTo(const std::vector<int>& candidates, int step) {
        // Unique, still alive, not yet there; a stamp per sample avoids sorting.
        ++stamp_;
        stamps_.resize(samples_.size(), 0);
        std::vector<int> ids;
        for (int id : candidates) {
            if (stamps_[id] == stamp_) continue;
            stamps_[id] = stamp_;
            const Sample& s = samples_[id];
            if (s.death >= 0 || s.reached > step) continue;
            ids.push_back(id);
        }
        if (ids.empty()) return;
        // By the event they are at, so that each joins the batch when it gets there.
        std::stable_sort(ids.begin(), ids.end(), [&](int a, int b) { return samples_[a].reached < samples_[b].reached; });
        // The batch: rays_[k] belongs to owners_[k]; the dead leave it after each event.
        rays_.clear();
        owners_.clear();
        size_t next = 0;
        for (int k = samples_[ids[0]].reached; k <= step; ++k) {
            for (; next < ids.size() && samples_[ids[next]].reached == k; ++next) {
                rays_.push_back(samples_[ids[next]].state);
                owners_.push_back(ids[next]);
            }
            if (rays_.empty()) continue;
            outcomes_.assign(rays_.size(), StepOutcome{});
            if (k < tracerSteps_) {
                stepping_->advance(k, rays_, outcomes_, true);
            } else {  // the sensor rectangle, for the analysis
                const double halfW = 0.5 * lens_.sensor().widthMm, halfH = 0.5 * lens_.sensor().heightMm;
                for (size_t b = 0; b < rays_.size(); ++b) {
                    const glm::dvec3& p = rays_[b].ray.originMm;
                    outcomes_[b].margin = sensorMargin(lens_, {p.x, p.y});
                    outcomes_[b].alive = std::abs(p.x) <= halfW && std::abs(p.y) <= halfH;
                }
            }
            size_t kept = 0;
            for (size_t b = 0; b < rays_.size(); ++b) {
                const int id = owners_[b];
                margins_[static_cast<size_t>(id) * steps_ + k] = outcomes_[b].margin;
                if (!outcomes_[b].alive) {
                    Sample& s = samples_[id];
                    s.state = rays_[b];
                    s.reached = k + 1;
                    s.death = k;
                    continue;
                }
                rays_[kept] = rays_[b];
                owners_[kept++] = id;
            }
            rays_.resize(kept);
            owners_.resize(kept);
        }
        for (size_t b = 0; b < rays_.size(); ++b) {
            Sample& s = samples_[owners_[b]];
            s.state = rays_[b];
            s.reached = step + 1;
        }
    }

    // A model of one event's margin around a cell, in cell units (the cell is [0, 1]²): a plane
    // fitted to the margins of the 4 × 4 lattice points around the cell that reached the event,
    // and an allowance for what the plane misses (curvature, fit residual).
    struct EventModel {
        bool judged = false;  // enough points reached the event, with margins, to fit the plane
        int reached = 0;      // points of the block that reached the event
        double p0 = 0.0, px = 0.0, py = 0.0, allowance = 0.0;
        double curvaturePerMm2 = 0.0;
    };

    EventModel modelEvent(const Cell& c, int event) const {
        EventModel model;
        const double h = cellMm(c.level);
        double block[4][4];
        int valued = 0;
        for (long dj = 0; dj < 4; ++dj)
            for (long di = 0; di < 4; ++di) {
                const Sample* s = find(c.i + di - 1, c.j + dj - 1, c.level);
                const bool there = s && s->reached > event;
                block[dj][di] = there ? margins_[static_cast<size_t>(s - samples_.data()) * steps_ + event] : kNaN;
                valued += !std::isnan(block[dj][di]);
                model.reached += there;
            }
        if (valued < 3) return model;
        double curvature = 0.0;  // largest second difference along rows and columns
        for (int y = 0; y < 4; ++y)
            for (int x = 0; x < 4; ++x) {
                if (x < 2 && !std::isnan(block[y][x] + block[y][x + 1] + block[y][x + 2]))
                    curvature = std::max(curvature, std::abs(block[y][x] - 2.0 * block[y][x + 1] + block[y][x + 2]));
                if (y < 2 && !std::isnan(block[y][x] + block[y + 1][x] + block[y + 2][x]))
                    curvature = std::max(curvature, std::abs(block[y][x] - 2.0 * block[y + 1][x] + block[y + 2][x]));
            }
        model.curvaturePerMm2 = curvature / (h * h);
        // Least squares plane m ≈ p0 + px·u + py·v, u and v in cells from the cell's lower corner.
        double a[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}, b[3] = {0, 0, 0};
        for (int y = 0; y < 4; ++y)
            for (int x = 0; x < 4; ++x) {
                if (std::isnan(block[y][x])) continue;
                const double f[3] = {1.0, x - 1.0, y - 1.0};
                for (int r = 0; r < 3; ++r) {
                    b[r] += f[r] * block[y][x];
                    for (int q = 0; q < 3; ++q) a[r][q] += f[r] * f[q];
                }
            }
        auto det3 = [](const double m[3][3]) {
            return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                   m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        };
        const double det = det3(a);
        if (!(std::abs(det) > 1e-9)) return model;  // the points are collinear
        double p[3];
        for (int col = 0; col < 3; ++col) {
            double m[3][3];
            for (int r = 0; r < 3; ++r)
                for (int q = 0; q < 3; ++q) m[r][q] = q == col ? b[r] : a[r][q];
            p[col] = det3(m) / det;
        }
        model.p0 = p[0], model.px = p[1], model.py = p[2];
        double residual = 0.0;  // at the cell's own corners
        for (int k = 0; k < 4; ++k) {
            const double m = block[1 + kCorner[k][1]][1 + kCorner[k][0]];
            if (!std::isnan(m)) residual = std::max(residual, std::abs(m - (p[0] + p[1] * kCorner[k][0] + p[2] * kCorner[k][1])));
        }
        model.allowance = residual;
        model.judged = true;
        return model;
    }

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
    bool possiblyLive(Cell& c, int step) const {
        int events[4], count = 0, latest = -1;
        for (int k = 0; k < 4; ++k) {
            const int e = samples_[c.corner[k]].death;
            latest = std::max(latest, e);
            if (std::find(events, events + count, e) == events + count) events[count++] = e;
        }
        step = std::min(step, latest);
        if (c.slopeStep != step) c.blindDepth = 0;  // blind splits count per event
        c.blind = false;

        Polygon polygon;
        polygon.size = 4;
        polygon.p[0] = {0.0, 0.0}, polygon.p[1] = {1.0, 0.0}, polygon.p[2] = {1.0, 1.0}, polygon.p[3] = {0.0, 1.0};
        bool judged = false;
        const double h = cellMm(c.level);
        Cell::Allowance inherited[4];
        std::copy(c.allowances, c.allowances + 4, inherited);
        std::fill(c.allowances, c.allowances + 4, Cell::Allowance{});
        for (int n = 0; n < count && polygon.size > 0; ++n) {
            const int e = events[n];
            const EventModel model = modelEvent(c, e);
            if (e == latest && model.reached < 3) {
                c.slopeStep = step;
                c.blind = true;
                return c.blindDepth < kBlindLevels;
            }
            if (!model.judged) {
                // The rays that reached the last event have no margin there (they missed the
                // surface, say): no sign of survivors between them.
                if (e == latest) return false;
                continue;
            }
            // The allowance per mm², which a smooth margin keeps about constant from level to
            // level. Where it grows fourfold from the parent's, the block straddles a jump of the
            // margin (a ray that meets a surface on another branch, say), which no level resolves:
            // there the parent's value stands, and the allowance shrinks with the cell as a
            // smooth margin's does, instead of refining along the jump down to the finest level.
            double perMm2 = (model.curvaturePerMm2 * h * h * 0.25 + model.allowance) / (h * h);
            for (const Cell::Allowance& a : inherited)
                if (a.event == e) perMm2 = perMm2 <= 3.0 * a.perMm2 ? std::max(perMm2, a.perMm2) : a.perMm2;
            c.allowances[n] = {e, perMm2};
            polygon = clipBelow(polygon, model.p0 - o_.slopeSafety * perMm2 * h * h, model.px, model.py);
            judged = true;
        }
        c.slopeStep = step;
        if (!judged) return false;  // the margins there are undefined (missed surfaces)
        return polygonArea(polygon) > kNegligibleArea;
    }

    // A convex polygon in cell units: the square clipped by at most four half-planes.
    struct Polygon {
        glm::dvec2 p[8];
        int size = 0;
    };
    // The part of a convex polygon where p0 + px·u + py·v ≤ 0.
    static Polygon clipBelow(const Polygon& polygon, double p0, double px, double py) {
        Polygon out;
        for (int k = 0; k < polygon.size; ++k) {
            const glm::dvec2 a = polygon.p[k], b = polygon.p[(k + 1) % polygon.size];
            const double fa = p0 + px * a.x + py * a.y, fb = p0 + px * b.x + py * b.y;
            if (fa <= 0.0 && out.size < 8) out.p[out.size++] = a;
            if ((fa <= 0.0) != (fb <= 0.0) && out.size < 8) out.p[out.size++] = a + (b - a) * (fa / (fa - fb));
        }
        return out;
    }
    static double polygonArea(const Polygon& polygon) {
        double twice = 0.0;
        for (int k = 0; k < polygon.size; ++k) {
            const glm::dvec2 a = polygon.p[k], b = polygon.p[(k + 1) % polygon.size];
            twice += a.x * b.y - a.y * b.x;
        }
        return 0.5 * std::abs(twice);
    }

    std::vector<Cell> split(const Cell& c) {
        std::vector<Cell> children;
        for (long dj = 0; dj < 2; ++dj)
            for (long di = 0; di < 2; ++di) {
                Cell child = makeCell(c.level + 1, 2 * c.i + di, 2 * c.j + dj);
                child.slopeStep = c.slopeStep;
                std::copy(c.allowances, c.allowances + 4, child.allowances);
                child.blindDepth = c.blindDepth + (c.blind ? 1 : 0);
                children.push_back(child);
            }
        return children;
    }

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
    void processStep(int step) {
        // A cell is split at most kMaxSplitDepth levels below the coarsest cell of the region at
        // this event: along a kink or fold of a margin the models cannot settle, refinement would
        // otherwise double the cells along it at every level down to the finest.
        int coarsest = o_.maxLevel;
        for (const Cell& c : active_) coarsest = std::min(coarsest, c.level);
        const int deepest = std::min(o_.maxLevel, coarsest + kMaxSplitDepth);
        std::vector<Cell> work = std::move(active_);
        active_.clear();
        while (!work.empty()) {
            // The lattice points around the cells to judge must have met the event too (points of
            // cells dropped earlier have not been followed that far).
            std::vector<int> around;
            for (const Cell& c : work) {
                if (alive(c.corner[0]) || alive(c.corner[1]) || alive(c.corner[2]) || alive(c.corner[3])) continue;
                for (long dj = -1; dj <= 2; ++dj)
                    for (long di = -1; di <= 2; ++di)
                        if (const Sample* p = find(c.i + di, c.j + dj, c.level)) around.push_back(static_cast<int>(p - samples_.data()));
            }
            bringTo(around, step);
            std::vector<Cell> next;
            for (Cell& c : work) {
                if (alive(c.corner[0]) || alive(c.corner[1]) || alive(c.corner[2]) || alive(c.corner[3])) {
                    active_.push_back(c);
                    continue;
                }
                if (c.level < deepest && possiblyLive(c, step) && budgetLeft()) {
                    std::vector<Cell> children = split(c);
                    next.insert(next.end(), children.begin(), children.end());
                }
            }
            bringTo(cornersOf(next), step);
            work = std::move(next);
        }
    }

    // Splits the coarsest cells until the surviving rays number at least `points` and span at
    // least `across` cells of the coarsest level.
    void resolve(int step, int points, int across) {
        while (!active_.empty()) {
            int survivors = 0;
            glm::dvec2 lo(1e300), hi(-1e300);
            int coarsest = o_.maxLevel;
            ++stamp_;
            stamps_.resize(samples_.size(), 0);
            for (const Cell& c : active_) {
                coarsest = std::min(coarsest, c.level);
                for (int id : c.corner)
                    if (alive(id) && stamps_[id] != stamp_) {
                        stamps_[id] = stamp_;
                        ++survivors;
                        lo = glm::min(lo, samples_[id].pupilMm);
                        hi = glm::max(hi, samples_[id].pupilMm);
                    }
            }
            const double spanCells = survivors == 0 ? 0.0 : std::max(hi.x - lo.x, hi.y - lo.y) / cellMm(coarsest);
            if ((survivors >= points && spanCells >= across - 1e-9) || coarsest >= o_.maxLevel || !budgetLeft())
                return;
            std::vector<Cell> kept, children;
            for (const Cell& c : active_) {
                if (c.level != coarsest) {
                    kept.push_back(c);
                    continue;
                }
                std::vector<Cell> four = split(c);
                children.insert(children.end(), four.begin(), four.end());
            }
            bringTo(cornersOf(children), step);
            active_ = std::move(kept);
            active_.insert(active_.end(), children.begin(), children.end());
            // Children with no surviving corner go through the event's test again.
            processStep(step);
        }
    }

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
    bool interpolate(Crossing& c) const {
        const int step = samples_[c.hi].death;
        const double mLo = margin(c.lo, step), mHi = margin(c.hi, step);
        if (std::isnan(mLo) || std::isnan(mHi) || !(mHi > mLo)) return false;
        c.estimate = c.tLo + (c.tHi - c.tLo) * std::clamp(mLo / (mLo - mHi), 0.0, 1.0);
        return true;
    }

    void locate(std::vector<Crossing>& crossings) {
        for (Crossing& c : crossings) c.bisect = !interpolate(c);
        // Probes just inside the interpolated edge: a live probe next to the edge gives the vertex's
        // image by a short extrapolation and ends the search. A dead probe narrows the bracket:
        // the edge may belong to an event the dead corner never reached (rays between the corners
        // can fail at several events in turn), so the search goes on with the probe's own event.
        // Where margins are undefined, bisection on survival.
        const int rounds = std::max(2, o_.bisections);
        std::vector<char> done(crossings.size(), 0);
        for (int round = 0; round < rounds; ++round) {
            std::vector<size_t> todo;
            std::vector<int> probes;
            for (size_t q = 0; q < crossings.size(); ++q) {
                Crossing& c = crossings[q];
                if (done[q]) continue;
                // Probes may add as many rays as the refinement had; beyond, vertices stay where
                // the margins or the bisection last put them.
                if (static_cast<long>(samples_.size()) >= 2 * o_.maxRays) {
                    truncated_ = true;
                    break;
                }
                const double width = c.tHi - c.tLo;
                const double t = c.bisect ? 0.5 * (c.tLo + c.tHi)
                                          : std::max(c.tLo + 0.5 * (c.estimate - c.tLo), c.estimate - 0.02 * width);
                todo.push_back(q);
                probes.push_back(newSample(along(c, t)));
                c.estimate = t;  // where the probe sits, until it is back
            }
            if (todo.empty()) break;
            bringTo(probes, steps_ - 1);
            for (size_t p = 0; p < todo.size(); ++p) {
                Crossing& c = crossings[todo[p]];
                const double t = c.estimate;
                const bool live = alive(probes[p]);
                if (live) {
                    c.previousLive = c.lo;
                    c.tPrevious = c.tLo;
                    c.lo = probes[p];
                    c.tLo = t;
                } else {
                    c.hi = probes[p];
                    c.tHi = t;
                }
                if (!c.bisect) {
                    c.bisect = !interpolate(c);
                    done[todo[p]] = live && !c.bisect;
                }
                if (c.bisect) c.estimate = 0.5 * (c.tLo + c.tHi);
            }
        }
        for (Crossing& c : crossings) {
            PupilVertex v = vertexOf(c.lo);
            v.pupilMm = along(c, c.estimate);
            if (c.previousLive >= 0 && c.tLo > c.tPrevious) {
                // Linear extrapolation of the image and throughput from the two live samples.
                const PupilVertex p = vertexOf(c.previousLive);
                const double f = (c.estimate - c.tLo) / (c.tLo - c.tPrevious);
                v.sensorMm += f * (v.sensorMm - p.sensorMm);
                v.throughput = std::max(0.0, v.throughput + f * (v.throughput - p.throughput));
            }
            c.vertex = v;
        }
    }

    // The search traced geometry only; the live corner rays are traced again with the Fresnel and
    // coating factors (the same rays: the factors do not change their geometry), and every ray
    // from here on is traced with them.
    void weighLive() {
        if (search_) {
            std::vector<int> ids;
            for (const Cell& c : active_)
                for (int id : c.corner)
                    if (alive(id)) ids.push_back(id);
            std::sort(ids.begin(), ids.end());
            ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
            std::vector<glm::dvec2> points;
            for (int id : ids) points.push_back(samples_[id].pupilMm);
            std::vector<BundleLanding> landings(points.size());
            weighted_.trace(grid_, points, landings);
            for (size_t k = 0; k < ids.size(); ++k) samples_[ids[k]].state.throughput = landings[k].throughput;
        }
        stepping_ = &weighted_;
    }

    // Interior cells integrate the throughput by linear interpolation over two triangles, whose
    // error is about h²/12 (|∂²T/∂u²| + |∂²T/∂v²|) per unit area (h the cell size). Estimated from
    // the throughput's second differences along the lattice, it decides which cells to split:
    // those whose share of the estimated error exceeds their share of the budget (a fraction of
    // the ghost's power), until the estimate fits the budget.
    void refineForAccuracy(int lastEvent) {
        for (int round = 0; round < kAccuracyRounds; ++round) {
            double power = 0.0, error = 0.0;
            std::vector<double> cellError(active_.size(), 0.0);
            for (size_t n = 0; n < active_.size(); ++n) {
                const Cell& c = active_[n];
                if (!(alive(c.corner[0]) && alive(c.corner[1]) && alive(c.corner[2]) && alive(c.corner[3]))) continue;
                const double h = cellMm(c.level), area = h * h;
                double t[4];
                for (int k = 0; k < 4; ++k) t[k] = samples_[c.corner[k]].state.throughput;
                power += area * 0.25 * (t[0] + t[1] + t[2] + t[3]);
                double d2u = 0.0, d2v = 0.0;
                auto liveThroughput = [&](long i, long j, double* out) {
                    const Sample* s = find(i, j, c.level);
                    if (!s || s->death >= 0 || s->reached < steps_) return false;
                    *out = s->state.throughput;
                    return true;
                };
                for (long row = 0; row < 2; ++row)
                    for (long di = -1; di <= 1; di += 2) {  // triples (i−1, i, i+1) and (i, i+1, i+2)
                        const long centre = di < 0 ? c.i : c.i + 1;
                        double a = 0, b = 0, m = 0;
                        if (liveThroughput(centre - 1, c.j + row, &a) && liveThroughput(centre, c.j + row, &m) &&
                            liveThroughput(centre + 1, c.j + row, &b))
                            d2u = std::max(d2u, std::abs(a - 2.0 * m + b));
                    }
                for (long column = 0; column < 2; ++column)
                    for (long dj = -1; dj <= 1; dj += 2) {
                        const long centre = dj < 0 ? c.j : c.j + 1;
                        double a = 0, b = 0, m = 0;
                        if (liveThroughput(c.i + column, centre - 1, &a) && liveThroughput(c.i + column, centre, &m) &&
                            liveThroughput(c.i + column, centre + 1, &b))
                            d2v = std::max(d2v, std::abs(a - 2.0 * m + b));
                    }
                cellError[n] = area * (d2u + d2v) / 12.0;
                error += cellError[n];
            }
            const double budget = o_.interiorTolerance * power;
            if (!(error > budget) || !budgetLeft()) return;
            // Split cells holding more than their share of the budget.
            const double share = budget / static_cast<double>(active_.size());
            std::vector<Cell> kept, children;
            for (size_t n = 0; n < active_.size(); ++n) {
                const Cell& c = active_[n];
                if (cellError[n] > share && c.level < o_.maxLevel && budgetLeft()) {
                    std::vector<Cell> four = split(c);
                    children.insert(children.end(), four.begin(), four.end());
                } else {
                    kept.push_back(c);
                }
            }
            if (children.empty()) return;
            bringTo(cornersOf(children), lastEvent);
            std::erase_if(children, [&](const Cell& c) {
                return !(alive(c.corner[0]) || alive(c.corner[1]) || alive(c.corner[2]) || alive(c.corner[3]));
            });
            active_ = std::move(kept);
            active_.insert(active_.end(), children.begin(), children.end());
        }
    }

    // The edge of the region is meshed as a chord across each cell it cuts, between the two edge
    // points. A curved edge bulges away from its chord by an area of about c²·α/12 (c the chord,
    // α the angle the edge turns through along it); α is estimated from the angles between a
    // chord and its neighbours at its ends, so corners of the region (where two edges meet) show
    // as large turns. Cells whose estimated bulge (times the throughput) exceeds their share
    // of a fraction of the region's power are split. Returns whether any was.
    template <typename EdgeKey>
    bool refineBoundary(const std::vector<Crossing>& crossings, const KeyIndex& edgeIndex,
                        const EdgeKey& edgeKey) {
        struct Chord {
            size_t cell, from, to;  // crossings
        };
        std::vector<Chord> chords;
        // The chords meeting at each crossing (two at most: the cells either side of its edge).
        std::vector<std::array<long, 2>> atCrossing(crossings.size(), {-1, -1});
        auto meet = [&](size_t crossing, size_t chord) {
            std::array<long, 2>& slot = atCrossing[crossing];
            (slot[0] < 0 ? slot[0] : slot[1]) = static_cast<long>(chord);
        };
        double power = 0.0;
        for (size_t n = 0; n < active_.size(); ++n) {
            const Cell& c = active_[n];
            bool live[4];
            int count = 0;
            for (int k = 0; k < 4; ++k) count += live[k] = alive(c.corner[k]);
            const double h = cellMm(c.level);
            double mean = 0.0;
            for (int k = 0; k < 4; ++k)
                if (live[k]) mean += samples_[c.corner[k]].state.throughput;
            power += h * h * mean / 4.0;
            if (count == 0 || count == 4 || (count == 2 && live[0] == live[2])) continue;  // no single chord
            size_t ends[2], found = 0;
            for (int e = 0; e < 4; ++e)
                if (live[e] != live[(e + 1) % 4] && found < 2) ends[found++] = static_cast<size_t>(edgeIndex.find(edgeKey(c, e)));
            if (found != 2) continue;
            meet(ends[0], chords.size());
            meet(ends[1], chords.size());
            chords.push_back({n, ends[0], ends[1]});
        }
        auto direction = [&](const Chord& ch) {
            return crossings[ch.to].vertex.pupilMm - crossings[ch.from].vertex.pupilMm;
        };
        auto turn = [&](size_t self, size_t at) {
            for (long other : atCrossing[at]) {
                if (other < 0 || static_cast<size_t>(other) == self) continue;
                const glm::dvec2 u = direction(chords[self]), v = direction(chords[other]);
                const double lu = std::hypot(u.x, u.y), lv = std::hypot(v.x, v.y);
                if (!(lu > 0.0 && lv > 0.0)) return 0.0;
                // Chords run either way round; the angle between the lines is what matters.
                const double cosine = std::abs(u.x * v.x + u.y * v.y) / (lu * lv);
                return std::acos(std::min(1.0, cosine));
            }
            return 0.0;
        };
        std::vector<double> bulge(active_.size(), 0.0);
        double total = 0.0;
        for (size_t n = 0; n < chords.size(); ++n) {
            const Chord& ch = chords[n];
            const glm::dvec2 d = direction(ch);
            // The larger end turn and c²α/8 rather than c²α/12: a corner of the region cut by a
            // chord (area c²/4 for a right angle) shows as turns at the chord's ends, not along it.
            const double alpha = std::max(turn(n, ch.from), turn(n, ch.to));
            const double throughput = 0.5 * (crossings[ch.from].vertex.throughput + crossings[ch.to].vertex.throughput);
            bulge[ch.cell] = (d.x * d.x + d.y * d.y) * alpha / 8.0 * throughput;
            total += bulge[ch.cell];
        }
        const double budget = o_.boundaryTolerance * power;
        if (!(total > budget) || !budgetLeft()) return false;
        const double share = budget / static_cast<double>(std::max<size_t>(1, chords.size()));
        std::vector<Cell> kept, children;
        for (size_t n = 0; n < active_.size(); ++n) {
            const Cell& c = active_[n];
            if (bulge[n] > share && c.level < o_.maxLevel && budgetLeft()) {
                std::vector<Cell> four = split(c);
                children.insert(children.end(), four.begin(), four.end());
            } else {
                kept.push_back(c);
            }
        }
        if (children.empty()) return false;
        bringTo(cornersOf(children), steps_ - 1);
        std::erase_if(children, [&](const Cell& c) {
            return !(alive(c.corner[0]) || alive(c.corner[1]) || alive(c.corner[2]) || alive(c.corner[3]));
        });
        active_ = std::move(kept);
        active_.insert(active_.end(), children.begin(), children.end());
        return true;
    }

    void meshCells(PupilMesh* mesh) {
        // A lattice edge is keyed by its lower/left point, its orientation (bit 28, above any
        // point's a coordinate) and its level (bits 60 and up), so that two cells of the same
        // level that share it share its crossing.
        auto edgeKey = [](const Cell& c, int e) -> std::uint64_t {
            const std::uint64_t level = static_cast<std::uint64_t>(c.level) << 60, vertical = std::uint64_t{1} << 28;
            switch (e) {
                case 0: return key(c.i, c.j, c.level) | level;
                case 1: return key(c.i + 1, c.j, c.level) | vertical | level;
                case 2: return key(c.i, c.j + 1, c.level) | level;
                default: return key(c.i, c.j, c.level) | vertical | level;
            }
        };
        // The cells that hold the region before the refinements for accuracy: other wavelengths
        // are meshed on them (remeshLiveRegion), with their own refinements.
        mesh->lattice.windowMinMm = o_.windowMinMm;
        mesh->lattice.windowSizeMm = o_.windowSizeMm;
        mesh->lattice.baseCells = o_.baseCells;
        for (const Cell& c : active_) mesh->lattice.leaves.push_back({c.level, c.i, c.j});
        weighLive();
        refineForAccuracy(steps_ - 1);
        // Edge points, kept by edge across the rounds of boundary refinement (a cell that is not
        // split keeps its edges).
        KeyIndex edgeIndex;
        std::vector<Crossing> crossings;
        for (int round = 0;; ++round) {
            std::vector<Crossing> fresh;
            std::vector<std::uint64_t> freshKeys;
            KeyIndex freshIndex;
            for (const Cell& c : active_)
                for (int e = 0; e < 4; ++e) {
                    const int a = c.corner[e], b = c.corner[(e + 1) % 4];
                    if (alive(a) == alive(b)) continue;
                    const std::uint64_t k = edgeKey(c, e);
                    if (edgeIndex.contains(k) || !freshIndex.emplace(k, 1).second) continue;
                    Crossing x;
                    x.live = x.lo = alive(a) ? a : b;
                    x.dead = x.hi = alive(a) ? b : a;
                    fresh.push_back(x);
                    freshKeys.push_back(k);
                }
            locate(fresh);
            for (size_t n = 0; n < fresh.size(); ++n) {
                edgeIndex.emplace(freshKeys[n], static_cast<int>(crossings.size()));
                crossings.push_back(fresh[n]);
            }
            if (round == kBoundaryRounds || !refineBoundary(crossings, edgeIndex, edgeKey)) break;
        }

        std::vector<PupilVertex> polygon;
        auto fan = [&](const std::vector<PupilVertex>& p) {
            for (size_t k = 1; k + 1 < p.size(); ++k) {
                PupilTriangle t{{p[0], p[k], p[k + 1]}, 0.0};
                const glm::dvec2 u = p[k].pupilMm - p[0].pupilMm, v = p[k + 1].pupilMm - p[0].pupilMm;
                t.pupilAreaMm2 = 0.5 * std::abs(u.x * v.y - u.y * v.x);
                if (t.pupilAreaMm2 > 0.0) mesh->triangles.push_back(t);
            }
        };
        for (const Cell& c : active_) {
            bool live[4];
            int count = 0;
            for (int k = 0; k < 4; ++k) count += live[k] = alive(c.corner[k]);
            if (count == 0) continue;
            auto crossing = [&](int e) { return crossings[static_cast<size_t>(edgeIndex.find(edgeKey(c, e)))].vertex; };
            if (count == 2 && live[0] == live[2]) {
                // A saddle: decide by the mean of the last event's margins whether the two live
                // corners are joined across the cell.
                double mean = 0.0;
                for (int k = 0; k < 4; ++k) {
                    const double m = margin(c.corner[k], steps_ - 1);
                    mean += std::isnan(m) ? (live[k] ? -1.0 : 1.0) : m;
                }
                if (mean > 0.0) {
                    for (int k = 0; k < 4; ++k)
                        if (live[k]) fan({vertexOf(c.corner[k]), crossing(k), crossing((k + 3) % 4)});
                    continue;
                }
            }
            polygon.clear();
            for (int k = 0; k < 4; ++k) {
                if (live[k]) polygon.push_back(vertexOf(c.corner[k]));
                if (live[k] != live[(k + 1) % 4]) polygon.push_back(crossing(k));
            }
            fan(polygon);
        }

        // The region, on the lattice of the coarsest level among the cells, coarser still where
        // its bounding box would span more than kMaxRegionCells of them: a region made only of
        // fine cells (thin or scattered pieces the search refined to the deepest level) can lie
        // anywhere in the window, and at the finest level the window is 16 · 2¹² cells across, a
        // bitmap of gigabytes. A coarser cell covering fine live cells still covers the region;
        // its users (the guide mask) only re-trace the cells, which then stay few.
        int level = kKeyLevels;
        for (const Cell& c : active_) level = std::min(level, c.level);
        long iMin = 0, iMax = 0, jMin = 0, jMax = 0;
        for (;; --level) {
            iMin = jMin = std::numeric_limits<long>::max();
            iMax = jMax = std::numeric_limits<long>::min();
            for (const Cell& c : active_) {
                const long i = c.i >> (c.level - level), j = c.j >> (c.level - level);
                iMin = std::min(iMin, i), iMax = std::max(iMax, i);
                jMin = std::min(jMin, j), jMax = std::max(jMax, j);
            }
            if (std::max(iMax - iMin, jMax - jMin) < kMaxRegionCells || level == 0) break;
        }
        const double h = cellMm(level);
        LivePupilRegion& region = mesh->region;
        region.cellMm = h;
        region.aMinMm = o_.windowMinMm.x + static_cast<double>(iMin) * h;
        region.bMinMm = o_.windowMinMm.y + static_cast<double>(jMin) * h;
        region.cellsA = static_cast<int>(iMax - iMin + 1);
        region.cellsB = static_cast<int>(jMax - jMin + 1);
        region.live.assign(static_cast<size_t>(region.cellsA) * region.cellsB, 0);
        for (const Cell& c : active_) {
            const long i = c.i >> (c.level - level), j = c.j >> (c.level - level);
            region.live[static_cast<size_t>(j - jMin) * region.cellsA + static_cast<size_t>(i - iMin)] = 1;
        }
        mesh->level = level;
    }

    const BundleTracer& weighted_;
    const BundleTracer tracer_;  // geometry only when searching: the search needs no Fresnel factors
    const BundleTracer* stepping_ = &tracer_;  // the tracer new rays are followed with
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
    std::vector<StepOutcome> outcomes_;
};

}  // namespace

PupilMesh meshLiveRegion(const BundleTracer& tracer, const PupilGrid& grid, const PupilMeshOptions& options) {
    return Mesher(tracer, grid, options, true).run();
}

PupilMesh remeshLiveRegion(const BundleTracer& tracer, const PupilGrid& grid, const PupilLattice& lattice,
                           const PupilRemeshOptions& options) {
    if (lattice.empty()) return {};
    PupilMeshOptions o;
    o.windowMinMm = lattice.windowMinMm;
    o.windowSizeMm = lattice.windowSizeMm;
    o.baseCells = lattice.baseCells;
    o.requireOnSensor = options.requireOnSensor;
    o.bisections = options.bisections;
    o.interiorTolerance = options.interiorTolerance;
    o.boundaryTolerance = options.boundaryTolerance;
    o.maxRays = options.maxRays;
    return Mesher(tracer, grid, o, false).remesh(lattice, options);
}

}  // namespace flare
