#include "flare/render/BeamStrategy.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>

#include "flare/core/Random.h"
#include "flare/core/ScrambledSobol.h"
#include "flare/ghosts/GhostRinging.h"
#include "flare/optics/SequentialTracer.h"

namespace flare::renderer {

namespace {

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
// The outermost points of a region light that probe a ghost its centre misses (LightSampler::rimGrids).
constexpr int kRegionProbeRimPoints = 8;

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

// A beam's path at the beam's wavelength, traced ray by ray (the vertices' clear crossing, the
// correction photons). Guided paths own only unscattered light: with dust, grease or bulk media a
// ray's weight carries its probability of crossing them clear, which needs the path's points.
struct BeamPath {
    BeamPath(const LensSystem& lens, const PhotonTracer& tracer, const std::vector<int>& reflections, double wavelengthNm)
        : lens(lens), photonTracer(tracer), indices(lens.indicesAt(wavelengthNm)), wavelengthNm(wavelengthNm),
          clearWeight(tracer.hasContamination() || tracer.hasMedia()), scratch(tracer.makeScratch()) {
        sequence.reflections = reflections;
        if (clearWeight) {
            options.pathPointsMm = &pathPoints;
            options.pathSurfaces = &pathSurfaces;
        }
    }
    BeamPath(const BeamPath&) = delete;  // (options points at the path's points)
    BeamPath& operator=(const BeamPath&) = delete;

    TraceResult trace(const Ray& ray) {
        pathPoints.clear();
        pathSurfaces.clear();
        return tracePath(lens, indices, ray, sequence, options);
    }
    // The last traced ray's probability of crossing clear (ratio tracking in grids: unbiased).
    double clear(Rng& rng) const {
        return clearWeight ? photonTracer.clearTransmittance(pathPoints, pathSurfaces, wavelengthNm, rng, *scratch) : 1.0;
    }

    const LensSystem& lens;
    const PhotonTracer& photonTracer;
    const SpectralIndices indices;
    const double wavelengthNm;
    const bool clearWeight;
    SequentialPath sequence;
    std::vector<glm::dvec3> pathPoints;
    std::vector<int> pathSurfaces;
    TraceOptions options;
    const std::unique_ptr<PhotonTracer::Scratch> scratch;
};

// The sample a beam was drawn at: its wavelength's XYZ weight, the uniforms of its sample of the
// light's extent (a direction within a directional light's disk, a point of a disk light), the
// light's central ray for it and the power per mm² of the plane its beam's throughputs are
// relative to (the central ray's; a point's rays carry their own relative to it).
struct BeamSample {
    glm::dvec3 xyzWeight{0.0};
    glm::dvec2 lightU{0.0};
    EmittedRay central;
    double referencePerMm2 = 0.0;
};

// Correction photons: the same wavelength and direction, pupil points stratified over the mask;
// each photon adds itself and subtracts its twin. `perBeam`: the beam's film weight.
void traceCorrectionPhotons(const RenderOptions& options, const LightState& light, const BeamSample& sample,
                            double perBeam, const FilmFrame& frame, BeamPath& path, Rng& rng, BeamJob& job) {
    const int photons = options.correctionPhotonsPerBeam;
    const GuideMask& mask = light.masks[job.slot];
    const double halfW = 0.5 * path.lens.sensor().widthMm, halfH = 0.5 * path.lens.sensor().heightMm;
    const double perPhoton = perBeam / photons;
    const glm::dvec3 base = sample.xyzWeight * (mask.areaMm2() * perPhoton);
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
        const EmittedRay emitted = light.sampler.rayThrough(ab.x, ab.y, sample.lightU.x, sample.lightU.y);
        ++job.photons;
        const TraceResult result = path.trace(emitted.ray);
        if (result.ok()) {
            const glm::dvec3& p = result.ray.originMm;
            if (std::abs(p.x) <= halfW && std::abs(p.y) <= halfH) {
                const double clear = path.clear(rng);
                const glm::dvec3 xyz = base * (emitted.powerPerMm2 * result.throughput * clear);
                hit({p.x, p.y}, xyz);
                correctionY += xyz.y;
            }
        }
        BeamTwin twin;
        if (job.beam.twin(ab, &twin)) {
            const glm::dvec2 sensorMm = frame.toSensorMm(twin.pixel);
            const glm::dvec3 xyz = -base * (sample.referencePerMm2 * twin.throughput);
            hit(sensorMm, xyz);
            correctionY += xyz.y;
        }
    }
    job.powerY += correctionY / static_cast<double>(options.photonsPerPass());
}

}  // namespace

