// A beam: the image one ghost path of one light casts on the sensor at one wavelength and one
// sample of the light's extent (a direction within a directional light's disk, a point of a disk
// light), integrated over the pupil deterministically. The
// path's live region is meshed at that wavelength and direction (PupilMesh, the preview's
// machinery) and clipped to the path's guide mask; each triangle maps the pupil affinely onto the
// sensor (a piecewise-linear ray map).
//
// Irradiance over a triangle's image. The map's Jacobian is constant on each triangle, so the
// irradiance of the piecewise-linear map jumps from triangle to triangle: an error of first order
// in the cell size, which shows as bands along the mesh. Instead, the Jacobian is recovered at
// every vertex as the area-weighted mean of its triangles' (second-order accurate on the regular
// lattice the mesh lives on) and the irradiance, throughput / |det J|, is interpolated linearly
// between the vertices: continuous, and second-order accurate like the positions. Where the map
// folds (the Jacobian changes sign: a caustic) or nearly so, the vertex irradiance is unbounded,
// and the triangles there keep their own, exact-power irradiance.
//
// The beam is the deterministic half of the final render's ghost estimator (Render.h): averaged
// over sampled wavelengths, directions and kernel jitters, beams give the ghost's image without
// per-pixel noise. The film's kernel (the tent of the fixed 1-px kernel) is integrated the same
// way: a beam's image is its irradiance sampled at the pixel centres shifted by one jitter drawn
// from the tent, whose expectation is exactly the tent-filtered image. Triangles whose image is
// smaller than about a pixel are too small for a sampled grid: each instead splats its power at
// a few random points of its image (the same expectation).
//
// Twins. A photon traced at the beam's wavelength and direction through pupil point u has a twin:
// u sent through the piecewise-linear map, weighted so that the twins' density is the beam's
// irradiance (GhostBeam::twin). photon − twin, splatted with the tent, corrects the beam without
// bias whatever the mesh's error (RenderOptions::correctionPhotonsPerBeam).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <utility>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "flare/ghosts/GuideMask.h"
#include "flare/ghosts/PupilMesh.h"
#include "flare/optics/BundleTracer.h"
#include "flare/render/BeamRim.h"

namespace flare {

// Where the film's pixels are: pixel coordinates of a sensor point, as Film::toPixel (the sensor
// image turned by 180°, pixel centres at i + 0.5).
struct FilmFrame {
    int widthPx = 0, heightPx = 0;
    double widthMm = 0.0, heightMm = 0.0, pixelMm = 0.0;

    glm::dvec2 toPixel(const glm::dvec2& sensorMm) const {
        return {(0.5 * widthMm - sensorMm.x) / pixelMm, (0.5 * heightMm + sensorMm.y) / pixelMm};
    }
    glm::dvec2 toSensorMm(const glm::dvec2& pixel) const {
        return {0.5 * widthMm - pixel.x * pixelMm, pixel.y * pixelMm - 0.5 * heightMm};
    }
};

// One triangle of a beam's piecewise-linear map, in pupil (mm) and film pixel coordinates.
struct BeamTriangle {
    glm::dvec2 pupilMm[3];
    glm::dvec2 pixel[3];
    double throughput[3];
    // Irradiance at the vertices per unit incident power density (pupil mm² per image px²,
    // times the throughput), interpolated linearly over the image.
    double irradiance[3];
    double imageAreaPx2 = 0.0;  // |area| of the image
    double pupilAreaMm2 = 0.0;
    bool small = false;         // splatted at random points instead of sampled on the pixel grid
};

// The twin of a photon: where the piecewise-linear map sends its pupil point, and its weight in
// throughput units (so that the twins' density is the beam's irradiance).
struct BeamTwin {
    glm::dvec2 pixel{0.0};
    double throughput = 0.0;
};

class GhostBeam {
public:
    GhostBeam() = default;
    // Meshes the path's live region for the rays of `grid` (the light's pupil plane, with the
    // beam's direction) traced by `tracer` (the beam's wavelength), on the cells of the ghost
    // analysis's search (`lattice`), and keeps the part inside `mask`. With `vertexFactor`, every
    // vertex's throughput is multiplied by it: the probability that the vertex's ray crosses the
    // lens's dust, grease and bulk media clear (guided paths own only unscattered light), and a
    // point source's power per mm² of the plane relative to the central ray's.
    static GhostBeam build(const BundleTracer& tracer, const PupilGrid& grid, const PupilLattice& lattice,
                           const GuideMask& mask, const FilmFrame& frame, const PupilRemeshOptions& options,
                           const std::function<double(const glm::dvec2& pupilMm)>& vertexFactor = {});

