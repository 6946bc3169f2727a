#include "flare/render/Render.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <fstream>
#include <memory>
#include <numbers>
#include <span>
#include <unordered_map>

#include <glm/geometric.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "flare/core/Error.h"
#include "flare/core/Random.h"
#include "flare/core/ScrambledSobol.h"
#include "flare/ghosts/GuideMask.h"
#include "flare/optics/PacketTracer.h"
#include "flare/optics/SequentialTracer.h"
#include "flare/photons/LightSampler.h"
#include "flare/render/GhostBeam.h"

namespace flare {

const char* renderLayerName(int layer) {
    switch (layer) {
        case kLayerDirect: return "direct";
        case kLayerGhost: return "ghost";
        case kLayerHigher: return "higher";
        case kLayerScatter: return "scatter";
        default: return "?";
    }
}

const char* toString(PathStrategy strategy) {
    switch (strategy) {
        case PathStrategy::Unguided: return "unguided";
        case PathStrategy::Photons: return "photons";
        case PathStrategy::Beams: return "beams";
    }
    return "?";
}

namespace {

constexpr double kMm2PerM2 = 1e6;
// Guide masks reach this far beyond the analysed live region (cells) and beyond the sensor (a
// fraction of its half-diagonal): dispersion across the visible and the sun's 0.5° move a
// ghost's landings by up to about a millimetre on a full-frame sensor.
constexpr int kGuideGrowCells = 4;
constexpr double kGuideSensorMargin = 0.1;
// A beam-rendered path's wavelengths are drawn in proportion to the light's spectrum times the
// throughput of one ray of the path, plus this share of its mean: coatings make a ghost's colour,
// and the floor keeps every wavelength possible.
constexpr double kSpectralFloor = 0.1;
constexpr int kBeamDimensions = 5;  // wavelength, direction (2), film-kernel jitter (2)
constexpr int kBeamTableIntervals = 128;
// The largest share of its layer's power a single beam is expected to carry (a floor under the
// weak paths' beam rates).
constexpr double kMaxBeamShare = 0.05;
// The share of the beam budget that may go to giving every beam-rendered path of a layer a beam
// per pass (per layer: the ghosts, the order-4 chains).
constexpr double kFloorBudgetShare = 0.1;

struct Hit {
    float xMm, yMm;
    float xyz[3];
    std::int16_t layer;
    std::int32_t ghostLayer;  // −1: none
};

// Shirley and Chiu's concentric map of the unit square onto the unit disk, as (r², φ / 2π): the
// uniforms LightSampler::rayThrough takes for a point of the light's disk. It keeps the
// stratification of the square (neighbouring strata map to neighbouring parts of the disk).
glm::dvec2 concentricToPolarUniforms(double s, double t) {
    const double a = 2.0 * s - 1.0, b = 2.0 * t - 1.0;
    if (a == 0.0 && b == 0.0) return {0.0, 0.0};
    double r = 0.0, phi = 0.0;
    if (std::abs(a) > std::abs(b)) {
        r = a;
        phi = 0.25 * std::numbers::pi * (b / a);
    } else {
        r = b;
        phi = 0.5 * std::numbers::pi - 0.25 * std::numbers::pi * (a / b);
    }
    if (r < 0.0) r = -r, phi += std::numbers::pi;
    double u2 = phi / (2.0 * std::numbers::pi);
    u2 -= std::floor(u2);
    return {std::min(r * r, std::nextafter(1.0, 0.0)), std::min(u2, std::nextafter(1.0, 0.0))};
}

}  // namespace

struct Renderer::LightState {
    LightSampler sampler;
    WavelengthSampler wavelengths;
    GhostReport report;
    // Slots: 0 the direct image, 1..G the enumerated ghosts in report order.
    std::unordered_map<PathKey, int> slotOfKey;
    std::vector<GuideMask> masks;           // per slot; empty where the slot is not guided
    std::vector<int> ghostLayer;            // per slot: per-ghost film layer, −1 if none
    std::vector<PathStrategy> strategy;     // per slot
    std::vector<int> layer;                 // per slot: the fixed layer its light lands in
    // Beam-rendered slots: the wavelength sampler weighted by the path's throughput, and the
    // expected number of beams per pass (a pass draws its floor, plus one more with the
    // probability of its fraction, and weights every beam by one over the expectation).
    std::vector<std::unique_ptr<WavelengthSampler>> beamWavelengths;
    std::vector<double> beamRate;
    int tallyOffset = 0;                    // tallies: offset + slot, then higher, then scatter
    int slots = 0;

