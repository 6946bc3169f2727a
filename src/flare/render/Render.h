// The final render: light from every light through the lens onto the sensor, estimated into
// layers (direct, ghost, higher, scatter, and one per ghost on request).
//
// Every light path belongs to exactly one estimator (the rule that keeps the hybrid unbiased):
//   beams    (guided mode, every light) each kept ghost path is owned for the pupil points
//            inside its guide mask. Its image is estimated per pass by beams (GhostBeam.h): the
//            path meshed at a sampled wavelength, sample of the light's extent (a direction within
//            a directional light's disk, a point of a disk light; a point light's rays fan from
//            it) and film-kernel jitter, its irradiance integrated over the pupil deterministically; the samples
//            continue an Owen-scrambled Sobol' sequence from pass to pass (one per replicate,
//            below), with wavelengths drawn where the path's coatings reflect. Photons traced through the path at a beam's wavelength and direction correct
//            the beam through their twins (photon − twin, both splatted with the film's kernel),
//            so the estimate is unbiased whatever the mesh's error, and the noise left is that of
//            the difference, which vanishes where the piecewise-linear map is accurate.
//   guided photons  the direct image, and kept ghosts in mode GuidedPhotons: photons emitted only through the path's
//            live cells and traced through its forced sequence, weighted by the Fresnel/coating
//            factors.
//   unguided the non-sequential photon tracer (Fresnel roulette, unbounded bounces), emitting
//            uniformly towards the whole front opening: the thesis's method. It scores every path
//            the others do not own: pruned ghosts, rays outside the masks, longer chains
//            (`higher`), scattered light.
// The photons of a pass pick the unguided tracer or a photon-guided path at random (a mixture
// with fixed probabilities, the budget); beams and their correction photons are added on top, a
// fixed number per path and pass. The sum is an unbiased estimate of the full transport, which a
// test checks against naive mode (the unguided tracer alone).
//
// Work is split into passes of photon batches and beams; a batch's random numbers come from
// (seed, batch), a beam's sample from its path's sequence in its replicate (scrambled from the
// seed, the path and the replicate) and its other random numbers from (seed, pass, index), and a
// pass is merged into the film band by band in a fixed order,
// in parallel, so the image depends on the seed and never on the thread count. Without beams,
// passes are independent estimates: the spread between them gives the variance of every layer
// and of the flare without the direct image (the render's error estimate). With beams, the passes
// interleave `beamReplicates` independent replicates (pass p extends replicate p mod K's Sobol'
// sequences; core/Replicates.h), and the spread between the replicates gives it. Passes are the
// unit of checkpoints.
//
// The code, internal headers in the namespace flare::renderer:
//   RenderPlan.h          the plan of every light (the paths' strategies, masks and beam rates)
//                         and the photon budget's mixture;
//   BeamStrategy.h        beams: the probe beam, the beams' rates and counts, a beam's trace;
//   PhotonBatches.h       a batch of guided and unguided photons;
//   SensorHit.h           what the strategies hand to the merge;
//   Render.cpp            the renderer: the passes, their merge into the film, the tallies;
//   RenderCheckpoint.cpp  its checkpoints;
//   RenderDistributed.cpp a pass shared among processes (PassExchange.h, PassWire.h).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "flare/core/OutputFiles.h"
#include "flare/core/Replicates.h"
#include "flare/film/Film.h"
#include "flare/film/LayerSelection.h"
#include "flare/ghosts/GhostAnalysis.h"
#include "flare/optics/IndexTable.h"
#include "flare/photons/Light.h"
#include "flare/photons/PhotonTracer.h"
#include "flare/render/PassPlan.h"

