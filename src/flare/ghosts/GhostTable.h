// The ghost table of one light, as `flare ghosts --json` prints it and the Python module returns
// it: the report's totals and one object per ghost (surfaces, label, paraxial focus, power,
// footprint, pruning), strongest first.
#pragma once

#include <nlohmann/json.hpp>

#include "flare/ghosts/GhostAnalysis.h"

namespace flare {

// `report` is analyseGhosts(lens, lightDirection, options). Pruned ghosts are listed only with
// `includePruned`.
nlohmann::json ghostTableJson(const LensSystem& lens, const glm::dvec3& lightDirection,
                              const GhostAnalysisOptions& options, const GhostReport& report, bool includePruned);

// The field angles (X, Y) in degrees at which a light travelling along `direction` is seen: the
// inverse of directionFromFieldDeg.
glm::dvec2 fieldDegFromDirection(const glm::dvec3& direction);

}  // namespace flare
