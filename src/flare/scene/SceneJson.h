// A scene written back as scene-file JSON (docs/scene-format.md): what `flare composite
// --lights-json` writes, so that the lights it found can be edited and rendered. Written: the
// lens and its state, the sensor, the lights and the render settings; the scattering block and
// the scene's coating are not (a scene built from a plate has neither). Numbers are written to
// round-trip exactly (nlohmann-json's shortest representation), so the scene read back renders
// the same image.
#pragma once

#include <nlohmann/json.hpp>

#include "flare/scene/Scene.h"

namespace flare {

nlohmann::json sceneToJson(const Scene& scene);

}  // namespace flare
