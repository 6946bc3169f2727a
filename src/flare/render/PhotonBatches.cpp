#include "flare/render/PhotonBatches.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <span>

#include "flare/core/Random.h"
#include "flare/optics/SequentialTracer.h"

namespace flare::renderer {

namespace {

constexpr size_t kPacketPhotons = 256;

// Unguided photons waiting to be traced together, and what scoring them needs.
struct Pending {
    double a = 0.0, b = 0.0;  // the emission point (mm in the emission disk)
    double weight = 0.0;      // W
    glm::dvec3 xyzWeight{0.0};
    int light = 0;
};
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

PacketBuffers& threadBuffers() {
    static thread_local PacketBuffers buffers;
    return buffers;
}

// A photon's uniforms after its component and wavelength: the emission point's (three for a
// guide mask, two for the emission disk) and the light's extent's.
struct EmissionUniforms {
    double u1, u2, u3, uLight1, uLight2;
};

// One batch in flight: the photons drawn in order from the batch's generator, the unguided ones
// traced a packet at a time as they fill, the guided ones at the end.
class BatchTracer {
public:
    BatchTracer(const PhotonBatchInputs& in, std::int64_t batchIndex, BatchResult& out);
    BatchTracer(const BatchTracer&) = delete;  // (guidedOptions points at the path's points)
    BatchTracer& operator=(const BatchTracer&) = delete;

    void run();

private:
    void score(int layer, int ghostLayer, int tally, const glm::dvec2& sensorMm, const glm::dvec3& xyzW);
    void emitGuided(size_t c, double wavelengthNm, const glm::dvec3& xyzWeight, const SpectralIndices& indices,
                    const EmissionUniforms& u);
    void emitUnguided(const PhotonComponent& component, int photon, const glm::dvec3& xyzWeight,
                      const EmissionUniforms& u);
    void traceGuided();
    void tracePending();

