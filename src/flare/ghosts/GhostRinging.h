// The Fresnel scale of a ghost's edges: a ghost is a defocused image of the aperture stop, and its
// rim carries the stop edge's Fresnel diffraction. In the paraxial (Collins) picture the field on
// the sensor is the stop's field propagated through the path's ray-transfer matrix from the stop
// to the sensor, [A B; C D] in reduced slopes (n·u, so that the vacuum wavelength applies), lit by
// the converging or diverging beam that the lens ahead of the stop makes of the light. With A' the
// beam's magnification from the stop to the sensor (the marginal ray's height there over its
// height at the stop), the Fresnel scaling theorem makes the sensor's intensity the plane-wave
// Fresnel pattern of the stop's geometric image (radius |A'|·r) at the distance
//
//     z = |A'·B|     (free space: L·(d − L)/d for a stop at L before the sensor, focus d after it),
//
// so the rim's profile across the geometric boundary is the straight edge's intensity
// (FresnelIntegrals.h) of u = x / w, w = √(λz/2), with Fresnel number N = (A'r)² / (λz). When the
// path crosses the stop more than once (a reflection behind it and one in front), the crossing
// where the beam is widest clips it and is the one that counts.
#pragma once

#include "flare/ghosts/Ghosts.h"

namespace flare {

struct GhostFresnelScale {
    bool valid = false;          // false: a malformed path, or the marginal ray misses the stop
    double distanceMm = 0.0;     // z = |A'·B|, on the sensor
    double magnification = 0.0;  // A': stop → sensor, for the beam (negative: the image is inverted)
    double imageRadiusMm = 0.0;  // |A'|·r, the stop's geometric image on the sensor
    int stopCrossing = 0;        // which crossing of the stop (0: the first) limits the beam
    // G: how far the rim moves on the sensor per radian of the light's direction (the image of
    // the limiting stop crossing's edge, for rays from a direction θ: G·θ). The direct image's is
    // the focal length.
    double fieldShiftMmPerRad = 0.0;

    // w = √(λz/2) in mm, and the Fresnel number (A'r)² / (λz), at a vacuum wavelength.
    double edgeScaleMm(double wavelengthNm) const;
    double fresnelNumber(double wavelengthNm) const;
};

// From the path's paraxial trace at `indices` (an axial beam from infinity, as analyseGhostParaxial;
// a field angle moves the ghost but leaves its defocus to first order). The empty path is the
// direct image: z = 0 when the sensor is at the paraxial focus.
GhostFresnelScale ghostFresnelScale(const LensSystem& lens, const SpectralIndices& indices, const GhostPath& path);

// The straight-edge profile leaves out the rim's curvature and the opposite rim's wave, errors of
// order w/R = 1/√(2N) in the ripples' amplitude (6 % at N = 128, test_ghost_ringing.cpp). Below
// this Fresnel number (w/R = 10 %) it stands for little: the ghost is then a few Fresnel zones
// across (near its focus, or tiny), its rims' ripples overlap and its centre oscillates; the
// renderer leaves such a ghost's image geometric (docs/rendering.md).
inline constexpr double kMinRingingFresnelNumber = 50.0;

// A light's apparent extent washes the ripples out: its points (a sun's disk of apparent radius
// α, a disk light's face) move the rim by up to |G|·α, and averaged over them the ripples keep
// FresnelEdgeExcess::smearedPeak(|G|·α / w) of the edge's irradiance (1.4 % at 4 w). The
// renderer rings a beam only where that is at least this much: below it the mean image's
// ripples are a smaller error than the render's own noise, and leaving them out saves the cost
// of rasterising every beam's rim (a third of a preview of the sun).
inline constexpr double kMinSmearedRipple = 0.02;

// Whether a beam of this path at this wavelength rings, for a light of apparent radius
// `apparentRadiusRad` (0: a point or a collimated light): the Fresnel number is at least
// kMinRingingFresnelNumber and the smeared ripples at least kMinSmearedRipple.
bool ghostRipplesVisible(const GhostFresnelScale& scale, double wavelengthNm, double apparentRadiusRad);

}  // namespace flare
