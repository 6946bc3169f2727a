// A sensor hit: light that a pass's work (a photon, a beam's correction photon or its twin) lands
// at one sensor point, bound for a fixed layer and perhaps a per-path layer. The strategies
// (PhotonBatches.h, BeamStrategy.h) collect a pass's hits, and the renderer (Render.h) merges
// them into the film band by band in a fixed order, so that the image never depends on which
// thread traced what. Internal to the renderer.
#pragma once

#include <cstdint>

namespace flare::renderer {

struct SensorHit {
    float xMm, yMm;
    float xyz[3];
    std::int16_t layer;
    std::int32_t ghostLayer;  // −1: none
};

}  // namespace flare::renderer
