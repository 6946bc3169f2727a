// The predicted variance of one beam of a path, and its cost: what the render shares its beams by
// (BeamShare.h). Internal to the renderer.
//
// A beam is the path's image at one sample u of (wavelength, point of the light's extent, film-kernel
// jitter); the path's estimate averages beams, so what more beams buy is set by the spread of the
// image over u: v = E‖B(u) − E B‖², summed over the film's pixels and Rec.709 channels in the film's
// absolute units (every path of every light comparable). The probe measures it directly: K beams
// drawn exactly as the render draws them, each at an independent uniform u (the first point of a
// Sobol' sequence under a scramble of its own: uniform, and independent from probe to probe and of
// the render's sequences), rasterised on the film's pixels band by band, and
//     v̂ = Σ_k ‖B_k − B̄‖² / (K − 1),
// an unbiased estimate of v. Independent points matter: consecutive points of one scrambled
// sequence are stratified, and their spread underestimates v, the more so the denser the
// sequence (docs/BENCHMARKS.md, the tenth part).
//
// What the central probe (BeamStrategy.h: ‖image‖² at the analysis's wavelength and the light's
// centre) misses, this sees: whether the light's extent moves the image by more than its features
// (a disk light's ghosts; a point light's stay put), how much the path's colour changes with the
// wavelength, and the rims' ripples. The render's sequences converge faster than 1 / n where the
// image changes smoothly with u (a point light's ghosts: one wavelength dimension), so v̂ / n is an
// upper bound there: such paths get more beams than they need, never fewer.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "flare/photons/PhotonTracer.h"
#include "flare/render/GhostBeam.h"
#include "flare/render/Render.h"
#include "flare/render/RenderPlan.h"

namespace flare::renderer {

// A path's predicted variance per beam (film units², Rec.709, summed over pixels) and cost per beam
// (traced rays, plus a tenth of one per pixel of its image rasterised).
struct BeamPathVariance {
    double variancePerBeam = 0.0;
    double costRays = 0.0;
};

// One beam's image as the film adds it: the beam, its jitter, its scale (film units per unit of
// irradiance) and the seed of its small triangles' points.
struct BeamImage {
    const GhostBeam* beam = nullptr;
    glm::dvec2 jitterPx{0.0};
    glm::dvec3 scale{0.0};
    std::uint64_t seed = 0;
};

// Σ_k ‖B_k − B̄‖² / (K − 1) over the film's pixels, in linear Rec.709 (the beams rasterised in XYZ,
// band by band, over the part of the frame they reach): the sample variance of K ≥ 2 images.
double imageSampleVariance(const std::vector<BeamImage>& images, const FilmFrame& frame);

// The probe of path `slot` of light `lightIndex` (a beam-rendered path): `probes` (≥ 2) beams at
// independent uniform samples, drawn as the render draws its beams (traceBeam), with seeds of
// their own.
BeamPathVariance probeBeamVariance(const LensSystem& lens, const RenderOptions& options, const PhotonTracer& tracer,
                                   const LightState& light, int lightIndex, int slot, int probes);

}  // namespace flare::renderer
