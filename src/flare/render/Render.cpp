#include "flare/render/Render.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <unordered_map>

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include "flare/core/Error.h"
#include "flare/ghosts/GuideMask.h"
#include "flare/optics/SequentialTracer.h"
#include "flare/photons/LightSampler.h"

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

namespace {

constexpr double kMm2PerM2 = 1e6;
// Guide masks reach this far beyond the analysed live region (cells) and beyond the sensor (a
// fraction of its half-diagonal): dispersion across the visible and the sun's 0.5° move a
// ghost's landings by up to about a millimetre on a full-frame sensor.
constexpr int kGuideGrowCells = 4;
constexpr double kGuideSensorMargin = 0.1;

struct Hit {
    float xMm, yMm;
    float xyz[3];
    std::int16_t layer;
    std::int32_t ghostLayer;  // −1: none
};

}  // namespace

struct Renderer::LightState {
    LightSampler sampler;
    WavelengthSampler wavelengths;
    GhostReport report;
    // Slots: 0 the direct image, 1..G the enumerated ghosts in report order.
    std::unordered_map<PathKey, int> slotOfKey;
    std::vector<GuideMask> masks;   // per slot; empty where the slot is not guided
    std::vector<int> ghostLayer;    // per slot: per-ghost film layer, −1 if none
    int tallyOffset = 0;            // tallies: offset + slot, then higher, then scatter
    int slots = 0;

    int higherTally() const { return tallyOffset + slots; }
    int scatterTally() const { return tallyOffset + slots + 1; }
};

struct Renderer::Component {
    int light = 0;
    int slot = -1;  // −1: the unguided tracer
    double probability = 0.0;
};

constexpr int kScatterSources = static_cast<int>(ScatterSource::Count) - 1;

struct Renderer::BatchResult {
    std::vector<Hit> hits;
    std::vector<double> tallySums;  // Σ Y power (W) per tally
    double layerSums[kFixedLayerCount] = {};
    double sourceSums[kScatterSources] = {};
    RenderStatistics statistics;    // photon counts and fates of this batch
};