double beamCostRays(const GhostBeam& beam, int correctionPhotonsPerBeam) {
    // Rasterising a pixel costs about a tenth of a traced ray.
    double imageAreaPx2 = 0.0;
    for (const BeamTriangle& t : beam.triangles()) imageAreaPx2 += t.small ? 0.0 : t.imageAreaPx2;
    return static_cast<double>(beam.tracedRays()) + 0.1 * imageAreaPx2 + correctionPhotonsPerBeam * 2.0;
}

FilmFrame filmFrame(const FilmSettings& film) {
    return {film.widthPx, film.heightPx, film.widthMm, film.heightMm, film.widthMm / film.widthPx};
}

BeamProbe probeBeamPath(const LensSystem& lens, const SpectralIndices& indices, const LightState& light, int slot,
                        const PathSpectrum& pathShape, const Spectrum& lightSpectrum, const RenderOptions& options) {
    const GhostEstimate& estimate = light.report.ghosts[slot - 1];
    BeamProbe out;
    // Wavelengths where the path's coatings reflect (its ray's throughput at every
    // nanometre), and the power it carries in this light.
    std::vector<double> importance = pathShape.throughput;
    if (importance.empty()) importance.assign(kWavelengthBins, 0.0);
    out.spectralPower = estimate.powerFraction * pathShape.ratio;
    double mean = 0.0;
    for (double v : importance) mean += v / kWavelengthBins;
    if (!(mean > 0.0)) std::fill(importance.begin(), importance.end(), 1.0), mean = 1.0;
    for (double& v : importance) v += kSpectralFloor * mean;
    out.wavelengths = std::make_unique<WavelengthSampler>(lightSpectrum, importance);
    // A beam at the analysis's wavelength and the light's central direction measures
    // what the path's beams will cost and how uneven its image is (Σ power² / area:
    // its squared L2 norm for a point source, which caustics dominate); beams then go
    // to the paths in proportion to √(that / cost), which minimises the summed
    // variance for a given time if a beam's variance follows that norm.
    const BundleTracer probeTracer(lens, indices, estimate.path.reflections);
    PupilRemeshOptions remesh;
    remesh.minLevel = options.beamMeshLevel;
    GhostBeam probe = GhostBeam::build(probeTracer, light.report.grid, light.beamLattices[slot], light.masks[slot],
                                       filmFrame(options.film), remesh);
    // A region light's centre need not hold a point, nor see every ghost its points see: its
    // outermost points probe a ghost the centre misses.
    if (probe.empty() && light.sampler.light().isRegion())
        for (const PupilGrid& rim : light.sampler.rimGrids(kRegionProbeRimPoints)) {
            probe = GhostBeam::build(probeTracer, rim, light.beamLattices[slot], light.masks[slot], filmFrame(options.film), remesh);
            if (!probe.empty()) break;
        }
    if (probe.empty()) return out;
    double squaredNorm = 0.0;
    for (const BeamTriangle& t : probe.triangles()) {
        const double power = t.pupilAreaMm2 * (t.throughput[0] + t.throughput[1] + t.throughput[2]) / 3.0;
        const double area = t.small ? 1.0 : std::max(t.imageAreaPx2, 1.0);
        squaredNorm += power * power / area;
    }
    const double cost = beamCostRays(probe, options.correctionPhotonsPerBeam);
    out.weight = std::sqrt(squaredNorm / cost) * (out.spectralPower / estimate.powerFraction);
    out.beams = true;
    return out;
}

