// The deterministic ghost preview of a whole scene (Preview.h), as `flare preview` and the Python
// module render it: every light analysed and previewed at the scene's lens state, resolution and
// ghost settings, the layers summed over the lights.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "flare/film/ImageIO.h"
#include "flare/ghosts/Preview.h"
#include "flare/optics/LensSystem.h"
#include "flare/photons/Light.h"
#include "flare/scene/Scene.h"

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
    long tracedRays = 0;
    int renderedGhosts = 0, prunedGhosts = 0;  // summed over the lights
};

// `lens` is built at the scene's state (buildSceneLens).
ScenePreview previewScene(const Scene& scene, const LensSystem& lens, bool perGhostLayers);

// The preview's images in linear Rec.709 RGB, as `flare preview` writes them: the main image ""
// (direct + ghosts), then with `withLayers` "direct", "ghost" and the per-ghost layers by label.
// Each per-ghost XYZ buffer is released once converted (one copy at a time).
std::vector<ImageLayer> previewLayers(ScenePreview& preview, bool withLayers);

}  // namespace flare
