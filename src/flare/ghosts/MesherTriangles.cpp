#include "flare/ghosts/Mesher.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include <glm/common.hpp>

namespace flare::mesher {

bool Mesher::interpolate(Crossing& c) const {
    const int step = samples_[c.hi].death;
    const double mLo = margin(c.lo, step), mHi = margin(c.hi, step);
    if (std::isnan(mLo) || std::isnan(mHi) || !(mHi > mLo)) return false;
    c.estimate = c.tLo + (c.tHi - c.tLo) * std::clamp(mLo / (mLo - mHi), 0.0, 1.0);
    return true;
}

void Mesher::locate(std::vector<Crossing>& crossings) {
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

void Mesher::weighLive() {
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

void Mesher::refineForAccuracy(int lastEvent) {
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

template <typename EdgeKey>
bool Mesher::refineBoundary(const std::vector<Crossing>& crossings, const KeyIndex& edgeIndex,
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

void Mesher::meshCells(PupilMesh* mesh) {
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

}  // namespace flare::mesher
