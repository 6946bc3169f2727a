#include "flare/ghosts/PupilMesh.h"

#include "flare/ghosts/Mesher.h"

namespace flare {

using mesher::Mesher;

PupilMesh meshLiveRegion(const BundleTracer& tracer, const PupilGrid& grid, const PupilMeshOptions& options) {
    return Mesher(tracer, grid, options, true).run();
}

PupilMesh remeshLiveRegion(const BundleTracer& tracer, const PupilGrid& grid, const PupilLattice& lattice,
                           const PupilRemeshOptions& options) {
    if (lattice.empty()) return {};
    PupilMeshOptions o;
    o.windowMinMm = lattice.windowMinMm;
    o.windowSizeMm = lattice.windowSizeMm;
    o.baseCells = lattice.baseCells;
    o.requireOnSensor = options.requireOnSensor;
    o.bisections = options.bisections;
    o.interiorTolerance = options.interiorTolerance;
    o.boundaryTolerance = options.boundaryTolerance;
    o.maxRays = options.maxRays;
    return Mesher(tracer, grid, o, false).remesh(lattice, options);
}

}  // namespace flare
