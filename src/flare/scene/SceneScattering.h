// The scene's scattering block (and the lens file's finishes and dirt) turned into the render's
// options: interior finishes, per-surface dust and grease with their coverage masks, bulk media
// with their grids. Checked against the lens: every error names the scene file and line.
#pragma once

#include "flare/optics/LensSystem.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"

namespace flare {

// Fills options.materials, .contamination and .media from the scene's lens file's scattering
// (finishes, per-surface dust and grease) overridden by the scene's "scattering" block, checking
// the scene against the lens (a surface number that does not exist, dust on the stop, bulk
// scattering in an air space: InputError naming the scene file and line), loading the coverage
// masks (errors name the scene file, line and key) and the grids (errors name the .vdb file).
void applySceneScattering(const Scene& scene, const LensSystem& lens, RenderOptions& options);

}  // namespace flare
