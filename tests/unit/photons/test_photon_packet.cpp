// PhotonTracer::tracePacket against trace(), photon by photon and bit for bit, on every
// instruction set that this processor runs and Highway compiled: the same fate, events,
// reflections, arrivals (positions, weights, paths), deposits, and the generator left in the same
// state. The photons come from many directions and wavelengths, so that they end in every way the
// lanes hand over (walls, rings, the iris blades, the sensor, escape) and some are trapped; the
// lenses cover spheres (the double Gauss), aspheres (the zoom: intersect()'s Newton iteration in
// the lanes), a fisheye's steep surfaces, dust and grease, bulk media, stray light sampling, a
// bounce limit, a black interior and a strongly reflecting coating.
#include <cmath>
#include <cstdint>
#include <numbers>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <hwy/targets.h>

#include "TestUtil.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/PacketTracer.h"
#include "flare/photons/PhotonTracer.h"

namespace flare {
namespace {

InteriorMaterials greyInterior() {
    InteriorMaterials m;
    m.housingAlbedo = 0.3, m.housingGlossy = 0.2;
    m.edgeAlbedo = 0.3, m.irisAlbedo = 0.3, m.irisGlossy = 0.1;
    m.glossExponent = 12.0;
    return m;
}

// `count` photons aimed at the front of the lens from directions up to 40° off axis (some miss
// it, some graze it), at wavelengths across the visible; each photon's generator is stream i.
struct Photons {
    std::vector<SpectralIndices> indices;
    std::vector<Ray> rays;
};
Photons makePhotons(const LensSystem& lens, int count, std::uint64_t seed) {
    Rng rng(seed, 1000);
    Photons p;
    p.indices.reserve(count);
    const double front = 1.2 * lens.surface(0).mechSemiDiameterMm;
    for (int i = 0; i < count; ++i) {
        p.indices.push_back(lens.indicesAt(390.0 + 380.0 * rng.uniform()));
        const double field = 40.0 * std::numbers::pi / 180.0 * std::sqrt(rng.uniform());
        const double azimuth = 2.0 * std::numbers::pi * rng.uniform();
        const glm::dvec3 d(std::sin(field) * std::cos(azimuth), std::sin(field) * std::sin(azimuth), std::cos(field));
        const double r = front * std::sqrt(rng.uniform()), phi = 2.0 * std::numbers::pi * rng.uniform();
        p.rays.push_back(Ray{glm::dvec3(r * std::cos(phi), r * std::sin(phi), -2.0) - 20.0 * d, d});
    }
    return p;
}

// Every field of two histories, bit for bit; false (with a message) at the first difference.
::testing::AssertionResult sameHistory(const PhotonHistory& a, const PhotonHistory& b) {
    auto differ = [](const char* what) { return ::testing::AssertionFailure() << what << " differs"; };
    if (a.fate != b.fate) return differ("fate") << " (" << toString(a.fate) << " vs " << toString(b.fate) << ")";
    if (a.entered != b.entered) return differ("entered");
    if (a.reflections != b.reflections) return differ("reflections");
    if (a.scatters != b.scatters) return differ("scatters");
    if (a.events != b.events) return differ("events") << " (" << a.events << " vs " << b.events << ")";
    if (a.nullCollisions != b.nullCollisions || a.realCollisions != b.realCollisions) return differ("collisions");
    if (a.arrivalCount != b.arrivalCount) return differ("arrivalCount");
    for (int i = 0; i < a.arrivalCount; ++i) {
        const SensorArrival &x = a.arrivals[i], &y = b.arrivals[i];
        if (x.positionMm != y.positionMm || x.weight != y.weight || x.key != y.key || x.scattered != y.scattered ||
            x.firstScatter != y.firstScatter)
            return differ("arrival") << " " << i;
    }
    if (a.weight != b.weight) return differ("weight");
    if (a.deposited != b.deposited) return differ("deposited");
    return ::testing::AssertionSuccess();
}

struct Outcome {
    long photons = 0, events = 0, laneEvents = 0, arrivals = 0;
    long fates[static_cast<int>(PhotonFate::Count)] = {};
};

// trace() and tracePacket() on the same photons with the same generators, on every instruction
// set; returns the counts of the last run (the same on every one).
Outcome compareWalks(const PhotonTracer& tracer, int count, std::uint64_t seed) {
    const Photons photons = makePhotons(tracer.lens(), count, seed);
    const auto scratch = tracer.makeScratch();
    std::vector<PhotonHistory> expected(count);
    std::vector<std::uint32_t> expectedNext(count);
    Outcome outcome;
    for (int i = 0; i < count; ++i) {
        Rng rng(seed, static_cast<std::uint64_t>(i));
        tracer.trace(photons.indices[i], photons.rays[i], rng, expected[i], *scratch);
        expectedNext[i] = rng.next();
        ++outcome.photons;
        outcome.events += expected[i].events;
        outcome.arrivals += expected[i].arrivalCount;
        ++outcome.fates[static_cast<int>(expected[i].fate)];
    }
    for (const std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
        hwy::SetSupportedTargetsForTest(target);
        EXPECT_STREQ(PacketTracer::targetName(), hwy::TargetName(target));
        std::vector<PhotonTracer::PacketPhoton> packet;
        packet.reserve(count);
        for (int i = 0; i < count; ++i)
            packet.push_back({photons.rays[i], &photons.indices[i], Rng(seed, static_cast<std::uint64_t>(i))});
        std::vector<PhotonHistory> histories(count);
        outcome.laneEvents = tracer.tracePacket(packet, histories, *scratch);
        int mismatches = 0;
        for (int i = 0; i < count && mismatches < 5; ++i) {
            const ::testing::AssertionResult same = sameHistory(histories[i], expected[i]);
            if (!same) ++mismatches;
            EXPECT_TRUE(same) << hwy::TargetName(target) << ", photon " << i;
            EXPECT_EQ(packet[i].rng.next(), expectedNext[i]) << hwy::TargetName(target) << ", photon " << i;
        }
    }
    hwy::SetSupportedTargetsForTest(0);
    return outcome;
}

long fate(const Outcome& o, PhotonFate f) { return o.fates[static_cast<int>(f)]; }

// A walk starts its history with restart(), which leaves the arrivals' storage alone: every
// other member must come out as in a new history.
TEST(PhotonPacket, RestartResetsEveryMemberButTheArrivalsStorage) {
    PhotonHistory h;
    h.fate = PhotonFate::EventLimit, h.entered = true, h.reflections = 3, h.scatters = 2, h.events = 9;
    h.nullCollisions = 4, h.realCollisions = 5, h.arrivalCount = 6, h.weight = 0.25;
    h.deposited.fill(0.5);
    h.arrivals[0].weight = 7.0;
    h.restart();
    const PhotonHistory fresh;
    EXPECT_TRUE(sameHistory(h, fresh));
    EXPECT_EQ(h.arrivals[0].weight, 7.0);  // left as it was
    // The members sameHistory compares and the arrivals are all the history holds (a new member
    // changes the size: restart() and sameHistory must learn it). The padding on x86-64: 2 bytes
    // after the two one-byte members, 4 before the 8-byte-aligned arrivals.
    const size_t padding = 2 + 4;
    EXPECT_EQ(sizeof(PhotonHistory), sizeof(fresh.fate) + sizeof(fresh.entered) + 6 * sizeof(int) + sizeof(fresh.arrivals) +
                                         sizeof(fresh.weight) + sizeof(fresh.deposited) + padding);
}

TEST(PhotonPacket, EqualsTraceBitForBitOnTheDoubleGauss) {
    LensPrescription p = loadLensFile(test::sourcePath("lenses/double-gauss-50mm.lens"));
    p.sensor.reflectance = 0.3;  // light comes back from the sensor into the lanes
    const LensSystem lens = LensSystem::build(p);
    const PhotonTracer tracer(lens, greyInterior());
    const Outcome o = compareWalks(tracer, 6000, 11);
    // The comparison covered every way out of the lanes, and the lanes did most of the work.
    for (PhotonFate f : {PhotonFate::Escaped, PhotonFate::AbsorbedSensor, PhotonFate::AbsorbedHousing,
                         PhotonFate::AbsorbedEdge, PhotonFate::AbsorbedIris})
        EXPECT_GT(fate(o, f), 20) << toString(f);
    EXPECT_GT(o.arrivals, 500);
    EXPECT_GT(o.laneEvents, o.events / 2) << o.laneEvents << " of " << o.events;
}

// A strongly reflecting single layer (index 2.3, quarter-wave at 550 nm: about 30 % at normal
// incidence on these glasses) on every air–glass surface: many draws then fall between the
// reflectance and the bound the lanes refract above, where only the exact response decides.
TEST(PhotonPacket, EqualsTraceWhereTheCoatingReflectsMuch) {
    LensPrescription p = loadLensFile(test::sourcePath("lenses/double-gauss-50mm.lens"));
    p.coatings.push_back(Coating::quarterWave("high", 2.3, 550.0));
    p.defaultCoating = "high";
    for (PrescriptionRow& row : p.rows) row.coatingName.reset();
    const LensSystem lens = LensSystem::build(p);
    const PhotonTracer tracer(lens, greyInterior());
    const Outcome o = compareWalks(tracer, 4000, 16);
    EXPECT_GT(o.laneEvents, o.events / 2);
    // And a black interior: the blades absorb without a draw.
    const Outcome black = compareWalks(PhotonTracer(lens, InteriorMaterials{}), 2000, 17);
    EXPECT_GT(fate(black, PhotonFate::AbsorbedIris), 30);
}

TEST(PhotonPacket, EqualsTraceOnAspheresAndSteepSurfaces) {
    for (const char* name : {"lenses/zoom-24-70mm.lens", "lenses/fisheye-16mm.lens"}) {
        SCOPED_TRACE(name);
        const LensSystem lens = test::loadLens(name);
        const PhotonTracer tracer(lens, greyInterior());
        const Outcome o = compareWalks(tracer, 3000, 12);
        EXPECT_GT(o.laneEvents, o.events / 3);  // the zoom's aspheres in the lanes too
        EXPECT_GT(o.arrivals, 10);
    }
}

TEST(PhotonPacket, EqualsTraceWithDustGreaseMediaStrayLightAndABounceLimit) {
    LensPrescription p = loadLensFile(test::sourcePath("lenses/double-gauss-50mm.lens"));
    p.sensor.reflectance = 0.3;
    const LensSystem lens = LensSystem::build(p);
    std::vector<SurfaceContamination> dirt(lens.surfaceCount());
    dirt[1].dustCoverage = 0.3;
    dirt[lens.surfaceCount() - 1].greaseCoverage = 0.4;
    std::vector<BulkMedium> media;
    for (int cell = 1; cell < lens.surfaceCount() && media.empty(); ++cell)
        if (!lens.mediumBefore(cell).isAir()) {
            BulkMedium m;
            m.cell = cell, m.scatteringPerMm = 0.05, m.absorptionPerMm = 0.01, m.g = 0.5;
            media.push_back(m);
        }
    {
        SCOPED_TRACE("dust, grease and a medium, analog");
        const PhotonTracer tracer(lens, greyInterior(), -1, dirt, media);
        EXPECT_GT(compareWalks(tracer, 3000, 13).laneEvents, 0);
    }
    {
        SCOPED_TRACE("the same with stray light sampling");
        PhotonTracer tracer(lens, greyInterior(), -1, dirt, media);
        tracer.setStrayLightSampling({true, true});
        EXPECT_GT(compareWalks(tracer, 3000, 14).laneEvents, 0);
    }
    {
        SCOPED_TRACE("the same, the interior's bounces split in four");
        PhotonTracer tracer(lens, greyInterior(), -1, dirt, media);
        tracer.setStrayLightSampling({.weighted = true, .connectSensor = true, .scatterSplits = 4});
        EXPECT_GT(compareWalks(tracer, 3000, 16).laneEvents, 0);
    }
    {
        SCOPED_TRACE("a bounce limit of 2 (one photon at a time)");
        const PhotonTracer tracer(lens, greyInterior(), 2);
        const Outcome o = compareWalks(tracer, 2000, 15);
        EXPECT_GT(fate(o, PhotonFate::BounceLimit), 0);
    }
}

}  // namespace
}  // namespace flare
