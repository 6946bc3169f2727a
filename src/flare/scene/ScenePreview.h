// The preview of a whole scene, as `flare preview` and the Python module render it: the final
// render's first passes without its photons. Its ghosts are the render's beams (the same plan, the
// same seed, the same beam sequences: what the render's first passes draw), so that the preview
// is the render's image, sooner, and converges to it as its budget grows: the light's disk, its
// spectrum and the film's kernel are integrated as the render integrates them. Each light's own
// image is the deterministic mesh preview of its direct path (Preview.h), the starburst's input.
// Left out, and said so: scattering, the paths the render leaves to photons (pruned ghosts, rays
// outside the guide masks) and, unless asked, the order-4 chains (`higher`).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "flare/film/Film.h"
#include "flare/film/ImageIO.h"
#include "flare/film/LayerSelection.h"
#include "flare/ghosts/Preview.h"
#include "flare/optics/LensSystem.h"
#include "flare/photons/Light.h"
#include "flare/scene/Scene.h"
#include "flare/wave/Starburst.h"

namespace flare {

// The light as the mesh preview of its own (direct) image sees it: its rays are the light's (the
// analysis's grid), carrying a uniform irradiance, I/d² at the lens for a point or disk light at
// distance d (exact in the far field, d ≫ the aperture), and for a disk the angular diameter it
// subtends. The preview's ghosts are the render's beams, which weight each ray exactly.
PreviewLight previewLight(const LightSpec& spec, int wavelengths);

// How long the preview renders: `passes` passes of the final render's beams, or (timeS > 0) as
// many as fit in timeS seconds of wall time from the call, analysis included (at least one per
// replicate; the pass count then depends on the machine, and is reported).
struct PreviewBudget {
    // Two passes, one per replicate of the beams (so that the preview estimates its error), of
    // half the render's beams each: together one pass of the render (docs/BENCHMARKS.md).
    static constexpr int kDefaultPasses = 2;
    int passes = kDefaultPasses;
    int beamsPerPass = 0;  // per light; 0: half the scene's render.beams_per_pass (at least 16)
    double timeS = 0.0;
    // > 0: after `passes`, the passes continue (whole rounds, one pass per replicate) until the
    // ghosts' estimated relative error is at most this, the passes already made kept (at most
    // maxPasses). Each round's length is forecast from the error falling as one over the square
    // root of the passes (× 1.1); a forecast more than twice the passes made goes halfway, where
    // the error is estimated and the passes forecast again.
    double targetError = 0.0;
    int maxPasses = 1 << 16;
    std::optional<std::uint64_t> seed;  // default: the scene's render.seed
    bool higher = false;                // add the guided order-4 chains (the `higher` layer)
    LayerSelection ghostLayers;         // with per-ghost layers: which ghosts keep one (RenderOptions)
    // The lights' own (direct) image, and from it the starburst; `flare composite` takes both from
    // the plate instead and leaves them out (a full-frame mesh preview per light).
    bool direct = true;
};

// Sensor irradiance in CIE XYZ (XyzLayer's layout), summed over the scene's lights.
struct ScenePreview {
    int widthPx = 0, heightPx = 0;
    std::vector<float> direct, ghosts, higher;
    // With per-ghost layers: by path label, each over its footprint (the bounding box of the
    // pixels it reaches; a ghost that reaches none has no layer), not the frame.
    std::map<std::string, FilmWindow> perGhost;
    // With the scene's render.diffraction: the direct image diffracted (SceneStarburst.h).
    std::optional<StarburstImage> starburst;
    long tracedRays = 0;
    int renderedGhosts = 0, prunedGhosts = 0;  // summed over the lights
    int passes = 0;
    std::int64_t beams = 0;
    // The ghost layer's estimated relative L2 error (the spread of the beams' replicates; 0 before
    // every replicate has a pass).
    double ghostEstimatedError = 0.0;
    std::string leftOut;  // what the preview does not render, in words
};

// `lens` is built at the scene's state (buildSceneLens). The starburst is computed when the
// scene's render.diffraction is set.
ScenePreview previewScene(const Scene& scene, const LensSystem& lens, bool perGhostLayers,
                          const PreviewBudget& budget = {});

// The preview's images in linear Rec.709 RGB, as `flare preview` writes them: the main image ""
// (the starburst, or the direct image without diffraction, + ghosts, + higher when rendered), then
// with `withLayers` "direct", "starburst" (with diffraction), "ghost", "higher" (when rendered) and
// the per-ghost layers by label (with kOtherGhostsLayer last when PreviewBudget::ghostLayers left
// ghosts out), each over its footprint (ImageLayer's window).
// Each per-ghost XYZ buffer is released once converted (one copy at a time).
std::vector<ImageLayer> previewLayers(ScenePreview& preview, bool withLayers);

}  // namespace flare
