#include "flare/GhostAnalysis.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <glm/common.hpp>
#include <tbb/parallel_for.h>

#include "flare/SequentialTracer.h"

namespace flare {

int LivePupilRegion::liveCount() const {
    return static_cast<int>(std::count(live.begin(), live.end(), std::uint8_t{1}));
}

namespace {

struct Landing {
    bool live = false;
    double throughput = 0.0;
    glm::dvec2 sensorMm{0.0};
};

Landing traceCell(const LensSystem& lens, const SpectralIndices& indices, const PupilGrid& grid,
                  const SequentialPath& path, double a, double b) {
    const TraceResult r = tracePath(lens, indices, grid.ray(a, b), path);
    if (!r.ok()) return {};
    const glm::dvec3& p = r.ray.originMm;
    const bool onSensor = std::abs(p.x) <= 0.5 * lens.sensor().widthMm && std::abs(p.y) <= 0.5 * lens.sensor().heightMm;
    if (!onSensor) return {};
    return {true, r.throughput, {p.x, p.y}};
}

}  // namespace

GhostEstimate estimatePath(const LensSystem& lens, const SpectralIndices& indices, const PupilGrid& grid,
                           double enteringAreaMm2, const GhostPath& ghost, const GhostAnalysisOptions& options) {
    GhostEstimate estimate;
    estimate.path = ghost;
    estimate.paraxial = analyseGhostParaxial(lens, indices, ghost);
    SequentialPath path;
    path.reflections = ghost.reflections;

    // Coarse pass: which part of the grid survives at all.
    const int n0 = options.coarseCells;
    const double coarse = 2.0 * grid.halfSizeMm / n0;
    int iMin = n0, iMax = -1, jMin = n0, jMax = -1;
    for (int j = 0; j < n0; ++j)
        for (int i = 0; i < n0; ++i) {
            const Landing l = traceCell(lens, indices, grid, path, -grid.halfSizeMm + (i + 0.5) * coarse,
                                        -grid.halfSizeMm + (j + 0.5) * coarse);
            if (!l.live) continue;
            iMin = std::min(iMin, i), iMax = std::max(iMax, i);
            jMin = std::min(jMin, j), jMax = std::max(jMax, j);
        }
    if (iMax < 0) return estimate;

    // Fine pass over the live region grown by one coarse cell (rays beyond the coarse samples).
    const double a0 = -grid.halfSizeMm + std::max(0, iMin - 1) * coarse;
    const double a1 = -grid.halfSizeMm + std::min(n0, iMax + 2) * coarse;
    const double b0 = -grid.halfSizeMm + std::max(0, jMin - 1) * coarse;
    const double b1 = -grid.halfSizeMm + std::min(n0, jMax + 2) * coarse;
    LivePupilRegion& region = estimate.pupil;
    region.cellMm = std::max(a1 - a0, b1 - b0) / options.fineCells;
    region.cellsA = std::max(1, static_cast<int>(std::ceil((a1 - a0) / region.cellMm - 1e-9)));
    region.cellsB = std::max(1, static_cast<int>(std::ceil((b1 - b0) / region.cellMm - 1e-9)));
    region.aMinMm = a0;
    region.bMinMm = b0;
    region.live.assign(static_cast<size_t>(region.cellsA) * region.cellsB, 0);

    std::vector<Landing> landings(region.live.size());
    double power = 0.0;
    glm::dvec2 lo(1e300), hi(-1e300);
    for (int j = 0; j < region.cellsB; ++j)
        for (int i = 0; i < region.cellsA; ++i) {
            const Landing l = traceCell(lens, indices, grid, path, a0 + (i + 0.5) * region.cellMm,
                                        b0 + (j + 0.5) * region.cellMm);
            const size_t index = static_cast<size_t>(j) * region.cellsA + i;
            landings[index] = l;
            if (!l.live) continue;
            region.live[index] = 1;
            power += l.throughput;
            lo = glm::min(lo, l.sensorMm);
            hi = glm::max(hi, l.sensorMm);
        }
    const double cellArea = region.cellMm * region.cellMm;
    estimate.powerFraction = power * cellArea / enteringAreaMm2;
    if (power == 0.0) return estimate;
    estimate.footprintMinMm = lo;
    estimate.footprintMaxMm = hi;

    // Peak irradiance from a 32 × 32 histogram over the footprint: robust against the infinite
    // density of caustics (fold lines) that a per-cell Jacobian would report.
    constexpr int kBins = 32;
    const glm::dvec2 extent = glm::max(hi - lo, glm::dvec2(1e-3));
    std::vector<double> bins(kBins * kBins, 0.0);
    for (const Landing& l : landings) {
        if (!l.live) continue;
        const glm::dvec2 t = (l.sensorMm - lo) / extent;
        const int bx = std::min(kBins - 1, static_cast<int>(t.x * kBins));
        const int by = std::min(kBins - 1, static_cast<int>(t.y * kBins));
        bins[by * kBins + bx] += l.throughput * cellArea;
    }
    const double binArea = (extent.x / kBins) * (extent.y / kBins);
    estimate.peakIrradianceRatio = *std::max_element(bins.begin(), bins.end()) / binArea;
    return estimate;
}

void pruneGhosts(std::vector<GhostEstimate>& ghosts, double keepShare, double relativeThreshold) {
    double total = 0.0;
    for (const GhostEstimate& g : ghosts) total += g.powerFraction;
    const double strongest = ghosts.empty() ? 0.0 : ghosts.front().powerFraction;
    double cumulative = 0.0;
    for (GhostEstimate& g : ghosts) {
        const bool withinShare = cumulative < keepShare * total;
        const bool aboveThreshold = g.powerFraction > relativeThreshold * strongest;
        g.pruned = g.powerFraction == 0.0 || !(withinShare || aboveThreshold);
        cumulative += g.powerFraction;
    }
}

GhostReport analyseGhosts(const LensSystem& lens, const glm::dvec3& lightDirection,
                          const GhostAnalysisOptions& options) {
    GhostReport report;
    report.wavelengthNm = options.wavelengthNm;
    report.grid = PupilGrid::forDirection(lens, lightDirection);
    report.enteringAreaMm2 = report.grid.enteringAreaMm2(lens, 512);
    const SpectralIndices indices = lens.indicesAt(options.wavelengthNm);
    report.direct = estimatePath(lens, indices, report.grid, report.enteringAreaMm2, GhostPath{}, options);

    const std::vector<GhostPath> paths = enumerateGhosts(lens, options.order, options.includeSensor);
    report.ghosts.resize(paths.size());
    tbb::parallel_for(size_t{0}, paths.size(), [&](size_t i) {
        report.ghosts[i] = estimatePath(lens, indices, report.grid, report.enteringAreaMm2, paths[i], options);
    });
    // Strongest first; ties keep enumeration order so that reports are deterministic.
    std::stable_sort(report.ghosts.begin(), report.ghosts.end(),
                     [](const GhostEstimate& a, const GhostEstimate& b) { return a.powerFraction > b.powerFraction; });
    pruneGhosts(report.ghosts, options.keepShare, options.relativeThreshold);
    for (const GhostEstimate& g : report.ghosts) {
        report.totalGhostPowerFraction += g.powerFraction;
        if (g.pruned) {
            ++report.prunedCount;
            report.prunedPowerFraction += g.powerFraction;
        }
    }
    return report;
}

}  // namespace flare
