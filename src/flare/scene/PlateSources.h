// The bright sources of a plate: pixels whose luminance exceeds a threshold, grouped into
// connected components (8-neighbours: the sources, counted and reported), and the source pixels
// gathered into the cells of a grid of cellPx × cellPx pixels over the frame, each cell a light of
// `flare composite` (PlateLights.h). A cell's ghosts are the ghosts of a light at its centroid
// spread over its extent: the cell bounds how far apart the ghosts of pixels merged into one light
// lie (a ghost's image moves with its light's field angle, by a magnification of order one).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "flare/scene/Plate.h"

namespace flare {

struct PlateSource {
    int group = 0;            // the connected component of its first pixel (0-based, in scan order)
    int pixelCount = 0;
    glm::dvec3 xyzSum{0.0};   // Σ of its pixels' XYZ (plate values through the plate's matrix)
    glm::dvec2 centroidPx{0}; // luminance-weighted, in pixel coordinates (a pixel's centre at +0.5)
    int minX = 0, minY = 0, maxX = 0, maxY = 0;  // the bounding box of its pixels (inclusive)
};

struct PlateSources {
    double threshold = 0.0;    // luminance (Y) above which a pixel is a source pixel
    std::string thresholdRule; // how it was chosen, in words
    double maxLuminance = 0.0;
    int groups = 0;            // connected components
    long sourcePixels = 0;
    std::vector<PlateSource> cells;  // in scan order of the grid
};

// The default threshold, chosen from the image's luminance: the larger of the 99.5th percentile
// (sources are a small part of a frame) and 1e-3 of the brightest pixel (a pixel a thousand times
// dimmer than the brightest source gives ghosts a thousand times weaker than its, under the
// plate's noise). At least the smallest positive value, so that a black frame gives no sources.
double automaticThreshold(const std::vector<float>& luminance, std::string* rule);

// Finds the sources: Y > threshold (default automaticThreshold), 8-connected groups, and their
// pixels in the cells of a grid of cellPx (≥ 1) anchored at the frame's top-left corner.
PlateSources findPlateSources(const Plate& plate, std::optional<double> threshold, int cellPx);

}  // namespace flare