namespace flare {

// Directions per bounce off the interior finishes for stray light sampling (RenderOptions::scatterSplits).
inline constexpr int kDefaultScatterSplits = 8;

struct RenderOptions {
    // Naive: the unguided tracer alone (the seed thesis's method). Guided: beams where they
    // apply, guided photons elsewhere. GuidedPhotons: guided photons for every kept path.
    enum class Mode { Naive, Guided, GuidedPhotons };
    Mode mode = Mode::Guided;
    std::uint64_t seed = 1;
    int maxBounces = -1;  // −1: unbounded
    bool perGhostLayers = false;
    // With perGhostLayers: which ghosts get a layer of their own, by their estimated power (each
    // path's power over its light's spectrum, summed over the lights that have it). The order-2
    // ghosts left out share one layer, kOtherGhostsLayer; an order-4 chain left out has none (its
    // light is in `higher`).
    LayerSelection ghostLayers;
    FilmSettings film;    // size from the scene; kernel choice
    InteriorMaterials materials;
    std::vector<SurfaceContamination> contamination;  // per surface, or empty (clean)
    std::vector<BulkMedium> media;
    GhostAnalysisOptions analysis;
    // The photons of a pass: shares of the unguided tracer and of the direct image; the rest goes
    // to photon-guided ghosts in proportion to their estimated power (when there are none, the
    // unguided tracer and the direct image share everything in these proportions).
    double unguidedShare = 0.1;
    // The `scatter` layer (veiling glare, which varies slowly across the frame) and the photons
    // of the `higher` layer (the few that the guided chains leave to the unguided tracer) are
    // estimated as smooth: with the film's fixed kernel, they get an adaptive kernel (Film::
    // setLayerKernel, by power) that holds about this many times the photon's own power of the
    // earlier photons, times passes^(2/3), at most a sixteenth of the frame's width in radius (0:
    // the film's kernel, like the other layers). Beams are rasterised exactly whatever the kernel.
    int smoothNeighbours = 256;
    double directShare = 0.1;
    int batchPhotons = 1024;
    int batchesPerPass = 64;
    // Beams of a pass, per light (in expectation; the lights' beams are shared among all their
    // paths, beamVarianceProbes); and the correction photons traced with each beam. A path's beams continue its sequence from pass
    // to pass, so the pass size matters little to the error.
    int beamsPerPass = 1024;
    // Per light (the lights' order), in place of beamsPerPass: lights of unequal power given beams
    // by their share (`flare composite`'s regions). Each light's paths then share its own budget,
    // weighted by one over their rates as always: unbiased whatever the split. Empty: beamsPerPass.
    std::vector<int> lightBeamsPerPass;
    // With two lights or more, the beams of all lights are shared among their paths by each
    // path's variance per beam over its cost, predicted from this many probe beams at independent
    // samples, mixed within each light with the central probe's shares (BeamVariance.h,
    // BeamShare.h); 0, or a single light: each light's own beams shared by its central probe's
    // √(‖image‖² / cost).
    int beamVarianceProbes = 4;
    int correctionPhotonsPerBeam = 0;
    // Independent replicates of the beams' sequences (2 to kMaxReplicates): the render's
    // error estimate, and each beam path's standard error, come from their spread. Each replicate
    // continues its own Sobol' sequence, whose error falls faster than one over the square root
    // of its length, so fewer replicates give a cleaner image in the same time (docs/BENCHMARKS.md:
    // on the default scene four replicates had 1.16× the error of two, eight 1.38×) but a rougher
    // estimate of its error (K − 1 degrees of freedom per pixel and per path); each costs a
    // full-frame image per variance group.
    int beamReplicates = 2;
    // Beams are meshed on the ghost analysis's cells split to this level (PupilRemeshOptions).
    int beamMeshLevel = 2;
    // Each beam's rim rings with the Fresnel diffraction of the aperture stop's edge at the beam's
    // wavelength and the path's defocus (GhostRinging.h, BeamRim.h); false: geometric rims.
    bool ghostRinging = true;
    // Fault injection for tests only: moves every beam's image by this many pixels (to the
    // right), which biases the render; the tests check that their comparisons catch it.
    double testBeamShiftPx = 0.0;
    // The photon tracer's reflect-or-refract probabilities from a SpectralReflectance table
    // (PhotonTracer::tabulateReflectance) rather than the exact coating response.
    bool tabulatedReflectance = true;
    // The unguided photons of the guided modes sample stray light with weights and connections to
    // the sensor (PhotonTracer's StrayLightSampling); the naive mode stays analog, the reference.
    bool strayLightSampling = true;
    // With stray light sampling, each bounce off the interior finishes splits into this many
    // directions (StrayLightSampling::scatterSplits; 1: none). The default's measurement:
    // docs/BENCHMARKS.md, "Every light converges, fifth part".
    int scatterSplits = kDefaultScatterSplits;
    // Chains of four reflections (the `higher` layer): the strongest are enumerated and guided
    // like ghosts when the lens's reflectances make them matter (Auto: when the estimated ratio of
    // their power to the ghosts', higherOrderShareEstimate, reaches the threshold), else they are
    // left to the unguided tracer. Every chain is analysed when there are at most
    // maxAnalysedChains (the double Gauss has 2530: about 3 s on two cores); Auto leaves a lens
    // with more (the 24–70 zoom has 119 133) to the unguided tracer, On analyses the strongest
    // maxAnalysedChains by their normal-incidence reflectances. The
    // strongest analysed chains holding higherOrderKeepShare of their power are kept, at most
    // maxHigherOrderPaths.
    enum class HigherOrder { Auto, Off, On };
    HigherOrder higherOrder = HigherOrder::Auto;
    double higherOrderThreshold = 1e-3;
    double higherOrderKeepShare = 0.99;  // of the chains' analysed power
    int maxHigherOrderPaths = 512;
    int maxAnalysedChains = 2560;

