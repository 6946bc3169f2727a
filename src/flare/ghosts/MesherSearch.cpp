#include "flare/ghosts/Mesher.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace flare::mesher {

PupilMesh Mesher::run() {
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

PupilMesh Mesher::remesh(const PupilLattice& lattice, const PupilRemeshOptions& options) {
    PupilMesh mesh;
    // Room for about twice the cells' corners (the growth around live corners and the edge's
    // points add to them): the samples, their margins and the indices then grow in place instead
    // of being copied and rehashed as they double, which cost a few percent of a beam.
    size_t cells = 0;
    for (const PupilLattice::Leaf& leaf : lattice.leaves)
        cells += leaf.level >= options.minLevel ? 1 : size_t{1} << (2 * (std::min(options.minLevel, o_.maxLevel) - leaf.level));
    cells = std::min(cells, static_cast<size_t>(std::max(o_.maxRays, 0L)));  // (the budget stops the cells beyond)
    const size_t expected = 2 * cells + 64;
    samples_.reserve(expected);
    margins_.reserve(expected * static_cast<size_t>(steps_));
    index_.reserve(expected);
    leaves_.reserve(2 * cells);
    holders_.reserve(cells);
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

int Mesher::newSample(const glm::dvec2& pupilMm) {
    Sample s;
    s.pupilMm = pupilMm;
    s.state = {grid_.ray(pupilMm.x, pupilMm.y), 1.0};
    samples_.push_back(s);
    margins_.resize(samples_.size() * static_cast<size_t>(steps_), kNaN);
    return static_cast<int>(samples_.size() - 1);
}

int Mesher::sampleAt(long i, long j, int level) {
    const auto [id, inserted] = index_.emplace(key(i, j, level), static_cast<int>(samples_.size()));
    if (inserted) {
        const double h = cellMm(level);
        newSample(o_.windowMinMm + glm::dvec2(static_cast<double>(i) * h, static_cast<double>(j) * h));
    }
    return id;
}

Mesher::Cell Mesher::makeCell(int level, long i, long j) {
    Cell c;
    c.level = level;
    c.i = i;
    c.j = j;
    for (int k = 0; k < 4; ++k) c.corner[k] = sampleAt(i + kCorner[k][0], j + kCorner[k][1], level);
    return c;
}

std::vector<int> Mesher::cornersOf(const std::vector<Cell>& cells) {
    std::vector<int> ids;
    ids.reserve(cells.size() * 4);
    for (const Cell& c : cells) ids.insert(ids.end(), c.corner, c.corner + 4);
    return ids;
}

void Mesher::addCell(int level, long i, long j) {
    leaves_.emplace(cellKey(level, i, j), 1);
    for (int l = level - 1; l >= 0; --l) holders_.emplace(cellKey(l, i >> (level - l), j >> (level - l)), 1);
    active_.push_back(makeCell(level, i, j));
}

bool Mesher::covered(int level, long i, long j) const {
    if (i < 0 || j < 0) return true;
    const long last = static_cast<long>(o_.baseCells) << level;
    if (i >= last || j >= last) return true;
    // The cell itself first: around a live corner it is most often there already.
    if (leaves_.contains(cellKey(level, i, j)) || holders_.contains(cellKey(level, i, j))) return true;
    for (int l = level - 1; l >= 0; --l)
        if (leaves_.contains(cellKey(l, i >> (level - l), j >> (level - l)))) return true;
    return false;
}

void Mesher::dropDead() {
    std::erase_if(active_, [&](const Cell& c) {
        return !(alive(c.corner[0]) || alive(c.corner[1]) || alive(c.corner[2]) || alive(c.corner[3]));
    });
}

void Mesher::completeAroundLiveCorners(int passes) {
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
                    for (long di = -1; di <= 0; ++di) {
                        if (ci + di == c.i && cj + dj == c.j) continue;  // the cell itself
                        if (!covered(c.level, ci + di, cj + dj) && budgetLeft()) addCell(c.level, ci + di, cj + dj);
                    }
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

void Mesher::bringTo(const std::vector<int>& candidates, int step) {
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
    // The batch: rays_[k] belongs to owners_[k]; the dead leave it after each event. Once every
    // ray has joined, the tracer's events up to `step` run at once (the rays stay in its lanes).
    rays_.clear();
    owners_.clear();
    size_t next = 0;
    for (int k = samples_[ids[0]].reached; k <= step;) {
        for (; next < ids.size() && samples_[ids[next]].reached == k; ++next) {
            rays_.push_back(samples_[ids[next]].state);
            owners_.push_back(ids[next]);
        }
        if (rays_.empty()) {
            ++k;
            continue;
        }
        size_t kept = 0;
        if (k < tracerSteps_) {
            const int through = next == ids.size() ? std::min(step, tracerSteps_ - 1) : k;
            ends_.resize(rays_.size());
            marginRows_.resize(rays_.size());
            for (size_t b = 0; b < rays_.size(); ++b) marginRows_[b] = &margins_[static_cast<size_t>(owners_[b]) * steps_];
            stepping_->advance(k, through, rays_, ends_, marginRows_);
            for (size_t b = 0; b < rays_.size(); ++b) {
                if (ends_[b].step >= 0) {
                    Sample& s = samples_[owners_[b]];
                    s.state = rays_[b];
                    s.reached = ends_[b].step + 1;
                    s.death = ends_[b].step;
                    continue;
                }
                rays_[kept] = rays_[b];
                owners_[kept++] = owners_[b];
            }
            k = through + 1;
        } else {  // the sensor rectangle, for the analysis
            const double halfW = 0.5 * lens_.sensor().widthMm, halfH = 0.5 * lens_.sensor().heightMm;
            for (size_t b = 0; b < rays_.size(); ++b) {
                const int id = owners_[b];
                const glm::dvec3& p = rays_[b].ray.originMm;
                margins_[static_cast<size_t>(id) * steps_ + k] = sensorMargin(lens_, {p.x, p.y});
                if (!(std::abs(p.x) <= halfW && std::abs(p.y) <= halfH)) {
                    Sample& s = samples_[id];
                    s.state = rays_[b];
                    s.reached = k + 1;
                    s.death = k;
                    continue;
                }
                rays_[kept] = rays_[b];
                owners_[kept++] = id;
            }
            ++k;
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

Mesher::Block Mesher::blockOf(const Cell& c) const {
    Block block;
    for (long dj = 0; dj < 4; ++dj)
        for (long di = 0; di < 4; ++di) {
            const Sample* s = find(c.i + di - 1, c.j + dj - 1, c.level);
            block[dj * 4 + di] = s ? static_cast<int>(s - samples_.data()) : -1;
        }
    return block;
}

MarginModel Mesher::modelEvent(const Cell& c, const Block& ids, int event) const {
    double block[4][4];
    int reached = 0;
    for (int k = 0; k < 16; ++k) {
        const bool there = ids[k] >= 0 && samples_[ids[k]].reached > event;
        block[k / 4][k % 4] = there ? margins_[static_cast<size_t>(ids[k]) * steps_ + event] : kNaN;
        reached += there;
    }
    MarginModel model = fitMarginModel(block, cellMm(c.level));
    model.reached = reached;
    return model;
}

bool Mesher::possiblyLive(Cell& c, const Block& block, int step) const {
    int events[4], count = 0, latest = -1;
    for (int k = 0; k < 4; ++k) {
        const int e = samples_[c.corner[k]].death;
        latest = std::max(latest, e);
        if (std::find(events, events + count, e) == events + count) events[count++] = e;
    }
    step = std::min(step, latest);
    if (c.slopeStep != step) c.blindDepth = 0;  // blind splits count per event
    c.blind = false;

    CellPolygon polygon;
    polygon.size = 4;
    polygon.p[0] = {0.0, 0.0}, polygon.p[1] = {1.0, 0.0}, polygon.p[2] = {1.0, 1.0}, polygon.p[3] = {0.0, 1.0};
    bool judged = false;
    const double h = cellMm(c.level);
    Cell::Allowance inherited[4];
    std::copy(c.allowances, c.allowances + 4, inherited);
    std::fill(c.allowances, c.allowances + 4, Cell::Allowance{});
    for (int n = 0; n < count && polygon.size > 0; ++n) {
        const int e = events[n];
        const MarginModel model = modelEvent(c, block, e);
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

std::vector<Mesher::Cell> Mesher::split(const Cell& c) {
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

void Mesher::processStep(int step) {
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
        // cells dropped earlier have not been followed that far). Their blocks are found once:
        // the points the splits below add have met no event yet, so they would not count anyway.
        std::vector<int> around;
        std::vector<Block> blocks(work.size());
        for (size_t n = 0; n < work.size(); ++n) {
            const Cell& c = work[n];
            if (alive(c.corner[0]) || alive(c.corner[1]) || alive(c.corner[2]) || alive(c.corner[3])) continue;
            blocks[n] = blockOf(c);
            for (int id : blocks[n])
                if (id >= 0) around.push_back(id);
        }
        bringTo(around, step);
        std::vector<Cell> next;
        for (size_t n = 0; n < work.size(); ++n) {
            Cell& c = work[n];
            if (alive(c.corner[0]) || alive(c.corner[1]) || alive(c.corner[2]) || alive(c.corner[3])) {
                active_.push_back(c);
                continue;
            }
            if (c.level < deepest && possiblyLive(c, blocks[n], step) && budgetLeft()) {
                std::vector<Cell> children = split(c);
                next.insert(next.end(), children.begin(), children.end());
            }
        }
        bringTo(cornersOf(next), step);
        work = std::move(next);
    }
}

void Mesher::resolve(int step, int points, int across) {
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

}  // namespace flare::mesher
