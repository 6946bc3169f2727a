#include "flare/render/RenderPlan.h"

#include <algorithm>
#include <optional>
#include <span>
#include <string>
#include <utility>

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include "flare/ghosts/Ghosts.h"
#include "flare/render/BeamStrategy.h"

namespace flare::renderer {

namespace {

constexpr double kMm2PerM2 = 1e6;
// Guide masks reach beyond the sensor by a fraction of its half-diagonal (dispersion across the
// visible and the sun's 0.5° move a ghost's landings by up to about a millimetre on a full-frame
// sensor), and their probes' regions are found where they come within this many cells of the
// regions found so far. Every dead cell within that reach costs every probe: 2 cells against 4
// took the night plate's masks from 12.4 M rays to 8.1 M and the examples' by a third to a half,
// and kept their live cells to 0.5 % (docs/BENCHMARKS.md).
constexpr int kGuideGrowCells = 2;
constexpr double kGuideSensorMargin = 0.1;
// The wavelengths (nm) and the points of the light's rim at which the masks are traced besides
// the analysis's: near the ends of the range that holds nearly all the colour-matching functions'
// weight, then between them and the middle.
constexpr double kMaskProbeNm[] = {410.0, 690.0, 470.0, 620.0};
constexpr int kMaskProbeRimPoints = 4;

// Whether the order-4 chains are guided, and why. `tooMany`: the lens has more chains than
// maxAnalysedChains.
void chooseHigherOrder(const RenderOptions& options, bool tooMany, LightPlan& plan) {
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
}

// The maxAnalysedChains strongest of `chains` by their normal-incidence reflectances, in
// enumeration order.
std::vector<GhostPath> strongestChains(const LensSystem& lens, const RenderOptions& options,
                                       std::vector<GhostPath> chains) {
    const SpectralIndices at = lens.indicesAt(options.analysis.wavelengthNm);
    std::vector<std::pair<double, size_t>> ranked;
    for (size_t c = 0; c < chains.size(); ++c) ranked.push_back({-normalIncidenceReflectance(lens, at, chains[c]), c});
    // Strongest first; ties by enumeration order, so the choice is deterministic.
    std::partial_sort(ranked.begin(), ranked.begin() + options.maxAnalysedChains, ranked.end());
    std::vector<size_t> keep;
    for (int i = 0; i < options.maxAnalysedChains; ++i) keep.push_back(ranked[i].second);
    std::sort(keep.begin(), keep.end());
    std::vector<GhostPath> strongest;
    for (size_t c : keep) strongest.push_back(std::move(chains[c]));
    return strongest;
}

// Longer chains: the strongest order-4 paths are enumerated and guided too when the lens's
// reflectances make them matter (uncoated glass: a few per cent of the ghosts' power), else they
// stay with the unguided tracer (coated glass: about R² of the ghosts'). Guided chains join the
// report's ghosts, the strongest maxHigherOrderPaths of them kept.
void planHigherOrder(const LensSystem& lens, const RenderOptions& options, GhostReport& report, LightPlan& plan) {
    plan.higherOrderShareEstimate = higherOrderShareEstimate(
        lens, lens.indicesAt(options.analysis.wavelengthNm), options.analysis.includeSensor);
    std::vector<GhostPath> chains;
    if (options.mode != RenderOptions::Mode::Naive && options.analysis.order == 2 &&
        options.higherOrder != RenderOptions::HigherOrder::Off) {
        chains = enumerateGhosts(lens, 4, options.analysis.includeSensor);
        plan.higherOrderChains = static_cast<long>(chains.size());
    }
    const bool tooMany = chains.size() > static_cast<size_t>(std::max(options.maxAnalysedChains, 0));
    chooseHigherOrder(options, tooMany, plan);
    if (!plan.higherOrderGuided) return;
    // Their power spreads over hundreds of paths, and vignetting, not the reflectances,
    // decides which are strong: every chain is analysed, up to maxAnalysedChains; past
    // that (with --higher-order on; a zoom has 10⁵ chains: minutes of analysis) the
    // strongest by reflectance.
    if (tooMany) chains = strongestChains(lens, options, std::move(chains));
    plan.higherOrderAnalysed = static_cast<int>(chains.size());
    const size_t before = report.ghosts.size();
    GhostAnalysisOptions chainOptions = options.analysis;
    chainOptions.order = 4;
    chainOptions.keepShare = options.higherOrderKeepShare;
    appendGhostPaths(lens, chains, chainOptions, report);
    int kept = 0;
    for (size_t g = before; g < report.ghosts.size(); ++g) {
        GhostEstimate& estimate = report.ghosts[g];
        if (!estimate.pruned && kept >= options.maxHigherOrderPaths) {
            estimate.pruned = true;
            ++report.prunedCount;
            report.prunedPowerFraction += estimate.powerFraction;
        }
        kept += !estimate.pruned;
    }
    plan.higherOrderPaths = kept;
}

// A region light's analysis is at its centre, where a ghost may be weak or miss the sensor while
// its outer points make it strong (a ghost's image and vignetting move with the field angle, and
// the centre need not hold a point at all). Each ghost the centre pruned is estimated again at the
// region's outermost points (and so is one the centre kept with nothing live there); one that is
// there at least as strong as the weakest ghost the centre kept is kept, with that point's
// estimate (its live pupil region seeds the guide mask, which every probe then grows over all the
// points: GuideMask::traced's seedProbes).
void keepRegionRimGhosts(const LensSystem& lens, const LightSampler& sampler, const RenderOptions& options,
                         GhostReport& report) {
    if (!sampler.light().isRegion() || options.mode == RenderOptions::Mode::Naive) return;
    const std::vector<PupilGrid> rims = sampler.rimGrids(kMaskProbeRimPoints);
    if (rims.empty()) return;
    double weakestKept = 1e300;
    for (const GhostEstimate& g : report.ghosts)
        if (!g.pruned && g.path.reflections.size() == 2 && g.powerFraction > 0.0) weakestKept = std::min(weakestKept, g.powerFraction);
    if (weakestKept == 1e300) return;
    const SpectralIndices indices = lens.indicesAt(options.analysis.wavelengthNm);
    std::vector<std::optional<GhostEstimate>> stronger(report.ghosts.size());
    tbb::parallel_for(0, static_cast<int>(report.ghosts.size()), [&](int g) {
        const GhostEstimate& estimate = report.ghosts[g];
        // (Pruned, or kept with nothing live at the centre: its mask would be empty.)
        const bool dark = !(estimate.powerFraction > 0.0) || estimate.pupil.liveCount() == 0;
        if (!(estimate.pruned || dark) || estimate.path.reflections.size() != 2) return;
        for (const PupilGrid& rim : rims) {
            GhostEstimate atRim = estimatePath(lens, indices, rim, report.enteringAreaMm2, estimate.path, options.analysis);
            if (atRim.powerFraction >= weakestKept && (!stronger[g] || atRim.powerFraction > stronger[g]->powerFraction))
                stronger[g] = std::move(atRim);
        }
    });
    for (size_t g = 0; g < report.ghosts.size(); ++g) {
        if (!stronger[g]) continue;
        if (report.ghosts[g].pruned) {
            --report.prunedCount;
            report.prunedPowerFraction -= report.ghosts[g].powerFraction;
        }
        report.ghosts[g] = std::move(*stronger[g]);
        report.ghosts[g].pruned = false;
    }
}

// Every path's spectrum in this light, for the second pruning (GhostAnalysis.h: the
// analysis pruned at one wavelength; the zoom's ghost-layer fireflies were ghosts it pruned
// that reflect far more in the blue and red) and for the beams' wavelengths. Prunes `report`'s
// ghosts again; one spectrum per report ghost (empty where none was traced).
std::vector<PathSpectrum> prunePathsBySpectrum(const LensSystem& lens, const Spectrum& spectrum,
                                               const RenderOptions& options, GhostReport& report, LightPlan& plan) {
    std::vector<PathSpectrum> spectra(report.ghosts.size());
    if (options.mode == RenderOptions::Mode::Naive) return spectra;
    // Every nanometre for the kept paths (their beams' wavelengths), every ten for the
    // pruned ghosts (the pruning); then every nanometre for the ghosts the pruning keeps.
    auto trace = [&](bool afterPruning) {
        tbb::parallel_for(0, static_cast<int>(report.ghosts.size()), [&](int g) {
            const GhostEstimate& estimate = report.ghosts[g];
            if (!(estimate.powerFraction > 0.0) || !spectra[g].throughput.empty()) return;
            const bool ghost = estimate.path.reflections.size() == 2;
            if (afterPruning ? !estimate.pruned : !estimate.pruned || ghost)
                spectra[g] = pathSpectrum(lens, report.grid, estimate, spectrum, options.analysis.wavelengthNm,
                                          estimate.pruned ? kPruningStepNm : 1);
        });
    };
    trace(false);
    plan.spectrallyKeptGhosts = keepSpectrallyStrongGhosts(lens, spectrum, options.analysis, report, &spectra);
    trace(true);
    return spectra;
}

// The guide masks' probes: the analysis's own rays first, then the ends and quarters of the
// visible at the light's centre, then its extent's edge (a sun's rim, a disk's circumference, a
// region's outermost points) at the ends and the middle. A path's live region moves with both.
std::vector<GuideMask::Probe> maskProbes(const LensSystem& lens, const LightSampler& sampler, const PupilGrid& grid,
                                         double analysisNm) {
    std::vector<GuideMask::Probe> probes{{grid, lens.indicesAt(analysisNm)}};
    for (double nm : kMaskProbeNm) probes.push_back({grid, lens.indicesAt(nm)});
    for (const PupilGrid& rim : sampler.rimGrids(kMaskProbeRimPoints))
        for (double nm : {kMaskProbeNm[0], analysisNm, kMaskProbeNm[1]}) probes.push_back({rim, lens.indicesAt(nm)});
    return probes;
}

// Guide masks and strategies of the light's paths, and the beams' rates where `beamLight`.
void planStrategies(const LensSystem& lens, const Spectrum& spectrum, const RenderOptions& options, bool beamLight,
                    const std::vector<PathSpectrum>& spectra, LightState& state) {
    const GhostReport& report = state.report;
    std::vector<double> beamWeight(state.slots, 0.0);
    std::vector<double> spectralPower(state.slots, 0.0);  // per slot: power fraction over the spectrum
    // Guide masks: the analysed regions re-traced with a margin around the sensor (see
    // GuideMask::traced), in parallel over paths; each mask is a pure function of its path.
    const SpectralIndices indices = lens.indicesAt(options.analysis.wavelengthNm);
    const double marginMm = kGuideSensorMargin * lens.sensorHalfDiagonalMm();
    const std::vector<GuideMask::Probe> probes = maskProbes(lens, state.sampler, report.grid, options.analysis.wavelengthNm);
    tbb::parallel_for(0, state.slots, [&](int slot) {
        const GhostEstimate& estimate = slot == 0 ? report.direct : report.ghosts[slot - 1];
        if (slot > 0 && estimate.pruned) return;
        state.masks[slot] = GuideMask::traced(lens, probes, estimate.path, estimate.pupil, kGuideGrowCells, marginMm,
                                              report.grid.halfSizeMm, state.sampler.light().isRegion() ? probes.size() : 1);
        if (state.masks[slot].empty()) return;
        state.strategy[slot] = PathStrategy::Photons;
        if (slot == 0 || !beamLight || estimate.lattice.empty()) return;
        state.beamLattices[slot] = state.masks[slot].coveringLattice(estimate.lattice);
        BeamProbe probe = probeBeamPath(lens, indices, state, slot, spectra[slot - 1], spectrum, options);
        spectralPower[slot] = probe.spectralPower;
        state.beamWavelengths[slot] = std::move(probe.wavelengths);
        if (!probe.beams) return;
        beamWeight[slot] = probe.weight;
        state.strategy[slot] = PathStrategy::Beams;
    });
    state.beamRate = beamRates(state, beamWeight, spectralPower, options.beamsPerPass);
    state.beamSpectralPower = spectralPower;
    for (int slot = 1; slot < state.slots; ++slot)
        state.pathPowerFraction[slot] = spectralPower[slot] > 0.0 ? spectralPower[slot] : report.ghosts[slot - 1].powerFraction;
}

}  // namespace

PlannedLight planLight(const LensSystem& lens, const LightSpec& spec, const RenderOptions& options, bool anyScattering) {
    const Spectrum spectrum = toSpectrum(spec.spectrum);
    LightSampler sampler(spec, lens);
    // The analysis traces the light's own rays: parallel for a directional light, fanning from the
    // light for a point or disk (its centre), so that masks and beams see its live regions.
    GhostReport analysed = analyseGhosts(lens, sampler.grid(), options.analysis);
    PlannedLight planned{LightState{std::move(sampler), WavelengthSampler(spectrum), std::move(analysed),
                                    {}, {}, {}, {}, {}, {}, {}, {}, {}, 0, 0, {}, 0},
                         LightPlan{}};
    LightState& state = planned.state;
    LightPlan& plan = planned.plan;
    plan.name = spec.name;
    keepRegionRimGhosts(lens, state.sampler, options, state.report);
    planHigherOrder(lens, options, state.report, plan);
    const std::vector<PathSpectrum> spectra = prunePathsBySpectrum(lens, spectrum, options, state.report, plan);
    const GhostReport& report = state.report;
    state.slots = 1 + static_cast<int>(report.ghosts.size());
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

    state.masks.resize(state.slots);
    state.beamLattices.resize(state.slots);
    state.ghostLayer.assign(state.slots, -1);
    state.strategy.assign(state.slots, PathStrategy::Unguided);
    state.layer.assign(state.slots, kLayerGhost);
    state.layer[0] = kLayerDirect;
    for (int slot = 1; slot < state.slots; ++slot)
        if (report.ghosts[slot - 1].path.reflections.size() > 2) state.layer[slot] = kLayerHigher;
    state.beamWavelengths.resize(state.slots);
    state.beamRate.assign(state.slots, 0.0);
    state.beamSpectralPower.assign(state.slots, 0.0);
    state.beamsPerPass = options.beamsPerPass;
    state.pathPowerFraction.assign(state.slots, 0.0);
    for (int slot = 1; slot < state.slots; ++slot) state.pathPowerFraction[slot] = report.ghosts[slot - 1].powerFraction;
    if (options.mode != RenderOptions::Mode::Naive && !plan.skipped) {
        // Beams are splatted with the fixed 1-px tent: other kernels leave the ghosts to photons.
        const bool beamLight = options.mode == RenderOptions::Mode::Guided &&
                               options.film.kernel == FilmSettings::Kernel::Fixed && options.film.radiusPx <= 1.0;
        planStrategies(lens, spectrum, options, beamLight, spectra, state);
    }
    for (int slot = 1; slot < state.slots; ++slot) plan.beamGhosts += state.strategy[slot] == PathStrategy::Beams;
    for (const GhostEstimate& g : report.ghosts) {
        if (g.path.reflections.size() > 2) continue;  // (a chain)
        plan.prunedGhosts += g.pruned;
        plan.keptGhosts += !g.pruned;
    }
    return planned;
}

std::vector<PhotonComponent> photonComponents(const LensSystem& lens, const RenderOptions& options,
                                              const std::vector<LightState>& lights,
                                              const std::vector<double>& lightWeight) {
    // The photon budget: lights in proportion to the power they send in (every photon then
    // carries a similar power); within a light, the unguided share, the direct share, and the
    // photon-guided ghosts in proportion to their analysed power (floored, so that a ghost the
    // analysis underrates still gets photons).
    std::vector<PhotonComponent> components;
    double totalWeight = 0.0;
    for (double w : lightWeight) totalWeight += w;
    for (size_t l = 0; l < lights.size() && totalWeight > 0.0; ++l) {
        const double share = lightWeight[l] / totalWeight;
        if (share == 0.0) continue;
        const LightState& state = lights[l];
        if (options.mode == RenderOptions::Mode::Naive) {
            components.push_back({static_cast<int>(l), -1, share, nullptr});
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
        components.push_back({static_cast<int>(l), -1, share * unguidedShare, nullptr});
        if (directShare > 0.0) components.push_back({static_cast<int>(l), 0, share * directShare, nullptr});
        for (int slot = 1; slot < state.slots; ++slot)
            if (ghostWeight[slot] > 0.0)
                components.push_back({static_cast<int>(l), slot, share * ghostShare * ghostWeight[slot] / ghostTotal, nullptr});
    }
    // (Its steps do not depend on the wavelength it is built at: each photon refracts at its own.)
    for (PhotonComponent& c : components) {
        if (c.slot < 0) continue;
        const LightState& state = lights[c.light];
        const std::span<const int> reflections =
            c.slot == 0 ? std::span<const int>() : std::span<const int>(state.report.ghosts[c.slot - 1].path.reflections);
        c.tracer = std::make_shared<const PacketTracer>(BundleTracer(lens, lens.indicesAt(kLineDNm), reflections, true));
    }
    return components;
}

std::vector<double> cumulativeProbabilities(const std::vector<PhotonComponent>& components) {
    std::vector<double> cdf;
    double cumulative = 0.0;
    for (const PhotonComponent& c : components) cdf.push_back(cumulative += c.probability);
    if (!cdf.empty()) cdf.back() = 1.0;
    return cdf;
}

}  // namespace flare::renderer