    // How a guided render's passes share their cost between beams and photons (PassPlan.h):
    // Fixed, every pass the nominal one (beamsPerPass, batchesPerPass); Adaptive, from the third
    // pass on each pass's beams and photons are scaled, at the nominal pass's deterministic cost,
    // so that the largest of errorTargets' estimated errors over their targets falls fastest.
    // Either way every pass is an unbiased estimate of the image.
    enum class PassPlan { Fixed, Adaptive };
    PassPlan passPlan = PassPlan::Adaptive;
    // The errors the adaptive plan drives down: variance groups (RenderVarianceGroup) with their
    // target relative errors (only their ratios matter to the plan); empty: the flare without the
    // direct image alone.
    struct ErrorTarget {
        int group = 0;
        double relativeError = 0.0;
    };
    std::vector<ErrorTarget> errorTargets;

    // False: the passes trace the beams alone (the preview: the render's first passes without their
    // photons). The film's normalisation is the same, so the beams' image is the render's.
    bool tracePhotons = true;
    // True (the preview, which reads the layers and the ghost group's error estimate alone): the
    // film accumulates no running sums for the total and the flare groups (kGroupTotal,
    // kGroupFlare). A beam's rows otherwise go to four stores of the frame's size (its layer, the
    // total, the ghost and the flare groups), each summed per replicate at the end of a pass: two
    // of them are the ghost layer's own sums again while the preview has nothing else.
    // estimatedRelativeError refuses those two groups; every layer and the other groups are the
    // same bits.
    bool ghostGroupsOnly = false;

