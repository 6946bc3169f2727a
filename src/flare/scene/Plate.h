// A plate for `flare composite`: a linear HDR EXR (a photograph or a rendering) whose bright
// sources are to flare. Any size and aspect; its main RGB image over the display window (pixels
// outside the data window are black, as EXR defines them), in the plate's own colour space.
#pragma once

#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "flare/scene/PlateColourSpace.h"

namespace flare {

struct Plate {
    std::string path;
    int width = 0, height = 0;   // the display window
    std::vector<float> rgb;      // interleaved, row-major from the top row, in `space`
    PlateColourSpace space;

    glm::dvec3 pixel(int x, int y) const {
        const size_t i = 3 * (static_cast<size_t>(y) * width + x);
        return {rgb[i], rgb[i + 1], rgb[i + 2]};
    }
};

// Reads the plate. `colourSpace` "" takes the file's `chromaticities` attribute (without one,
// OpenEXR's default: linear Rec.709), else resolveColourSpace(colourSpace). Raises InputError
// naming the file for a file that is not an EXR, one without R, G and B channels, and a NaN or
// infinite value (naming the pixel, column and row from the display window's top-left, and the
// channel).
Plate readPlate(const std::string& path, const std::string& colourSpace);

}  // namespace flare
