#include "StarburstReport.h"

#include <cstdio>

namespace flare::cli {

void printStarburst(const StarburstImage& image) {
    for (const StarburstLightReport& l : image.lights) {
        if (!l.diffracted) {
            std::fprintf(stderr, "  diffraction of %s: none (%s)\n", l.name.c_str(), l.why.c_str());
            continue;
        }
        std::fprintf(stderr,
                     "  diffraction of %s: pupil %.3g mm², %d straight edges, %.0f %% of its outline curved; %d "
                     "wavelengths; window %d px (exact core %.1f px); %.2g %% of the light outside the frame; %.2f s\n",
                     l.name.c_str(), l.pupilAreaMm2, l.spikeEdges, 100.0 * l.smoothOutlineShare, l.wavelengths,
                     l.windowRadiusPx, l.coherentRadiusPx, 100.0 * l.outsideFrameShare, l.seconds);
        if (l.dustSurfaces > 0)
            std::fprintf(stderr, "    dust glow from %d surface(s): %.3g %% of the light, %.0f %% of it on the sensor\n",
                         l.dustSurfaces, 100.0 * l.dustGlowShare, 100.0 * l.dustGlowInFrameShare);
    }
}

}  // namespace flare::cli