Renderer::Renderer(const LensSystem& lens, const std::vector<LightSpec>& lights, const RenderOptions& options)
    : lens_(&lens), options_(options), indexTable_(lens),
      tracer_(lens, options.materials, options.maxBounces, options.contamination, options.media),
      film_(options.film, kFixedLayerCount) {
    for (int l = 0; l < kFixedLayerCount; ++l) layerNames_.push_back(renderLayerName(l));
    std::unordered_map<std::string, int> ghostLayerOfLabel;
    const InteriorMaterials& m = options.materials;
    const bool anyScattering = m.housingAlbedo + m.edgeAlbedo + m.irisAlbedo + m.housingGlossy + m.edgeGlossy +
                                       m.irisGlossy > 0.0 ||
                               tracer_.hasContamination() || tracer_.hasMedia();

    std::vector<double> lightWeight;
    for (const LightSpec& spec : lights) {
        LightState state{LightSampler(spec, lens), WavelengthSampler(toSpectrum(spec.spectrum)),
                         analyseGhosts(lens, spec.travelDirection(), options.analysis), {}, {}, {}, 0, 0};
        LightPlan plan;
        plan.name = spec.name;
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
        if (options.mode == RenderOptions::Mode::Guided && !plan.skipped) {
            // Guide masks: the analysed regions re-traced with a margin around the sensor (see
            // GuideMask::traced), in parallel over paths; each mask is a pure function of its path.
            const SpectralIndices indices = lens.indicesAt(options.analysis.wavelengthNm);
            const double marginMm = kGuideSensorMargin * lens.sensorHalfDiagonalMm();
            tbb::parallel_for(0, state.slots, [&](int slot) {
                const GhostEstimate& estimate = slot == 0 ? report.direct : report.ghosts[slot - 1];
                if (slot > 0 && estimate.pruned) return;
                state.masks[slot] = GuideMask::traced(lens, indices, report.grid, estimate.path, estimate.pupil,
                                                      kGuideGrowCells, marginMm);
            });
        }
        for (size_t g = 0; g < report.ghosts.size(); ++g) {
            if (report.ghosts[g].pruned) {
                ++plan.prunedGhosts;
                continue;
            }
            ++plan.keptGhosts;
            if (!options.perGhostLayers) continue;
            const std::string label = report.ghosts[g].path.label();
            auto [it, inserted] = ghostLayerOfLabel.try_emplace(label, static_cast<int>(layerNames_.size()));
            if (inserted) layerNames_.push_back(label);
            state.ghostLayer[g + 1] = it->second;
        }
        for (int slot = 0; slot < state.slots; ++slot)
            if (!state.masks[slot].empty()) tallies_[state.tallyOffset + slot].guided = true;

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
    if (layerNames_.size() > kFixedLayerCount) film_ = Film(options.film, static_cast<int>(layerNames_.size()));

    // The budget: lights in proportion to the power they send in (every photon then carries a
    // similar power); within a light, the unguided share, the direct share, and the kept ghosts
    // in proportion to their analysed power (floored, so that a ghost the analysis underrates
    // still gets photons).
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
            if (!state.masks[slot].empty()) strongest = std::max(strongest, state.report.ghosts[slot - 1].powerFraction);
        std::vector<double> ghostWeight(state.slots, 0.0);
        double ghostTotal = 0.0;
        for (int slot = 1; slot < state.slots; ++slot) {
            if (state.masks[slot].empty()) continue;
            ghostWeight[slot] = std::max(state.report.ghosts[slot - 1].powerFraction, 1e-3 * strongest);
            ghostTotal += ghostWeight[slot];
        }
        const double directShare = state.masks[0].empty() ? 0.0 : options.directShare;
        const double ghostShare = ghostTotal > 0.0 ? 1.0 - options.unguidedShare - options.directShare : 0.0;
        const double unguidedShare = 1.0 - directShare - ghostShare;
        components_.push_back({static_cast<int>(l), -1, share * unguidedShare});
        if (directShare > 0.0) components_.push_back({static_cast<int>(l), 0, share * directShare});
        for (int slot = 1; slot < state.slots; ++slot)
            if (ghostWeight[slot] > 0.0)
                components_.push_back({static_cast<int>(l), slot, share * ghostShare * ghostWeight[slot] / ghostTotal});
    }
    double cumulative = 0.0;
    for (const Component& c : components_) componentCdf_.push_back(cumulative += c.probability);
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
    PhotonHistory history;
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
        ++stats.sensorHits;
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
        const SpectralIndices indices = indexTable_.at(wavelengthNm);
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
            score(component.slot == 0 ? kLayerDirect : kLayerGhost, light.ghostLayer[component.slot],
                  light.tallyOffset + component.slot, {p.x, p.y}, xyzWeight * (weight * result.throughput * clear));
            continue;
        }

        // Unguided: uniform over the emission square, non-sequential tracing.
        ++stats.unguidedPhotons;
        const double half = light.sampler.emissionHalfSizeMm();
        const double a = (2.0 * u1 - 1.0) * half, b = (2.0 * u2 - 1.0) * half;
        const EmittedRay emitted = light.sampler.rayThrough(a, b, uLight1, uLight2);
        const double weight = emitted.powerPerMm2 * 4.0 * half * half / component.probability;
        stats.unguidedEmittedPowerW += weight;
        tracer_.trace(indices, emitted.ray, rng, history, *scratch);
        stats.nullCollisions += history.nullCollisions;
        stats.realCollisions += history.realCollisions;
        FateTally& fate = stats.fates[static_cast<int>(history.fate)];
        ++fate.photons;
        fate.powerW += weight;
        if (history.entered) stats.unguidedEnteredPowerW += weight;
        if (weight == 0.0) continue;
        for (int i = 0; i < history.arrivalCount; ++i) {
            const SensorArrival& arrival = history.arrivals[i];
            int layer = kLayerScatter, tally = light.scatterTally(), ghostLayer = -1;
            if (!arrival.scattered) {
                const auto it = light.slotOfKey.find(arrival.key);
                if (it == light.slotOfKey.end()) {
                    layer = kLayerHigher;
                    tally = light.higherTally();
                } else {
                    const int slot = it->second;
                    // Owned by the guided strategy: already counted there.
                    if (light.masks[slot].contains(a, b)) continue;
                    layer = slot == 0 ? kLayerDirect : kLayerGhost;
                    tally = light.tallyOffset + slot;
                    ghostLayer = light.ghostLayer[slot];
                }
            }
            if (arrival.scattered) out.sourceSums[static_cast<int>(arrival.firstScatter) - 1] += (xyzWeight * weight).y;
            score(layer, ghostLayer, tally, arrival.positionMm, xyzWeight * weight);
        }
    }
}

