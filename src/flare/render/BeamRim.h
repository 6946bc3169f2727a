// The ringing of a beam's rim (GhostRinging.h): the edges of the beam's region as its image shows
// them, each ringing like a straight edge. A pixel near the rim belongs to the one edge segment
// whose wedge holds it (the wedge between the bisectors of the rim's angles at the segment's two
// ends, so that the segments share the rim's surroundings without gaps or overlaps), and gets the
// irradiance at the segment, interpolated along it, times the straight edge's excess over the
// geometric step (FresnelEdgeExcess) at u = the pixel's distance from the segment / w, positive
// inside. The excess integrates to zero across an edge, so the ringing moves power and
// makes none (to the pixel sampling and a rim's curvature over w: O((w / R)²)).
//
// The rim is the set of mesh edges that belong to a single triangle and have no triangle beyond
// them in the pupil (an edge of a coarse cell next to two finer ones belongs to one triangle, but
// the finer ones cover its far side), less those along the sensor's edge (where the mesh stops
// because the rays leave the sensor: no aperture there). A fold of the map (a caustic) is not on it and stays
// geometric; so do edges of small triangles (under a pixel²: near a focus, where the straight-edge
// model does not apply anyway).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace flare {

struct RimVertex {
    glm::dvec2 pupilMm{0.0};
    glm::dvec2 pixel{0.0};
    double irradiance = 0.0;  // the beam's units (BeamTriangle::irradiance)
};
struct RimTriangle {
    std::array<RimVertex, 3> v;
    bool small = false;  // its image is under a pixel²: its edges do not ring
};

class BeamRim {
public:
    BeamRim() = default;
    // The rim of `triangles` (vertices shared exactly between neighbours, as the mesh gives them),
    // ringing at the Fresnel scale w = `edgeScalePx` (> 0), for a film of widthPx × heightPx.
    // `covered(pupilMm)`: whether a pupil point lies in some triangle.
    static BeamRim build(const std::vector<RimTriangle>& triangles, double edgeScalePx, int widthPx, int heightPx,
                         const std::function<bool(const glm::dvec2& pupilMm)>& covered);

    bool empty() const { return segments_.empty(); }
    size_t segmentCount() const { return segments_.size(); }
    double edgeScalePx() const { return edgeScalePx_; }

    // Adds the ringing over film band `band` (rows [band, band + 1) × Film::kBandRows, `rows` as
    // GhostBeam::rasterise), sampled at the pixel centres shifted by `jitterPx`, times `scale`.
    void rasterise(int band, const glm::dvec2& jitterPx, const glm::dvec3& scale, int widthPx, int heightPx,
                   double* rows) const;

    // A segment of the rim, as build() makes it (trivially copyable).
    struct Segment {
        glm::dvec2 a{0.0}, b{0.0};        // ends, in pixels
        glm::dvec2 along{0.0};            // unit, a → b
        glm::dvec2 inward{0.0};           // unit normal towards the region
        glm::dvec2 bisectorA{0.0}, bisectorB{0.0};  // the wedge's sides through a and b
        double sideA = 0.0, sideB = 0.0;  // the sign of b beyond a's bisector, of a beyond b's
        double length = 0.0;
        double irradianceA = 0.0, irradianceB = 0.0;
        double rowMin = 0.0, rowMax = 0.0, columnMin = 0.0, columnMax = 0.0;  // the wedge's reach
    };
    const std::vector<Segment>& segments() const { return segments_; }
    // The segments rasterise reads over the bands [firstBand, lastBand], by index, ascending: a
    // rim of them alone (fromSegments) rasterises those bands bit for bit as the whole rim.
    std::vector<std::uint32_t> segmentsReaching(int firstBand, int lastBand) const;
    // Widens [xMinPx, xMaxPx] by the wedges' reach in x of the segments reaching band `band`
    // (without the jitter: GhostBeam::columnsInBand adds it); a reach that is not finite makes it
    // the whole line.
    void widenByBand(int band, double& xMinPx, double& xMaxPx) const;
    // A rim of segments that build() made (another process's beam, PassWire.h: sent as they are
    // rather than rebuilt from the triangles' pupil points), for a film heightPx rows high.
    static BeamRim fromSegments(std::vector<Segment> segments, double edgeScalePx, int heightPx);

private:
    // Lists the segments reaching each film band (bandStart_, bandSegments_).
    void indexBands(int heightPx);
    std::vector<Segment> segments_;
    double edgeScalePx_ = 0.0;
    std::vector<int> bandStart_, bandSegments_;  // segments reaching band b, as GhostBeam's triangles
};

}  // namespace flare
