// Renderer's checkpoints (Render.h): the film, the tallies, the statistics and the passes done,
// with a fingerprint of everything that decides which random numbers go where, so that a render
// resumes only from its own checkpoints.
#include "flare/render/Render.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "flare/core/Error.h"
#include "flare/render/RenderPlan.h"

namespace flare {

namespace {
constexpr std::uint64_t kCheckpointMagic = 0x3454504b43524c46ull;  // "FLRCKPT4"
// More passes than any render makes (2^24 passes of 65 536 photons: 10^12 photons); the bound keeps
// a hostile checkpoint from making the load recount beams for hours.
constexpr int kMaxCheckpointPasses = 1 << 24;
}

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
                        options_.strayLightSampling ? 1 : 0, film_.replicates(), options_.tracePhotons ? 1 : 0,
                        options_.scatterSplits, adaptivePlan_ ? 1 : 0};
    mix(ints, sizeof ints);
    // (Only when set, so that the checkpoints of renders keep their fingerprints.)
    if (options_.ghostGroupsOnly) mix("ghost groups only", 17);
    // The beams' planned rates (the probes' shares: RenderOptions::beamVarianceProbes), which
    // decide how many points of each sequence a pass draws.
    for (const renderer::LightState& light : lightStates_) mix(light.beamRate.data(), light.beamRate.size() * sizeof(double));
    for (const renderer::PhotonComponent& c : components_) {
        mix(&c.light, sizeof c.light);
        mix(&c.slot, sizeof c.slot);
        mix(&c.probability, sizeof c.probability);
    }
    for (const renderer::LightState& light : lightStates_) mix(light.beamRate.data(), light.beamRate.size() * sizeof(double));
    const double doubles[] = {options_.film.radiusPx, options_.materials.housingAlbedo, options_.materials.edgeAlbedo,
                              options_.materials.irisAlbedo, lens_->sensorZMm(), lens_->iris().radiusMm()};
    mix(doubles, sizeof doubles);
    mix(lens_->name().data(), lens_->name().size());
    // The adaptive plan's targets decide the passes' sizes.
    if (adaptivePlan_)
        for (const RenderOptions::ErrorTarget& t : options_.errorTargets) {
            mix(&t.group, sizeof t.group);
            mix(&t.relativeError, sizeof t.relativeError);
        }
    // Which ghosts have layers of their own (--layers top:N or share:F keep some).
    for (const std::string& name : layerNames_) mix(name.data(), name.size() + 1);
    return hash;
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
    // Every pass's sizes and the next two's, as planned (PassPlan.h): a resumed render goes on
    // with the plan the uninterrupted one would have made.
    const std::uint64_t planned = passSizes_.size();
    out.write(reinterpret_cast<const char*>(&planned), sizeof planned);
    for (const renderer::PassSizes& p : passSizes_) {
        const std::int32_t batches = p.photonBatches;
        out.write(reinterpret_cast<const char*>(&p.beamScale), sizeof p.beamScale);
        out.write(reinterpret_cast<const char*>(&batches), sizeof batches);
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
        if (statistics.passes > kMaxCheckpointPasses) throw std::runtime_error("checkpoint: its pass count is out of range");
        // The plan: the passes done and the next two, each within the plan's bounds, and the
        // batches of the passes done the checkpoint's count.
        std::uint64_t planned = 0;
        in.read(reinterpret_cast<char*>(&planned), sizeof planned);
        if (!in || planned != static_cast<std::uint64_t>(statistics.passes) + 2)
            throw std::runtime_error("checkpoint: its pass plan does not cover its passes and the next two");
        std::vector<renderer::PassSizes> plan(planned);
        const int nominal = options_.tracePhotons ? options_.batchesPerPass : 0;
        std::uint64_t batches = 0;
        for (std::uint64_t p = 0; p < planned; ++p) {
            std::int32_t count = 0;
            in.read(reinterpret_cast<char*>(&plan[p].beamScale), sizeof plan[p].beamScale);
            in.read(reinterpret_cast<char*>(&count), sizeof count);
            plan[p].photonBatches = count;
            const double scale = plan[p].beamScale;
            const bool sizesValid =
                adaptivePlan_ ? scale >= renderer::kMinPassScale - 1e-9 && scale <= renderer::kMaxPassScale + 1e-9 &&
                                    count >= 1 && count <= renderer::kMaxPassScale * nominal + 1
                              : scale == 1.0 && count == nominal;
            if (!in || !sizesValid) throw std::runtime_error("checkpoint: a pass's planned size is out of range");
            if (p < static_cast<std::uint64_t>(statistics.passes)) batches += static_cast<std::uint64_t>(count);
        }
        if (header[2] != batches) throw std::runtime_error("checkpoint: its batch count is not the one its passes planned");
        // Where each replicate's sequences go on: the beams its passes drew (which must be the
        // beams the checkpoint counts).
        std::vector<std::vector<std::uint64_t>> drawn = beamsDrawn_;
        std::uint64_t total = 0;
        for (auto& d : drawn) std::fill(d.begin(), d.end(), 0);
        for (int pass = 0; pass < statistics.passes; ++pass)
            for (size_t l = 0; l < lightStates_.size(); ++l)
                for (int slot = 1; slot < lightStates_[l].slots; ++slot) {
                    const int count = beamCount(pass, l, slot, plan);
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
        passSizes_ = std::move(plan);
    } catch (const std::runtime_error& e) {
        throw InputError(path, 0, e.what());
    }
}

}  // namespace flare
