// Real-ray estimate of what each ghost path puts on the sensor for one directional light: power
// fraction, footprint, peak irradiance and the region of the pupil grid whose rays survive the
// path (which later guides photon emission). Then pruning by power. The live region is found and
// integrated adaptively (PupilMesh): small or thin regions between coarse samples are found, and
// the power is integrated over the region's contour, not counted cell by cell.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/vec2.hpp>

#include "flare/core/Spectrum.h"
#include "flare/ghosts/Ghosts.h"
#include "flare/optics/PupilGrid.h"

namespace flare {

// Cells of the pupil grid whose rays survive a path and land on the sensor. The analysis marks
// every cell with a surviving ray at one of its corners (and, where it refined a thin part of the
// region into smaller cells, the cell holding them), so the marked set covers the live region as
// far as the analysis resolves it, with a partial cell along its edge. The cells are at most 128
// across the region (coarser where the region's pieces are fine cells far apart).
struct LivePupilRegion {
    double aMinMm = 0.0, bMinMm = 0.0;  // corner of the region on the pupil plane
    double cellMm = 0.0;                // square cells
    int cellsA = 0, cellsB = 0;
    std::vector<std::uint8_t> live;     // cellsA × cellsB, row-major in b

    bool empty() const { return cellsA == 0 || cellsB == 0; }
    int liveCount() const;
};

struct GhostEstimate {
    GhostPath path;  // empty: the direct (no-reflection) image
    GhostParaxial paraxial;
    double powerFraction = 0.0;  // share of the power entering the front aperture that lands on the sensor
    glm::dvec2 footprintMinMm{0.0}, footprintMaxMm{0.0};  // bounding box on the sensor
    double peakIrradianceRatio = 0.0;  // peak sensor irradiance / incident irradiance
    LivePupilRegion pupil;
    // The cells of the adaptive search that hold the live region (finer where it is thin): the
    // preview traces its other wavelengths on them.
    PupilLattice lattice;
    long tracedRays = 0;  // by the search and the mesh
    // False when the search ran out of its ray budget (PupilMeshOptions::maxRays) before it had
    // resolved the region: a region folded along many events (random lenses, never the shipped
    // ones). Power, footprint and region are then what the cells found so far give.
    bool resolved = true;
    bool pruned = false;
};

// The rays the analysis may start for one path (and the preview for one path at one wavelength),
// which bounds its time and memory (about 0.1 kB a ray, plus 8 bytes per event of the path; the
// edge location may add as many probe rays again). The shipped lenses need at most ~39 000
// (99 % of their paths fewer than 10 000); random lenses whose regions fold along many events
// (strong aspheres, caustics) asked for hundreds of thousands (half a gigabyte for one analysis).
inline constexpr long kMaxRaysPerPath = 65536;

struct GhostAnalysisOptions {
    int order = 2;
    bool includeSensor = true;
    double wavelengthNm = 550.0;
    // The search (PupilMesh): lattice cells across the whole pupil grid at the first level, split
    // where the region may be, until the live region spans fineCells cells (its larger side) and
    // holds minLivePoints live lattice points. The region's edge is located between lattice
    // points, so the power's error falls with the square of the cell size.
    int coarseCells = 16;
    int fineCells = 16;
    int minLivePoints = 150;
    int minPassingPoints = 32;  // the rays kept alive after each event, to follow the region
    long maxRaysPerPath = kMaxRaysPerPath;
    double keepShare = 0.999;           // keep the strongest ghosts carrying this share of ghost power...
    double relativeThreshold = 1e-5;    // ...and any ghost above this fraction of the strongest
};

struct GhostReport {
    PupilGrid grid;
    double wavelengthNm = 0.0;
    double enteringAreaMm2 = 0.0;
    GhostEstimate direct;
    std::vector<GhostEstimate> ghosts;  // sorted by power, strongest first
    double totalGhostPowerFraction = 0.0;
    int prunedCount = 0;
    double prunedPowerFraction = 0.0;
};

// Estimates one path (parallel over nothing: callers parallelise over paths).
GhostEstimate estimatePath(const LensSystem& lens, const SpectralIndices& indices, const PupilGrid& grid,
                           double enteringAreaMm2, const GhostPath& path, const GhostAnalysisOptions& options);

// Enumerates, estimates (in parallel over paths, deterministically) and prunes, for the rays of
// `grid` (a light's: LightSampler::grid(), parallel or fanning from a point).
GhostReport analyseGhosts(const LensSystem& lens, const PupilGrid& grid, const GhostAnalysisOptions& options);
// The same for parallel rays travelling along `lightDirection`.
GhostReport analyseGhosts(const LensSystem& lens, const glm::dvec3& lightDirection,
                          const GhostAnalysisOptions& options);

// Estimates `paths` for the light of `report` (its grid and entering area), in parallel and
// deterministically, sorts them strongest first, prunes them among themselves and appends them to
// report.ghosts (the totals follow). The final render adds the strongest order-4 chains so.
void appendGhostPaths(const LensSystem& lens, const std::vector<GhostPath>& paths, const GhostAnalysisOptions& options,
                      GhostReport& report);

// Marks ghosts as pruned: the kept set is the strongest ghosts whose cumulative power reaches
// keepShare of the total, plus every ghost above relativeThreshold × the strongest. Expects
// `ghosts` sorted by power.
void pruneGhosts(std::vector<GhostEstimate>& ghosts, double keepShare, double relativeThreshold);
// The same rule on powers sorted strongest first: which are pruned.
std::vector<bool> prunedByPower(const std::vector<double>& powers, double keepShare, double relativeThreshold);

// A path in a light's spectrum: the throughput of one ray through its analysed live region (the
// live cell nearest the region's centroid: a ring's centroid is not in it) per 1-nm bin from
// kCieMinNm (kWavelengthBins values), and the ratio of that ray's luminance-weighted throughput in
// `spectrum` to its throughput at the analysis's wavelength, which turns the analysed power into
// the power the path carries in that light (coatings tuned to one wavelength can reflect tens of
// times more elsewhere). A path without a live cell: no throughput, ratio 1. With `stepNm` > 1
// only the ratio, from every stepNm-th bin (kPruningStepNm is enough to decide a pruning).
inline constexpr int kPruningStepNm = 10;
struct PathSpectrum {
    std::vector<double> throughput;
    double ratio = 1.0;
};
PathSpectrum pathSpectrum(const LensSystem& lens, const PupilGrid& grid, const GhostEstimate& estimate,
                          const Spectrum& spectrum, double analysisWavelengthNm, int stepNm = 1);

// The analysis prunes on the power at its one wavelength, and a ghost whose coatings reflect
// little there can carry more of a light than ghosts it kept (the 24–70 zoom at tele has 15). This
// prunes the ghosts (order 2) again, by the same rule, on their power in `spectrum` and keeps those
// it keeps and the analysis pruned (the report's pruned totals follow); returns how many. The
// spectra are computed here (every 10 nm) for the ghosts with analysed power, or taken from
// `spectra` (one per report ghost) when given.
int keepSpectrallyStrongGhosts(const LensSystem& lens, const Spectrum& spectrum, const GhostAnalysisOptions& options,
                               GhostReport& report, std::vector<PathSpectrum>* spectra = nullptr);

}  // namespace flare
