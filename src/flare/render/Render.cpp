#include "flare/render/Render.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <unordered_map>
#include <utility>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "flare/render/BeamShare.h"
#include "flare/render/BeamStrategy.h"
#include "flare/render/PassExchange.h"
#include "flare/render/PhotonBatches.h"
#include "flare/render/RenderPlan.h"

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

// The interior finishes (barrel, element edges, iris blades) scatter light.
bool interiorScatters(const InteriorMaterials& m) {
    return m.housingAlbedo + m.edgeAlbedo + m.irisAlbedo + m.housingGlossy + m.edgeGlossy + m.irisGlossy > 0.0;
}

// Tallies of a light, from its tally offset on: direct, every ghost (and chain), higher, scatter.
void addLightTallies(int lightIndex, const renderer::LightState& light, std::vector<PathTally>& tallies) {
    for (int slot = 0; slot < light.slots; ++slot) {
        const GhostEstimate& estimate = slot == 0 ? light.report.direct : light.report.ghosts[slot - 1];
        PathTally t;
        t.kind = slot == 0 ? PathTally::Kind::Direct : PathTally::Kind::Ghost;
        t.light = lightIndex;
        if (slot > 0) t.path = estimate.path;
        t.analysedPowerFraction = estimate.powerFraction;
        t.plannedPowerFraction = light.pathPowerFraction[slot];
        t.strategy = light.strategy[slot];
        t.guided = light.strategy[slot] != PathStrategy::Unguided;
        tallies.push_back(t);
    }
    for (PathTally::Kind kind : {PathTally::Kind::Higher, PathTally::Kind::Scatter}) {
        PathTally t;
        t.kind = kind;
        t.light = lightIndex;
        tallies.push_back(t);
    }
}

// Per-ghost layers: one per label of a kept ghost (or chain), shared by the lights that have it,
// for the labels `selection` keeps by their power (summed over the lights); the order-2 ghosts
// left out share kOtherGhostsLayer, a chain left out has no layer (RenderOptions::ghostLayers).
void addGhostLayers(std::vector<renderer::LightState>& lights, const std::vector<LightPlan>& plans,
                    const LayerSelection& selection, std::vector<std::string>& layerNames) {
    std::vector<std::string> labels;
    std::vector<double> power;
    std::unordered_map<std::string, size_t> indexOfLabel;
    for (size_t l = 0; l < lights.size(); ++l) {
        const GhostReport& report = lights[l].report;
        for (size_t g = 0; g < report.ghosts.size(); ++g) {
            if (report.ghosts[g].pruned) continue;
            const auto [it, inserted] = indexOfLabel.try_emplace(report.ghosts[g].path.label(), labels.size());
            if (inserted) {
                labels.push_back(it->first);
                power.push_back(0.0);
            }
            power[it->second] += lights[l].pathPowerFraction[g + 1] * plans[l].enteringPowerW;
        }
    }
    const std::vector<bool> kept = keptLayers(power, labels, selection);
    std::vector<int> layerOfLabel(labels.size(), -1);
    int otherLayer = -1;
    for (size_t i = 0; i < labels.size(); ++i) {
        if (kept[i]) {
            layerOfLabel[i] = static_cast<int>(layerNames.size());
            layerNames.push_back(labels[i]);
        }
    }
    for (renderer::LightState& light : lights) {
        const GhostReport& report = light.report;
        for (size_t g = 0; g < report.ghosts.size(); ++g) {
            if (report.ghosts[g].pruned) continue;
            const size_t i = indexOfLabel.at(report.ghosts[g].path.label());
            if (!kept[i] && report.ghosts[g].path.reflections.size() == 2 && otherLayer < 0) {
                otherLayer = static_cast<int>(layerNames.size());
                layerNames.push_back(kOtherGhostsLayer);
            }
            light.ghostLayer[g + 1] = kept[i] ? layerOfLabel[i] : report.ghosts[g].path.reflections.size() == 2 ? otherLayer : -1;
        }
    }
}

}  // namespace

