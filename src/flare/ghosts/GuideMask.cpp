#include "flare/ghosts/GuideMask.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <unordered_set>
#include <utility>

#include "flare/optics/BundleTracer.h"
#include "flare/optics/PacketTracer.h"

namespace flare {

GuideMask::GuideMask(const LivePupilRegion& region) {
    if (region.empty() || region.liveCount() == 0) return;
    grow(region.live, region.cellsA, region.cellsB, region.aMinMm, region.bMinMm, region.cellMm);
}

GuideMask GuideMask::traced(const LensSystem& lens, std::span<const Probe> probes, const GhostPath& path,
                            const LivePupilRegion& region, int growCells, double sensorMarginMm, double maxHalfSizeMm,
                            size_t seedProbes) {
    GuideMask mask;
    if (region.empty() || region.liveCount() == 0 || probes.empty()) return mask;
    const double cell = region.cellMm;
    const double halfW = 0.5 * lens.sensor().widthMm + sensorMarginMm;
    const double halfH = 0.5 * lens.sensor().heightMm + sensorMarginMm;
    // Geometry only: which rays survive, in SIMD packets.
    std::vector<BundleTracer> paths;
    paths.reserve(probes.size());
    for (const Probe& probe : probes) paths.push_back(BundleTracer(lens, probe.indices, path.reflections, false));
    std::vector<PacketTracer> tracers;
    tracers.reserve(probes.size());
    for (const BundleTracer& p : paths) tracers.emplace_back(p);

    // Cells in the region's indices, those wholly inside the square (the analysis's window).
    constexpr double kSlack = 1e-9;
    const int iLo = static_cast<int>(std::ceil((-maxHalfSizeMm - region.aMinMm) / cell - kSlack));
    const int iHi = static_cast<int>(std::floor((maxHalfSizeMm - region.aMinMm) / cell + kSlack));
    const int jLo = static_cast<int>(std::ceil((-maxHalfSizeMm - region.bMinMm) / cell - kSlack));
    const int jHi = static_cast<int>(std::floor((maxHalfSizeMm - region.bMinMm) / cell + kSlack));
    auto inside = [&](int i, int j) { return i >= iLo && i < iHi && j >= jLo && j < jHi; };
    auto key = [](int i, int j) {
        return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(i)) << 32) | static_cast<std::uint32_t>(j);
    };
    // Which of `cells` are live for some probe from `firstProbe` on, appended to `live` in order.
    std::vector<glm::dvec2> centres;
    std::vector<BundleLanding> landings;
    std::vector<std::uint8_t> found;
    std::vector<std::pair<int, int>> live;
    size_t tracedRays = 0;
    auto traceCells = [&](const std::vector<std::pair<int, int>>& cells, size_t firstProbe, size_t endProbe) {
        found.assign(cells.size(), 0);
        for (size_t p = firstProbe; p < endProbe; ++p) {
            centres.clear();
            std::vector<size_t> which;
            for (size_t c = 0; c < cells.size(); ++c) {
                if (found[c]) continue;
                which.push_back(c);
                centres.push_back({region.aMinMm + (cells[c].first + 0.5) * cell,
                                   region.bMinMm + (cells[c].second + 0.5) * cell});
            }
            if (centres.empty()) break;
            landings.resize(centres.size());
            tracers[p].trace(probes[p].grid, centres, landings);
            tracedRays += centres.size();
            for (size_t n = 0; n < which.size(); ++n) {
                const BundleLanding& l = landings[n];
                if (l.ok() && std::abs(l.sensorMm.x) <= halfW && std::abs(l.sensorMm.y) <= halfH) found[which[n]] = 1;
            }
        }
        std::vector<std::pair<int, int>> fresh;
        for (size_t c = 0; c < cells.size(); ++c)
            if (found[c]) fresh.push_back(cells[c]);
        live.insert(live.end(), fresh.begin(), fresh.end());
        return fresh;
    };

    // The analysis's window, grown, with the first probe (the analysis's own rays), or the first
    // `seedProbes`.
    std::unordered_set<std::uint64_t> visited;
    std::vector<std::pair<int, int>> cells;
    for (int j = -growCells; j < region.cellsB + growCells; ++j)
        for (int i = -growCells; i < region.cellsA + growCells; ++i)
            if (inside(i, j)) cells.emplace_back(i, j);
    const size_t seeds = std::clamp<size_t>(seedProbes, 1, probes.size());
    std::vector<std::pair<int, int>> frontier = traceCells(cells, 0, seeds);
    // The window's cells the seeds found dead need only the other probes when a ring reaches them
    // (none when every probe seeded, as in a region light's window: tracing them again was a
    // third of the night plate's mask rays). Flagged on the window's rectangle.
    const int windowA = region.cellsA + 2 * growCells, windowB = region.cellsB + 2 * growCells;
    auto windowCell = [&](int i, int j) {  // (of a cell in the rectangle)
        return static_cast<size_t>(j + growCells) * static_cast<size_t>(windowA) + static_cast<size_t>(i + growCells);
    };
    std::vector<std::uint8_t> seededDead(static_cast<size_t>(windowA) * windowB, 0);
    for (const auto& [i, j] : cells) seededDead[windowCell(i, j)] = 1;
    for (const auto& [i, j] : frontier) {
        visited.insert(key(i, j));
        seededDead[windowCell(i, j)] = 0;
    }
    auto isSeededDead = [&](int i, int j) {
        return i >= -growCells && j >= -growCells && i < windowA - growCells && j < windowB - growCells &&
               seededDead[windowCell(i, j)] != 0;
    };
    // Then outwards, ring by ring: the cells within `growCells` of the last ring's live cells,
    // with every probe, until no new cell is live: the union of the probes' regions where they
    // touch. A cell costs up to one trace per probe, a dead one all of them; the cap bounds a
    // region that keeps growing.
    const size_t maxVisited = std::max<size_t>(65536, 16 * cells.size());
    std::vector<std::pair<int, int>> windowCells;
    while (!frontier.empty() && visited.size() < maxVisited) {
        cells.clear();
        windowCells.clear();
        for (const auto& [ci, cj] : frontier)
            for (int j = cj - growCells; j <= cj + growCells; ++j)
                for (int i = ci - growCells; i <= ci + growCells; ++i)
                    if (inside(i, j) && visited.insert(key(i, j)).second)
                        (isSeededDead(i, j) ? windowCells : cells).emplace_back(i, j);
        frontier = traceCells(cells, 0, probes.size());
        if (seeds < probes.size() && !windowCells.empty()) {
            const std::vector<std::pair<int, int>> more = traceCells(windowCells, seeds, probes.size());
            frontier.insert(frontier.end(), more.begin(), more.end());
        }
    }
    mask.tracedRays_ = tracedRays;
    mask.tracedCells_ = visited.size();
    for (int j = -growCells; j < region.cellsB + growCells; ++j)
        for (int i = -growCells; i < region.cellsA + growCells; ++i)
            mask.tracedCells_ += isSeededDead(i, j) && !visited.contains(key(i, j));
    if (live.empty()) return mask;
    int i0 = live[0].first, i1 = i0, j0 = live[0].second, j1 = j0;
    for (const auto& [i, j] : live) {
        i0 = std::min(i0, i);
        i1 = std::max(i1, i);
        j0 = std::min(j0, j);
        j1 = std::max(j1, j);
    }
    const int cellsA = i1 - i0 + 1, cellsB = j1 - j0 + 1;
    std::vector<std::uint8_t> liveCells(static_cast<size_t>(cellsA) * cellsB, 0);
    for (const auto& [i, j] : live) liveCells[static_cast<size_t>(j - j0) * cellsA + (i - i0)] = 1;
    mask.grow(liveCells, cellsA, cellsB, region.aMinMm + i0 * cell, region.bMinMm + j0 * cell, cell);
    return mask;
}