    // A beam of given triangles (pupil and pixel positions, throughput and irradiance per vertex,
    // pupil and image areas, `small` set by the caller), for tests and tools, and for a beam traced
    // by another process (PassWire.h: its triangles and the rays its mesh traced).
    // `seedIndices`, when given (one per triangle), are the triangles' indices in the beam they were
    // cut from (a band owner's part of another process's beam): a small triangle's points are
    // drawn from (seed, its index), so that the part rasterises its bands as the whole beam does.
    static GhostBeam fromTriangles(std::vector<BeamTriangle> triangles, const FilmFrame& frame, long tracedRays = 0,
                                   std::vector<std::uint32_t> seedIndices = {});

    bool empty() const { return triangles_.empty(); }
    const std::vector<BeamTriangle>& triangles() const { return triangles_; }
    // Triangle n's index in the beam it was cut from (fromTriangles), else n.
    std::uint32_t seedIndex(size_t n) const { return seedIndices_.empty() ? static_cast<std::uint32_t>(n) : seedIndices_[n]; }
    // The triangles rasterise reads over the bands [firstBand, lastBand], by index, ascending: a
    // beam cut to them (fromTriangles with their seed indices, the rim cut likewise) rasterises
    // those bands bit for bit as the whole beam.
    std::vector<std::uint32_t> trianglesReaching(int firstBand, int lastBand) const;
    long tracedRays() const { return tracedRays_; }

    // The piecewise-linear map at a pupil point: false outside the beam's region (or where the
    // map sends it off the sensor, which the film does not see).
    bool twin(const glm::dvec2& pupilMm, BeamTwin* out) const;

    // Rings the image's rim at the Fresnel scale `edgeScalePx` (BeamRim.h; GhostRinging.h gives
    // the scale from the path's paraxial system): rasterise then adds the rim's excess over the
    // geometric step. 0: the geometric image (the default).
    void ring(double edgeScalePx);
    // The same with a rim ring() made elsewhere (a beam traced by another process, PassWire.h).
    void ring(BeamRim rim) { rim_ = std::move(rim); }
    const BeamRim& rim() const { return rim_; }

    // The image's power on the sensor per unit incident power density (mm² of pupil, with the
    // throughput): its irradiance integrated over the sensor rectangle.
    double powerOnSensor() const;

    // Adds the beam's image over the film band `band` (rows [band, band + 1) × Film::kBandRows)
    // to `rows` (xyz per pixel, row-major from the band's first row, width frame.widthPx): the
    // irradiance, times `scale` (the light's power per mm² of pupil × the spectral weight, and any
    // normalisation), sampled at the pixel centres shifted by `jitterPx` (at most one pixel each
    // way); small triangles splat at random points drawn from (seed, triangle index). With ring(),
    // the rim's ringing is added (sampled at the same points).
    void rasterise(int band, const glm::dvec2& jitterPx, const glm::dvec3& scale, std::uint64_t seed,
                   double* rows) const;
    // Widens the columns [loPx, hiPx] by those rasterise may write in band `band` (any jitter: its
    // triangles' and rim's reach, a splat's and the jitter's pixels included); leaves them as they
    // are when it writes none. Outside them, rasterise leaves the band's rows as they were.
    void columnsInBand(int band, int& loPx, int& hiPx) const;

private:
    void index() const;
    void bucketByBand();
    const BeamTriangle* locate(const glm::dvec2& pupilMm, double* b1, double* b2) const;

    FilmFrame frame_;
    std::vector<BeamTriangle> triangles_;
    BeamRim rim_;
    long tracedRays_ = 0;
    // Point location: a grid of buckets over the pupil bounding box of the triangles, built once
    // by the first twin (under indexOnce_).
    mutable glm::dvec2 bucketMinMm_{0.0};
    mutable double bucketMm_ = 1.0;
    mutable int bucketsA_ = 0, bucketsB_ = 0;
    mutable std::vector<int> bucketStart_, bucketTriangles_;
    std::unique_ptr<std::once_flag> indexOnce_ = std::make_unique<std::once_flag>();  // (movable)
    // Triangles sorted by the film band of their first row (jitter included); band b's, in that
    // order, are bandTriangles_[bandStart_[b] .. bandStart_[b + 1]).
    std::vector<int> bandStart_, bandTriangles_;
    std::vector<std::uint32_t> seedIndices_;  // (fromTriangles) per triangle, or empty
};

// A draw from the tent (the film's 1-px kernel) in each axis, from two uniforms in [0, 1).
glm::dvec2 tentJitter(double u1, double u2);

}  // namespace flare