Renderer::Renderer(const LensSystem& lens, const std::vector<LightSpec>& lights, const RenderOptions& options)
    : lens_(&lens), options_(options), indexTable_(lens),
      tracer_(lens, options.materials, options.maxBounces, options.contamination, options.media),
      film_(options.film, kFixedLayerCount) {
    if (options.beamReplicates < 2 || options.beamReplicates > kMaxReplicates)
        throw std::invalid_argument("RenderOptions: beamReplicates must be in [2, " + std::to_string(kMaxReplicates) + "]");
    if (options.beamVarianceProbes < 0 || options.beamVarianceProbes == 1 || options.beamVarianceProbes > 64)
        throw std::invalid_argument("RenderOptions: beamVarianceProbes must be 0 or in [2, 64]");
    for (int l = 0; l < kFixedLayerCount; ++l) layerNames_.push_back(renderLayerName(l));
    if (options.tabulatedReflectance) tracer_.tabulateReflectance();
    if (options.strayLightSampling && options.mode != RenderOptions::Mode::Naive)
        tracer_.setStrayLightSampling({.weighted = true, .connectSensor = true, .scatterSplits = options.scatterSplits});
    const bool anyScattering = interiorScatters(options.materials) || tracer_.hasContamination() || tracer_.hasMedia();

    std::vector<double> lightWeight;
    // The lights' analyses and plans are independent (each deterministic on its own): planned
    // side by side, so that many lights (a plate's regions) keep both cores busy through each
    // analysis's serial stretches; kept in the lights' order.
    if (!options.lightBeamsPerPass.empty() && options.lightBeamsPerPass.size() != lights.size())
        throw std::invalid_argument("RenderOptions::lightBeamsPerPass: one count per light");
    std::vector<std::optional<renderer::PlannedLight>> plannedLights(lights.size());
    tbb::parallel_for(size_t{0}, lights.size(), size_t{1}, [&](size_t l) {
        if (options.lightBeamsPerPass.empty()) {
            plannedLights[l].emplace(renderer::planLight(lens, lights[l], options, anyScattering));
            return;
        }
        RenderOptions own = options;  // this light's budget of beams
        own.beamsPerPass = options.lightBeamsPerPass.at(l);
        plannedLights[l].emplace(renderer::planLight(lens, lights[l], own, anyScattering));
    });
    for (std::optional<renderer::PlannedLight>& slot : plannedLights) {
        renderer::PlannedLight planned = std::move(*slot);
        slot.reset();
        planned.state.tallyOffset = static_cast<int>(tallies_.size());
        addLightTallies(static_cast<int>(lightPlans_.size()), planned.state, tallies_);
        lightWeight.push_back(planned.plan.skipped ? 0.0 : planned.plan.enteringPowerW);
        lightStates_.push_back(std::move(planned.state));
        lightPlans_.push_back(std::move(planned.plan));
    }
    if (options.beamVarianceProbes > 0) renderer::shareBeamsByVariance(lens, options, tracer_, lightStates_);
    if (options.perGhostLayers) addGhostLayers(lightStates_, lightPlans_, options.ghostLayers, layerNames_);
    for (PathTally::Kind kind : {PathTally::Kind::Direct, PathTally::Kind::Ghost, PathTally::Kind::Higher,
                                 PathTally::Kind::Scatter}) {
        PathTally t;
        t.kind = kind;
        t.light = -1;
        layerTallies_.push_back(t);
    }
    for (int source = 0; source < renderer::kScatterSources; ++source) {
        PathTally t;
        t.kind = PathTally::Kind::Scatter;
        t.light = -1;
        scatterSourceTallies_.push_back(t);
    }
    addScatterSourceLayers();
    setUpFilm();
    // Beams continue their sequences from pass to pass (per light, per slot × replicate).
    for (const renderer::LightState& light : lightStates_)
        beamsDrawn_.emplace_back(static_cast<size_t>(light.slots) * options.beamReplicates, 0);

    // (Without photons, as the preview renders, no photon component is built: their packet tracers
    // cost time, and nothing would draw them.)
    if (options.tracePhotons) {
        components_ = renderer::photonComponents(lens, options, lightStates_, lightWeight);
        componentCdf_ = renderer::cumulativeProbabilities(components_);
        batches_.resize(options.batchesPerPass);
    }
    // The first passes are nominal: the plan needs an error estimate (a pass in every replicate).
    passSizes_.assign(2, renderer::PassSizes{1.0, static_cast<int>(batches_.size())});
}

