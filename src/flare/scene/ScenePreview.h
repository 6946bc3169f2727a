// The deterministic ghost preview of a whole scene (Preview.h), as `flare preview` and the Python
// module render it: every light analysed and previewed at the scene's lens state, resolution and
// ghost settings, the layers summed over the lights.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "flare/film/ImageIO.h"
#include "flare/ghosts/Preview.h"
#include "flare/optics/LensSystem.h"
#include "flare/photons/Light.h"
#include "flare/scene/Scene.h"
#include "flare/wave/Starburst.h"

namespace flare {

// The preview traces parallel rays. A point or disk light at distance d is previewed as a distant
// source in its direction with irradiance I/d² at the lens (exact in the far field, d ≫ the
// aperture) and, for a disk, the angular diameter it subtends.
PreviewLight previewLight(const LightSpec& spec, int wavelengths);

// Sensor irradiance in CIE XYZ (XyzLayer's layout), summed over the scene's lights.
struct ScenePreview {
    int widthPx = 0, heightPx = 0;
    std::vector<float> direct, ghosts;
    std::map<std::string, std::vector<float>> perGhost;  // with per-ghost layers: by path label
    // With the scene's render.diffraction: the direct image diffracted (SceneStarburst.h).
    std::optional<StarburstImage> starburst;
    long tracedRays = 0;
    int renderedGhosts = 0, prunedGhosts = 0;  // summed over the lights
};

// `lens` is built at the scene's state (buildSceneLens). The starburst is computed when the
// scene's render.diffraction is set.
ScenePreview previewScene(const Scene& scene, const LensSystem& lens, bool perGhostLayers);

// The preview's images in linear Rec.709 RGB, as `flare preview` writes them: the main image ""
// (the starburst, or the direct image without diffraction, + ghosts), then with `withLayers`
// "direct", "starburst" (with diffraction), "ghost" and the per-ghost layers by label.
// Each per-ghost XYZ buffer is released once converted (one copy at a time).
std::vector<ImageLayer> previewLayers(ScenePreview& preview, bool withLayers);

}  // namespace flare