PupilLattice GuideMask::coveringLattice(const PupilLattice& lattice) const {
    if (empty() || lattice.empty() || !(lattice.windowSizeMm > 0.0)) return lattice;
    // The mask's level: its cell is the lattice's at that level, and its corner a lattice point.
    const double levels = std::log2(lattice.windowSizeMm / (lattice.baseCells * cellMm_));
    const int level = static_cast<int>(std::lround(levels));
    if (level < 0 || level > 40 || std::abs(lattice.cellMm(level) - cellMm_) > 1e-9 * cellMm_) return lattice;
    const double i0Exact = (aMinMm_ - lattice.windowMinMm.x) / cellMm_, j0Exact = (bMinMm_ - lattice.windowMinMm.y) / cellMm_;
    const long i0 = std::lround(i0Exact), j0 = std::lround(j0Exact);
    if (std::abs(i0Exact - i0) > 1e-6 || std::abs(j0Exact - j0) > 1e-6) return lattice;

    auto key = [](int l, long i, long j) {
        return (static_cast<std::uint64_t>(l) << 58) ^ (static_cast<std::uint64_t>(i) << 29) ^ static_cast<std::uint64_t>(j);
    };
    std::unordered_set<std::uint64_t> leaves, holders;  // the leaves, and every cell above one
    int deepest = 0;
    for (const PupilLattice::Leaf& leaf : lattice.leaves) {
        leaves.insert(key(leaf.level, leaf.i, leaf.j));
        for (int l = leaf.level - 1; l >= 0; --l) holders.insert(key(l, leaf.i >> (leaf.level - l), leaf.j >> (leaf.level - l)));
        deepest = std::max(deepest, leaf.level);
    }
    const long last = static_cast<long>(lattice.baseCells) << level;
    PupilLattice out = lattice;
    // A cell the leaves leave uncovered becomes a leaf; one that holds finer leaves, its
    // uncovered children.
    std::function<void(int, long, long)> cover = [&](int l, long i, long j) {
        for (int m = 0; m <= l; ++m)
            if (leaves.contains(key(m, i >> (l - m), j >> (l - m)))) return;
        if (!holders.contains(key(l, i, j))) {
            out.leaves.push_back({l, i, j});
            return;
        }
        if (l >= deepest) return;
        for (long dj = 0; dj < 2; ++dj)
            for (long di = 0; di < 2; ++di) cover(l + 1, 2 * i + di, 2 * j + dj);
    };
    for (int c : cells_) {
        const long i = i0 + c % cellsA_, j = j0 + c / cellsA_;
        if (i >= 0 && j >= 0 && i < last && j < last) cover(level, i, j);
    }
    return out;
}

// Live cells and their eight neighbours.
void GuideMask::grow(const std::vector<std::uint8_t>& live, int cellsA, int cellsB, double aMinMm, double bMinMm,
                     double cellMm) {
    cellMm_ = cellMm;
    cellsA_ = cellsA + 2;
    cellsB_ = cellsB + 2;
    aMinMm_ = aMinMm - cellMm_;
    bMinMm_ = bMinMm - cellMm_;
    live_.assign(static_cast<size_t>(cellsA_) * cellsB_, 0);
    for (int j = 0; j < cellsB; ++j)
        for (int i = 0; i < cellsA; ++i) {
            if (!live[static_cast<size_t>(j) * cellsA + i]) continue;
            for (int dj = 0; dj <= 2; ++dj)
                for (int di = 0; di <= 2; ++di) live_[static_cast<size_t>(j + dj) * cellsA_ + i + di] = 1;
        }
    cells_.clear();
    for (size_t c = 0; c < live_.size(); ++c)
        if (live_[c]) cells_.push_back(static_cast<int>(c));
    areaMm2_ = static_cast<double>(cells_.size()) * cellMm_ * cellMm_;
}

}  // namespace flare