    std::int64_t photonsPerPass() const { return static_cast<std::int64_t>(batchPhotons) * batchesPerPass; }
};

// Film layers of every render, in this order; per-ghost layers follow.
enum RenderLayer : int { kLayerDirect = 0, kLayerGhost, kLayerHigher, kLayerScatter, kFixedLayerCount };
const char* renderLayerName(int layer);

// The film's variance groups of a render: the total (0), each fixed layer, and the flare without
// the direct image (ghost + higher + scatter), whose estimated error a render can be run to.
enum RenderVarianceGroup : int {
    kGroupTotal = 0,
    kGroupDirect,
    kGroupGhost,
    kGroupHigher,
    kGroupScatter,
    kGroupFlare,
    kVarianceGroupCount
};

// How a path tally's path is estimated.
enum class PathStrategy : std::uint8_t { Unguided, Photons, Beams };
const char* toString(PathStrategy strategy);

// What a path tally counts, per light. The estimate is the sum of two independent parts, each
// with its own samples: per photon batch (photon strategies) and per pass (beams, whose passes
// are correlated within a replicate and independent across replicates).
struct PathTally {
    enum class Kind { Direct, Ghost, Higher, Scatter };
    Kind kind = Kind::Ghost;
    int light = 0;
    GhostPath path;            // Direct and Ghost
    double analysedPowerFraction = 0.0;  // the ghost analysis's estimate (0 for Higher/Scatter)
    // Over the light's spectrum, as planned (the beam probe's; else the analysis's): what
    // RenderOptions::ghostLayers ranks the ghosts by (0 for Direct, Higher, Scatter).
    double plannedPowerFraction = 0.0;
    PathStrategy strategy = PathStrategy::Unguided;
    bool guided = false;       // owned by a guided strategy (photons or beams) inside its mask
    double sumMeans = 0.0, sumSquaredMeans = 0.0;          // over batches: per-photon mean Y power (W)
    std::array<double, kMaxReplicates> replicateSums{};   // per replicate: Σ over its passes of the beams' Y power (W)
};

struct LightPlan {
    std::string name;
    bool skipped = false;
    std::string skipReason;
    double enteringPowerW = 0.0;  // the light's power entering the front clear aperture (nominal)
    int keptGhosts = 0, prunedGhosts = 0;
    int beamGhosts = 0;           // kept ghosts rendered by beams
    // Kept ghosts the analysis had pruned at its one wavelength, kept for their power over this
    // light's spectrum.
    int spectrallyKeptGhosts = 0;
    // Order-4 chains: the estimated ratio of their power to the ghosts' (higherOrderShareEstimate
    // in Ghosts.h), whether they were enumerated and guided, how many chains the lens has, how
    // many were analysed and how many kept.
    double higherOrderShareEstimate = 0.0;
    bool higherOrderGuided = false;
    long higherOrderChains = 0;
    int higherOrderAnalysed = 0;
    int higherOrderPaths = 0;
    std::string higherOrderWhy;
};

struct FateTally {
    std::int64_t photons = 0;
    double powerW = 0.0;
};

struct RenderStatistics {
    std::int64_t photons = 0;          // emitted by the pass budgets (unguided + photon-guided)
    std::int64_t unguidedPhotons = 0;
    std::int64_t guidedPhotons = 0;
    std::int64_t sensorHits = 0;
    std::int64_t beams = 0;
    std::int64_t beamRays = 0;         // traced to mesh the beams
    std::int64_t correctionPhotons = 0;
    int passes = 0;
    double seconds = 0.0;              // wall time of the passes (summed over resumed sessions)
    double unguidedEmittedPowerW = 0.0;  // Σ weights of the unguided photons
    double unguidedEnteredPowerW = 0.0;
    FateTally fates[static_cast<int>(PhotonFate::Count)];
    std::int64_t nullCollisions = 0, realCollisions = 0;  // delta tracking in bulk media
    // Per fixed layer: the largest Y power a single photon added (W per photon drawn, as the
    // photon weights), for the report's firefly check: divided by the photon count and the
    // layer's power it is the share of the layer one photon carries.
    std::array<double, kFixedLayerCount> largestPhotonY{};
};

// What sharing the passes among ranks cost so far (Renderer::exchangeCosts, rank 0's view; all
// zero for a render alone), summed over the passes, in wall and CPU seconds (…Cpu: the process's
// CPU time, all its threads; on a shared machine the wall time also counts other processes'):
// rank 0's share of the jobs (summed) and its time tracing and encoding them; the other ranks'
// time tracing and encoding theirs (their mean per pass, as they report it); rank 0's time
// waiting for and receiving the others' results at the exchange (gatherS), and their bands after
// its own (bandsWaitS), and the bytes; rank 0's share
// of the bands (summed) and its time decoding the others' results, rasterising its bands and
// splatting every band's hits (besidesBandsS: the decoding and the hits, wall); the others' time rasterising theirs (their mean, as they report
// it); rank 0's time adding the others' bands and ending the pass. docs/scaling.md models renders
// on many nodes from them.
struct ExchangeCosts {
    int passes = 0;
    double rootShare = 0.0;
    double traceS = 0.0, traceCpuS = 0.0;
    double othersTraceS = 0.0, othersTraceCpuS = 0.0;
    double gatherS = 0.0, bytesReceived = 0.0;
    double bandsWaitS = 0.0;  // rank 0 waiting for (and receiving) the others' band images
    double rootBands = 0.0, bandsS = 0.0, bandsCpuS = 0.0, besidesBandsS = 0.0, othersBandsS = 0.0, othersBandsCpuS = 0.0;
    double mergeS = 0.0, mergeCpuS = 0.0;
};
// The renderer's internals: its plan (RenderPlan.h) and the strategies' work (PhotonBatches.h,
// BeamStrategy.h).
class PassExchange;

namespace renderer {
struct LightState;
struct PhotonComponent;
struct BatchResult;
struct BeamJob;
struct SensorHit;
struct DistributedPasses;
}  // namespace renderer

class Renderer {
public:
    // Analyses the ghosts of every light, plans the budget and allocates the film. `lens` is
    // built at the scene's state (buildSceneLens); `options` carries its scattering
    // (applySceneScattering).
    Renderer(const LensSystem& lens, const std::vector<LightSpec>& lights, const RenderOptions& options);
    ~Renderer();
    Renderer(const Renderer&) = delete;
    Renderer& operator=(const Renderer&) = delete;

