// Emission of photons from one light towards the lens. A photon is named by the point (a, b) where
// its ray crosses the light's pupil plane: the PupilGrid plane, normal to the light's central
// direction through the first vertex, shared with the ghost analysis. Naive emission draws (a, b)
// uniformly over a disk that covers every ray able to enter the front aperture; guided emission
// draws it over a ghost's live cells. The light's own extent (the sun's disk, a point's position,
// a disk's area) then gives the ray through that point and the power it carries per unit area of
// the plane, so that power density × area / probability is an unbiased photon power.
#pragma once

#include <vector>

#include "flare/core/Spectrum.h"
#include "flare/optics/PupilGrid.h"
#include "flare/photons/Light.h"

namespace flare {

struct EmittedRay {
    Ray ray;                     // starts in front of the lens (a far light's, near it: PupilGrid::rayFrom)
    double powerPerMm2 = 0.0;    // W per mm² of the pupil plane (0: this ray carries nothing)
    glm::dvec3 sourceMm{0.0};    // point and disk lights: the emitting point the ray comes from
};

class LightSampler {
public:
    LightSampler(const LightSpec& light, const LensSystem& lens);

    const PupilGrid& grid() const { return grid_; }
    const LightSpec& light() const { return light_; }
    // Unguided emission covers the disk of radius h about the pupil plane's centre (h ≥
    // grid().halfSizeMm, widened for the light's angular extent) so that no ray that can enter
    // the lens is left out (tested for the shipped lenses and light kinds).
    double emissionHalfSizeMm() const { return emissionHalfSizeMm_; }
    // The ray through (aMm, bMm) on the pupil plane, with the light's angular extent sampled by
    // u1, u2 in [0, 1): uniform over the sun's cone, or a uniform point of a disk light.
    EmittedRay rayThrough(double aMm, double bMm, double u1, double u2) const;
    // The rays of one sample (u1, u2) of the light's extent, as rayThrough draws it, over the whole
    // plane: a directional light's direction within its disk (parallel rays), a disk light's
    // point (rays fanning from it), a point light's own rays. A beam meshes one such grid.
    PupilGrid gridFor(double u1, double u2) const;
    // Whether the power per mm² of the plane is the same for every ray of a gridFor grid (parallel
    // rays); else it varies over the plane (a point's inverse square and obliquity) and beams
    // weight each ray by rayThrough's.
    bool uniformOverPlane() const { return light_.type == LightSpec::Type::Directional; }
    // Whether the light has an extent (a sun's disk, a disk light's face, a region's points):
    // gridFor then depends on (u1, u2).
    bool hasExtent() const {
        return light_.isRegion()                           ? regionDirections_.size() > 1
               : light_.type == LightSpec::Type::Directional ? light_.angularDiameterDeg > 0.0
               : light_.type == LightSpec::Type::Disk      ? light_.radiusMm > 0.0
                                                           : false;
    }
    // The grids of the extent's edge, where a path's live region reaches farthest (the guide
    // masks' probes): a disk's rim at `count` azimuths; a region's points farthest out in at least
    // 8 azimuths (distinct points only). Empty without an extent.
    std::vector<PupilGrid> rimGrids(int count) const;
    // A region light: the point a light uniform u1 draws (by the points' shares), and the factor
    // its own colour puts on a wavelength drawn from the light's spectrum: the point's spectrum
    // over the light's, each at unit luminance (so the estimate stays unbiased whatever colour the
    // light's spectrum is). 1 for every other light.
    int regionPoint(double u1) const;
    double colourFactor(double u1, double wavelengthNm) const;

private:
    // A disk light's point for (u1, u2): uniform over its area.
    glm::dvec3 diskPoint(double u1, double u2) const;

    LightSpec light_;
    PupilGrid grid_;
    double emissionHalfSizeMm_ = 0.0;
    double cosHalfAngle_ = 1.0;         // directional: the cone of the light's apparent disk
    double meanCosine_ = 1.0;           // of rays uniform over that cone
    glm::dvec3 diskU_{1, 0, 0}, diskV_{0, 1, 0};
    // A region light: per point its direction, cumulative share and colour; per colour its
    // spectrum at unit luminance relative to the light's (the light's spectrum at unit luminance).
    std::vector<glm::dvec3> regionDirections_;
    std::vector<double> regionCdf_;
    std::vector<int> regionColour_;
    Spectrum ownSpectrum_;
    std::vector<Spectrum> colourSpectra_;
    std::vector<double> colourScale_;  // Y(light's spectrum) / Y(colour's spectrum)
};

}  // namespace flare
