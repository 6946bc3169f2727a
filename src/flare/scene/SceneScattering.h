// The scene's "scattering" block: read from the scene's JSON tree (interior finishes, dust and
// grease with their masks, bulk media with their grids), then, once the lens is built, turned
// with the lens file's own finishes and dirt into the render's options, checked against the lens.
// Every error names the scene file and line.
#pragma once

#include "flare/optics/LensSystem.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"
#include "flare/scene/SceneChecker.h"

namespace flare {

namespace scenefile {

// Reads the block into `s`; data files (masks, grids) are resolved against the scene's folder.
void parseScattering(const Checker& c, const Node& node, const std::string& baseDir, ScatteringSettings& s);

}  // namespace scenefile

// Fills options.materials, .contamination and .media from the scene's lens file's scattering
// (finishes, per-surface dust and grease) overridden by the scene's "scattering" block, checking
// the scene against the lens (a surface number that does not exist, dust on the stop, bulk
// scattering in an air space: InputError naming the scene file and line), loading the coverage
// masks (errors name the scene file, line and key) and the grids (errors name the .vdb file).
void applySceneScattering(const Scene& scene, const LensSystem& lens, RenderOptions& options);

}  // namespace flare