Renderer::~Renderer() = default;

const GhostReport& Renderer::ghostReport(int light) const { return lightStates_.at(static_cast<size_t>(light)).report; }

double Renderer::plannedBeamRate(int light, int slot) const {
    return lightStates_.at(static_cast<size_t>(light)).beamRate.at(static_cast<size_t>(slot));
}

void Renderer::addScatterSourceLayers() {
    // With per-path layers, the scatter layer split by what the light met first, for the sources
    // this scene has (the report's scatter_sources split the power the same way).
    scatterSourceLayer_.assign(renderer::kScatterSources, -1);
    if (!options_.perGhostLayers) return;
    bool dust = false, grease = false;
    for (const SurfaceContamination& c : options_.contamination)
        dust = dust || c.dustCoverage > 0.0, grease = grease || c.greaseCoverage > 0.0;
    const bool present[renderer::kScatterSources] = {interiorScatters(options_.materials), dust, grease,
                                                     !options_.media.empty()};
    for (int source = 0; source < renderer::kScatterSources; ++source) {
        if (!present[source]) continue;
        scatterSourceLayer_[source] = static_cast<int>(layerNames_.size());
        layerNames_.push_back(std::string("scatter_") + toString(static_cast<ScatterSource>(source + 1)));
    }
}

void Renderer::setUpFilm() {
    const FilmSettings& film = options_.film;
    bool anyBeams = false;
    for (const renderer::LightState& light : lightStates_)
        for (int slot = 1; slot < light.slots; ++slot) anyBeams = anyBeams || light.beamRate[slot] > 0.0;
    // The plan moves effort between the two strategies only when a pass has both.
    adaptivePlan_ = options_.passPlan == RenderOptions::PassPlan::Adaptive && options_.tracePhotons && anyBeams &&
                    options_.batchesPerPass > 0;
    const int layers = static_cast<int>(layerNames_.size()) + (adaptivePlan_ ? 1 : 0);
    if (layers > kFixedLayerCount) film_ = Film(film, layers);
    if (options_.smoothNeighbours > 0 && film.kernel == FilmSettings::Kernel::Fixed) {
        const double maxRadiusPx = std::max(film.maxRadiusPx, film.widthPx / 16.0);
        film_.setLayerKernel(kLayerScatter, FilmSettings::Kernel::Adaptive, options_.smoothNeighbours, maxRadiusPx, true);
        // The higher layer's photons too (its beams are rasterised exactly, whatever the kernel):
        // what the guided chains leave to the unguided tracer, a few sparse photons.
        film_.setLayerKernel(kLayerHigher, FilmSettings::Kernel::Adaptive, options_.smoothNeighbours, maxRadiusPx, true);
        for (int layer : scatterSourceLayer_)
            if (layer >= 0)
                film_.setLayerKernel(layer, FilmSettings::Kernel::Adaptive, options_.smoothNeighbours, maxRadiusPx, true);
    }
    // Per-ghost layers are only read out: single precision halves their memory (Film.h).
    for (int l = kFixedLayerCount; l < static_cast<int>(layerNames_.size()); ++l)
        if (layerNames_[l].starts_with("ghost_")) film_.setLayerSinglePrecision(l);
    for (int l = 0; l < kFixedLayerCount; ++l) film_.addVarianceGroup({l});
    // (Without the flare group's sums, its index stays: kGroupFlare, no layers.)
    film_.addVarianceGroup(options_.ghostGroupsOnly ? std::vector<int>{} : std::vector<int>{kLayerGhost, kLayerHigher, kLayerScatter});
    // The beams' own image (not in the total, never written): its variance is the beams' part of
    // every group's, the plan's measure of what more beams would buy.
    if (adaptivePlan_) {
        beamsLayer_ = static_cast<int>(layerNames_.size());
        beamsGroup_ = film_.addVarianceGroup({beamsLayer_});
    }
    // Beams continue their sequences from pass to pass: the error is estimated from replicates.
    if (anyBeams) film_.setReplicates(options_.beamReplicates);
}

