// A composite shown through an OpenColorIO display and view (`flare composite --display --view`):
// the look a colourist would see, in place of flare's own tone curve (docs/composite.md). The
// plate's RGB goes to CIE XYZ by its colour space's matrix, then from the config's
// `cie_xyz_d65_interchange` role (or `aces_interchange`, through ACES2065-1) to the display and
// view, so that a plate whose space came from the file's chromaticities needs no name in the config.
#pragma once

#include <string>
#include <vector>

#include "flare/film/ImageIO.h"
#include "flare/scene/PlateColourSpace.h"

namespace flare {

struct DisplayView {
    std::string display, view;  // an empty view: the config's default view of the display
};

// `image` (plate RGB in `space`) times `exposure`, through the $OCIO config's display and view:
// display-referred RGB, as the view's transform leaves it (a PNG stores it clamped to [0, 1]).
// InputError(optionName, 0, ...) without a config, for a display or view it does not have (listing
// those it has), or for a config without an interchange role to start from.
ImageLayer applyDisplayView(const ImageLayer& image, const PlateColourSpace& space, const DisplayView& displayView,
                            double exposure, const std::string& optionName = "--display");

}  // namespace flare
