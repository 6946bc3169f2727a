// The final render of a whole scene (Render.h), as `flare render` and the Python module run it:
// the render options from the scene and the caller's overrides, when to stop, and the images.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include "flare/film/ImageIO.h"
#include "flare/film/LayerSelection.h"
#include "flare/optics/LensSystem.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"
#include "flare/wave/Starburst.h"

namespace flare {

// What a caller may change of the scene's render settings; unset values are the scene's.
struct SceneRenderOverrides {
    RenderOptions::Mode mode = RenderOptions::Mode::Guided;
    std::optional<std::uint64_t> seed;
    std::optional<int> maxBounces;  // −1: unbounded
    std::optional<int> beamsPerPass;
    int beamReplicates = 2;         // RenderOptions::beamReplicates
    std::optional<int> beamVarianceProbes;  // RenderOptions::beamVarianceProbes (unset: its default)
    bool perGhostLayers = false;
    LayerSelection ghostLayers;  // with perGhostLayers: which ghosts keep a layer (RenderOptions)
    // Auto guides the order-4 chains when the scene's ghost_order is 4, else leaves the choice to
    // the lens's reflectances (RenderOptions::HigherOrder::Auto).
    RenderOptions::HigherOrder higherOrder = RenderOptions::HigherOrder::Auto;
    FilmSettings::Kernel kernel = FilmSettings::Kernel::Fixed;
    double radiusPx = 1.0;  // the progressive kernel starts at 4 px when this is left at 1
    int smoothNeighbours = 256;
    bool strayLightSampling = true;  // false: the unguided photons' stray light stays analog
    std::optional<int> scatterSplits;  // RenderOptions::scatterSplits (unset: its default)
    // The diffuse albedo of the barrel, element edges and iris blades (not glossy), replacing the
    // scene's finishes.
    std::optional<double> interiorAlbedo;
};

// Photon batches (RenderOptions::batchPhotons each) per pass of a guided render. On the default
// scene a pass's 1024 beams took two thirds of the CPU and its 65 536 photons under 2 %, while the
// 2 % target waited for the photons' `scatter` layer: 262 144 photons per pass reach the target in
// 12 passes instead of 26, for 46 % less CPU; on the street lights (ghost-limited) the same passes
// cost 1 % more and halve the flare's error (docs/BENCHMARKS.md, "fourth part"). The photon
// modes keep RenderOptions' 64: their passes hold photons only.
inline constexpr int kGuidedBatchesPerPass = 256;

// The render options of the scene's lights on `lens` (built at the scene's state by
// buildSceneLens), its scattering applied (applySceneScattering: InputError for a scattering block
// the lens cannot take).
RenderOptions sceneRenderOptions(const Scene& scene, const LensSystem& lens, const SceneRenderOverrides& overrides);

// The error estimate of a render with fewer passes than this is too rough to stop on (its
// variance estimate has passes − 1 degrees of freedom); with beams, whose estimate comes from K
// replicates, fewer than four passes per replicate.
inline constexpr int kMinPassesToStop = 8;
inline constexpr int kMinPassesPerReplicateToStop = 4;

// When a render stops: at the target error (the estimated relative L2 error of the flare without
// the direct image; and the ghost layer's at its own target, when given: both met), the time or the photon count, whichever is reached first, and never before two
// passes (the target never before the estimate exists). Without a time or a photon count, the scene's
// photon count is the limit, so that a target the scene cannot reach still ends. The target is
// checked after every pass up to 16, then every (passes / 16)-th pass (the estimate scans the
// whole film).
struct RenderStopRule {
    std::int64_t passesWanted = 0;  // 0: no photon limit
    double timeS = 0.0;             // 0: no time limit
    double targetError = 0.0;       // 0: no target
    double ghostTargetError = 0.0;  // the ghost layer's, besides (0: none)

    // photons, timeS, targetError, ghostTargetError: 0 for none.
    static RenderStopRule make(const Scene& scene, const RenderOptions& options, std::int64_t photons, double timeS,
                               double targetError, double ghostTargetError = 0.0);
    // The targets as the adaptive pass plan takes them (RenderOptions::errorTargets).
    std::vector<RenderOptions::ErrorTarget> errorTargets() const;
    bool reached(const Renderer& renderer, double elapsedS) const;
    // The share of the work done, in [0, 1], whichever limit comes first: the photon count, the
    // time, or the target error (whose square falls as one over the passes for photons, faster
    // for beams: the time left it implies is an upper bound), the last not before the passes a
    // stop needs. What `flare render`'s progress bar and the Python module's progress callback show.
    double progress(const Renderer& renderer, double elapsedS) const;
};

// The render's report (renderReportJson, RenderReport.h) for the scene: labelled with the scene
// file (or "embedded default scene") and the lens's name, with the starburst's report under
// "diffraction" when the render has one. `targetError`: the target it ran to (0: none).
nlohmann::json sceneRenderReportJson(const Renderer& renderer, const Scene& scene, const LensSystem& lens,
                                     double targetError, const StarburstImage* starburst = nullptr);

// The render's images in linear Rec.709 RGB, as `flare render` writes them: the main image ""
// (the sum of the fixed layers, the starburst in place of the direct layer when given), then
// every film layer by name (direct, ghost, higher, scatter, then per-ghost and per-scatter-source
// layers when asked for), then "starburst" when given, then "variance" when the film estimates it.
// The per-ghost layers (those RenderOptions::ghostLayers kept, and kOtherGhostsLayer) are each over
// its footprint (ImageLayer's window; a ghost that reached no pixel has none).
std::vector<ImageLayer> renderLayers(const Renderer& renderer, const StarburstImage* starburst = nullptr);

}  // namespace flare