    int higherTally() const { return tallyOffset + slots; }
    int scatterTally() const { return tallyOffset + slots + 1; }
};

struct Renderer::Component {
    int light = 0;
    int slot = -1;  // −1: the unguided tracer
    double probability = 0.0;
    // A guided path's forced sequence in SIMD packets, its photons at their own wavelengths.
    std::shared_ptr<const PacketTracer> tracer;
};

constexpr int kScatterSources = static_cast<int>(ScatterSource::Count) - 1;

struct Renderer::BatchResult {
    std::vector<Hit> hits;
    std::vector<double> tallySums;  // Σ Y power (W) per tally
    double layerSums[kFixedLayerCount] = {};
    double sourceSums[kScatterSources] = {};
    RenderStatistics statistics;    // photon counts and fates of this batch
};

// One beam of one path in one pass, and what it produced.
struct Renderer::BeamJob {
    int light = 0, slot = 0, index = 0;  // index: the beam's number within the path's pass
    int replicate = 0;
    std::uint64_t sequenceIndex = 0;     // the beam's point in its replicate's sequence
    GhostBeam beam;
    glm::dvec2 jitterPx{0.0};
    glm::dvec3 scale{0.0};     // film units per unit irradiance × pupil area
    std::uint64_t seed = 0;    // the small triangles' random points
    std::vector<Hit> hits;     // correction photons (+) and their twins (−)
    double powerY = 0.0;       // the beam's Y power on the sensor plus its corrections (W)
    std::int64_t photons = 0;
};

Renderer::Renderer(const LensSystem& lens, const std::vector<LightSpec>& lights, const RenderOptions& options)
    : lens_(&lens), options_(options), indexTable_(lens),
      tracer_(lens, options.materials, options.maxBounces, options.contamination, options.media),
      film_(options.film, kFixedLayerCount) {
    if (options.beamReplicates < 2 || options.beamReplicates > kMaxReplicates)
        throw std::invalid_argument("RenderOptions: beamReplicates must be in [2, " + std::to_string(kMaxReplicates) + "]");
    for (int l = 0; l < kFixedLayerCount; ++l) layerNames_.push_back(renderLayerName(l));
    if (options.tabulatedReflectance) tracer_.tabulateReflectance();
    if (options.strayLightSampling && options.mode != RenderOptions::Mode::Naive)
        tracer_.setStrayLightSampling({.weighted = true, .connectSensor = true});
    std::unordered_map<std::string, int> ghostLayerOfLabel;
    const InteriorMaterials& m = options.materials;
    const bool anyScattering = m.housingAlbedo + m.edgeAlbedo + m.irisAlbedo + m.housingGlossy + m.edgeGlossy +
                                       m.irisGlossy > 0.0 ||
                               tracer_.hasContamination() || tracer_.hasMedia();
    // Beams are splatted with the fixed 1-px tent: other kernels leave the ghosts to photons.
    const bool beamsPossible = options.mode == RenderOptions::Mode::Guided &&
                               options.film.kernel == FilmSettings::Kernel::Fixed && options.film.radiusPx <= 1.0;
    const FilmFrame frame{options.film.widthPx, options.film.heightPx, options.film.widthMm, options.film.heightMm,
                          options.film.widthMm / options.film.widthPx};

    std::vector<double> lightWeight;
    for (const LightSpec& spec : lights) {
        LightState state{LightSampler(spec, lens), WavelengthSampler(toSpectrum(spec.spectrum)),
                         analyseGhosts(lens, spec.travelDirection(), options.analysis), {}, {}, {}, {}, {}, {}, {}, 0, 0};
        LightPlan plan;
        plan.name = spec.name;
        // Longer chains: the strongest order-4 paths are enumerated and guided too when the lens's
        // reflectances make them matter (uncoated glass: a few per cent of the ghosts' power),
        // else they stay with the unguided tracer (coated glass: about R² of the ghosts').
        plan.higherOrderShareEstimate = higherOrderShareEstimate(
            lens, lens.indicesAt(options.analysis.wavelengthNm), options.analysis.includeSensor);
        std::vector<GhostPath> chains;
        if (options.mode != RenderOptions::Mode::Naive && options.analysis.order == 2 &&
            options.higherOrder != RenderOptions::HigherOrder::Off) {
            chains = enumerateGhosts(lens, 4, options.analysis.includeSensor);
            plan.higherOrderChains = static_cast<long>(chains.size());
        }
        const bool tooMany = chains.size() > static_cast<size_t>(std::max(options.maxAnalysedChains, 0));
        if (options.mode == RenderOptions::Mode::Naive) {
            plan.higherOrderWhy = "naive mode guides nothing";
        } else if (options.analysis.order != 2) {
            plan.higherOrderWhy = "enumerated with the ghosts (ghost_order 4)";
        } else if (options.higherOrder == RenderOptions::HigherOrder::Off) {
            plan.higherOrderWhy = "left to the unguided tracer: --higher-order off";
        } else if (options.higherOrder == RenderOptions::HigherOrder::On) {
            plan.higherOrderGuided = true;
            plan.higherOrderWhy = tooMany ? "--higher-order on: the strongest chains by reflectance analysed"
                                          : "--higher-order on";
        } else if (plan.higherOrderShareEstimate < options.higherOrderThreshold) {
            plan.higherOrderWhy = "left to the unguided tracer: their estimated share is below the threshold";
        } else if (tooMany) {
            plan.higherOrderWhy = "left to the unguided tracer: too many chains to analyse them all "
                                  "(--higher-order on analyses the strongest by reflectance)";
        } else {
            plan.higherOrderGuided = true;
            plan.higherOrderWhy = "the lens's reflectances make order-4 chains matter";
        }
        if (plan.higherOrderGuided) {
            // Their power spreads over hundreds of paths, and vignetting, not the reflectances,
            // decides which are strong: every chain is analysed, up to maxAnalysedChains; past
            // that (with --higher-order on; a zoom has 10⁵ chains: minutes of analysis) the
            // strongest by reflectance.
            if (tooMany) {
                const SpectralIndices at = lens.indicesAt(options.analysis.wavelengthNm);
                std::vector<std::pair<double, size_t>> ranked;
                for (size_t c = 0; c < chains.size(); ++c)
                    ranked.push_back({-normalIncidenceReflectance(lens, at, chains[c]), c});
                // Strongest first; ties by enumeration order, so the choice is deterministic.
                std::partial_sort(ranked.begin(), ranked.begin() + options.maxAnalysedChains, ranked.end());
                std::vector<size_t> keep;
                for (int i = 0; i < options.maxAnalysedChains; ++i) keep.push_back(ranked[i].second);
                std::sort(keep.begin(), keep.end());
                std::vector<GhostPath> strongest;
                for (size_t c : keep) strongest.push_back(std::move(chains[c]));
                chains = std::move(strongest);
            }
            plan.higherOrderAnalysed = static_cast<int>(chains.size());
            const size_t before = state.report.ghosts.size();
            GhostAnalysisOptions chainOptions = options.analysis;
            chainOptions.order = 4;
            chainOptions.keepShare = options.higherOrderKeepShare;
            appendGhostPaths(lens, chains, chainOptions, state.report);
            int kept = 0;
            for (size_t g = before; g < state.report.ghosts.size(); ++g) {
                GhostEstimate& estimate = state.report.ghosts[g];
                if (!estimate.pruned && kept >= options.maxHigherOrderPaths) {
                    estimate.pruned = true;
                    ++state.report.prunedCount;
                    state.report.prunedPowerFraction += estimate.powerFraction;
                }
                kept += !estimate.pruned;
            }
            plan.higherOrderPaths = kept;
        }
        // Every path's spectrum in this light, for the second pruning (GhostAnalysis.h: the
        // analysis pruned at one wavelength; the zoom's ghost-layer fireflies were ghosts it pruned
        // that reflect far more in the blue and red) and for the beams' wavelengths.
        std::vector<PathSpectrum> spectra(state.report.ghosts.size());
        if (options.mode != RenderOptions::Mode::Naive) {
            const Spectrum spectrum = toSpectrum(spec.spectrum);
            // Every nanometre for the kept paths (their beams' wavelengths), every ten for the
            // pruned ghosts (the pruning); then every nanometre for the ghosts the pruning keeps.
            auto trace = [&](bool afterPruning) {
                tbb::parallel_for(0, static_cast<int>(state.report.ghosts.size()), [&](int g) {
                    const GhostEstimate& estimate = state.report.ghosts[g];
                    if (!(estimate.powerFraction > 0.0) || !spectra[g].throughput.empty()) return;
                    const bool ghost = estimate.path.reflections.size() == 2;
                    if (afterPruning ? !estimate.pruned : !estimate.pruned || ghost)
                        spectra[g] = pathSpectrum(lens, state.report.grid, estimate, spectrum, options.analysis.wavelengthNm,
                                                  estimate.pruned ? kPruningStepNm : 1);
                });
            };
            trace(false);
            plan.spectrallyKeptGhosts = keepSpectrallyStrongGhosts(lens, spectrum, options.analysis, state.report, &spectra);
            trace(true);
        }
        const GhostReport& report = state.report;
        state.slots = 1 + static_cast<int>(report.ghosts.size());
        state.tallyOffset = static_cast<int>(tallies_.size());
        state.slotOfKey[pathKey({})] = 0;
        for (size_t g = 0; g < report.ghosts.size(); ++g)
            state.slotOfKey[pathKey(report.ghosts[g].path.reflections)] = static_cast<int>(g) + 1;

        // Nominal entering power: the light's irradiance at the lens times the entering area.
        const double irradianceWPerMm2 =
            spec.type == LightSpec::Type::Directional
                ? spec.power / kMm2PerM2
                : spec.power / glm::dot(spec.positionMm, spec.positionMm);
        plan.enteringPowerW = irradianceWPerMm2 * report.enteringAreaMm2;

        const bool reaches = report.direct.powerFraction > 0.0 ||
                             std::any_of(report.ghosts.begin(), report.ghosts.end(),
                                         [](const GhostEstimate& g) { return g.powerFraction > 0.0; });
        if (!reaches && !anyScattering) {
            plan.skipped = true;
            plan.skipReason = spec.travelDirection().z <= 0.0
                                  ? "the light is behind the lens"
                                  : "no analysed ray of the direct image or of any enumerated ghost reaches the sensor";
        }

        // Tallies of this light: direct, every ghost, higher, scatter.
        PathTally direct;
        direct.kind = PathTally::Kind::Direct;
        direct.light = static_cast<int>(lightPlans_.size());
        direct.analysedPowerFraction = report.direct.powerFraction;
        tallies_.push_back(direct);
        for (const GhostEstimate& g : report.ghosts) {
            PathTally t;
            t.kind = PathTally::Kind::Ghost;
            t.light = direct.light;
            t.path = g.path;
            t.analysedPowerFraction = g.powerFraction;
            tallies_.push_back(t);
        }
        for (PathTally::Kind kind : {PathTally::Kind::Higher, PathTally::Kind::Scatter}) {
            PathTally t;
            t.kind = kind;
            t.light = direct.light;
            tallies_.push_back(t);
        }

        state.masks.resize(state.slots);
        state.ghostLayer.assign(state.slots, -1);
        state.strategy.assign(state.slots, PathStrategy::Unguided);
        state.layer.assign(state.slots, kLayerGhost);
        state.layer[0] = kLayerDirect;
        for (int slot = 1; slot < state.slots; ++slot)
            if (report.ghosts[slot - 1].path.reflections.size() > 2) state.layer[slot] = kLayerHigher;
        state.beamWavelengths.resize(state.slots);
        state.beamRate.assign(state.slots, 0.0);
        std::vector<double> beamWeight(state.slots, 0.0);
        std::vector<double> spectralPower(state.slots, 0.0);  // per slot: power fraction over the spectrum
        if (options.mode != RenderOptions::Mode::Naive && !plan.skipped) {
            // Guide masks: the analysed regions re-traced with a margin around the sensor (see
            // GuideMask::traced), in parallel over paths; each mask is a pure function of its path.
            const SpectralIndices indices = lens.indicesAt(options.analysis.wavelengthNm);
            const double marginMm = kGuideSensorMargin * lens.sensorHalfDiagonalMm();
            const bool beamLight = beamsPossible && spec.type == LightSpec::Type::Directional;
            tbb::parallel_for(0, state.slots, [&](int slot) {
                const GhostEstimate& estimate = slot == 0 ? report.direct : report.ghosts[slot - 1];
                if (slot > 0 && estimate.pruned) return;
                state.masks[slot] = GuideMask::traced(lens, indices, report.grid, estimate.path, estimate.pupil,
                                                      kGuideGrowCells, marginMm);
                if (state.masks[slot].empty()) return;
                state.strategy[slot] = PathStrategy::Photons;
                if (slot == 0 || !beamLight || estimate.lattice.empty()) return;
                // Wavelengths where the path's coatings reflect (its ray's throughput at every
                // nanometre), and the power it carries in this light.
                const PathSpectrum& pathShape = spectra[slot - 1];
                std::vector<double> importance = pathShape.throughput;
                if (importance.empty()) importance.assign(kWavelengthBins, 0.0);
                spectralPower[slot] = estimate.powerFraction * pathShape.ratio;
                double mean = 0.0;
                for (double v : importance) mean += v / kWavelengthBins;
                if (!(mean > 0.0)) std::fill(importance.begin(), importance.end(), 1.0), mean = 1.0;
                for (double& v : importance) v += kSpectralFloor * mean;
                const Spectrum spectrum = toSpectrum(spec.spectrum);
                state.beamWavelengths[slot] = std::make_unique<WavelengthSampler>(spectrum, importance);
                // A beam at the analysis's wavelength and the light's central direction measures
                // what the path's beams will cost and how uneven its image is (Σ power² / area:
                // its squared L2 norm for a point source, which caustics dominate); beams then go
                // to the paths in proportion to √(that / cost), which minimises the summed
                // variance for a given time if a beam's variance follows that norm.
                const BundleTracer probeTracer(lens, indices, estimate.path.reflections);
                PupilRemeshOptions remesh;
                remesh.minLevel = options.beamMeshLevel;
                const GhostBeam probe = GhostBeam::build(probeTracer, report.grid, estimate.lattice, state.masks[slot],
                                                         frame, remesh);
                if (probe.empty()) return;
                double squaredNorm = 0.0, imageAreaPx2 = 0.0;
                for (const BeamTriangle& t : probe.triangles()) {
                    const double power = t.pupilAreaMm2 * (t.throughput[0] + t.throughput[1] + t.throughput[2]) / 3.0;
                    const double area = t.small ? 1.0 : std::max(t.imageAreaPx2, 1.0);
                    squaredNorm += power * power / area;
                    imageAreaPx2 += t.small ? 0.0 : t.imageAreaPx2;
                }
                // Cost in units of a traced ray: rasterising a pixel costs about a tenth of one.
                const double cost = static_cast<double>(probe.tracedRays()) + 0.1 * imageAreaPx2 +
                                    options.correctionPhotonsPerBeam * 2.0;
                beamWeight[slot] = std::sqrt(squaredNorm / cost) * (spectralPower[slot] / estimate.powerFraction);
                state.strategy[slot] = PathStrategy::Beams;
            });
        }
        // Rates: the budget split by weight, with two floors. A weak path drawn with a tiny rate
        // would appear in a few passes only, each time weighted by one over that rate:
        // heavy-tailed, and a short render that drew none would see no spread and report its
        // part as 0 ± 0. So every path of a layer (ghosts; order-4 chains) gets one beam per
        // pass, or, when the layer has too many paths for that, an equal share of
        // kFloorBudgetShare of the budget; and no beam is expected to carry more than
        // kMaxBeamShare of its layer's power (over the spectrum), a floor that sums to at most
        // 1 / kMaxBeamShare beams per layer.
        double totalBeamWeight = 0.0;
        double layerPower[kFixedLayerCount] = {};
        int layerPaths[kFixedLayerCount] = {};
        for (int slot = 1; slot < state.slots; ++slot) {
            totalBeamWeight += beamWeight[slot];
            if (state.strategy[slot] != PathStrategy::Beams) continue;
            layerPower[state.layer[slot]] += spectralPower[slot];
            ++layerPaths[state.layer[slot]];
        }
        for (int slot = 1; slot < state.slots; ++slot)
            if (state.strategy[slot] == PathStrategy::Beams) {
                const int layer = state.layer[slot];
                const double everyPathFloor = std::min(1.0, kFloorBudgetShare * options.beamsPerPass / layerPaths[layer]);
                const double shareFloor = spectralPower[slot] / (kMaxBeamShare * layerPower[layer]);
                state.beamRate[slot] = std::max({options.beamsPerPass * beamWeight[slot] / totalBeamWeight,
                                                 shareFloor, everyPathFloor});
                ++plan.beamGhosts;
            }
        for (size_t g = 0; g < report.ghosts.size(); ++g) {
            const bool chain = report.ghosts[g].path.reflections.size() > 2;
            if (report.ghosts[g].pruned) {
                plan.prunedGhosts += !chain;
                continue;
            }
            plan.keptGhosts += !chain;
            if (!options.perGhostLayers) continue;
            const std::string label = report.ghosts[g].path.label();
            auto [it, inserted] = ghostLayerOfLabel.try_emplace(label, static_cast<int>(layerNames_.size()));
            if (inserted) layerNames_.push_back(label);
            state.ghostLayer[g + 1] = it->second;
        }
        for (int slot = 0; slot < state.slots; ++slot) {
            tallies_[state.tallyOffset + slot].strategy = state.strategy[slot];
            tallies_[state.tallyOffset + slot].guided = state.strategy[slot] != PathStrategy::Unguided;
        }

        lightWeight.push_back(plan.skipped ? 0.0 : plan.enteringPowerW);
        lightStates_.push_back(std::move(state));
        lightPlans_.push_back(plan);
    }
    for (PathTally::Kind kind : {PathTally::Kind::Direct, PathTally::Kind::Ghost, PathTally::Kind::Higher,
                                 PathTally::Kind::Scatter}) {
        PathTally t;
        t.kind = kind;
        t.light = -1;
        layerTallies_.push_back(t);
    }
    for (int source = 0; source < kScatterSources; ++source) {
        PathTally t;
        t.kind = PathTally::Kind::Scatter;
        t.light = -1;
        scatterSourceTallies_.push_back(t);
    }
    // With per-path layers, the scatter layer split by what the light met first, for the sources
    // this scene has (the report's scatter_sources split the power the same way).
    scatterSourceLayer_.assign(kScatterSources, -1);
    if (options.perGhostLayers) {
        bool dust = false, grease = false;
        for (const SurfaceContamination& c : options.contamination)
            dust = dust || c.dustCoverage > 0.0, grease = grease || c.greaseCoverage > 0.0;
        const bool present[kScatterSources] = {
            m.housingAlbedo + m.edgeAlbedo + m.irisAlbedo + m.housingGlossy + m.edgeGlossy + m.irisGlossy > 0.0, dust,
            grease, !options.media.empty()};
        for (int source = 0; source < kScatterSources; ++source) {
            if (!present[source]) continue;
            scatterSourceLayer_[source] = static_cast<int>(layerNames_.size());
            layerNames_.push_back(std::string("scatter_") + toString(static_cast<ScatterSource>(source + 1)));
        }
    }
    if (layerNames_.size() > kFixedLayerCount) film_ = Film(options.film, static_cast<int>(layerNames_.size()));
    if (options.smoothNeighbours > 0 && options.film.kernel == FilmSettings::Kernel::Fixed) {
        const double maxRadiusPx = std::max(options.film.maxRadiusPx, options.film.widthPx / 16.0);
        film_.setLayerKernel(kLayerScatter, FilmSettings::Kernel::Adaptive, options.smoothNeighbours, maxRadiusPx, true);
        // The higher layer's photons too (its beams are rasterised exactly, whatever the kernel):
        // what the guided chains leave to the unguided tracer, a few sparse photons.
        film_.setLayerKernel(kLayerHigher, FilmSettings::Kernel::Adaptive, options.smoothNeighbours, maxRadiusPx, true);
        for (int layer : scatterSourceLayer_)
            if (layer >= 0)
                film_.setLayerKernel(layer, FilmSettings::Kernel::Adaptive, options.smoothNeighbours, maxRadiusPx, true);
    }
    for (int l = 0; l < kFixedLayerCount; ++l) film_.addVarianceGroup({l});
    film_.addVarianceGroup({kLayerGhost, kLayerHigher, kLayerScatter});
    // Beams continue their sequences from pass to pass: the error is estimated from replicates.
    bool anyBeams = false;
    for (const LightState& light : lightStates_) {
        beamsDrawn_.emplace_back(static_cast<size_t>(light.slots) * options.beamReplicates, 0);
        for (int slot = 1; slot < light.slots; ++slot) anyBeams = anyBeams || light.beamRate[slot] > 0.0;
    }
    if (anyBeams) film_.setReplicates(options.beamReplicates);

    // The photon budget: lights in proportion to the power they send in (every photon then
    // carries a similar power); within a light, the unguided share, the direct share, and the
    // photon-guided ghosts in proportion to their analysed power (floored, so that a ghost the
    // analysis underrates still gets photons).
    double totalWeight = 0.0;
    for (double w : lightWeight) totalWeight += w;
    for (size_t l = 0; l < lightStates_.size() && totalWeight > 0.0; ++l) {
        const double share = lightWeight[l] / totalWeight;
        if (share == 0.0) continue;
        const LightState& state = lightStates_[l];
        if (options.mode == RenderOptions::Mode::Naive) {
            components_.push_back({static_cast<int>(l), -1, share});
            continue;
        }
        double strongest = 0.0;
        for (int slot = 1; slot < state.slots; ++slot)
            if (state.strategy[slot] == PathStrategy::Photons)
                strongest = std::max(strongest, state.report.ghosts[slot - 1].powerFraction);
        std::vector<double> ghostWeight(state.slots, 0.0);
        double ghostTotal = 0.0;
        for (int slot = 1; slot < state.slots; ++slot) {
            if (state.strategy[slot] != PathStrategy::Photons) continue;
            ghostWeight[slot] = std::max(state.report.ghosts[slot - 1].powerFraction, 1e-3 * strongest);
            ghostTotal += ghostWeight[slot];
        }
        double directShare = state.strategy[0] == PathStrategy::Photons ? options.directShare : 0.0;
        double unguidedShare = options.unguidedShare;
        double ghostShare = ghostTotal > 0.0 ? 1.0 - unguidedShare - directShare : 0.0;
        if (ghostShare == 0.0) {
            const double sum = unguidedShare + directShare;
            unguidedShare /= sum;
            directShare /= sum;
        }
        components_.push_back({static_cast<int>(l), -1, share * unguidedShare});
        if (directShare > 0.0) components_.push_back({static_cast<int>(l), 0, share * directShare});
        for (int slot = 1; slot < state.slots; ++slot)
            if (ghostWeight[slot] > 0.0)
                components_.push_back({static_cast<int>(l), slot, share * ghostShare * ghostWeight[slot] / ghostTotal});
    }
    double cumulative = 0.0;
    for (const Component& c : components_) componentCdf_.push_back(cumulative += c.probability);
    // (Its steps do not depend on the wavelength it is built at: each photon refracts at its own.)
    for (Component& c : components_) {
        if (c.slot < 0) continue;
        const LightState& state = lightStates_[c.light];
        const std::span<const int> reflections =
            c.slot == 0 ? std::span<const int>() : std::span<const int>(state.report.ghosts[c.slot - 1].path.reflections);
        c.tracer = std::make_shared<const PacketTracer>(BundleTracer(lens, lens.indicesAt(kLineDNm), reflections, true));
    }
    if (!componentCdf_.empty()) componentCdf_.back() = 1.0;
    batches_.resize(options.batchesPerPass);
}

Renderer::~Renderer() = default;

void Renderer::traceBatch(std::int64_t batchIndex, BatchResult& out) const {
    out.hits.clear();
    out.tallySums.assign(tallies_.size(), 0.0);
    std::fill(std::begin(out.layerSums), std::end(out.layerSums), 0.0);
    std::fill(std::begin(out.sourceSums), std::end(out.sourceSums), 0.0);
    out.statistics = RenderStatistics{};
    RenderStatistics& stats = out.statistics;
    if (components_.empty()) {
        stats.photons = options_.batchPhotons;
        return;
    }
    Rng rng(options_.seed, static_cast<std::uint64_t>(batchIndex));
    const LensSystem& lens = *lens_;
    const double halfW = 0.5 * lens.sensor().widthMm, halfH = 0.5 * lens.sensor().heightMm;
    std::vector<int> noReflections;
    SequentialPath sequence;
    const std::unique_ptr<PhotonTracer::Scratch> scratch = tracer_.makeScratch();
    // Guided paths own only unscattered light: with dust, grease or bulk media their weight is the
    // probability of crossing them clear, which needs the path's points.
    const bool clearWeight = tracer_.hasContamination() || tracer_.hasMedia();
    std::vector<glm::dvec3> pathPoints;
    std::vector<int> pathSurfaces;
    TraceOptions guidedOptions;
    if (clearWeight) {
        guidedOptions.pathPointsMm = &pathPoints;
        guidedOptions.pathSurfaces = &pathSurfaces;
    }

    auto score = [&](int layer, int ghostLayer, int tally, const glm::dvec2& sensorMm, const glm::dvec3& xyzW) {
        out.hits.push_back({static_cast<float>(sensorMm.x), static_cast<float>(sensorMm.y),
                            {static_cast<float>(xyzW.x), static_cast<float>(xyzW.y), static_cast<float>(xyzW.z)},
                            static_cast<std::int16_t>(layer), ghostLayer});
        out.tallySums[tally] += xyzW.y;
        out.layerSums[layer] += xyzW.y;
        stats.largestPhotonY[layer] = std::max(stats.largestPhotonY[layer], xyzW.y);
        ++stats.sensorHits;
    };

    // Unguided photons waiting to be traced together, and what scoring them needs.
    struct Pending {
        double a = 0.0, b = 0.0;  // the emission point (mm in the emission disk)
        double weight = 0.0;      // W
        glm::dvec3 xyzWeight{0.0};
        int light = 0;
    };
    constexpr size_t kPacketPhotons = 256;
    const std::uint64_t walkSeed = mixBits(options_.seed ^ 0x3a1f5c0de0f7a1c5ull);
    const std::uint64_t walkStream = static_cast<std::uint64_t>(batchIndex) * static_cast<std::uint64_t>(options_.batchPhotons);
    // Guided photons waiting for their paths' packets (the whole batch's), and what scoring them
    // needs.
    struct GuidedPending {
        int component = 0;
        double weight = 0.0;  // W
        glm::dvec3 xyzWeight{0.0};
    };
    // (Per thread and kept from batch to batch: the histories alone are 400 KB.)
    struct PacketBuffers {
        std::vector<Pending> pending;
        std::vector<SpectralIndices> indices = std::vector<SpectralIndices>(kPacketPhotons);
        std::vector<PhotonTracer::PacketPhoton> packet;
        std::vector<PhotonHistory> histories = std::vector<PhotonHistory>(kPacketPhotons);
        std::vector<GuidedPending> guided;
        std::vector<Ray> guidedRays, sortedRays;
        std::vector<SpectralIndices> guidedIndices;
        std::vector<const SpectralIndices*> sortedIndices;
        std::vector<BundleLanding> landings;
        std::vector<int> start, position;
    };
    static thread_local PacketBuffers buffers;
    std::vector<Pending>& pending = buffers.pending;
    std::vector<SpectralIndices>& pendingIndices = buffers.indices;
    std::vector<PhotonTracer::PacketPhoton>& packet = buffers.packet;
    std::vector<PhotonHistory>& histories = buffers.histories;
    pending.clear();
    packet.clear();
    // Guided photons are traced at the end of the batch, each path's together in SIMD packets
    // (PacketTracer, each photon at its own wavelength: tracePath's results to the bit), and
    // scored in the order they were drawn. With dust, grease or media their clear transmittance
    // draws from the batch's generator in that order, so they are traced one at a time there.
    const bool guidedInPackets = !clearWeight;
    std::vector<GuidedPending>& guided = buffers.guided;
    guided.clear();
    if (guidedInPackets && buffers.guidedIndices.size() < static_cast<size_t>(options_.batchPhotons))
        buffers.guidedIndices.resize(static_cast<size_t>(options_.batchPhotons));
    buffers.guidedRays.clear();
    SpectralIndices oneIndices;  // a guided photon's, traced at once
    auto traceGuided = [&] {
        const size_t count = guided.size();
        if (count == 0) return;
        // A counting sort by path.
        std::vector<int>& start = buffers.start;
        std::vector<int>& position = buffers.position;
        start.assign(components_.size() + 1, 0);
        for (const GuidedPending& g : guided) ++start[g.component + 1];
        for (size_t c = 0; c < components_.size(); ++c) start[c + 1] += start[c];
        position.resize(count);
        buffers.sortedRays.resize(count);
        buffers.sortedIndices.resize(count);
        buffers.landings.resize(count);
        {
            std::vector<int> next(start.begin(), start.end() - 1);
            for (size_t j = 0; j < count; ++j) {
                const int at = next[guided[j].component]++;
                position[j] = at;
                buffers.sortedRays[at] = buffers.guidedRays[j];
                buffers.sortedIndices[at] = &buffers.guidedIndices[j];
            }
        }
        for (size_t c = 0; c < components_.size(); ++c) {
            const size_t from = static_cast<size_t>(start[c]), n = static_cast<size_t>(start[c + 1]) - from;
            if (n == 0) continue;
            components_[c].tracer->trace(std::span<const Ray>(buffers.sortedRays).subspan(from, n),
                                         std::span<const SpectralIndices* const>(buffers.sortedIndices).subspan(from, n),
                                         std::span<BundleLanding>(buffers.landings).subspan(from, n));
        }
        for (size_t j = 0; j < count; ++j) {
            const GuidedPending& g = guided[j];
            const BundleLanding& landing = buffers.landings[position[j]];
            if (!landing.ok()) continue;
            const glm::dvec2& p = landing.sensorMm;
            if (std::abs(p.x) > halfW || std::abs(p.y) > halfH) continue;
            const Component& component = components_[g.component];
            const LightState& light = lightStates_[component.light];
            score(light.layer[component.slot], light.ghostLayer[component.slot], light.tallyOffset + component.slot, p,
                  g.xyzWeight * (g.weight * landing.throughput));
        }
        guided.clear();
        buffers.guidedRays.clear();
    };
    auto tracePending = [&] {
        if (pending.empty()) return;
        tracer_.tracePacket(packet, std::span(histories).first(packet.size()), *scratch);
        for (size_t i = 0; i < pending.size(); ++i) {
            const Pending& photon = pending[i];
            const PhotonHistory& history = histories[i];
            const LightState& light = lightStates_[photon.light];
            const double weight = photon.weight;
            stats.nullCollisions += history.nullCollisions;
            stats.realCollisions += history.realCollisions;
            FateTally& fate = stats.fates[static_cast<int>(history.fate)];
            ++fate.photons;
            fate.powerW += weight * history.weight;
            // (Stray light sampling deposits shares on the way; an analog photon's are all zero.)
            for (int f = 0; f < static_cast<int>(PhotonFate::Count); ++f) stats.fates[f].powerW += weight * history.deposited[f];
            if (history.entered) stats.unguidedEnteredPowerW += weight;
            if (weight == 0.0) continue;
            for (int k = 0; k < history.arrivalCount; ++k) {
                const SensorArrival& arrival = history.arrivals[k];
                int layer = kLayerScatter, tally = light.scatterTally(), ghostLayer = -1;
                if (!arrival.scattered) {
                    const auto it = light.slotOfKey.find(arrival.key);
                    if (it == light.slotOfKey.end()) {
                        layer = kLayerHigher;
                        tally = light.higherTally();
                    } else {
                        const int slot = it->second;
                        // Owned by a guided strategy: already counted there.
                        if (light.masks[slot].contains(photon.a, photon.b)) continue;
                        layer = light.layer[slot];
                        tally = light.tallyOffset + slot;
                        ghostLayer = light.ghostLayer[slot];
                    }
                }
                const glm::dvec3 xyzW = photon.xyzWeight * (weight * arrival.weight);
                if (arrival.scattered) {
                    const int source = static_cast<int>(arrival.firstScatter) - 1;
                    out.sourceSums[source] += xyzW.y;
                    ghostLayer = scatterSourceLayer_[source];
                }
                score(layer, ghostLayer, tally, arrival.positionMm, xyzW);
            }
        }
        pending.clear();
        packet.clear();
    };

    for (int photon = 0; photon < options_.batchPhotons; ++photon) {
        ++stats.photons;
        const double uComponent = rng.uniform();
        const size_t c = std::min(components_.size() - 1,
                                  static_cast<size_t>(std::upper_bound(componentCdf_.begin(), componentCdf_.end(), uComponent) -
                                                      componentCdf_.begin()));
        const Component& component = components_[c];
        const LightState& light = lightStates_[component.light];
        double pdfPerNm = 0.0;
        const double wavelengthNm = light.wavelengths.sample(rng.uniform(), &pdfPerNm);
        const glm::dvec3 xyzWeight = light.wavelengths.xyzWeight(wavelengthNm, pdfPerNm);
        // The indices go straight where the photon's trace reads them.
        SpectralIndices& indices = component.slot < 0   ? pendingIndices[pending.size()]
                                   : guidedInPackets    ? buffers.guidedIndices[guided.size()]
                                                        : oneIndices;
        indexTable_.fill(wavelengthNm, indices);
        const double u1 = rng.uniform(), u2 = rng.uniform(), u3 = rng.uniform();
        const double uLight1 = rng.uniform(), uLight2 = rng.uniform();

        if (component.slot >= 0) {
            // Guided: emission over the path's live cells, forced sequence, Fresnel weights.
            ++stats.guidedPhotons;
            const GuideMask& mask = light.masks[component.slot];
            const glm::dvec2 ab = mask.sample(u1, u2, u3);
            const EmittedRay emitted = light.sampler.rayThrough(ab.x, ab.y, uLight1, uLight2);
            const double weight = emitted.powerPerMm2 * mask.areaMm2() / component.probability;
            if (weight == 0.0) continue;
            if (guidedInPackets) {
                buffers.guidedRays.push_back(emitted.ray);
                guided.push_back({static_cast<int>(c), weight, xyzWeight});
                continue;
            }
            sequence.reflections = component.slot == 0 ? std::span<const int>(noReflections)
                                                       : std::span<const int>(light.report.ghosts[component.slot - 1].path.reflections);
            pathPoints.clear();
            pathSurfaces.clear();
            const TraceResult result = tracePath(lens, indices, emitted.ray, sequence, guidedOptions);
            if (!result.ok()) continue;
            const glm::dvec3& p = result.ray.originMm;
            if (std::abs(p.x) > halfW || std::abs(p.y) > halfH) continue;
            const double clear =
                clearWeight ? tracer_.clearTransmittance(pathPoints, pathSurfaces, wavelengthNm, rng, *scratch) : 1.0;
            score(light.layer[component.slot], light.ghostLayer[component.slot], light.tallyOffset + component.slot,
                  {p.x, p.y}, xyzWeight * (weight * result.throughput * clear));
            continue;
        }

        // Unguided: uniform over the emission disk, non-sequential tracing. (The disk, not its
        // square: the corners hold no ray that can enter, and were a fifth of the photons.) The
        // photons are traced in packets (PhotonTracer::tracePacket), each walk drawing from a
        // generator of its own: stream (batch, photon) of a seed apart from the batches'.
        ++stats.unguidedPhotons;
        const double radius = light.sampler.emissionHalfSizeMm();
        const double r = radius * std::sqrt(u1), phi = 2.0 * std::numbers::pi * u2;
        const double a = r * std::cos(phi), b = r * std::sin(phi);
        const EmittedRay emitted = light.sampler.rayThrough(a, b, uLight1, uLight2);
        const double weight = emitted.powerPerMm2 * std::numbers::pi * radius * radius / component.probability;
        stats.unguidedEmittedPowerW += weight;
        const size_t i = pending.size();
        pending.push_back({a, b, weight, xyzWeight, component.light});
        packet.push_back({emitted.ray, &pendingIndices[i], Rng(walkSeed, walkStream + static_cast<std::uint64_t>(photon))});
        if (pending.size() == kPacketPhotons) tracePending();
    }
    tracePending();
    traceGuided();
}

void Renderer::traceBeam(BeamJob& job) const {
    const LightState& light = lightStates_[job.light];
    const GhostEstimate& estimate = light.report.ghosts[job.slot - 1];
    const GuideMask& mask = light.masks[job.slot];
    const double beams = light.beamRate[job.slot];
    const std::uint64_t pass = static_cast<std::uint64_t>(statistics_.passes);
    const std::uint64_t path = (static_cast<std::uint64_t>(job.light) << 20) ^ static_cast<std::uint64_t>(job.slot);
    // The beam's sample: the next point of its path's sequence in its replicate (every path and
    // replicate scrambled independently), so a render's beams of a path are one stratified
    // sequence per replicate, not a fresh set per pass.
    double u[kBeamDimensions];
    const ScrambledSobol points(kBeamDimensions, mixBits(options_.seed ^ 0x5eedbea5u) ^
                                                     mixBits((static_cast<std::uint64_t>(job.replicate) << 40) ^ path));
    points.point(job.sequenceIndex, u);
    const std::uint64_t stream = (pass << 32) ^ path;
    Rng rng(options_.seed, (stream << 16) ^ static_cast<std::uint64_t>(job.index) ^ 0xbea7000000000000ull);

    double pdfPerNm = 0.0;
    const WavelengthSampler& wavelengths = *light.beamWavelengths[job.slot];
    const double wavelengthNm = wavelengths.sample(u[0], &pdfPerNm);
    const glm::dvec3 xyzWeight = wavelengths.xyzWeight(wavelengthNm, pdfPerNm);
    const glm::dvec2 lightU = concentricToPolarUniforms(u[1], u[2]);
    const EmittedRay central = light.sampler.rayThrough(0.0, 0.0, lightU.x, lightU.y);
    // (A test's deliberate error: the jitter moves the sampled image, so a shifted jitter shifts it.)
    job.jitterPx = tentJitter(u[3], u[4]) - glm::dvec2(options_.testBeamShiftPx, 0.0);
    job.seed = rng.next();

    const LensSystem& lens = *lens_;
    const SpectralIndices indices = lens.indicesAt(wavelengthNm);
    // Coating tables for this one wavelength: coarse ones build in a fraction of a millisecond and
    // agree with the exact response to a few 1e-4 at worst (test_bundle_tracer.cpp), far below the
    // mesh's own error. Only the path's own interfaces (the whole lens's cost several times as
    // much), with slopes from the values (one response per point instead of three: they were a
    // tenth of a default render; the interpolant moves by < 1e-5 relative).
    const std::vector<InterfaceTables::Interface> interfaces =
        BundleTracer(lens, indices, estimate.path.reflections, false).interfaces();
    const InterfaceTables tables(lens, indices, kBeamTableIntervals, interfaces, true);
    const BundleTracer tracer(lens, indices, estimate.path.reflections, true, &tables);
    PupilGrid grid = light.report.grid;
    grid.direction = central.ray.direction;
    const FilmFrame frame{options_.film.widthPx, options_.film.heightPx, options_.film.widthMm, options_.film.heightMm,
                          options_.film.widthMm / options_.film.widthPx};
    PupilRemeshOptions remesh;
    remesh.minLevel = options_.beamMeshLevel;
    // Guided paths own only unscattered light: with dust, grease or bulk media every vertex's
    // throughput carries its probability of crossing them clear (ratio tracking in grids: an
    // unbiased estimate, so the beam stays an unbiased estimate of its piecewise-linear map).
    const bool clearWeight = tracer_.hasContamination() || tracer_.hasMedia();
    SequentialPath sequence;
    sequence.reflections = estimate.path.reflections;
    std::vector<glm::dvec3> pathPoints;
    std::vector<int> pathSurfaces;
    TraceOptions traceOptions;
    if (clearWeight) {
        traceOptions.pathPointsMm = &pathPoints;
        traceOptions.pathSurfaces = &pathSurfaces;
    }
    const std::unique_ptr<PhotonTracer::Scratch> scratch = tracer_.makeScratch();
    std::function<double(const glm::dvec2&)> clear;
    if (clearWeight)
        clear = [&](const glm::dvec2& pupilMm) {
            pathPoints.clear();
            pathSurfaces.clear();
            const TraceResult r = tracePath(lens, indices, grid.ray(pupilMm.x, pupilMm.y), sequence, traceOptions);
            return r.ok() ? tracer_.clearTransmittance(pathPoints, pathSurfaces, wavelengthNm, rng, *scratch) : 1.0;
        };
    job.beam = GhostBeam::build(tracer, grid, estimate.lattice, mask, frame, remesh, clear);

    // Film units: the pass's image is its accumulated power over photonsPerPass (the film's
    // divisor), and the path's estimate is the mean of its beams.
    const double perBeam = static_cast<double>(options_.photonsPerPass()) / beams;  // beams: the expectation
    job.scale = xyzWeight * (central.powerPerMm2 * perBeam);
    job.powerY = job.beam.powerOnSensor() * central.powerPerMm2 * xyzWeight.y / static_cast<double>(beams);

    // Correction photons: the same wavelength and direction, pupil points stratified over the
    // mask; each photon adds itself and subtracts its twin.
    const int photons = options_.correctionPhotonsPerBeam;
    if (photons <= 0 || job.beam.empty()) return;
    const double halfW = 0.5 * lens.sensor().widthMm, halfH = 0.5 * lens.sensor().heightMm;
    const double perPhoton = perBeam / photons;
    const glm::dvec3 base = xyzWeight * (mask.areaMm2() * perPhoton);
    const int layer = light.layer[job.slot];
    const int ghostLayer = light.ghostLayer[job.slot];
    auto hit = [&](const glm::dvec2& sensorMm, const glm::dvec3& xyz) {
        job.hits.push_back({static_cast<float>(sensorMm.x), static_cast<float>(sensorMm.y),
                            {static_cast<float>(xyz.x), static_cast<float>(xyz.y), static_cast<float>(xyz.z)},
                            static_cast<std::int16_t>(layer), ghostLayer});
    };
    double correctionY = 0.0;
    for (int i = 0; i < photons; ++i) {
        const glm::dvec2 ab = mask.sample((i + rng.uniform()) / photons, rng.uniform(), rng.uniform());
        const EmittedRay emitted = light.sampler.rayThrough(ab.x, ab.y, lightU.x, lightU.y);
        ++job.photons;
        pathPoints.clear();
        pathSurfaces.clear();
        const TraceResult result = tracePath(lens, indices, emitted.ray, sequence, traceOptions);
        if (result.ok()) {
            const glm::dvec3& p = result.ray.originMm;
            if (std::abs(p.x) <= halfW && std::abs(p.y) <= halfH) {
                const double clear =
                    clearWeight ? tracer_.clearTransmittance(pathPoints, pathSurfaces, wavelengthNm, rng, *scratch) : 1.0;
                const glm::dvec3 xyz = base * (emitted.powerPerMm2 * result.throughput * clear);
                hit({p.x, p.y}, xyz);
                correctionY += xyz.y;
            }
        }
        BeamTwin twin;
        if (job.beam.twin(ab, &twin)) {
            const glm::dvec2 sensorMm = frame.toSensorMm(twin.pixel);
            const glm::dvec3 xyz = -base * (central.powerPerMm2 * twin.throughput);
            hit(sensorMm, xyz);
            correctionY += xyz.y;
        }
    }
    job.powerY += correctionY / static_cast<double>(options_.photonsPerPass());
}

void Renderer::merge(const std::vector<BatchResult>& batches, const std::vector<BeamJob>& beams) {
    const int bandCount = film_.bandCount();
    const int width = options_.film.widthPx;
    // Every hit, by the bands its kernel touches (a kernel near a band's edge reaches two).
    struct Ref {
        const Hit* hit;
    };
    std::vector<std::vector<Ref>> byBand(bandCount);
    auto bucket = [&](const Hit& hit) {
        const glm::dvec2 sensorMm(hit.xMm, hit.yMm);
        const double row = film_.toPixel(sensorMm).y;
        const double power = Film::kernelPower(glm::dvec3(hit.xyz[0], hit.xyz[1], hit.xyz[2]));
        const double reach = std::max(film_.bandReachPx(hit.layer, sensorMm, power),
                                      hit.ghostLayer >= 0 ? film_.bandReachPx(hit.ghostLayer, sensorMm, power) : 0.0);
        const int first = std::max(0, static_cast<int>(std::floor((row - reach) / Film::kBandRows)));
        const int last = std::min(bandCount - 1, static_cast<int>(std::floor((row + reach) / Film::kBandRows)));
        for (int b = first; b <= last; ++b) byBand[b].push_back({&hit});
    };
    for (const BatchResult& batch : batches)
        for (const Hit& hit : batch.hits) bucket(hit);
    for (const BeamJob& job : beams)
        for (const Hit& hit : job.hits) bucket(hit);

    const bool perGhost = options_.perGhostLayers;
    tbb::parallel_for(tbb::blocked_range<int>(0, bandCount, 1), [&](const tbb::blocked_range<int>& range) {
        const size_t bandValues = static_cast<size_t>(Film::kBandRows) * width * 3;
        std::vector<double> rows[2], own;
        for (int band = range.begin(); band != range.end(); ++band) {
            for (const Ref& ref : byBand[band]) {
                const Hit& hit = *ref.hit;
                const glm::dvec2 p(hit.xMm, hit.yMm);
                const glm::dvec3 xyz(hit.xyz[0], hit.xyz[1], hit.xyz[2]);
                film_.splatInBand(band, hit.layer, p, xyz);
                if (hit.ghostLayer >= 0) film_.splatInBand(band, hit.ghostLayer, p, xyz, false);
            }
            // Beams, path by path (a path's beams are consecutive jobs): into the ghost or higher
            // rows, and into the path's own layer when asked.
            for (auto& r : rows) r.assign(bandValues, 0.0);
            bool touched[2] = {false, false};
            for (size_t j = 0; j < beams.size();) {
                const BeamJob& first = beams[j];
                const LightState& light = lightStates_[first.light];
                const int target = light.layer[first.slot] == kLayerHigher ? 1 : 0;
                const int ghostLayer = perGhost ? light.ghostLayer[first.slot] : -1;
                if (ghostLayer >= 0) own.assign(bandValues, 0.0);
                std::vector<double>& into = ghostLayer >= 0 ? own : rows[target];
                size_t k = j;
                for (; k < beams.size() && beams[k].light == first.light && beams[k].slot == first.slot; ++k)
                    beams[k].beam.rasterise(band, beams[k].jitterPx, beams[k].scale, beams[k].seed, into.data());
                if (ghostLayer >= 0) {
                    film_.addBand(band, ghostLayer, own.data(), false);
                    for (size_t i = 0; i < bandValues; ++i) rows[target][i] += own[i];
                }
                touched[target] = touched[target] || k > j;
                j = k;
            }
            if (touched[0]) film_.addBand(band, kLayerGhost, rows[0].data());
            if (touched[1]) film_.addBand(band, kLayerHigher, rows[1].data());
        }
    });
}

int Renderer::beamCount(int pass, size_t light, int slot) const {
    // The expected number's floor, and one more with the probability of its fraction (the
    // estimate divides by the expectation: unbiased).
    const double rate = lightStates_[light].beamRate[slot];
    if (!(rate > 0.0)) return 0;
    Rng countRng(options_.seed ^ 0xc0c0a0a0u,
                 (static_cast<std::uint64_t>(pass) << 32) ^ (static_cast<std::uint64_t>(light) << 20) ^
                     static_cast<std::uint64_t>(slot));
    return static_cast<int>(rate) + (countRng.uniform() < rate - std::floor(rate) ? 1 : 0);
}

void Renderer::runPass() {
    const auto start = std::chrono::steady_clock::now();
    const int batches = options_.batchesPerPass;
    std::vector<BeamJob> beamJobs;
    const int replicate = replicateOfPass(statistics_.passes);
    for (size_t l = 0; l < lightStates_.size(); ++l) {
        const LightState& light = lightStates_[l];
        for (int slot = 1; slot < light.slots; ++slot) {
            const int count = beamCount(statistics_.passes, l, slot);
            std::uint64_t& drawn = beamsDrawn_[l][static_cast<size_t>(slot) * options_.beamReplicates + replicate];
            for (int k = 0; k < count; ++k) {
                BeamJob job;
                job.light = static_cast<int>(l);
                job.slot = slot;
                job.index = k;
                job.replicate = replicate;
                job.sequenceIndex = drawn++;
                beamJobs.push_back(std::move(job));
            }
        }
    }
    // Beams first (they cost more each), then the photon batches: one loop balances both.
    const int jobs = static_cast<int>(beamJobs.size()) + batches;
    tbb::parallel_for(tbb::blocked_range<int>(0, jobs, 1), [&](const tbb::blocked_range<int>& range) {
        for (int j = range.begin(); j != range.end(); ++j) {
            if (j < static_cast<int>(beamJobs.size())) traceBeam(beamJobs[j]);
            else traceBatch(batchesDone_ + (j - static_cast<int>(beamJobs.size())), batches_[j - beamJobs.size()]);
        }
    });
    merge(batches_, beamJobs);

    const double inverseCount = 1.0 / options_.batchPhotons;
    for (const BatchResult& batch : batches_) {
        for (size_t t = 0; t < tallies_.size(); ++t) {
            const double mean = batch.tallySums[t] * inverseCount;
            tallies_[t].sumMeans += mean;
            tallies_[t].sumSquaredMeans += mean * mean;
        }
        for (int l = 0; l < kFixedLayerCount; ++l) {
            const double mean = batch.layerSums[l] * inverseCount;
            layerTallies_[l].sumMeans += mean;
            layerTallies_[l].sumSquaredMeans += mean * mean;
        }
        for (int source = 0; source < kScatterSources; ++source) {
            const double mean = batch.sourceSums[source] * inverseCount;
            scatterSourceTallies_[source].sumMeans += mean;
            scatterSourceTallies_[source].sumSquaredMeans += mean * mean;
        }
        const RenderStatistics& s = batch.statistics;
        statistics_.photons += s.photons;
        statistics_.guidedPhotons += s.guidedPhotons;
        statistics_.unguidedPhotons += s.unguidedPhotons;
        statistics_.sensorHits += s.sensorHits;
        statistics_.unguidedEmittedPowerW += s.unguidedEmittedPowerW;
        statistics_.unguidedEnteredPowerW += s.unguidedEnteredPowerW;
        statistics_.nullCollisions += s.nullCollisions;
        statistics_.realCollisions += s.realCollisions;
        for (int f = 0; f < static_cast<int>(PhotonFate::Count); ++f) {
            statistics_.fates[f].photons += s.fates[f].photons;
            statistics_.fates[f].powerW += s.fates[f].powerW;
        }
        for (int l = 0; l < kFixedLayerCount; ++l)
            statistics_.largestPhotonY[l] = std::max(statistics_.largestPhotonY[l], s.largestPhotonY[l]);
    }
    // Beam-rendered paths: one sample per pass (their beams are stratified together).
    std::vector<double> passTally(tallies_.size(), 0.0);
    double passLayer[kFixedLayerCount] = {};
    for (const BeamJob& job : beamJobs) {
        const LightState& light = lightStates_[job.light];
        passTally[light.tallyOffset + job.slot] += job.powerY;
        passLayer[light.layer[job.slot]] += job.powerY;
        ++statistics_.beams;
        statistics_.beamRays += job.beam.tracedRays();
        statistics_.correctionPhotons += job.photons;
    }
    for (size_t t = 0; t < tallies_.size(); ++t)
        if (tallies_[t].strategy == PathStrategy::Beams) tallies_[t].replicateSums[replicate] += passTally[t];
    for (int l = 0; l < kFixedLayerCount; ++l) layerTallies_[l].replicateSums[replicate] += passLayer[l];
    film_.endPass(options_.photonsPerPass());
    batchesDone_ += batches;
    ++statistics_.passes;
    statistics_.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::vector<float> Renderer::layerXyz(int layer) const {
    return film_.irradianceXyz(layer, static_cast<double>(statistics_.passes) * options_.photonsPerPass());
}

double Renderer::tallyPowerW(const PathTally& tally) const {
    double power = 0.0;
    if (batchesDone_ > 0) power += tally.sumMeans / static_cast<double>(batchesDone_);
    if (statistics_.passes > 0)
        for (int r = 0; r < options_.beamReplicates; ++r) power += tally.replicateSums[r] / statistics_.passes;
    return power;
}

double Renderer::tallyStandardErrorW(const PathTally& tally) const {
    // Var of a mean of n i.i.d. samples with these sums, estimated without bias.
    auto varianceOfMean = [](double sum, double sumSquares, double n) {
        if (n < 2.0) return 0.0;
        const double mean = sum / n;
        return std::max(0.0, (sumSquares - n * mean * mean) / (n - 1.0)) / n;
    };
    return std::sqrt(varianceOfMean(tally.sumMeans, tally.sumSquaredMeans, static_cast<double>(batchesDone_)) +
                     replicateVarianceOfMean(tally.replicateSums.data(), options_.beamReplicates, statistics_.passes));
}

double Renderer::estimatedRelativeError(int group) const { return film_.errorEstimate(group).relative(); }

std::uint64_t Renderer::fingerprint() const {
    // FNV-1a over everything that decides which random numbers go where.
    std::uint64_t hash = 0xcbf29ce484222325ull;
    auto mix = [&](const void* data, size_t size) {
        const auto* bytes = static_cast<const unsigned char*>(data);
        for (size_t i = 0; i < size; ++i) hash = (hash ^ bytes[i]) * 0x100000001b3ull;
    };
    mix(&options_.seed, sizeof options_.seed);
    const int ints[] = {static_cast<int>(options_.mode), static_cast<int>(options_.higherOrder), options_.maxBounces,
                        options_.batchPhotons,
                        options_.batchesPerPass, film_.layerCount(), options_.film.widthPx, options_.film.heightPx,
                        static_cast<int>(options_.film.kernel), lens_->surfaceCount(), options_.beamsPerPass,
                        options_.correctionPhotonsPerBeam, options_.beamMeshLevel,
                        static_cast<int>(std::lround(options_.testBeamShiftPx * 1024.0)), options_.maxAnalysedChains,
                        options_.smoothNeighbours, options_.tabulatedReflectance ? 1 : 0,
                        options_.strayLightSampling ? 1 : 0, film_.replicates()};
    mix(ints, sizeof ints);
    for (const Component& c : components_) {
        mix(&c.light, sizeof c.light);
        mix(&c.slot, sizeof c.slot);
        mix(&c.probability, sizeof c.probability);
    }
    for (const LightState& light : lightStates_) mix(light.beamRate.data(), light.beamRate.size() * sizeof(double));
    const double doubles[] = {options_.film.radiusPx, options_.materials.housingAlbedo, options_.materials.edgeAlbedo,
                              options_.materials.irisAlbedo, lens_->sensorZMm(), lens_->iris().radiusMm()};
    mix(doubles, sizeof doubles);
    mix(lens_->name().data(), lens_->name().size());
    return hash;
}

namespace {
constexpr std::uint64_t kCheckpointMagic = 0x3354504b43524c46ull;  // "FLRCKPT3"
// More passes than any render makes (2^24 passes of 65 536 photons: 10^12 photons); the bound keeps
// a hostile checkpoint from making the load recount beams for hours.
constexpr int kMaxCheckpointPasses = 1 << 24;
}

void Renderer::saveCheckpoint(OutputFiles& outputs, const std::string& path) const {
    std::ofstream out(outputs.file(path), std::ios::binary | std::ios::trunc);
    const std::uint64_t header[] = {kCheckpointMagic, fingerprint(), static_cast<std::uint64_t>(batchesDone_)};
    out.write(reinterpret_cast<const char*>(header), sizeof header);
    out.write(reinterpret_cast<const char*>(&statistics_), sizeof statistics_);
    for (const auto* list : {&tallies_, &layerTallies_, &scatterSourceTallies_})
        for (const PathTally& t : *list) {
            const double sums[] = {t.sumMeans, t.sumSquaredMeans};
            out.write(reinterpret_cast<const char*>(sums), sizeof sums);
            out.write(reinterpret_cast<const char*>(t.replicateSums.data()), sizeof t.replicateSums);
        }
    film_.save(out);
    out.close();
    if (!out) throw std::runtime_error("cannot write checkpoint " + path + ": " + std::strerror(errno));
}

void Renderer::saveCheckpoint(const std::string& path) const {
    OutputFiles outputs;
    outputs.add(path, "checkpoint");
    saveCheckpoint(outputs, path);
    outputs.commit();
}

void Renderer::loadCheckpoint(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(path, 0, "cannot open the checkpoint");
    std::uint64_t header[3] = {};
    in.read(reinterpret_cast<char*>(header), sizeof header);
    if (!in || header[0] != kCheckpointMagic) throw InputError(path, 0, "not a flare render checkpoint");
    if (header[1] != fingerprint())
        throw InputError(path, 0, "the checkpoint was written by a render with a different scene, lens, seed or options");
    try {
        RenderStatistics statistics;
        in.read(reinterpret_cast<char*>(&statistics), sizeof statistics);
        std::vector<PathTally> tallies = tallies_, layerTallies = layerTallies_, sourceTallies = scatterSourceTallies_;
        for (auto* list : {&tallies, &layerTallies, &sourceTallies})
            for (PathTally& t : *list) {
                double sums[2] = {};
                in.read(reinterpret_cast<char*>(sums), sizeof sums);
                in.read(reinterpret_cast<char*>(t.replicateSums.data()), sizeof t.replicateSums);
                t.sumMeans = sums[0], t.sumSquaredMeans = sums[1];
            }
        if (!in) throw std::runtime_error("checkpoint: truncated");
        // The doubles are taken as written: a corrupt or hostile file could hold a NaN or an
        // infinity, which would turn every power reported from here on into NaN. Photon counts
        // and times are never negative, nor are sums of squares; a beam path's sum can be (its
        // corrections may outweigh a pass's beams).
        auto bad = [](double v) { return !std::isfinite(v) || v < 0.0; };
        bool valid = !bad(statistics.seconds) && !bad(statistics.unguidedEmittedPowerW) &&
                     !bad(statistics.unguidedEnteredPowerW) && statistics.photons >= 0 && statistics.passes >= 0 &&
                     statistics.beams >= 0 && statistics.beamRays >= 0 && statistics.correctionPhotons >= 0;
        for (const FateTally& f : statistics.fates) valid = valid && !bad(f.powerW) && f.photons >= 0;
        for (double y : statistics.largestPhotonY) valid = valid && !bad(y);
        for (const auto* list : {&tallies, &layerTallies, &sourceTallies})
            for (const PathTally& t : *list)
                valid = valid && !bad(t.sumMeans) && !bad(t.sumSquaredMeans) &&
                        std::all_of(t.replicateSums.begin(), t.replicateSums.end(), [](double v) { return std::isfinite(v); });
        if (!valid) throw std::runtime_error("checkpoint: a statistic or tally is negative or not finite");
        if (statistics.passes > kMaxCheckpointPasses ||
            header[2] != static_cast<std::uint64_t>(statistics.passes) * static_cast<std::uint64_t>(options_.batchesPerPass))
            throw std::runtime_error("checkpoint: its pass or batch count is out of range");
        // Where each replicate's sequences go on: the beams its passes drew (which must be the
        // beams the checkpoint counts).
        std::vector<std::vector<std::uint64_t>> drawn = beamsDrawn_;
        std::uint64_t total = 0;
        for (auto& d : drawn) std::fill(d.begin(), d.end(), 0);
        for (int pass = 0; pass < statistics.passes; ++pass)
            for (size_t l = 0; l < lightStates_.size(); ++l)
                for (int slot = 1; slot < lightStates_[l].slots; ++slot) {
                    const int count = beamCount(pass, l, slot);
                    drawn[l][static_cast<size_t>(slot) * options_.beamReplicates + replicateOfPass(pass)] += count;
                    total += static_cast<std::uint64_t>(count);
                }
        if (total != static_cast<std::uint64_t>(statistics.beams))
            throw std::runtime_error("checkpoint: its beam count is not the one its passes draw");
        film_.load(in);  // (leaves the film as it was if it throws)
        if (film_.passes() != statistics.passes) throw std::runtime_error("checkpoint: the film's passes differ from the statistics'");
        statistics_ = statistics;
        tallies_ = std::move(tallies);
        layerTallies_ = std::move(layerTallies);
        scatterSourceTallies_ = std::move(sourceTallies);
        batchesDone_ = static_cast<std::int64_t>(header[2]);
        beamsDrawn_ = std::move(drawn);
    } catch (const std::runtime_error& e) {
        throw InputError(path, 0, e.what());
    }
}

}  // namespace flare