double Renderer::beamRate(int pass, size_t light, int slot, const std::vector<renderer::PassSizes>& plan) const {
    // Scaled by the pass's plan; a path drawn at least once a pass keeps that floor (BeamStrategy.h:
    // a rare path weighted by one over a tiny rate is heavy-tailed).
    const double rate = lightStates_[light].beamRate[slot];
    const double scale = plan.at(static_cast<size_t>(pass)).beamScale;
    return scale == 1.0 ? rate : std::max(rate * scale, std::min(rate, 1.0));
}

int Renderer::beamCount(int pass, size_t light, int slot, const std::vector<renderer::PassSizes>& plan) const {
    return renderer::beamCount(options_.seed, beamRate(pass, light, slot, plan), pass, light, slot);
}

std::vector<renderer::BeamJob> Renderer::drawBeamJobs() {
    // Each path's beams of this pass continue its sequence in the pass's replicate.
    std::vector<renderer::BeamJob> jobs;
    const int replicate = replicateOfPass(statistics_.passes);
    for (size_t l = 0; l < lightStates_.size(); ++l) {
        const renderer::LightState& light = lightStates_[l];
        for (int slot = 1; slot < light.slots; ++slot) {
            const int count = beamCount(statistics_.passes, l, slot, passSizes_);
            const double rate = beamRate(statistics_.passes, l, slot, passSizes_);
            std::uint64_t& drawn = beamsDrawn_[l][static_cast<size_t>(slot) * options_.beamReplicates + replicate];
            for (int k = 0; k < count; ++k) {
                renderer::BeamJob job;
                job.light = static_cast<int>(l);
                job.slot = slot;
                job.index = k;
                job.replicate = replicate;
                job.rate = rate;
                job.sequenceIndex = drawn++;
                jobs.push_back(std::move(job));
            }
        }
    }
    return jobs;
}

void Renderer::startPass() {
    // The pass's photon batches (the plan's; the options' without photons: none).
    if (options_.tracePhotons) batches_.resize(static_cast<size_t>(passSizes(statistics_.passes).photonBatches));
}

void Renderer::weightPhotonHits(std::vector<renderer::BatchResult>& batches) const {
    // A pass of π photon batches weights its photons by nominal / π: every pass is then an
    // estimate of the film's nominal pass (the film divides by the nominal photon count). The
    // tallies take the batches' per-photon means, which do not depend on the pass's size.
    if (batches.empty() || static_cast<int>(batches.size()) == options_.batchesPerPass) return;
    const double weight = static_cast<double>(options_.batchesPerPass) / static_cast<double>(batches.size());
    for (renderer::BatchResult& batch : batches)
        for (renderer::SensorHit& hit : batch.hits)
            for (float& v : hit.xyz) v = static_cast<float>(v * weight);
}

