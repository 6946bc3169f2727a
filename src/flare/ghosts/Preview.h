// The deterministic ghost preview: for each ghost path and each of a few wavelengths, the rays
// over the live pupil region that the ghost analysis found (on the cells of its adaptive search,
// split to the resolution the ghost's image needs) are traced through the forced sequence, and the
// region is meshed (PupilMesh): cells with four live corners give two triangles, cells cut by the
// region's edge (the iris, an aperture, the sensor's edge) give the polygon of their live part,
// with its vertices placed on the edge. Each triangle's power (mean throughput × pupil area ×
// incident irradiance) is spread over the triangle's image on the sensor, so irradiance comes from
// the change of area between pupil and sensor; folded cells overlap and add instead of being
// smeared, and edges stay sharp at any grid resolution.
#pragma once

#include <string>
#include <vector>

#include "flare/core/Spectrum.h"
#include "flare/ghosts/GhostAnalysis.h"

namespace flare {

struct PreviewLight {
    glm::dvec3 direction{0.0, 0.0, 1.0};  // of travel
    double irradiance = 1.0;               // on a plane normal to the rays (W/m²)
    double angularDiameterDeg = 0.0;       // blurs the direct image (the sun: 0.53°)
    std::vector<SpectralSample> spectrum;  // quadrature: Σ xyzWeight.y = 1
};

struct PreviewOptions {
    int widthPx = 1536;
    int heightPx = 1024;
    bool perGhostLayers = false;
    // Grid cells across a ghost's pupil region: the throughput and the pupil→sensor map are smooth
    // inside the region, so triangles interpolate them well from a coarse grid, and the region's
    // edge is placed between grid points by the rays' margins (BundleTracer), not by subdivision.
    int minCells = 12;
    int maxCells = 48;
    double pixelsPerCell = 24.0;  // target size of a grid cell's image, in pixels
    // Bisection steps for an edge point where no margin can place it (a missed surface): each
    // halves the uncertainty.
    int edgeRefinement = 6;
};

// Sensor irradiance in CIE XYZ (W/m² weighted by the colour-matching functions, Y = 1 for the
// light's own irradiance), row-major from the top row, seen as a camera shows it (the sensor image
// rotated by 180°, so a light at the top right of the scene is at the top right of the picture).
struct XyzLayer {
    std::string name;
    std::vector<float> xyz;
};

struct PreviewImage {
    int widthPx = 0, heightPx = 0;
    double pixelMm = 0.0;
    XyzLayer direct;                // the light's own image
    XyzLayer ghosts;                // every kept ghost
    std::vector<XyzLayer> perGhost; // with perGhostLayers: one per kept ghost, in report order
    std::vector<long> tracedRays;   // per kept ghost, for statistics
};

// Renders the direct image and every ghost of `report` that is not pruned. Deterministic whatever
// the number of threads: ghosts are meshed in parallel, and the image is rasterised in bands of
// rows, each pixel receiving its additions in report order. No per-ghost image buffers unless
// perGhostLayers. The pixels must be square (widthPx/heightPx = the sensor's aspect), else
// std::invalid_argument.
PreviewImage renderPreview(const LensSystem& lens, const PreviewLight& light, const GhostReport& report,
                           const PreviewOptions& options);

// Total power (sensor irradiance × area) of a layer's Y channel divided by the light's power
// entering the front aperture: comparable with GhostEstimate::powerFraction.
double layerPowerFraction(const PreviewImage& image, const XyzLayer& layer, const GhostReport& report,
                          double irradiance);

}  // namespace flare