    // Traces one pass (options.photonsPerPass() photons and the beams) in parallel and merges it.
    // With an exchange of several ranks (setExchange), every rank must call it: each traces its
    // share of the pass and rasterises the beams over its share of the film's bands, and rank 0
    // merges the rest (every hit, the bands' images, the pass's end); only rank 0's film, tallies
    // and statistics are the render's (the others' count the passes, nothing else). The other
    // ranks return having traced their share of the next pass too (sent by their next call),
    // unless the pass limit is reached: rank 0's end of this pass overlaps their tracing of the next.
    void runPass();
    // Shares the passes among the exchange's ranks (PassExchange.h); null, or one rank: this
    // process traces every pass alone. The exchange must outlive the passes.
    void setExchange(PassExchange* exchange);
    // The passes the render will run at most (0: unknown): no rank traces ahead beyond them.
    void setPassLimit(int passes) { passLimit_ = passes; }
    const ExchangeCosts& exchangeCosts() const { return exchangeCosts_; }

    const RenderOptions& options() const { return options_; }
    const RenderStatistics& statistics() const { return statistics_; }
    const std::vector<LightPlan>& lights() const { return lightPlans_; }
    // A light's ghost analysis (its grid, direct path and paths, pruning as the render uses it).
    const GhostReport& ghostReport(int light) const;
    const std::vector<PathTally>& tallies() const { return tallies_; }
    // The planned beams per pass of path `slot` (0 the direct image, then the report's ghosts) of
    // light `light`: 0 unless beams render it; a pass draws it times the pass's beam scale.
    double plannedBeamRate(int light, int slot) const;
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
    // The same over the layer's footprint (Film::irradianceXyzFootprint): a per-ghost layer's
    // memory follows the pixels its ghost reaches, not the frame.
    FilmWindow layerXyzFootprint(int layer) const;
    // The same, freeing the layer's pixels (it reads as zero afterwards): for taking per-ghost
    // layers out one at a time once the passes are done.
    FilmWindow takeLayerXyzFootprint(int layer);
    // Estimated mean Y power (W) on the sensor of a tally and its standard error, from the spread
    // between its batches (independent, identically distributed estimates) and between its beams'
    // replicates.
    double tallyPowerW(const PathTally& tally) const;
    double tallyStandardErrorW(const PathTally& tally) const;
    // The estimated relative L2 error (over pixels and RGB channels, as `flare compare`) of a
    // variance group's image (RenderVarianceGroup), from the spread between passes (or
    // replicates); 0 before two passes (before every replicate has one).
    double estimatedRelativeError(int group) const;
    // Whether the estimate exists yet (two passes; with beams, a pass in every replicate).
    bool hasErrorEstimate() const { return film_.hasVariance(); }
    // Each pass's beam scale and photon batches so far (RenderOptions::passPlan), and whether the
    // plan adapts them.
    std::vector<std::pair<double, int>> passPlan() const;
    bool adaptivePassPlan() const { return adaptivePlan_; }