std::vector<double> beamRateFloors(const LightState& light, const std::vector<double>& spectralPower, int beamsPerPass) {
    // A weak path drawn with a tiny rate would appear in a few passes only, each time weighted by
    // one over that rate: heavy-tailed, and a short render that drew none would see no spread and
    // report its part as 0 ± 0. So every path of a layer (ghosts; order-4 chains) gets one beam
    // per pass, or, when the layer has too many paths for that, an equal share of
    // kFloorBudgetShare of the budget; and no beam is expected to carry more than kMaxBeamShare
    // of its layer's power (over the spectrum), a floor that sums to at most 1 / kMaxBeamShare
    // beams per layer.
    std::vector<double> floor(light.slots, 0.0);
    double layerPower[kFixedLayerCount] = {};
    int layerPaths[kFixedLayerCount] = {};
    for (int slot = 1; slot < light.slots; ++slot) {
        if (light.strategy[slot] != PathStrategy::Beams) continue;
        layerPower[light.layer[slot]] += spectralPower[slot];
        ++layerPaths[light.layer[slot]];
    }
    for (int slot = 1; slot < light.slots; ++slot)
        if (light.strategy[slot] == PathStrategy::Beams) {
            const int layer = light.layer[slot];
            const double everyPathFloor = std::min(1.0, kFloorBudgetShare * beamsPerPass / layerPaths[layer]);
            const double shareFloor = spectralPower[slot] / (kMaxBeamShare * layerPower[layer]);
            floor[slot] = std::max(shareFloor, everyPathFloor);
        }
    return floor;
}

std::vector<double> beamRates(const LightState& light, const std::vector<double>& weight,
                              const std::vector<double>& spectralPower, int beamsPerPass) {
    // Rates: the budget split by weight, with the floors (beamRateFloors).
    std::vector<double> rate = beamRateFloors(light, spectralPower, beamsPerPass);
    double totalBeamWeight = 0.0;
    for (int slot = 1; slot < light.slots; ++slot) totalBeamWeight += weight[slot];
    for (int slot = 1; slot < light.slots; ++slot)
        if (light.strategy[slot] == PathStrategy::Beams)
            rate[slot] = std::max(beamsPerPass * weight[slot] / totalBeamWeight, rate[slot]);
    return rate;
}

int beamCount(std::uint64_t seed, double rate, int pass, size_t light, int slot) {
    // The expected number's floor, and one more with the probability of its fraction (the
    // estimate divides by the expectation: unbiased).
    if (!(rate > 0.0)) return 0;
    Rng countRng(seed ^ 0xc0c0a0a0u,
                 (static_cast<std::uint64_t>(pass) << 32) ^ (static_cast<std::uint64_t>(light) << 20) ^
                     static_cast<std::uint64_t>(slot));
    return static_cast<int>(rate) + (countRng.uniform() < rate - std::floor(rate) ? 1 : 0);
}

