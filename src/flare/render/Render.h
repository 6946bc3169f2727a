// The final render: photons from every light through the lens onto the sensor, density-estimated
// into layers (direct, ghost, higher, scatter, and one per ghost on request).
//
// Two strategies share the work, and every light path belongs to exactly one of them
// (DESIGN.md, "the one rule"):
//   guided   for each light and each path the ghost analysis kept (the direct image included),
//            photons are emitted only through the path's live pupil cells and traced through its
//            forced reflection sequence; the weight is the product of the Fresnel/coating factors.
//            It owns the paths with that exact sequence that start in those cells.
//   unguided the non-sequential photon tracer (Fresnel roulette, unbounded bounces), emitting
//            uniformly towards the whole front opening: the thesis's method. It scores every path
//            the guided strategy does not own: pruned ghosts, rays outside the live cells, longer
//            chains (`higher`), scattered light.
// Each photon picks one strategy (a mixture with fixed probabilities, the budget), so the sum is
// an unbiased estimate of the full transport. In naive mode the unguided tracer does everything.
//
// Work is split into passes of fixed-size batches; a batch's random numbers come from
// (seed, batch index) and passes are merged in batch order, so the image depends on the seed and
// never on the thread count. A pass is also the unit of checkpoints and of the variance estimate.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "flare/film/Film.h"
#include "flare/ghosts/GhostAnalysis.h"
#include "flare/optics/IndexTable.h"
#include "flare/photons/Light.h"
#include "flare/photons/PhotonTracer.h"

namespace flare {

struct RenderOptions {
    enum class Mode { Naive, Guided };
    Mode mode = Mode::Guided;
    std::uint64_t seed = 1;
    int maxBounces = -1;  // −1: unbounded
    bool perGhostLayers = false;
    FilmSettings film;    // size from the scene; kernel choice
    InteriorMaterials materials;
    std::vector<SurfaceContamination> contamination;  // per surface, or empty (clean)
    std::vector<BulkMedium> media;
    GhostAnalysisOptions analysis;
    // Guided mode: shares of the photons given to the unguided tracer and to the direct image;
    // the rest goes to the kept ghosts in proportion to their estimated power.
    double unguidedShare = 0.1;
    double directShare = 0.1;
    int batchPhotons = 1024;
    int batchesPerPass = 64;

    std::int64_t photonsPerPass() const { return static_cast<std::int64_t>(batchPhotons) * batchesPerPass; }
};


// Film layers of every render, in this order; per-ghost layers follow.
enum RenderLayer : int { kLayerDirect = 0, kLayerGhost, kLayerHigher, kLayerScatter, kFixedLayerCount };
const char* renderLayerName(int layer);

// What a path tally counts, per light.
struct PathTally {
    enum class Kind { Direct, Ghost, Higher, Scatter };
    Kind kind = Kind::Ghost;
    int light = 0;
    GhostPath path;            // Direct and Ghost
    double analysedPowerFraction = 0.0;  // the ghost analysis's estimate (0 for Higher/Scatter)
    bool guided = false;       // sampled by the guided strategy (else: by the unguided tracer only)
    double sumMeans = 0.0, sumSquaredMeans = 0.0;  // over batches of the per-photon mean Y power (W)
};

struct LightPlan {
    std::string name;
    bool skipped = false;
    std::string skipReason;
    double enteringPowerW = 0.0;  // the light's power entering the front clear aperture (nominal)
    int keptGhosts = 0, prunedGhosts = 0;
};

struct FateTally {
    std::int64_t photons = 0;
    double powerW = 0.0;
};

struct RenderStatistics {
    std::int64_t photons = 0;          // emitted, both strategies
    std::int64_t unguidedPhotons = 0;
    std::int64_t guidedPhotons = 0;
    std::int64_t sensorHits = 0;
    int passes = 0;
    double seconds = 0.0;              // wall time of the passes (summed over resumed sessions)
    double unguidedEmittedPowerW = 0.0;  // Σ weights of the unguided photons
    double unguidedEnteredPowerW = 0.0;
    FateTally fates[static_cast<int>(PhotonFate::Count)];
    std::int64_t nullCollisions = 0, realCollisions = 0;  // delta tracking in bulk media
};

class Renderer {
public:
    // Analyses the ghosts of every light, plans the photon budget and allocates the film. `lens`
    // is built at the scene's state (buildSceneLens); `options` carries its scattering
    // (applySceneScattering).
    Renderer(const LensSystem& lens, const std::vector<LightSpec>& lights, const RenderOptions& options);
    ~Renderer();
    Renderer(const Renderer&) = delete;
    Renderer& operator=(const Renderer&) = delete;

    // Traces one pass (options.photonsPerPass() photons) in parallel and merges it.
    void runPass();

    const RenderOptions& options() const { return options_; }
    const RenderStatistics& statistics() const { return statistics_; }
    const std::vector<LightPlan>& lights() const { return lightPlans_; }
    const std::vector<PathTally>& tallies() const { return tallies_; }
    // One tally per layer kind (direct, ghost, higher, scatter), summed over lights and paths.
    const std::vector<PathTally>& layerTallies() const { return layerTallies_; }
    // The `scatter` layer split by what each path met first: housing, dust, grease, bulk
    // (indexed by ScatterSource − 1).
    const std::vector<PathTally>& scatterSourceTallies() const { return scatterSourceTallies_; }
    const Film& film() const { return film_; }
    // Film layer names: direct, ghost, higher, scatter, then ghost_03_07, ... (kept ghosts).
    const std::vector<std::string>& layerNames() const { return layerNames_; }

    // Irradiance (W/m², XYZ) of a film layer after the passes so far.
    std::vector<float> layerXyz(int layer) const;
    // Estimated mean Y power (W) on the sensor of a tally and its standard error, from the spread
    // between batches (independent, identically distributed estimates).
    double tallyPowerW(const PathTally& tally) const;
    double tallyStandardErrorW(const PathTally& tally) const;

    // Checkpoints (binary): the film, the tallies, the statistics and the number of passes done.
    // Loading checks that the checkpoint was written by a render with the same scene, lens and
    // options; else InputError(path, 0, why).
    void saveCheckpoint(const std::string& path) const;
    void loadCheckpoint(const std::string& path);

private:
    struct Component;
    struct LightState;
    struct BatchResult;
    void traceBatch(std::int64_t batchIndex, BatchResult& out) const;
    std::uint64_t fingerprint() const;

    const LensSystem* lens_;
    RenderOptions options_;
    std::vector<LightState> lightStates_;
    std::vector<LightPlan> lightPlans_;
    std::vector<Component> components_;
    std::vector<double> componentCdf_;
    std::vector<PathTally> tallies_;
    std::vector<PathTally> layerTallies_;
    std::vector<PathTally> scatterSourceTallies_;
    std::vector<BatchResult> batches_;  // scratch, one per batch of a pass
    std::vector<std::string> layerNames_;
    IndexTable indexTable_;
    PhotonTracer tracer_;
    Film film_;
    RenderStatistics statistics_;
    std::int64_t batchesDone_ = 0;
};

}  // namespace flare
