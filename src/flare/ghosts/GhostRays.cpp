#include "flare/ghosts/GhostRays.h"

#include <algorithm>

#include "flare/ghosts/GhostAnalysis.h"
#include "flare/optics/PupilGrid.h"
#include "flare/optics/SequentialTracer.h"

namespace flare {

std::vector<DrawnRay> traceGhostRays(const LensSystem& lens, const std::vector<int>& reflections, double fieldDeg,
                                     int count, double wavelengthNm) {
    const PupilGrid grid = PupilGrid::forDirection(lens, directionFromFieldDeg(fieldDeg, 0.0));
    const SpectralIndices indices = lens.indicesAt(wavelengthNm);
    const GhostEstimate estimate =
        estimatePath(lens, indices, grid, grid.enteringAreaMm2(lens, 128), GhostPath{reflections}, GhostAnalysisOptions{});
    std::vector<DrawnRay> rays;
    const LivePupilRegion& region = estimate.pupil;
    if (region.liveCount() == 0) return rays;
    // The row of the live region with the most live cells, near its middle.
    int bestRow = 0, bestCount = -1;
    for (int j = 0; j < region.cellsB; ++j) {
        int live = 0;
        for (int i = 0; i < region.cellsA; ++i) live += region.live[static_cast<size_t>(j) * region.cellsA + i];
        if (live > bestCount) bestCount = live, bestRow = j;
    }
    std::vector<int> columns;
    for (int i = 0; i < region.cellsA; ++i)
        if (region.live[static_cast<size_t>(bestRow) * region.cellsA + i]) columns.push_back(i);
    const int n = std::min<int>(std::max(1, count), static_cast<int>(columns.size()));
    const double zFront = drawingStartZMm(lens);
    SequentialPath path;
    path.reflections = reflections;
    for (int k = 0; k < n; ++k) {
        const int i = columns[n == 1 ? columns.size() / 2 : k * (columns.size() - 1) / (n - 1)];
        const Ray ray = grid.ray(region.aMinMm + (i + 0.5) * region.cellMm, region.bMinMm + (bestRow + 0.5) * region.cellMm);
        DrawnRay drawn;
        drawn.colour = "#e377c2";
        const double back = (ray.originMm.z - zFront) / ray.direction.z;
        drawn.pointsMm.push_back(ray.at(std::min(0.0, -back)));
        TraceOptions options;
        options.fresnelWeights = false;
        options.pathPointsMm = &drawn.pointsMm;
        tracePath(lens, indices, ray, path, options);
        rays.push_back(std::move(drawn));
    }
    return rays;
}

}  // namespace flare