void traceBeam(const LensSystem& lens, const RenderOptions& options, const PhotonTracer& tracer,
               const LightState& light, int pass, BeamJob& job) {
    const GhostEstimate& estimate = light.report.ghosts[job.slot - 1];
    const double beams = job.rate;
    const std::uint64_t path = (static_cast<std::uint64_t>(job.light) << 20) ^ static_cast<std::uint64_t>(job.slot);
    // The beam's sample: the next point of its path's sequence in its replicate (every path and
    // replicate scrambled independently), so a render's beams of a path are one stratified
    // sequence per replicate, not a fresh set per pass.
    double u[kBeamDimensions];
    const ScrambledSobol points(kBeamDimensions, mixBits(options.seed ^ 0x5eedbea5u) ^
                                                     mixBits((static_cast<std::uint64_t>(job.replicate) << 40) ^ path));
    points.point(job.sequenceIndex, u);
    const std::uint64_t stream = (static_cast<std::uint64_t>(pass) << 32) ^ path;
    Rng rng(options.seed, (stream << 16) ^ static_cast<std::uint64_t>(job.index) ^ 0xbea7000000000000ull);

    double pdfPerNm = 0.0;
    const WavelengthSampler& wavelengths = *light.beamWavelengths[job.slot];
    const double wavelengthNm = wavelengths.sample(u[0], &pdfPerNm);
    BeamSample sample;
    sample.lightU = concentricToPolarUniforms(u[1], u[2]);
    // (A region light's point reweights the wavelength by its own colour.)
    sample.xyzWeight = wavelengths.xyzWeight(wavelengthNm, pdfPerNm) * light.sampler.colourFactor(sample.lightU.x, wavelengthNm);
    sample.central = light.sampler.rayThrough(0.0, 0.0, sample.lightU.x, sample.lightU.y);
    // Parallel rays carry the same power per mm² of the plane; a point's rays carry its inverse
    // square and obliquity, which every vertex's throughput takes relative to the central ray's.
    const bool uniform = light.sampler.uniformOverPlane();
    sample.referencePerMm2 = uniform || sample.central.powerPerMm2 > 0.0 ? sample.central.powerPerMm2 : 1.0;
    // (A test's deliberate error: the jitter moves the sampled image, so a shifted jitter shifts it.)
    job.jitterPx = tentJitter(u[3], u[4]) - glm::dvec2(options.testBeamShiftPx, 0.0);
    job.seed = rng.next();

    BeamPath beamPath(lens, tracer, estimate.path.reflections, wavelengthNm);
    const SpectralIndices& indices = beamPath.indices;
    // Coating tables for this one wavelength: coarse ones build in a fraction of a millisecond and
    // agree with the exact response to a few 1e-4 at worst (test_bundle_tracer.cpp), far below the
    // mesh's own error. Only the path's own interfaces (the whole lens's cost several times as
    // much), with slopes from the values (one response per point instead of three: they were a
    // tenth of a default render; the interpolant moves by < 1e-5 relative).
    const std::vector<InterfaceTables::Interface> interfaces =
        BundleTracer(lens, indices, estimate.path.reflections, false).interfaces();
    const InterfaceTables tables(lens, indices, kBeamTableIntervals, interfaces, true);
    const BundleTracer bundleTracer(lens, indices, estimate.path.reflections, true, &tables);
    // The rays of the beam's sample of the light: parallel, or fanning from its point.
    const PupilGrid grid = light.sampler.gridFor(sample.lightU.x, sample.lightU.y);
    const FilmFrame frame = filmFrame(options.film);
    PupilRemeshOptions remesh;
    remesh.minLevel = options.beamMeshLevel;
    // Guided paths own only unscattered light: with dust, grease or bulk media every vertex's
    // throughput carries its probability of crossing them clear (ratio tracking in grids: an
    // unbiased estimate, so the beam stays an unbiased estimate of its piecewise-linear map); a
    // point's, its power per mm² relative to the central ray's.
    std::function<double(const glm::dvec2&)> vertexFactor;
    if (beamPath.clearWeight || !uniform)
        vertexFactor = [&](const glm::dvec2& pupilMm) {
            const double factor =
                uniform ? 1.0
                        : light.sampler.rayThrough(pupilMm.x, pupilMm.y, sample.lightU.x, sample.lightU.y).powerPerMm2 /
                              sample.referencePerMm2;
            if (!beamPath.clearWeight) return factor;
            const TraceResult r = beamPath.trace(grid.ray(pupilMm.x, pupilMm.y));
            return r.ok() ? factor * beamPath.clear(rng) : factor;
        };
    job.beam = GhostBeam::build(bundleTracer, grid, light.beamLattices[job.slot], light.masks[job.slot], frame, remesh,
                                vertexFactor);
    // The rim's Fresnel ripples, at the beam's wavelength, from the path's paraxial defocus; a ghost
    // only a few Fresnel zones across (near its focus) stays geometric, and so does one whose
    // ripples the light's apparent disk averages out (GhostRinging.h).
    if (options.ghostRinging && !job.beam.empty()) {
        const GhostFresnelScale fresnel = ghostFresnelScale(lens, indices, estimate.path);
        if (ghostRipplesVisible(fresnel, wavelengthNm, light.sampler.light().apparentRadiusRad()))
            job.beam.ring(fresnel.edgeScaleMm(wavelengthNm) / frame.pixelMm);
    }

    // Film units: the pass's image is its accumulated power over photonsPerPass (the film's
    // divisor), and the path's estimate is the mean of its beams.
    const double perBeam = static_cast<double>(options.photonsPerPass()) / beams;  // beams: the expectation
    job.scale = sample.xyzWeight * (sample.referencePerMm2 * perBeam);
    job.powerY = job.beam.powerOnSensor() * sample.referencePerMm2 * sample.xyzWeight.y / static_cast<double>(beams);

    if (options.correctionPhotonsPerBeam <= 0 || job.beam.empty()) return;
    traceCorrectionPhotons(options, light, sample, perBeam, frame, beamPath, rng, job);
}

}  // namespace flare::renderer
