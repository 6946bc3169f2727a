// The starburst of a scene (wave/Starburst.h): its lights' direct image diffracted by the lens at
// the scene's state, with the scene's spectral quadrature, and the glow of the dust of the scene
// and of the lens file; and its report as JSON.
#pragma once

#include <vector>

#include <nlohmann/json.hpp>

#include "flare/optics/LensSystem.h"
#include "flare/scene/Scene.h"
#include "flare/wave/Starburst.h"

namespace flare {

// `directXyz`: the direct layer of the preview or the render (widthPx × heightPx × XYZ).
// `options`: its crops and windows (the wavelengths are the scene's).
StarburstImage sceneStarburst(const Scene& scene, const LensSystem& lens, const std::vector<float>& directXyz,
                              int widthPx, int heightPx, StarburstOptions options = {});

nlohmann::json starburstJson(const StarburstImage& image);

}  // namespace flare