    // Checkpoints (binary): the film, the tallies, the statistics and the number of passes done.
    // Loading checks that the checkpoint was written by a render with the same scene, lens and
    // options; else InputError(path, 0, why). Saving is all or nothing (OutputFiles); the second
    // form writes into `outputs`' temporary for `path`, moved into place by their commit().
    void saveCheckpoint(const std::string& path) const;
    void saveCheckpoint(OutputFiles& outputs, const std::string& path) const;
    void loadCheckpoint(const std::string& path);

private:
    // The passes' plan (RenderPlan.h) and work (PhotonBatches.h, BeamStrategy.h); the checkpoints
    // are in RenderCheckpoint.cpp.
    void addScatterSourceLayers();
    void setUpFilm();
    std::vector<renderer::BeamJob> drawBeamJobs();
    void merge(const std::vector<renderer::BatchResult>& batches, const std::vector<renderer::BeamJob>& beams);
    // The merge's parts, band by band (a band's tiles are its own: bands run in parallel): the
    // pass's hits by the bands their kernels reach, splatted into one band; the beams' image over
    // one band, handed to `add` (Film::addBand's arguments) in the order one process adds them, in
    // buffers of `scratch` (a band owner rasterises its bands and sends them, RenderDistributed).
    using HitsByBand = std::vector<std::vector<const renderer::SensorHit*>>;
    // (Only the rows' columns [xBegin, xEnd) are to be read: the others are zero, or hold what an
    // earlier run left there.)
    using BandAdder = std::function<void(int layer, const double* rows, bool inTotal, int xBegin, int xEnd)>;
    HitsByBand hitsByBand(const std::vector<renderer::BatchResult>& batches,
                          const std::vector<renderer::BeamJob>& beams) const;
    void splatHitsInBand(int band, const std::vector<const renderer::SensorHit*>& hits);
    void rasteriseBeamsInBand(int band, const std::vector<renderer::BeamJob>& beams,
                              std::array<std::vector<double>, 3>& scratch, const BandAdder& add) const;
    void runDistributedPass();
    void addPassTallies(const std::vector<renderer::BeamJob>& beams, int replicate);
    std::uint64_t fingerprint() const;
    // The beams a path draws in a pass (renderer::beamCount at the path's rate).
    // (The rate and count under a plan of every pass's sizes: the render's, or a checkpoint's.)
    int beamCount(int pass, size_t light, int slot, const std::vector<renderer::PassSizes>& plan) const;
    double beamRate(int pass, size_t light, int slot, const std::vector<renderer::PassSizes>& plan) const;
    int replicateOfPass(int pass) const { return pass % options_.beamReplicates; }
    // The adaptive pass plan (PassPlan.h): the sizes of pass `pass` (planned two passes ahead, so
    // that the ranks, which trace a pass ahead, learn them in time), the pass's photon hits
    // weighted to the nominal pass, and the plan of the pass after next from the film's estimate.
    const renderer::PassSizes& passSizes(int pass) const { return passSizes_.at(static_cast<size_t>(pass)); }
    void startPass();
    void weightPhotonHits(std::vector<renderer::BatchResult>& batches) const;
    void planPassAfterNext();

    const LensSystem* lens_;
    RenderOptions options_;
    std::vector<renderer::LightState> lightStates_;
    std::vector<LightPlan> lightPlans_;
    std::vector<renderer::PhotonComponent> components_;
    std::vector<double> componentCdf_;
    std::vector<PathTally> tallies_;
    std::vector<PathTally> layerTallies_;
    std::vector<PathTally> scatterSourceTallies_;
    std::vector<renderer::BatchResult> batches_;  // scratch, one per batch of a pass
    std::vector<std::string> layerNames_;
    std::vector<int> scatterSourceLayer_;  // per scatter source: its film layer, −1 if none
    IndexTable indexTable_;
    PhotonTracer tracer_;
    Film film_;
    RenderStatistics statistics_;
    std::int64_t batchesDone_ = 0;
    // Every pass's sizes so far and the next two's (PassPlan.h); with the adaptive plan, a hidden
    // film layer (after layerNames_) that every beam also goes to, whose variance group is the
    // beams' part of the error (−1: none).
    std::vector<renderer::PassSizes> passSizes_;
    bool adaptivePlan_ = false;
    int beamsLayer_ = -1, beamsGroup_ = -1;
    // Per light, per slot × replicate: the beams drawn so far, where the next pass's continue the
    // replicate's sequence.
    std::vector<std::vector<std::uint64_t>> beamsDrawn_;
    PassExchange* exchange_ = nullptr;
    ExchangeCosts exchangeCosts_;
    int passLimit_ = 0;
    // A shared pass's buffers, the next pass traced ahead and the shares (RenderDistributed.cpp).
    std::shared_ptr<renderer::DistributedPasses> distributed_;
};

}  // namespace flare
