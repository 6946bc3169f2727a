// The deterministic ghost preview: for each ghost path, a grid of rays over the part of the pupil
// grid that survives the path is traced through the forced sequence at a few wavelengths; each
// grid cell is split into two triangles whose power (mean throughput × pupil area × incident
// irradiance) is spread over the triangle's image on the sensor. Irradiance thus comes from the
// change of cell area between pupil and sensor; folded cells overlap and add instead of being
// smeared, and cells cut by the iris or an aperture are subdivided so that edges stay sharp.
#pragma once

#include <string>
#include <vector>

#include "flare/GhostAnalysis.h"
#include "flare/Spectrum.h"

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
    // inside the region, so triangles interpolate them well from a coarse grid; resolution goes
    // where it matters, to the cells cut by the iris or an aperture, which are subdivided.
    int minCells = 12;
    int maxCells = 48;
    double pixelsPerCell = 24.0;  // target size of a grid cell's image, in pixels
    int edgeRefinement = 4;       // subdivision levels for cells cut by an edge (16× finer)
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

// Renders the direct image and every ghost of `report` that is not pruned. Deterministic: ghosts
// are rendered in parallel into their own buffers and summed in report order. The pixels must be
// square (widthPx/heightPx = the sensor's aspect), else std::invalid_argument.
PreviewImage renderPreview(const LensSystem& lens, const PreviewLight& light, const GhostReport& report,
                           const PreviewOptions& options);

// Total power (sensor irradiance × area) of a layer's Y channel divided by the light's power
// entering the front aperture: comparable with GhostEstimate::powerFraction.
double layerPowerFraction(const PreviewImage& image, const XyzLayer& layer, const GhostReport& report,
                          double irradiance);

}  // namespace flare