void Renderer::runPass() {
    if (exchange_ != nullptr && exchange_->size() > 1) return runDistributedPass();
    const auto start = std::chrono::steady_clock::now();
    startPass();
    const int batches = static_cast<int>(batches_.size());  // 0 without photons
    const int replicate = replicateOfPass(statistics_.passes);
    std::vector<renderer::BeamJob> beamJobs = drawBeamJobs();
    const renderer::PhotonBatchInputs batchInputs{*lens_, options_, tracer_, indexTable_, lightStates_, components_,
                                                  componentCdf_, scatterSourceLayer_, tallies_.size()};
    // Beams first (they cost more each), then the photon batches: one loop balances both.
    const int jobs = static_cast<int>(beamJobs.size()) + batches;
    tbb::parallel_for(tbb::blocked_range<int>(0, jobs, 1), [&](const tbb::blocked_range<int>& range) {
        for (int j = range.begin(); j != range.end(); ++j) {
            if (j < static_cast<int>(beamJobs.size()))
                renderer::traceBeam(*lens_, options_, tracer_, lightStates_[beamJobs[j].light], statistics_.passes,
                                    beamJobs[j]);
            else
                renderer::traceBatch(batchInputs, batchesDone_ + (j - static_cast<int>(beamJobs.size())),
                                     batches_[j - beamJobs.size()]);
        }
    });
    weightPhotonHits(batches_);
    merge(batches_, beamJobs);
    addPassTallies(beamJobs, replicate);
    film_.endPass(options_.photonsPerPass());
    batchesDone_ += batches;
    ++statistics_.passes;
    planPassAfterNext();
    statistics_.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::vector<std::pair<double, int>> Renderer::passPlan() const {
    std::vector<std::pair<double, int>> plan;
    for (int p = 0; p < statistics_.passes; ++p) plan.emplace_back(passSizes(p).beamScale, passSizes(p).photonBatches);
    return plan;
}

void Renderer::planPassAfterNext() {
    // After pass q (passes = q + 1) the sizes of pass q + 2: the ranks, tracing a pass ahead, are
    // told pass q + 1's during pass q (RenderDistributed.cpp).
    const int passes = statistics_.passes;
    passSizes_.resize(static_cast<size_t>(passes) + 1);
    renderer::PassSizes sizes = passSizes_.back();
    if (adaptivePlan_ && film_.hasVariance() && (passes < 16 || passes % std::max(1, passes / 16) == 0)) {
        // (The estimate scans the whole film: after 16 passes the plan is revised every sixteenth
        // of the passes done, as the stop rule checks its target, and otherwise kept.)
        const int nominalBatches = options_.batchesPerPass;
        double inverseBeams = 0.0, inversePhotons = 0.0, beamScales = 0.0, photonScales = 0.0;
        for (int p = 0; p < passes; ++p) {
            const renderer::PassSizes& s = passSizes(p);
            const double photonScale = static_cast<double>(s.photonBatches) / nominalBatches;
            inverseBeams += 1.0 / s.beamScale, inversePhotons += 1.0 / photonScale;
            beamScales += s.beamScale, photonScales += photonScale;
        }
        // A nominal pass's work: beam rays, photons in ray units (PassPlan.h).
        const double beamCost = static_cast<double>(statistics_.beamRays) / beamScales;
        const double photonCost =
            static_cast<double>(statistics_.photons) * renderer::photonCostInRays(options_.scatterSplits) / photonScales;
        const double beamsVariance = film_.errorEstimate(beamsGroup_).sumVariance;
        std::vector<RenderOptions::ErrorTarget> wanted = options_.errorTargets;
        if (wanted.empty()) wanted.push_back({kGroupFlare, 1.0});
        std::vector<renderer::PlanTarget> targets;
        const double p2 = static_cast<double>(passes) * passes;
        for (const RenderOptions::ErrorTarget& w : wanted) {
            if (!(w.relativeError > 0.0) || w.group < 0 || w.group >= kVarianceGroupCount) continue;
            const Film::ErrorEstimate e = film_.errorEstimate(w.group);
            if (!(e.squaredNorm > 0.0)) continue;
            // The beams' part of the group's variance (the two strategies' estimates are
            // independent: the variances add); groups without beams have none.
            const bool hasBeams = w.group == kGroupTotal || w.group == kGroupGhost || w.group == kGroupHigher ||
                                  w.group == kGroupFlare;
            const double beamPart = hasBeams ? std::min(beamsVariance, e.sumVariance) : 0.0;
            renderer::PlanTarget t;
            t.beamVariance = beamPart * p2 / inverseBeams;
            t.photonVariance = (e.sumVariance - beamPart) * p2 / inversePhotons;
            t.accumulated = e.sumVariance * p2;
            t.normTimesTarget2 = e.squaredNorm * w.relativeError * w.relativeError;
            targets.push_back(t);
        }
        const renderer::PlanSplit split =
            renderer::choosePassSplit(targets, beamCost, photonCost, renderer::kMinPassScale, renderer::kMaxPassScale);
        sizes.beamScale = std::max(1.0, std::round(split.beamScale * renderer::kBeamScaleSteps)) / renderer::kBeamScaleSteps;
        sizes.photonBatches = std::max(1, static_cast<int>(std::lround(split.photonScale * nominalBatches)));
    }
    passSizes_.push_back(sizes);
}

Renderer::HitsByBand Renderer::hitsByBand(const std::vector<renderer::BatchResult>& batches,
                                          const std::vector<renderer::BeamJob>& beams) const {
    // Every hit, by the bands its kernel touches (a kernel near a band's edge reaches two).
    const int bandCount = film_.bandCount();
    HitsByBand byBand(bandCount);
    auto bucket = [&](const renderer::SensorHit& hit) {
        const glm::dvec2 sensorMm(hit.xMm, hit.yMm);
        const double row = film_.toPixel(sensorMm).y;
        const double power = Film::kernelPower(glm::dvec3(hit.xyz[0], hit.xyz[1], hit.xyz[2]));
        const double reach = std::max(film_.bandReachPx(hit.layer, sensorMm, power),
                                      hit.ghostLayer >= 0 ? film_.bandReachPx(hit.ghostLayer, sensorMm, power) : 0.0);
        const int first = std::max(0, static_cast<int>(std::floor((row - reach) / Film::kBandRows)));
        const int last = std::min(bandCount - 1, static_cast<int>(std::floor((row + reach) / Film::kBandRows)));
        for (int b = first; b <= last; ++b) byBand[b].push_back(&hit);
    };
    for (const renderer::BatchResult& batch : batches)
        for (const renderer::SensorHit& hit : batch.hits) bucket(hit);
    for (const renderer::BeamJob& job : beams)
        for (const renderer::SensorHit& hit : job.hits) bucket(hit);
    return byBand;
}

void Renderer::splatHitsInBand(int band, const std::vector<const renderer::SensorHit*>& hits) {
    for (const renderer::SensorHit* hit : hits) {
        const glm::dvec2 p(hit->xMm, hit->yMm);
        const glm::dvec3 xyz(hit->xyz[0], hit->xyz[1], hit->xyz[2]);
        film_.splatInBand(band, hit->layer, p, xyz, !options_.ghostGroupsOnly);
        if (hit->ghostLayer >= 0) film_.splatInBand(band, hit->ghostLayer, p, xyz, false);
    }
}

void Renderer::rasteriseBeamsInBand(int band, const std::vector<renderer::BeamJob>& beams,
                                    std::array<std::vector<double>, 3>& scratch, const BandAdder& add) const {
    // Beams, run by run of the same destination: into the ghost or higher rows, and into the
    // path's own layer when asked.
    if (beams.empty()) return;
    const int width = options_.film.widthPx;
    const size_t bandValues = static_cast<size_t>(Film::kBandRows) * width * 3;
    // (scratch[0] and [1]: the ghost and higher rows; scratch[2]: a path's own.)
    std::vector<double>& own = scratch[2];
    scratch[0].assign(bandValues, 0.0);
    scratch[1].assign(bandValues, 0.0);
    own.resize(bandValues);
    bool touched[2] = {false, false};
    const bool perGhost = options_.perGhostLayers;
    // Where a beam goes: the ghost or the higher rows (0, 1), and its path's own layer (or −1).
    auto destination = [&](const renderer::BeamJob& beam) {
        const renderer::LightState& light = lightStates_[beam.light];
        return std::pair{light.layer[beam.slot] == kLayerHigher ? 1 : 0, perGhost ? light.ghostLayer[beam.slot] : -1};
    };
    for (size_t j = 0; j < beams.size();) {
        // The run of beams that go to the same rows and the same layer: a path's (its beams are
        // consecutive jobs), or consecutive paths' that share one (`ghost_other`, with --layers
        // top:N or share:F), added to it at once.
        const auto [target, ghostLayer] = destination(beams[j]);
        size_t k = j + 1;
        while (k < beams.size() && destination(beams[k]) == std::pair{target, ghostLayer}) ++k;
        touched[target] = true;
        if (ghostLayer < 0) {
            for (; j < k; ++j) beams[j].beam.rasterise(band, beams[j].jitterPx, beams[j].scale, beams[j].seed, scratch[target].data());
            continue;
        }
        // The run's layer over the columns its beams reach in this band, in whole tiles (the film's
        // runs, Film::addRow, and the band images' runs, PassWire.h): elsewhere its rows are zero,
        // and adding zeros leaves every sum's bits as they are. Most paths reach a few of the bands
        // and a part of their width: zeroing, adding and summing the whole band for each was most
        // of the per-ghost layers' cost.
        int lo = width, hi = -1;
        for (size_t m = j; m < k; ++m) beams[m].beam.columnsInBand(band, lo, hi);
        if (lo <= hi) {
            // (The film's tiles and the band images' runs are Film::kBandRows pixels wide.)
            const int xBegin = lo / Film::kBandRows * Film::kBandRows;
            const int xEnd = std::min(width, (hi / Film::kBandRows + 1) * Film::kBandRows);
            const size_t columns = static_cast<size_t>(xEnd - xBegin) * 3;
            for (int row = 0; row < Film::kBandRows; ++row)
                std::fill_n(own.data() + (static_cast<size_t>(row) * width + xBegin) * 3, columns, 0.0);
            for (size_t m = j; m < k; ++m) beams[m].beam.rasterise(band, beams[m].jitterPx, beams[m].scale, beams[m].seed, own.data());
            add(ghostLayer, own.data(), false, xBegin, xEnd);
            for (int row = 0; row < Film::kBandRows; ++row) {
                const size_t at = (static_cast<size_t>(row) * width + xBegin) * 3;
                for (size_t i = at; i < at + columns; ++i) scratch[target][i] += own[i];
            }
        }
        j = k;
    }
    if (touched[0]) add(kLayerGhost, scratch[0].data(), !options_.ghostGroupsOnly, 0, width);
    if (touched[1]) add(kLayerHigher, scratch[1].data(), !options_.ghostGroupsOnly, 0, width);
    if (beamsLayer_ >= 0)
        for (int target = 0; target < 2; ++target)
            if (touched[target]) add(beamsLayer_, scratch[target].data(), false, 0, width);
}

void Renderer::merge(const std::vector<renderer::BatchResult>& batches, const std::vector<renderer::BeamJob>& beams) {
    const HitsByBand byBand = hitsByBand(batches, beams);
    tbb::parallel_for(tbb::blocked_range<int>(0, film_.bandCount(), 1), [&](const tbb::blocked_range<int>& range) {
        std::array<std::vector<double>, 3> scratch;
        for (int band = range.begin(); band != range.end(); ++band) {
            splatHitsInBand(band, byBand[band]);
            rasteriseBeamsInBand(band, beams, scratch, [&](int layer, const double* rows, bool inTotal, int xBegin, int xEnd) {
                film_.addBandColumns(band, layer, rows, inTotal, xBegin, xEnd);
            });
        }
    });
}

void Renderer::addPassTallies(const std::vector<renderer::BeamJob>& beamJobs, int replicate) {
    const double inverseCount = 1.0 / options_.batchPhotons;
    for (const renderer::BatchResult& batch : batches_) {
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
        for (int source = 0; source < renderer::kScatterSources; ++source) {
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
    for (const renderer::BeamJob& job : beamJobs) {
        const renderer::LightState& light = lightStates_[job.light];
        passTally[light.tallyOffset + job.slot] += job.powerY;
        passLayer[light.layer[job.slot]] += job.powerY;
        ++statistics_.beams;
        statistics_.beamRays += job.beam.tracedRays();
        statistics_.correctionPhotons += job.photons;
    }
    for (size_t t = 0; t < tallies_.size(); ++t)
        if (tallies_[t].strategy == PathStrategy::Beams) tallies_[t].replicateSums[replicate] += passTally[t];
    for (int l = 0; l < kFixedLayerCount; ++l) layerTallies_[l].replicateSums[replicate] += passLayer[l];
}

std::vector<float> Renderer::layerXyz(int layer) const {
    return film_.irradianceXyz(layer, static_cast<double>(statistics_.passes) * options_.photonsPerPass());
}

FilmWindow Renderer::layerXyzFootprint(int layer) const {
    return film_.irradianceXyzFootprint(layer, static_cast<double>(statistics_.passes) * options_.photonsPerPass());
}

FilmWindow Renderer::takeLayerXyzFootprint(int layer) {
    FilmWindow window = layerXyzFootprint(layer);
    film_.clearLayer(layer);
    return window;
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

double Renderer::estimatedRelativeError(int group) const {
    if (options_.ghostGroupsOnly && (group == kGroupTotal || group == kGroupFlare))
        throw std::logic_error("Renderer::estimatedRelativeError: the film keeps no sums for group " + std::to_string(group) +
                               " (RenderOptions::ghostGroupsOnly)");
    return film_.errorEstimate(group).relative();
}

}  // namespace flare
