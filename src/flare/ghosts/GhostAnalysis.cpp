#include "flare/ghosts/GhostAnalysis.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/partitioner.h>

#include "flare/ghosts/PupilMesh.h"
#include "flare/optics/BundleTracer.h"
#include "flare/optics/SequentialTracer.h"

namespace flare {

int LivePupilRegion::liveCount() const {
    return static_cast<int>(std::count(live.begin(), live.end(), std::uint8_t{1}));
}

namespace {

GhostEstimate estimate(const LensSystem& lens, const SpectralIndices& indices, const InterfaceTables* tables,
                       const PupilGrid& grid, double enteringAreaMm2, const GhostPath& ghost,
                       const GhostAnalysisOptions& options) {
    GhostEstimate estimate;
    estimate.path = ghost;
    estimate.paraxial = analyseGhostParaxial(lens, indices, ghost);

    const BundleTracer tracer(lens, indices, ghost.reflections, true, tables);
    PupilMeshOptions search;
    search.windowMinMm = glm::dvec2(-grid.halfSizeMm);
    search.windowSizeMm = 2.0 * grid.halfSizeMm;
    search.baseCells = options.coarseCells;
    search.minCellsAcross = options.fineCells;
    search.minLivePoints = options.minLivePoints;
    search.minPassingPoints = options.minPassingPoints;
    search.requireOnSensor = true;
    search.maxRays = options.maxRaysPerPath;
    const PupilMesh mesh = meshLiveRegion(tracer, grid, search);
    estimate.pupil = mesh.region;
    estimate.lattice = mesh.lattice;
    estimate.tracedRays = mesh.tracedRays;
    estimate.resolved = mesh.resolved;
    if (mesh.empty()) return estimate;

    double power = 0.0;
    glm::dvec2 lo(1e300), hi(-1e300);
    for (const PupilTriangle& t : mesh.triangles) {
        power += t.power();
        for (const PupilVertex& v : t.v) {
            lo = glm::min(lo, v.sensorMm);
            hi = glm::max(hi, v.sensorMm);
        }
    }
    estimate.powerFraction = power / enteringAreaMm2;
    if (power == 0.0) return estimate;
    estimate.footprintMinMm = lo;
    estimate.footprintMaxMm = hi;

    // Peak irradiance from a 32 × 32 histogram over the footprint, each triangle's power at its
    // image's centroid: robust against the infinite density of caustics (fold lines) that a
    // per-triangle Jacobian would report.
    constexpr int kBins = 32;
    const glm::dvec2 extent = glm::max(hi - lo, glm::dvec2(1e-3));
    std::vector<double> bins(kBins * kBins, 0.0);
    for (const PupilTriangle& t : mesh.triangles) {
        const glm::dvec2 centroid = (t.v[0].sensorMm + t.v[1].sensorMm + t.v[2].sensorMm) / 3.0;
        const glm::dvec2 u = (centroid - lo) / extent;
        const int bx = std::clamp(static_cast<int>(u.x * kBins), 0, kBins - 1);
        const int by = std::clamp(static_cast<int>(u.y * kBins), 0, kBins - 1);
        bins[by * kBins + bx] += t.power();
    }
    const double binArea = (extent.x / kBins) * (extent.y / kBins);
    estimate.peakIrradianceRatio = *std::max_element(bins.begin(), bins.end()) / binArea;
    return estimate;
}

}  // namespace

GhostEstimate estimatePath(const LensSystem& lens, const SpectralIndices& indices, const PupilGrid& grid,
                           double enteringAreaMm2, const GhostPath& ghost, const GhostAnalysisOptions& options) {
    return estimate(lens, indices, nullptr, grid, enteringAreaMm2, ghost, options);
}

std::vector<bool> prunedByPower(const std::vector<double>& powers, double keepShare, double relativeThreshold) {
    double total = 0.0;
    for (double p : powers) total += p;
    const double strongest = powers.empty() ? 0.0 : powers.front();
    std::vector<bool> pruned(powers.size());
    double cumulative = 0.0;
    for (size_t i = 0; i < powers.size(); ++i) {
        const bool withinShare = cumulative < keepShare * total;
        const bool aboveThreshold = powers[i] > relativeThreshold * strongest;
        pruned[i] = powers[i] == 0.0 || !(withinShare || aboveThreshold);
        cumulative += powers[i];
    }
    return pruned;
}

void pruneGhosts(std::vector<GhostEstimate>& ghosts, double keepShare, double relativeThreshold) {
    std::vector<double> powers;
    for (const GhostEstimate& g : ghosts) powers.push_back(g.powerFraction);
    const std::vector<bool> pruned = prunedByPower(powers, keepShare, relativeThreshold);
    for (size_t i = 0; i < ghosts.size(); ++i) ghosts[i].pruned = pruned[i];
}

PathSpectrum pathSpectrum(const LensSystem& lens, const PupilGrid& grid, const GhostEstimate& estimate,
                          const Spectrum& spectrum, double analysisWavelengthNm, int stepNm) {
    const LivePupilRegion& region = estimate.pupil;
    auto cellCentre = [&](int i, int j) {
        return glm::dvec2(region.aMinMm + (i + 0.5) * region.cellMm, region.bMinMm + (j + 0.5) * region.cellMm);
    };
    auto live = [&](int i, int j) { return region.live[static_cast<size_t>(j) * region.cellsA + i] != 0; };
    glm::dvec2 centre(0.0);
    int count = 0;
    for (int j = 0; j < region.cellsB; ++j)
        for (int i = 0; i < region.cellsA; ++i)
            if (live(i, j)) centre += cellCentre(i, j), ++count;
    if (count == 0) return {};
    centre /= count;
    glm::dvec2 nearest = centre;
    double nearestMm2 = 1e300;
    for (int j = 0; j < region.cellsB; ++j)
        for (int i = 0; i < region.cellsA; ++i) {
            const glm::dvec2 d = cellCentre(i, j) - centre;
            if (live(i, j) && glm::dot(d, d) < nearestMm2) nearest = cellCentre(i, j), nearestMm2 = glm::dot(d, d);
        }
    SequentialPath sequence;
    sequence.reflections = estimate.path.reflections;
    PathSpectrum out;
    if (stepNm <= 1) out.throughput.assign(kWavelengthBins, 0.0);
    double luminance = 0.0, reflectedLuminance = 0.0;
    for (int i = 0; i < kWavelengthBins; i += std::max(stepNm, 1)) {
        const double nm = kCieMinNm + i + 0.5;
        const TraceResult r = tracePath(lens, lens.indicesAt(nm), grid.ray(nearest.x, nearest.y), sequence);
        const double throughput = r.ok() ? r.throughput : 0.0;
        if (stepNm <= 1) out.throughput[i] = throughput;
        const double y = spectrum.value(nm) * cieXyzBar(nm).y;
        luminance += y;
        reflectedLuminance += y * throughput;
    }
    const TraceResult atAnalysis =
        tracePath(lens, lens.indicesAt(analysisWavelengthNm), grid.ray(nearest.x, nearest.y), sequence);
    if (atAnalysis.ok() && atAnalysis.throughput > 0.0 && reflectedLuminance > 0.0)
        out.ratio = (reflectedLuminance / luminance) / atAnalysis.throughput;
    return out;
}

int keepSpectrallyStrongGhosts(const LensSystem& lens, const Spectrum& spectrum, const GhostAnalysisOptions& options,
                               GhostReport& report, std::vector<PathSpectrum>* spectra) {
    std::vector<PathSpectrum> own;
    std::vector<PathSpectrum>& shapes = spectra ? *spectra : own;
    if (!spectra) {
        own.resize(report.ghosts.size());
        tbb::parallel_for(0, static_cast<int>(report.ghosts.size()), [&](int g) {
            const GhostEstimate& estimate = report.ghosts[g];
            if (estimate.powerFraction > 0.0 && estimate.path.reflections.size() == 2)
                own[g] = pathSpectrum(lens, report.grid, estimate, spectrum, options.wavelengthNm, kPruningStepNm);
        });
    }
    // (ghost index, its power in this light), strongest first (ties in report order).
    std::vector<std::pair<size_t, double>> byLight;
    for (size_t g = 0; g < report.ghosts.size(); ++g)
        if (report.ghosts[g].path.reflections.size() == 2)
            byLight.push_back({g, report.ghosts[g].powerFraction * shapes[g].ratio});
    std::stable_sort(byLight.begin(), byLight.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
    std::vector<double> powers;
    for (const auto& [g, power] : byLight) powers.push_back(power);
    const std::vector<bool> pruned = prunedByPower(powers, options.keepShare, options.relativeThreshold);
    int kept = 0;
    for (size_t k = 0; k < byLight.size(); ++k) {
        GhostEstimate& estimate = report.ghosts[byLight[k].first];
        if (estimate.pruned && !pruned[k]) {
            estimate.pruned = false;
            --report.prunedCount;
            report.prunedPowerFraction -= estimate.powerFraction;
            ++kept;
        }
    }
    return kept;
}

namespace {

// appendGhostPaths with the indices and the Fresnel/coating factors at the analysis's wavelength.
void appendGhostPaths(const LensSystem& lens, const SpectralIndices& indices, const InterfaceTables& tables,
                      const std::vector<GhostPath>& paths, const GhostAnalysisOptions& options, GhostReport& report) {
    std::vector<GhostEstimate> estimates(paths.size());
    // One path per task: their costs differ by orders of magnitude (a path dead at the second
    // surface against a live one meeting fifty), so let TBB balance them one by one.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, paths.size(), 1),
                      [&](const tbb::blocked_range<size_t>& range) {
                          for (size_t i = range.begin(); i != range.end(); ++i)
                              estimates[i] = estimate(lens, indices, &tables, report.grid, report.enteringAreaMm2,
                                                      paths[i], options);
                      },
                      tbb::simple_partitioner());
    // Strongest first; ties keep enumeration order so that reports are deterministic.
    std::stable_sort(estimates.begin(), estimates.end(),
                     [](const GhostEstimate& a, const GhostEstimate& b) { return a.powerFraction > b.powerFraction; });
    pruneGhosts(estimates, options.keepShare, options.relativeThreshold);
    for (GhostEstimate& g : estimates) {
        report.totalGhostPowerFraction += g.powerFraction;
        if (g.pruned) {
            ++report.prunedCount;
            report.prunedPowerFraction += g.powerFraction;
        }
        report.ghosts.push_back(std::move(g));
    }
}

}  // namespace

void appendGhostPaths(const LensSystem& lens, const std::vector<GhostPath>& paths, const GhostAnalysisOptions& options,
                      GhostReport& report) {
    const SpectralIndices indices = lens.indicesAt(options.wavelengthNm);
    // The Fresnel/coating factors, tabulated once for all paths.
    const InterfaceTables tables(lens, indices);
    appendGhostPaths(lens, indices, tables, paths, options, report);
}

GhostReport analyseGhosts(const LensSystem& lens, const glm::dvec3& lightDirection,
                          const GhostAnalysisOptions& options) {
    return analyseGhosts(lens, PupilGrid::forDirection(lens, lightDirection), options);
}

GhostReport analyseGhosts(const LensSystem& lens, const PupilGrid& grid, const GhostAnalysisOptions& options) {
    GhostReport report;
    report.wavelengthNm = options.wavelengthNm;
    report.grid = grid;
    report.enteringAreaMm2 = report.grid.enteringAreaMm2(lens, 512);
    const SpectralIndices indices = lens.indicesAt(options.wavelengthNm);
    // The Fresnel/coating factors, tabulated once for all paths.
    const InterfaceTables tables(lens, indices);
    // The direct image alongside the ghosts (it is one of the larger tasks).
    tbb::parallel_invoke(
        [&] { report.direct = estimate(lens, indices, &tables, report.grid, report.enteringAreaMm2, GhostPath{}, options); },
        [&] {
            appendGhostPaths(lens, indices, tables, enumerateGhosts(lens, options.order, options.includeSensor), options,
                             report);
        });
    return report;
}

}  // namespace flare
