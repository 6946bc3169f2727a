// A plate's source pixels as region lights (`flare composite`): instead of merging the pixels of a
// cell into one light at its centroid (PlateLights.h), which moves each pixel's ghosts by up to a
// cell, the pixels are split into regions of bounded angular size and each region is one light
// whose rays come from its own pixels' directions, each with its power and colour
// (LightSpec::region): one ghost analysis and plan per region, no merging error.
//
// The bound: a region's points must share the analysis of its centre. Its pupil grid is widened
// to hold every point's rays (LightSampler), its guide masks are probed at its outermost points,
// and a ghost's live pupil region and image move smoothly with the field angle; what the bound
// keeps small is what the centre's analysis decides for all the points (which ghosts are pruned,
// the beams' shares of the paths) and the grid's widening (coarser analysis cells). Tested
// against the same pixels as separate directional lights (test_plate_regions.cpp).
#pragma once

#include <string>
#include <vector>

#include "flare/optics/LensSystem.h"
#include "flare/scene/PlateLights.h"
#include "flare/scene/PlateSources.h"

namespace flare {

// The default bound on a region's angular radius (its farthest point from its luminance-weighted
// centre), and the largest: below the scene files' kMaxRegionRadiusDeg (3°, the bound the tests
// validate), as the light is centred again on its points weighted by power, which moves the centre
// a little (the throughput and the colours vary across the region).
inline constexpr double kDefaultRegionRadiusDeg = 2.5;

struct PlateRegion {
    std::vector<PlateSource> pixels;  // one-pixel cells (findPlateSources with cellPx 1)
    PlateSource summary;              // all of them: group of the first, sums, centroid, bounds
};

// Splits the source pixels (one-pixel cells, findPlateSources(plate, threshold, 1)) into regions
// of angular radius at most maxRadiusDeg about their luminance-weighted centre: the whole set,
// halved at the middle of its wider side in field angle until every part fits. Deterministic (the
// pixels keep their scan order).
std::vector<PlateRegion> plateRegions(const PlateFieldMap& map, const PlateSources& pixels, double maxRadiusDeg);

// One light per region, named "<prefix><group>-<k>" (group: its first pixel's; k: its count
// among the regions of that group). A region of one pixel is a plain directional light at that
// pixel; a larger one a region light whose points are its pixels, each with the power whose
// direct image through the lens holds its energy (the direct path's throughput at its field angle,
// from a table over the plate's field angles, in its colour) and its colour from a palette of the
// region's chromaticities (CIE xy to 0.005). Culled as plateLights culls cells.
PlateLightSet plateRegionLights(const LensSystem& lens, const PlateFieldMap& map, const std::vector<PlateRegion>& regions,
                                double cullShare = 1e-3, const std::string& prefix = "source");

}  // namespace flare
