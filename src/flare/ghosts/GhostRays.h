// The rays of one ghost path for the lens cutaway (optics/LensDrawing.h): a fan across the middle
// of the path's live pupil region, as the ghost analysis finds it, drawn with every surface event.
#pragma once

#include <vector>

#include "flare/optics/LensDrawing.h"
#include "flare/optics/LensSystem.h"

namespace flare {

// Rays of one ghost path for a light at fieldDeg (in the x–z plane): up to `count` rays from the
// middle row of the path's live pupil region, each drawn with every surface event.
std::vector<DrawnRay> traceGhostRays(const LensSystem& lens, const std::vector<int>& reflections, double fieldDeg,
                                     int count, double wavelengthNm);

}  // namespace flare
