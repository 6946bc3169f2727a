// The photon tracer alone (no film, no light sampling): walks through the default scene's lens
// (the double Gauss at f/4, light 13.5° off axis over its front clear aperture, wavelengths
// across 400–700 nm, black paint of albedo 0.03, the sensor's own reflectance), traced one at a
// time (PhotonTracer::trace, `packet` 0) or together (tracePacket, `packet` 1), one thread. The
// walks are the same bit for bit (test_photon_packet.cpp), so the ratio of the two rates is the
// packets' gain. Counters: photons/s, events/s and the share of events the lanes traced.
#include <cmath>
#include <numbers>
#include <span>
#include <vector>

#include <benchmark/benchmark.h>
#include <glm/geometric.hpp>

#include "flare/photons/PhotonTracer.h"
#include "flare/scene/Scene.h"

namespace {

using namespace flare;

void BM_PhotonWalks(benchmark::State& state) {
    const bool packets = state.range(0) != 0;
    const LensSystem lens = buildSceneLens(defaultScene());
    InteriorMaterials materials;
    materials.housingAlbedo = materials.edgeAlbedo = materials.irisAlbedo = 0.03;
    const PhotonTracer tracer(lens, materials);
    const int count = 65536;
    Rng rng(1, 2);
    std::vector<SpectralIndices> indices;
    std::vector<Ray> rays;
    indices.reserve(count);
    const double front = lens.surface(0).semiApertureMm;
    const double field = 13.5 * std::numbers::pi / 180.0;
    const glm::dvec3 d(std::sin(field) * std::cos(0.6), std::sin(field) * std::sin(0.6), std::cos(field));
    for (int i = 0; i < count; ++i) {
        indices.push_back(lens.indicesAt(400.0 + 300.0 * rng.uniform()));
        const double r = front * std::sqrt(rng.uniform()), phi = 2.0 * std::numbers::pi * rng.uniform();
        rays.push_back(Ray{glm::dvec3(r * std::cos(phi), r * std::sin(phi), -1.0) - 10.0 * d, d});
    }
    const auto scratch = tracer.makeScratch();
    std::vector<PhotonTracer::PacketPhoton> packet;
    std::vector<PhotonHistory> histories(256);
    PhotonHistory history;
    long photons = 0, events = 0, laneEvents = 0;
    std::uint64_t stream = 0;
    for (auto _ : state) {
        for (int first = 0; first < count; first += 256) {
            const int n = std::min(256, count - first);
            if (packets) {
                packet.clear();
                for (int i = first; i < first + n; ++i) packet.push_back({rays[i], &indices[i], Rng(7, stream++)});
                laneEvents += tracer.tracePacket(packet, std::span(histories).first(n), *scratch);
                for (int i = 0; i < n; ++i) events += histories[i].events;
            } else {
                for (int i = first; i < first + n; ++i) {
                    Rng walk(7, stream++);
                    tracer.trace(indices[i], rays[i], walk, history, *scratch);
                    events += history.events;
                }
            }
            photons += n;
        }
    }
    state.counters["photons/s"] = benchmark::Counter(static_cast<double>(photons), benchmark::Counter::kIsRate);
    state.counters["events/s"] = benchmark::Counter(static_cast<double>(events), benchmark::Counter::kIsRate);
    state.counters["lane_share"] = events > 0 ? static_cast<double>(laneEvents) / static_cast<double>(events) : 0.0;
}

}  // namespace

BENCHMARK(BM_PhotonWalks)->ArgName("packet")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(1.0);
