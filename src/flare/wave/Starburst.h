// The starburst: the light's own (geometric) image convolved with the lens's diffraction PSF.
//
// Each light's part of the direct image (the pixels nearest its image; lights are far apart on
// the sensor) is cropped to the square holding all but 10⁻⁴ of its energy, and convolved with its
// PSF (DiffractionPsf) in two parts that add up to the whole PSF:
//   near: the PSF on a window around the point image, tapered to zero at the window's edge,
//         convolved with the crop exactly (FFT; KissFFT);
//   far:  the rest (the taper's complement), out to every pixel of the frame, from the PSF's
//         fringe-averaged asymptote: each straight edge's spike is a line whose energy falls as
//         1/r², so the crop convolved with it is, far from the crop, the line's envelope times the
//         crop's energy projected across the line (convolved with the spike's own sinc² profile
//         and the pixel's width) within a band around the line, and beyond it the sinc²'s tail
//         of the crop's energy taken as a point; the corners' interference (ApertureTransform.h)
//         and the smooth halo times the crop's energy. Every pixel of the frame gets all of them:
//         the light between the spikes (the spikes' tails and the corners, 1/r⁴) is not cut off.
// The window is several crop radii wide, so the far part's envelope is nearly constant across the
// crop. The PSF integrates to 1, so the starburst holds the crop's energy minus what falls
// outside the frame, which is reported. Dusty surfaces add their glow (DustGlow.h), `coverage` of
// the crop's energy, spread from its centre by the glow's pattern mapped through the lens behind
// the dust (it is far wider than the crop). Pixels of the direct image outside every crop stay as
// they are (undiffracted): at most 10⁻⁴ of a light's energy.
#pragma once

#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "flare/core/Spectrum.h"
#include "flare/optics/LensSystem.h"
#include "flare/wave/ApertureTransform.h"
#include "flare/wave/PupilOutline.h"

namespace flare {

struct StarburstOptions {
    int wavelengths = 32;           // spectral quadrature of each light's PSF
    double cropEnergy = 1.0 - 1e-4; // share of a light's direct image that is diffracted
    int maxCropRadiusPx = 128;
    int minWindowPx = 32;           // half-size of the near window, at least
    double windowPerCropRadius = 6.0;
    // At most (a large light's crop then spans much of the window, and the far part's envelope
    // varies across it: broad spikes of a broad light are approximate).
    int maxWindowPx = 320;
    // Lights whose PSFs differ by at most this (PsfGroups.h: the relative area of their pupils'
    // symmetric difference in pixel-frequency space) share one PSF, their founder's: its pupil
    // traced once, its near window evaluated once at the largest any of them needs. 0: every light
    // its own PSF.
    double psfGroupTolerance = 0.0;
    // > 0: lights of one PSF group whose crops lie close together get one far field, of the crop
    // holding all their pixels (each keeping its own near window and taper): a light joins a
    // cluster while the cluster's energy centroid stays within this share of every member's taper
    // start (half its window) from the member's crop centre. 0: every light its own far field.
    double clusterFarFields = 0.0;
};

// One light's diffraction, traced through the lens at the image's resolution.
struct StarburstLight {
    std::string name;
    glm::dvec3 direction{0.0, 0.0, 1.0};  // of travel
    std::vector<SpectralSample> spectrum; // the light's spectral quadrature (normalised weights)
};

// Dust on a surface, for its forward diffraction (DustGlow.h): a glow carrying `coverage` of the
// light, added to the starburst.
struct StarburstDust {
    int surface = 0;           // 0-based
    double coverage = 0.0;     // mean over the surface's clear aperture
    double medianDiameterUm = 20.0;
    double diameterSigma = 0.5;
};

struct StarburstLightReport {
    std::string name;
    bool diffracted = false;
    std::string why;                 // when not
    double pupilAreaMm2 = 0.0;
    int spikeEdges = 0;              // straight edges of the pupil's outline: spikes 2 × this
    double smoothOutlineShare = 0.0; // share of the outline that is curved (a halo, no spike)
    int wavelengths = 0;
    int cropRadiusPx = 0, windowRadiusPx = 0;
    double coherentRadiusPx = 0.0;
    int psfLight = -1;               // the light whose PSF it was given (itself, or its group's founder)
    double psfDifference = 0.0;      // PsfGroups.h's difference from that light's pupil
    int farCluster = -1;             // with clusterFarFields: its far field's cluster (its first light)
    double parsevalError = 0.0;      // the PSF model's energy before normalisation, minus 1
    double directEnergyY = 0.0;      // of this light's part of the direct image
    double diffractedShare = 0.0;    // of it, in the crop
    double outsideFrameShare = 0.0;  // of the diffracted energy, landing outside the frame
    int dustSurfaces = 0;            // dusty surfaces whose glow was added
    double dustGlowShare = 0.0;      // the glow's energy, as a share of the diffracted energy
    double dustGlowInFrameShare = 0.0;  // of the glow, on the sensor
    double seconds = 0.0;
};

// Where a starburst's wall time went, by stage (seconds).
struct StarburstStages {
    double outlines = 0.0;  // the lights' pupils traced, the direct image's pixels given to lights
    double psfs = 0.0;      // the PSFs: groups, exact transforms, near windows
    double near = 0.0;      // the crops convolved with their near windows (FFT)
    double far = 0.0;       // the far fields over the frame (and dust)
};

struct StarburstImage {
    std::vector<float> xyz;          // the starburst layer (W/m², XYZ), as the direct layer
    std::vector<StarburstLightReport> lights;
    StarburstStages stages;
    int farFields = 0;               // far fields evaluated over the frame
};

// `directXyz`: the direct layer (widthPx × heightPx × XYZ, camera orientation, as the preview and
// the render write it). The lens's sensor gives the pixel size.
// `dust`: the lens's dusty surfaces, whose glow is added (none: the iris's diffraction alone).
StarburstImage renderStarburst(const LensSystem& lens, const std::vector<float>& directXyz, int widthPx, int heightPx,
                               const std::vector<StarburstLight>& lights, const StarburstOptions& options = {},
                               const std::vector<StarburstDust>& dust = {});

}  // namespace flare
