#include "flare/render/RenderReport.h"

#include <algorithm>
#include <vector>

namespace flare {

namespace {

const char* kindName(PathTally::Kind kind) {
    switch (kind) {
        case PathTally::Kind::Direct: return "direct";
        case PathTally::Kind::Ghost: return "ghost";
        case PathTally::Kind::Higher: return "higher";
        case PathTally::Kind::Scatter: return "scatter";
    }
    return "?";
}

}  // namespace

const char* toString(RenderOptions::Mode mode) {
    switch (mode) {
        case RenderOptions::Mode::Guided: return "guided";
        case RenderOptions::Mode::GuidedPhotons: return "photons";
        case RenderOptions::Mode::Naive: return "naive";
    }
    return "?";
}

nlohmann::json renderReportJson(const Renderer& renderer, const std::string& sceneLabel, const std::string& lensName,
                                double targetError) {
    const RenderStatistics& s = renderer.statistics();
    nlohmann::json j;
    j["scene"] = sceneLabel;
    j["lens"] = lensName;
    j["mode"] = toString(renderer.options().mode);
    j["seed"] = renderer.options().seed;
    j["photons"] = s.photons;
    j["guided_photons"] = s.guidedPhotons;
    j["unguided_photons"] = s.unguidedPhotons;
    j["passes"] = s.passes;
    j["wall_time_s"] = s.seconds;
    // Each pass's sizes (RenderOptions::passPlan): the beams' scale of the planned rates and the
    // photon batches.
    nlohmann::json plan = nlohmann::json::array();
    for (const auto& [beamScale, batches] : renderer.passPlan()) plan.push_back({beamScale, batches});
    j["pass_plan"] = {{"adaptive", renderer.adaptivePassPlan()}, {"beam_scale_and_photon_batches", plan}};
    j["photons_per_second"] = s.seconds > 0.0 ? s.photons / s.seconds : 0.0;
    j["units"] = "power in W for the lights' power units; irradiance layers in W/m2";

    nlohmann::json lights = nlohmann::json::array();
    nlohmann::json skipped = nlohmann::json::array();
    for (const LightPlan& l : renderer.lights()) {
        lights.push_back({{"name", l.name}, {"entering_power_w", l.enteringPowerW}, {"kept_ghosts", l.keptGhosts},
                          {"beam_ghosts", l.beamGhosts}, {"pruned_ghosts", l.prunedGhosts},
                          {"spectrally_kept_ghosts", l.spectrallyKeptGhosts}, {"skipped", l.skipped},
                          {"higher_order",
                           {{"share_estimate", l.higherOrderShareEstimate},
                            {"guided", l.higherOrderGuided},
                            {"chains", l.higherOrderChains},
                            {"analysed", l.higherOrderAnalysed},
                            {"paths", l.higherOrderPaths},
                            {"why", l.higherOrderWhy}}}});
        if (l.skipped) skipped.push_back({{"light", l.name}, {"reason", l.skipReason}});
    }
    j["lights"] = lights;
    j["skipped"] = skipped;

    // Per layer: the power with its standard error, the estimated relative L2 error of the image
    // (as `flare compare` measures it against a reference), and the largest share of the layer's
    // power one photon carried (a firefly shows as a share far above 1 / photons).
    nlohmann::json layers;
    // No estimate yet (fewer than two passes, or a replicate without a pass): null, not 0.
    auto estimate = [&](int group) -> nlohmann::json {
        return renderer.hasErrorEstimate() ? nlohmann::json(renderer.estimatedRelativeError(group)) : nlohmann::json();
    };
    const double drawn = static_cast<double>(s.passes) * renderer.options().photonsPerPass();
    for (int l = 0; l < kFixedLayerCount; ++l) {
        const PathTally& t = renderer.layerTallies()[l];
        const double power = renderer.tallyPowerW(t);
        layers[kindName(t.kind)] = {
            {"power_w", power},
            {"standard_error_w", renderer.tallyStandardErrorW(t)},
            {"estimated_relative_error", estimate(kGroupDirect + l)},
            {"largest_photon_share", power > 0.0 && drawn > 0.0 ? s.largestPhotonY[l] / (drawn * power) : 0.0}};
    }
    j["layers"] = layers;
    j["flare_estimated_relative_error"] = estimate(kGroupFlare);
    j["target_error"] = targetError;
    j["beams"] = {{"beams", s.beams},
                  {"traced_rays", s.beamRays},
                  {"correction_photons", s.correctionPhotons},
                  {"replicates", renderer.film().replicates()}};
    nlohmann::json sources;
    for (size_t i = 0; i < renderer.scatterSourceTallies().size(); ++i) {
        const PathTally& t = renderer.scatterSourceTallies()[i];
        sources[toString(static_cast<ScatterSource>(i + 1))] = {{"power_w", renderer.tallyPowerW(t)},
                                                                {"standard_error_w", renderer.tallyStandardErrorW(t)}};
    }
    j["scatter_sources"] = sources;
    const double collisions = static_cast<double>(s.nullCollisions + s.realCollisions);
    j["delta_tracking"] = {{"real_collisions", s.realCollisions},
                           {"null_collisions", s.nullCollisions},
                           {"null_collision_ratio", collisions > 0.0 ? s.nullCollisions / collisions : 0.0}};

    std::vector<const PathTally*> ghosts;
    for (const PathTally& t : renderer.tallies())
        if (t.kind == PathTally::Kind::Ghost && (t.sumMeans != 0.0 || t.guided))
            ghosts.push_back(&t);
    std::stable_sort(ghosts.begin(), ghosts.end(), [&](const PathTally* a, const PathTally* b) {
        return renderer.tallyPowerW(*a) > renderer.tallyPowerW(*b);
    });
    nlohmann::json ghostArray = nlohmann::json::array();
    for (const PathTally* t : ghosts) {
        const double entering = renderer.lights()[t->light].enteringPowerW;
        const double power = renderer.tallyPowerW(*t);
        ghostArray.push_back({{"light", renderer.lights()[t->light].name},
                              {"label", t->path.label()},
                              {"surfaces", t->path.surfaceNumbers()},
                              {"power_w", power},
                              {"standard_error_w", renderer.tallyStandardErrorW(*t)},
                              {"power_fraction", entering > 0.0 ? power / entering : 0.0},
                              {"analysed_power_fraction", t->analysedPowerFraction},
                              {"guided", t->guided},
                              {"strategy", toString(t->strategy)}});
    }
    j["ghosts"] = ghostArray;

    // Photon weights are powers per photon drawn: their sum over all photons (both strategies)
    // divided by the photon count estimates a power.
    const double perPhoton = s.photons > 0 ? 1.0 / static_cast<double>(s.photons) : 0.0;
    nlohmann::json fates;
    for (int f = 0; f < static_cast<int>(PhotonFate::Count); ++f)
        fates[toString(static_cast<PhotonFate>(f))] = {{"photons", s.fates[f].photons},
                                                       {"power_w", s.fates[f].powerW * perPhoton}};
    j["unguided_energy"] = {{"emitted_power_w", s.unguidedEmittedPowerW * perPhoton},
                            {"entered_power_w", s.unguidedEnteredPowerW * perPhoton},
                            {"fates", fates}};
    return j;
}

}  // namespace flare