    const PhotonBatchInputs& in_;
    const std::vector<PhotonComponent>& components_;
    BatchResult& out_;
    RenderStatistics& stats_;
    Rng rng_;
    const double halfW_, halfH_;
    std::vector<int> noReflections_;
    SequentialPath sequence_;
    const std::unique_ptr<PhotonTracer::Scratch> scratch_;
    // Guided paths own only unscattered light: with dust, grease or bulk media their weight is the
    // probability of crossing them clear, which needs the path's points.
    const bool clearWeight_;
    std::vector<glm::dvec3> pathPoints_;
    std::vector<int> pathSurfaces_;
    TraceOptions guidedOptions_;
    const std::uint64_t walkSeed_;
    const std::uint64_t walkStream_;
    PacketBuffers& buffers_;
    // Guided photons are traced at the end of the batch, each path's together in SIMD packets
    // (PacketTracer, each photon at its own wavelength: tracePath's results to the bit), and
    // scored in the order they were drawn. With dust, grease or media their clear transmittance
    // draws from the batch's generator in that order, so they are traced one at a time there.
    const bool guidedInPackets_;
    SpectralIndices oneIndices_;  // a guided photon's, traced at once
};

BatchTracer::BatchTracer(const PhotonBatchInputs& in, std::int64_t batchIndex, BatchResult& out)
    : in_(in), components_(in.components), out_(out), stats_(out.statistics),
      rng_(in.options.seed, static_cast<std::uint64_t>(batchIndex)),
      halfW_(0.5 * in.lens.sensor().widthMm), halfH_(0.5 * in.lens.sensor().heightMm),
      scratch_(in.tracer.makeScratch()), clearWeight_(in.tracer.hasContamination() || in.tracer.hasMedia()),
      walkSeed_(mixBits(in.options.seed ^ 0x3a1f5c0de0f7a1c5ull)),
      walkStream_(static_cast<std::uint64_t>(batchIndex) * static_cast<std::uint64_t>(in.options.batchPhotons)),
      buffers_(threadBuffers()), guidedInPackets_(!clearWeight_) {
    if (clearWeight_) {
        guidedOptions_.pathPointsMm = &pathPoints_;
        guidedOptions_.pathSurfaces = &pathSurfaces_;
    }
    buffers_.pending.clear();
    buffers_.packet.clear();
    buffers_.guided.clear();
    if (guidedInPackets_ && buffers_.guidedIndices.size() < static_cast<size_t>(in.options.batchPhotons))
        buffers_.guidedIndices.resize(static_cast<size_t>(in.options.batchPhotons));
    buffers_.guidedRays.clear();
}

void BatchTracer::score(int layer, int ghostLayer, int tally, const glm::dvec2& sensorMm, const glm::dvec3& xyzW) {
    out_.hits.push_back({static_cast<float>(sensorMm.x), static_cast<float>(sensorMm.y),
                         {static_cast<float>(xyzW.x), static_cast<float>(xyzW.y), static_cast<float>(xyzW.z)},
                         static_cast<std::int16_t>(layer), ghostLayer});
    out_.tallySums[tally] += xyzW.y;
    out_.layerSums[layer] += xyzW.y;
    stats_.largestPhotonY[layer] = std::max(stats_.largestPhotonY[layer], xyzW.y);
    ++stats_.sensorHits;
}

void BatchTracer::run() {
    for (int photon = 0; photon < in_.options.batchPhotons; ++photon) {
        ++stats_.photons;
        const double uComponent = rng_.uniform();
        const size_t c = std::min(components_.size() - 1,
                                  static_cast<size_t>(std::upper_bound(in_.componentCdf.begin(), in_.componentCdf.end(),
                                                                       uComponent) -
                                                      in_.componentCdf.begin()));
        const PhotonComponent& component = components_[c];
        const LightState& light = in_.lights[component.light];
        double pdfPerNm = 0.0;
        const double wavelengthNm = light.wavelengths.sample(rng_.uniform(), &pdfPerNm);
        glm::dvec3 xyzWeight = light.wavelengths.xyzWeight(wavelengthNm, pdfPerNm);
        // The indices go straight where the photon's trace reads them.
        SpectralIndices& indices = component.slot < 0 ? buffers_.indices[buffers_.pending.size()]
                                   : guidedInPackets_ ? buffers_.guidedIndices[buffers_.guided.size()]
                                                      : oneIndices_;
        in_.indexTable.fill(wavelengthNm, indices);
        // (A braced list's initialisers are evaluated in order.)
        const EmissionUniforms u{rng_.uniform(), rng_.uniform(), rng_.uniform(), rng_.uniform(), rng_.uniform()};
        // (A region light's point reweights the wavelength by its own colour.)
        xyzWeight *= light.sampler.colourFactor(u.uLight1, wavelengthNm);

        if (component.slot >= 0) emitGuided(c, wavelengthNm, xyzWeight, indices, u);
        else emitUnguided(component, photon, xyzWeight, u);
    }
    tracePending();
    traceGuided();
}

void BatchTracer::emitGuided(size_t c, double wavelengthNm, const glm::dvec3& xyzWeight,
                             const SpectralIndices& indices, const EmissionUniforms& u) {
    // Guided: emission over the path's live cells, forced sequence, Fresnel weights.
    const PhotonComponent& component = components_[c];
    const LightState& light = in_.lights[component.light];
    ++stats_.guidedPhotons;
    const GuideMask& mask = light.masks[component.slot];
    const glm::dvec2 ab = mask.sample(u.u1, u.u2, u.u3);
    const EmittedRay emitted = light.sampler.rayThrough(ab.x, ab.y, u.uLight1, u.uLight2);
    const double weight = emitted.powerPerMm2 * mask.areaMm2() / component.probability;
    if (weight == 0.0) return;
    if (guidedInPackets_) {
        buffers_.guidedRays.push_back(emitted.ray);
        buffers_.guided.push_back({static_cast<int>(c), weight, xyzWeight});
        return;
    }
    sequence_.reflections = component.slot == 0
                                ? std::span<const int>(noReflections_)
                                : std::span<const int>(light.report.ghosts[component.slot - 1].path.reflections);
    pathPoints_.clear();
    pathSurfaces_.clear();
    const TraceResult result = tracePath(in_.lens, indices, emitted.ray, sequence_, guidedOptions_);
    if (!result.ok()) return;
    const glm::dvec3& p = result.ray.originMm;
    if (std::abs(p.x) > halfW_ || std::abs(p.y) > halfH_) return;
    const double clear =
        clearWeight_ ? in_.tracer.clearTransmittance(pathPoints_, pathSurfaces_, wavelengthNm, rng_, *scratch_) : 1.0;
    score(light.layer[component.slot], light.ghostLayer[component.slot], light.tallyOffset + component.slot, {p.x, p.y},
          xyzWeight * (weight * result.throughput * clear));
}

void BatchTracer::emitUnguided(const PhotonComponent& component, int photon, const glm::dvec3& xyzWeight,
                               const EmissionUniforms& u) {
    // Unguided: uniform over the emission disk, non-sequential tracing. (The disk, not its
    // square: the corners hold no ray that can enter, and were a fifth of the photons.) The
    // photons are traced in packets (PhotonTracer::tracePacket), each walk drawing from a
    // generator of its own: stream (batch, photon) of a seed apart from the batches'.
    const LightState& light = in_.lights[component.light];
    ++stats_.unguidedPhotons;
    const double radius = light.sampler.emissionHalfSizeMm();
    const double r = radius * std::sqrt(u.u1), phi = 2.0 * std::numbers::pi * u.u2;
    const double a = r * std::cos(phi), b = r * std::sin(phi);
    const EmittedRay emitted = light.sampler.rayThrough(a, b, u.uLight1, u.uLight2);
    const double weight = emitted.powerPerMm2 * std::numbers::pi * radius * radius / component.probability;
    stats_.unguidedEmittedPowerW += weight;
    const size_t i = buffers_.pending.size();
    buffers_.pending.push_back({a, b, weight, xyzWeight, component.light});
    buffers_.packet.push_back({emitted.ray, &buffers_.indices[i],
                               Rng(walkSeed_, walkStream_ + static_cast<std::uint64_t>(photon))});
    if (buffers_.pending.size() == kPacketPhotons) tracePending();
}

void BatchTracer::traceGuided() {
    std::vector<GuidedPending>& guided = buffers_.guided;
    const size_t count = guided.size();
    if (count == 0) return;
    // A counting sort by path.
    std::vector<int>& start = buffers_.start;
    std::vector<int>& position = buffers_.position;
    start.assign(components_.size() + 1, 0);
    for (const GuidedPending& g : guided) ++start[g.component + 1];
    for (size_t c = 0; c < components_.size(); ++c) start[c + 1] += start[c];
    position.resize(count);
    buffers_.sortedRays.resize(count);
    buffers_.sortedIndices.resize(count);
    buffers_.landings.resize(count);
    {
        std::vector<int> next(start.begin(), start.end() - 1);
        for (size_t j = 0; j < count; ++j) {
            const int at = next[guided[j].component]++;
            position[j] = at;
            buffers_.sortedRays[at] = buffers_.guidedRays[j];
            buffers_.sortedIndices[at] = &buffers_.guidedIndices[j];
        }
    }
    for (size_t c = 0; c < components_.size(); ++c) {
        const size_t from = static_cast<size_t>(start[c]), n = static_cast<size_t>(start[c + 1]) - from;
        if (n == 0) continue;
        components_[c].tracer->trace(std::span<const Ray>(buffers_.sortedRays).subspan(from, n),
                                     std::span<const SpectralIndices* const>(buffers_.sortedIndices).subspan(from, n),
                                     std::span<BundleLanding>(buffers_.landings).subspan(from, n));
    }
    for (size_t j = 0; j < count; ++j) {
        const GuidedPending& g = guided[j];
        const BundleLanding& landing = buffers_.landings[position[j]];
        if (!landing.ok()) continue;
        const glm::dvec2& p = landing.sensorMm;
        if (std::abs(p.x) > halfW_ || std::abs(p.y) > halfH_) continue;
        const PhotonComponent& component = components_[g.component];
        const LightState& light = in_.lights[component.light];
        score(light.layer[component.slot], light.ghostLayer[component.slot], light.tallyOffset + component.slot, p,
              g.xyzWeight * (g.weight * landing.throughput));
    }
    guided.clear();
    buffers_.guidedRays.clear();
}

void BatchTracer::tracePending() {
    std::vector<Pending>& pending = buffers_.pending;
    std::vector<PhotonTracer::PacketPhoton>& packet = buffers_.packet;
    if (pending.empty()) return;
    in_.tracer.tracePacket(packet, std::span(buffers_.histories).first(packet.size()), *scratch_);
    for (size_t i = 0; i < pending.size(); ++i) {
        const Pending& photon = pending[i];
        const PhotonHistory& history = buffers_.histories[i];
        const LightState& light = in_.lights[photon.light];
        const double weight = photon.weight;
        stats_.nullCollisions += history.nullCollisions;
        stats_.realCollisions += history.realCollisions;
        FateTally& fate = stats_.fates[static_cast<int>(history.fate)];
        ++fate.photons;
        fate.powerW += weight * history.weight;
        // (Stray light sampling deposits shares on the way; an analog photon's are all zero.)
        for (int f = 0; f < static_cast<int>(PhotonFate::Count); ++f) stats_.fates[f].powerW += weight * history.deposited[f];
        if (history.entered) stats_.unguidedEnteredPowerW += weight;
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
                out_.sourceSums[source] += xyzW.y;
                ghostLayer = in_.scatterSourceLayer[source];
            }
            score(layer, ghostLayer, tally, arrival.positionMm, xyzW);
        }
    }
    pending.clear();
    packet.clear();
}

}  // namespace

void traceBatch(const PhotonBatchInputs& in, std::int64_t batchIndex, BatchResult& out) {
    out.hits.clear();
    out.tallySums.assign(in.tallyCount, 0.0);
    std::fill(std::begin(out.layerSums), std::end(out.layerSums), 0.0);
    std::fill(std::begin(out.sourceSums), std::end(out.sourceSums), 0.0);
    out.statistics = RenderStatistics{};
    if (in.components.empty()) {
        out.statistics.photons = in.options.batchPhotons;
        return;
    }
    BatchTracer(in, batchIndex, out).run();
}

}  // namespace flare::renderer
