// The render's report (`flare render --report`, the Python module's `RenderResult.report`): what a
// render did and how good it is, as JSON. Built here, not in a front end, so that the CLI and the
// Python module give the same report for the same render.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "flare/render/Render.h"

namespace flare {

// The mode's name as `flare render --mode` takes it: guided, photons or naive.
const char* toString(RenderOptions::Mode mode);

// The report of a render after its passes: the scene label and the lens's name (as given), the
// mode, seed, photon counts, passes and wall time; per light what was planned and skipped; per
// fixed layer (direct, ghost, higher, scatter) the power with its standard error, the estimated
// relative L2 error of its image (null before the estimate exists) and the largest share one
// photon carried; the flare's estimated error and the target it ran to (0: none); the beams; the
// scatter sources; delta tracking; per ghost (strongest first) its power, standard error, share of
// the light's entering power and strategy; and the unguided photons' fates.
nlohmann::json renderReportJson(const Renderer& renderer, const std::string& sceneLabel, const std::string& lensName,
                                double targetError);

}  // namespace flare