void Renderer::runPass() {
    const auto start = std::chrono::steady_clock::now();
    const int batches = options_.batchesPerPass;
    tbb::parallel_for(0, batches, [&](int b) { traceBatch(batchesDone_ + b, batches_[b]); });

    // Merge in batch order: the result does not depend on which thread traced what.
    for (const BatchResult& batch : batches_) {
        for (const Hit& hit : batch.hits) {
            const glm::dvec2 p(hit.xMm, hit.yMm);
            const glm::dvec3 xyz(hit.xyz[0], hit.xyz[1], hit.xyz[2]);
            film_.splat(hit.layer, p, xyz);
            if (hit.ghostLayer >= 0) film_.splat(hit.ghostLayer, p, xyz, false);
        }
        const double inverseCount = 1.0 / options_.batchPhotons;
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
    }
    film_.endPass(options_.photonsPerPass());
    batchesDone_ += batches;
    ++statistics_.passes;
    statistics_.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::vector<float> Renderer::layerXyz(int layer) const {
    return film_.irradianceXyz(layer, static_cast<double>(batchesDone_) * options_.batchPhotons);
}

double Renderer::tallyPowerW(const PathTally& tally) const {
    return batchesDone_ > 0 ? tally.sumMeans / static_cast<double>(batchesDone_) : 0.0;
}

double Renderer::tallyStandardErrorW(const PathTally& tally) const {
    if (batchesDone_ < 2) return 0.0;
    const double n = static_cast<double>(batchesDone_);
    const double mean = tally.sumMeans / n;
    const double variance = std::max(0.0, (tally.sumSquaredMeans - n * mean * mean) / (n - 1.0));
    return std::sqrt(variance / n);
}

std::uint64_t Renderer::fingerprint() const {
    // FNV-1a over everything that decides which random numbers go where.
    std::uint64_t hash = 0xcbf29ce484222325ull;
    auto mix = [&](const void* data, size_t size) {
        const auto* bytes = static_cast<const unsigned char*>(data);
        for (size_t i = 0; i < size; ++i) hash = (hash ^ bytes[i]) * 0x100000001b3ull;
    };
    mix(&options_.seed, sizeof options_.seed);
    const int ints[] = {static_cast<int>(options_.mode), options_.maxBounces, options_.batchPhotons,
                        options_.batchesPerPass, film_.layerCount(), options_.film.widthPx, options_.film.heightPx,
                        static_cast<int>(options_.film.kernel), lens_->surfaceCount()};
    mix(ints, sizeof ints);
    for (const Component& c : components_) {
        mix(&c.light, sizeof c.light);
        mix(&c.slot, sizeof c.slot);
        mix(&c.probability, sizeof c.probability);
    }
    const double doubles[] = {options_.film.radiusPx, options_.materials.housingAlbedo, options_.materials.edgeAlbedo,
                              options_.materials.irisAlbedo, lens_->sensorZMm(), lens_->iris().radiusMm()};
    mix(doubles, sizeof doubles);
    mix(lens_->name().data(), lens_->name().size());
    return hash;
}

namespace {
constexpr std::uint64_t kCheckpointMagic = 0x3154504b43524c46ull;  // "FLRCKPT1"
}

void Renderer::saveCheckpoint(const std::string& path) const {
    const std::string partial = path + ".partial";
    {
        std::ofstream out(partial, std::ios::binary | std::ios::trunc);
        if (!out) throw std::runtime_error("cannot write checkpoint " + partial);
        const std::uint64_t header[] = {kCheckpointMagic, fingerprint(), static_cast<std::uint64_t>(batchesDone_)};
        out.write(reinterpret_cast<const char*>(header), sizeof header);
        out.write(reinterpret_cast<const char*>(&statistics_), sizeof statistics_);
        for (const auto* list : {&tallies_, &layerTallies_, &scatterSourceTallies_})
            for (const PathTally& t : *list) {
                out.write(reinterpret_cast<const char*>(&t.sumMeans), sizeof t.sumMeans);
                out.write(reinterpret_cast<const char*>(&t.sumSquaredMeans), sizeof t.sumSquaredMeans);
            }
        film_.save(out);
        out.flush();
        if (!out) {
            std::filesystem::remove(partial);
            throw std::runtime_error("cannot write checkpoint " + partial);
        }
    }
    std::filesystem::rename(partial, path);
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
                in.read(reinterpret_cast<char*>(&t.sumMeans), sizeof t.sumMeans);
                in.read(reinterpret_cast<char*>(&t.sumSquaredMeans), sizeof t.sumSquaredMeans);
            }
        if (!in) throw std::runtime_error("checkpoint: truncated");
        // The doubles are taken as written: a corrupt or hostile file could hold a NaN or an
        // infinity, which would turn every power reported from here on into NaN. Powers, sums of
        // squares, photon counts and times are never negative either.
        auto bad = [](double v) { return !std::isfinite(v) || v < 0.0; };
        bool valid = !bad(statistics.seconds) && !bad(statistics.unguidedEmittedPowerW) &&
                     !bad(statistics.unguidedEnteredPowerW) && statistics.photons >= 0 && statistics.passes >= 0;
        for (const FateTally& f : statistics.fates) valid = valid && !bad(f.powerW) && f.photons >= 0;
        for (const auto* list : {&tallies, &layerTallies, &sourceTallies})
            for (const PathTally& t : *list) valid = valid && !bad(t.sumMeans) && !bad(t.sumSquaredMeans);
        if (!valid) throw std::runtime_error("checkpoint: a statistic or tally is negative or not finite");
        film_.load(in);
        statistics_ = statistics;
        tallies_ = std::move(tallies);
        layerTallies_ = std::move(layerTallies);
        scatterSourceTallies_ = std::move(sourceTallies);
        batchesDone_ = static_cast<std::int64_t>(header[2]);
    } catch (const std::runtime_error& e) {
        throw InputError(path, 0, e.what());
    }
}

}  // namespace flare
