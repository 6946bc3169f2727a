// The non-sequential photon tracer against closed forms (an uncoated plate) and counting
// identities (every photon ends in exactly one fate).
#include <array>
#include <cmath>
#include <string>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/optics/LensFile.h"
#include "flare/photons/PhotonTracer.h"

namespace flare {
namespace {

// A plane-parallel plate of n = 1.5 behind a wide stop; the sensor does not reflect.
LensSystem plate(double sensorReflectance = 0.0) {
    const std::string text = "name plate\nfocal_length_mm 1\nsensor width_mm=60 height_mm=60 reflectance=" +
                             std::to_string(sensorReflectance) +
                             "\nsurfaces\n stop 1 air 10\n inf 5 n=1.5 12\n inf 10 air 12\n";
    return LensSystem::build(parseLensText(text, "plate.lens"));
}

struct Counts {
    long photons = 0, onSensor = 0, direct = 0, ghost = 0;
    long fates[static_cast<int>(PhotonFate::Count)] = {};
};

// Photons along the axis through random points of the stop (radius 10 mm).
Counts shootAtPlate(const PhotonTracer& tracer, long photons, std::uint64_t seed) {
    const SpectralIndices indices = tracer.lens().indicesAt(550.0);
    Rng rng(seed, 0);
    Counts counts;
    PhotonHistory history;
    for (long i = 0; i < photons; ++i) {
        const double r = 9.0 * std::sqrt(rng.uniform()), phi = 2.0 * M_PI * rng.uniform();
        tracer.trace(indices, Ray{{r * std::cos(phi), r * std::sin(phi), -5.0}, {0.0, 0.0, 1.0}}, rng, history);
        ++counts.photons;
        ++counts.fates[static_cast<int>(history.fate)];
        counts.onSensor += history.arrivalCount;
        for (int a = 0; a < history.arrivalCount; ++a) {
            counts.direct += history.arrivals[a].key == pathKey({});
            counts.ghost += history.arrivals[a].key == pathKey({2, 1});
        }
    }
    return counts;
}

// Binomial proportion check: |k/n − p| within z standard errors, z = 4.5 (two-sided p ≈ 7e-6 per
// comparison, a family of a few dozen comparisons stays below 1e-3).
void expectProportion(long k, long n, double p, const char* what) {
    const double sigma = std::sqrt(p * (1.0 - p) / n);
    EXPECT_NEAR(static_cast<double>(k) / n, p, 4.5 * sigma) << what;
}

TEST(PhotonTracer, PlateTransmitsTheIncoherentSumOfAllBounces) {
    const LensSystem lens = plate();
    const PhotonTracer tracer(lens, {});
    const double n = lens.indicesAt(550.0).n[2];
    const double R = std::pow((n - 1.0) / (n + 1.0), 2.0);
    const long N = 200000;
    const Counts c = shootAtPlate(tracer, N, 7);
    // Multiple reflections inside a lossless plate add up to T = (1 − R)/(1 + R); the rest escapes.
    expectProportion(c.onSensor, N, (1.0 - R) / (1.0 + R), "transmitted");
    expectProportion(c.fates[static_cast<int>(PhotonFate::Escaped)], N, 2.0 * R / (1.0 + R), "escaped");
    expectProportion(c.direct, N, (1.0 - R) * (1.0 - R), "direct");
    expectProportion(c.ghost, N, (1.0 - R) * (1.0 - R) * R * R, "ghost 3-2");
    EXPECT_EQ(c.fates[static_cast<int>(PhotonFate::AbsorbedSensor)], c.onSensor);
    EXPECT_EQ(c.fates[static_cast<int>(PhotonFate::Lost)], 0);
}

TEST(PhotonTracer, BounceLimitStopsTheFirstReflection) {
    const LensSystem lens = plate();
    const PhotonTracer tracer(lens, {}, 0);
    const double n = lens.indicesAt(550.0).n[2];
    const double R = std::pow((n - 1.0) / (n + 1.0), 2.0);
    const long N = 100000;
    const Counts c = shootAtPlate(tracer, N, 11);
    expectProportion(c.onSensor, N, (1.0 - R) * (1.0 - R), "transmitted without reflecting");
    expectProportion(c.fates[static_cast<int>(PhotonFate::BounceLimit)], N, 1.0 - (1.0 - R) * (1.0 - R), "stopped");
    EXPECT_EQ(c.ghost, 0);
}

TEST(PhotonTracer, SensorReflectionSendsLightBackAndIsCountedOnEveryArrival) {
    const LensSystem lens = plate(0.5);
    const PhotonTracer tracer(lens, {});
    const long N = 100000;
    const Counts c = shootAtPlate(tracer, N, 13);
    // Every arrival is counted; a photon absorbed by the sensor ends there. More arrivals than
    // absorptions: half of the first arrivals reflect, and some of those come back.
    EXPECT_GT(c.onSensor, c.fates[static_cast<int>(PhotonFate::AbsorbedSensor)]);
    long total = 0;
    for (long f : c.fates) total += f;
    EXPECT_EQ(total, N);
}

TEST(PhotonTracer, EveryPhotonEndsInOneFateWithWhiteWallsOnARealLens) {
    const LensSystem lens = test::loadLens("lenses/double-gauss-50mm.lens");
    InteriorMaterials white{1.0, 1.0, 1.0};
    const PhotonTracer tracer(lens, white);
    const SpectralIndices indices = lens.indicesAt(550.0);
    Rng rng(3, 0);
    PhotonHistory history;
    long fates[static_cast<int>(PhotonFate::Count)] = {};
    long scattered = 0;
    const long N = 20000;
    for (long i = 0; i < N; ++i) {
        // A 25° off-axis beam over the whole front: much of it meets the barrel and the iris.
        const double a = (2.0 * rng.uniform() - 1.0) * 20.0, b = (2.0 * rng.uniform() - 1.0) * 20.0;
        const glm::dvec3 d = glm::normalize(glm::dvec3(std::tan(25.0 * M_PI / 180.0), 0.0, 1.0));
        tracer.trace(indices, Ray{glm::dvec3(a, b, -10.0) - 20.0 * d, d}, rng, history);
        ++fates[static_cast<int>(history.fate)];
        scattered += history.scatters > 0;
    }
    // With nothing absorbing inside, light can only escape or be absorbed by the sensor.
    EXPECT_EQ(fates[static_cast<int>(PhotonFate::Escaped)] + fates[static_cast<int>(PhotonFate::AbsorbedSensor)] +
                  fates[static_cast<int>(PhotonFate::EventLimit)],
              N);
    EXPECT_EQ(fates[static_cast<int>(PhotonFate::Lost)], 0);
    EXPECT_LT(fates[static_cast<int>(PhotonFate::EventLimit)], N / 1000);
    EXPECT_GT(scattered, N / 10);
}

TEST(PhotonTracer, SteepRayInsideGlassMeetsTheElementEdge) {
    const LensSystem lens = plate();
    const PhotonTracer tracer(lens, {});
    const SpectralIndices indices = lens.indicesAt(550.0);
    Rng rng(1, 0);
    PhotonHistory history;
    // Enters at 60° in the x–z plane and refracts to ~35° in the glass: over the 5 mm thickness
    // it moves tan 35° · 5 mm = 3.5 mm outwards, so a ray entering near the rim meets the edge.
    const glm::dvec3 d = glm::normalize(glm::dvec3(std::tan(60.0 * M_PI / 180.0), 0.0, 1.0));
    int edge = 0;
    for (int i = 0; i < 1000; ++i) {
        tracer.trace(indices, Ray{glm::dvec3(9.0, 0.0, 1.0) - 2.0 / d.z * d, d}, rng, history);
        edge += history.fate == PhotonFate::AbsorbedEdge;
    }
    // The ray passes the stop at x = 9 − 1.73 ≈ 7.3 mm (inside its 10 mm), meets the plate at
    // x = 9 mm (< 12 mm clear), and in the glass moves 3.5 mm outwards: past the 12 mm edge.
    EXPECT_GT(edge, 800);
}

// Photons of the rays `aim` draws through `text` (uncoated, black interior), by fate.
template <typename Aim>
std::array<long, static_cast<int>(PhotonFate::Count)> fatesThrough(const LensSystem& lens, int photons, std::uint64_t seed,
                                                                   Aim aim) {
    const PhotonTracer tracer(lens, {});
    const SpectralIndices indices = lens.indicesAt(550.0);
    Rng rng(seed, 0);
    PhotonHistory history;
    std::array<long, static_cast<int>(PhotonFate::Count)> fates{};
    for (int i = 0; i < photons; ++i) {
        tracer.trace(indices, aim(rng), rng, history);
        ++fates[static_cast<int>(history.fate)];
    }
    return fates;
}

glm::dvec3 directionAt(double theta, double phi) {
    return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

// Two elements touching at their vertices (an air space of thickness 0, which the parser accepts):
// an axial photon leaves the first element exactly where the second begins, so the surface ahead
// is met at t = 0. It must cross both interfaces there, as through an air space of 10⁻⁴ mm.
TEST(PhotonTracer, PhotonsCrossSurfacesTouchingAtTheVertex) {
    auto lensWithGap = [](const std::string& gap) {
        return LensSystem::build(parseLensText("name touching\nfocal_length_mm 50\nsurfaces\n 40 4 n=1.5 8\n -40 " + gap +
                                                   " air 8\n 40 4 n=1.5 8\n -40 2 air 8\n stop 30 air 6\n",
                                               "touching.lens"));
    };
    const auto axial = [](Rng&) { return Ray{{0.0, 0.0, -5.0}, {0.0, 0.0, 1.0}}; };
    const int N = 20000;
    const auto touching = fatesThrough(lensWithGap("0"), N, 1, axial);
    const auto apart = fatesThrough(lensWithGap("1e-4"), N, 2, axial);
    EXPECT_EQ(touching[static_cast<int>(PhotonFate::Lost)], 0);
    // Same transmission (to the sensor) within 4 standard deviations of the difference.
    const double p1 = touching[static_cast<int>(PhotonFate::AbsorbedSensor)] / double(N);
    const double p2 = apart[static_cast<int>(PhotonFate::AbsorbedSensor)] / double(N);
    EXPECT_GT(p1, 0.5);
    EXPECT_LT(std::abs(p1 - p2), 4.0 * std::sqrt((p1 * (1.0 - p1) + p2 * (1.0 - p2)) / N));
}

// A photon that refracts within the seam tolerance of a surface's rim, where the rim meets the
// element's edge, ends a rounding error outside the edge cylinder: it meets the edge at once.
TEST(PhotonTracer, NoPhotonIsLostAtTheRimOfASurface) {
    const LensSystem lens =
        LensSystem::build(parseLensText("name rim\nfocal_length_mm 50\nsurfaces\n 40 4 n=1.5 8\n -40 2 air 8\n stop 40 air 6\n", "rim.lens"));
    const Surface& s0 = lens.surface(0);
    const auto atRim = [&](Rng& rng) {  // at the rim of the first surface, within 5·10⁻¹⁰ of it
        const double phi = 2.0 * M_PI * rng.uniform();
        const double r = s0.semiApertureMm * (1.0 + (rng.uniform() - 0.5) * 1e-9);
        double sag = 0.0;
        s0.sagMm(r * r, &sag);
        const glm::dvec3 p(r * std::cos(phi), r * std::sin(phi), s0.vertexZMm + sag);
        const glm::dvec3 d = directionAt(0.5 * rng.uniform(), 2.0 * M_PI * rng.uniform());
        return Ray{p - 20.0 * d, d};
    };
    const auto fates = fatesThrough(lens, 20000, 1, atRim);
    EXPECT_EQ(fates[static_cast<int>(PhotonFate::Lost)], 0);
    EXPECT_GT(fates[static_cast<int>(PhotonFate::AbsorbedEdge)], 0);  // the seam is really met
}

// A triangular iris opens out to its circumradius (1.56 × its nominal radius of 5 mm) between a
// wide element (8 mm) and a narrow one (5 mm), with no barrel margin: the barrel behind the stop
// must reach the opening's corners, or light through them would pass outside it.
TEST(PhotonTracer, NoPhotonIsLostThroughTheCornersOfABladedIris) {
    const LensSystem lens = LensSystem::build(parseLensText(
        "name corners\nfocal_length_mm 50\niris blades=3\nhousing margin_mm=0\nsurfaces\n 200 4 n=1.5 8\n -200 2 air 8\n"
        " stop 2 air 5\n 40 4 n=1.5 5\n -40 40 air 5\n",
        "corners.lens"));
    const int stop = lens.stopIndex();
    EXPECT_GE(lens.surface(stop).mechSemiDiameterMm, lens.iris().circumradiusMm());
    EXPECT_GE(lens.housing()[stop].innerRadiusMm, lens.iris().circumradiusMm());
    const auto atCorners = [&](Rng& rng) {  // aimed at the stop plane out to the opening's corners
        const double phi = 2.0 * M_PI * rng.uniform();
        const double r = lens.iris().circumradiusMm() * (0.7 + 0.3 * rng.uniform());
        const glm::dvec3 target(r * std::cos(phi), r * std::sin(phi), lens.surface(stop).vertexZMm);
        const glm::dvec3 d = directionAt(0.05 * rng.uniform(), 2.0 * M_PI * rng.uniform());
        return Ray{target - (target.z + 5.0) / d.z * d, d};
    };
    const auto fates = fatesThrough(lens, 20000, 3, atCorners);
    EXPECT_EQ(fates[static_cast<int>(PhotonFate::Lost)], 0);
    EXPECT_GT(fates[static_cast<int>(PhotonFate::AbsorbedHousing)], 0);  // beyond the narrow element
}

TEST(PhotonTracer, PathKeysEncodeTheReflectionSequence) {
    EXPECT_EQ(pathKey({}), 0u);
    EXPECT_NE(pathKey({2, 1}), pathKey({1, 2}));
    EXPECT_EQ(pathKey({2, 1}), (PathKey{2} << 56) | 2u | (1u << 8));
    EXPECT_EQ(pathKey({1, 2, 3, 4, 5, 6, 7, 8}), kLongPathKey);
}

}  // namespace
}  // namespace flare
