#include "flare/render/BeamVariance.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <glm/mat3x3.hpp>
#include <tbb/enumerable_thread_specific.h>

#include "flare/core/Spectrum.h"
#include "flare/film/Film.h"
#include "flare/render/BeamStrategy.h"

namespace flare::renderer {

namespace {

// The probes' scrambles and random streams: replicate numbers and beam indices no render uses
// (replicates are < kMaxReplicates; a path draws far fewer beams a pass than the index base), so
// the probes are independent of the render's beams, and of each other.
constexpr int kProbeReplicateBase = 1 << 14;
constexpr int kProbeIndexBase = 0xc000;
// Columns and rows beyond a beam's triangles (and its rim's wedges) that its kernel jitter (at
// most a pixel) and its small triangles' splats may reach.
constexpr int kReachMarginPx = 2;

struct PixelBox {
    int column0 = 0, column1 = -1, row0 = 0, row1 = -1;  // inclusive; empty when column1 < column0
    bool empty() const { return column1 < column0 || row1 < row0; }
};

PixelBox reachOf(const GhostBeam& beam, const FilmFrame& frame) {
    double xMin = 1e300, xMax = -1e300, yMin = 1e300, yMax = -1e300;
    for (const BeamTriangle& t : beam.triangles())
        for (const glm::dvec2& p : t.pixel) {
            xMin = std::min(xMin, p.x), xMax = std::max(xMax, p.x);
            yMin = std::min(yMin, p.y), yMax = std::max(yMax, p.y);
        }
    for (const BeamRim::Segment& s : beam.rim().segments()) {
        xMin = std::min(xMin, s.columnMin), xMax = std::max(xMax, s.columnMax);
        yMin = std::min(yMin, s.rowMin), yMax = std::max(yMax, s.rowMax);
    }
    PixelBox box;
    if (!(xMin <= xMax)) return box;
    auto clampTo = [](double v, int hi) { return static_cast<int>(std::clamp(v, -1.0, static_cast<double>(hi))); };
    box.column0 = std::max(0, clampTo(std::floor(xMin), frame.widthPx) - kReachMarginPx);
    box.column1 = std::min(frame.widthPx - 1, clampTo(std::ceil(xMax), frame.widthPx) + kReachMarginPx);
    box.row0 = std::max(0, clampTo(std::floor(yMin), frame.heightPx) - kReachMarginPx);
    box.row1 = std::min(frame.heightPx - 1, clampTo(std::ceil(yMax), frame.heightPx) + kReachMarginPx);
    return box;
}

}  // namespace

double imageSampleVariance(const std::vector<BeamImage>& images, const FilmFrame& frame) {
    const size_t count = images.size();
    if (count < 2) throw std::invalid_argument("imageSampleVariance: at least two images");
    PixelBox box;
    bool any = false;
    for (const BeamImage& image : images) {
        const PixelBox b = reachOf(*image.beam, frame);
        if (b.empty()) continue;
        if (!any) box = b, any = true;
        box.column0 = std::min(box.column0, b.column0), box.column1 = std::max(box.column1, b.column1);
        box.row0 = std::min(box.row0, b.row0), box.row1 = std::max(box.row1, b.row1);
    }
    if (!any) return 0.0;
    // One band of rows per image, reused from call to call on a thread (a probe's band buffers are
    // megabytes at full resolution); only the box's columns are ever written, and zeroed after.
    const size_t bandValues = static_cast<size_t>(Film::kBandRows) * frame.widthPx * 3;
    static tbb::enumerable_thread_specific<std::vector<double>> scratch;
    std::vector<double>& rows = scratch.local();
    if (rows.size() < bandValues * count) rows.assign(bandValues * count, 0.0);
    const glm::dmat3& toRgb = xyzToLinearSrgbMatrix();
    double sum = 0.0;
    const int firstBand = box.row0 / Film::kBandRows, lastBand = box.row1 / Film::kBandRows;
    for (int band = firstBand; band <= lastBand; ++band) {
        for (size_t k = 0; k < count; ++k)
            images[k].beam->rasterise(band, images[k].jitterPx, images[k].scale, images[k].seed, rows.data() + k * bandValues);
        const int rowBegin = band * Film::kBandRows;
        const int rowEnd = std::min(frame.heightPx, rowBegin + Film::kBandRows);
        for (int row = rowBegin; row < rowEnd; ++row)
            for (int column = box.column0; column <= box.column1; ++column) {
                const size_t at = (static_cast<size_t>(row - rowBegin) * frame.widthPx + column) * 3;
                glm::dvec3 mean(0.0);
                for (size_t k = 0; k < count; ++k) {
                    const double* p = rows.data() + k * bandValues + at;
                    mean += glm::dvec3(p[0], p[1], p[2]);
                }
                mean /= static_cast<double>(count);
                for (size_t k = 0; k < count; ++k) {
                    double* p = rows.data() + k * bandValues + at;
                    const glm::dvec3 d = toRgb * (glm::dvec3(p[0], p[1], p[2]) - mean);
                    sum += d.x * d.x + d.y * d.y + d.z * d.z;
                    p[0] = p[1] = p[2] = 0.0;
                }
            }
    }
    return sum / static_cast<double>(count - 1);
}

BeamPathVariance probeBeamVariance(const LensSystem& lens, const RenderOptions& options, const PhotonTracer& tracer,
                                   const LightState& light, int lightIndex, int slot, int probes) {
    if (probes < 2) throw std::invalid_argument("probeBeamVariance: at least two probes");
    // The beams without correction photons (they remove the mesh's bias, not the spread over u);
    // their cost is counted as the render pays it.
    RenderOptions probeOptions = options;
    probeOptions.correctionPhotonsPerBeam = 0;
    std::vector<BeamJob> jobs(static_cast<size_t>(probes));
    BeamPathVariance out;
    for (int k = 0; k < probes; ++k) {
        BeamJob& job = jobs[static_cast<size_t>(k)];
        job.light = lightIndex;
        job.slot = slot;
        job.index = kProbeIndexBase + k;
        job.replicate = kProbeReplicateBase + k;
        job.rate = 1.0;  // film units of a path drawn once a pass: every path's variance alike
        job.sequenceIndex = 0;
        traceBeam(lens, probeOptions, tracer, light, 0, job);
        out.costRays += beamCostRays(job.beam, options.correctionPhotonsPerBeam);
    }
    out.costRays /= probes;
    std::vector<BeamImage> images;
    for (const BeamJob& job : jobs) images.push_back({&job.beam, job.jitterPx, job.scale, job.seed});
    // (Film units: a pass's image is its accumulated power over photonsPerPass.)
    const double perFilm = 1.0 / static_cast<double>(options.photonsPerPass());
    out.variancePerBeam = imageSampleVariance(images, filmFrame(options.film)) * perFilm * perFilm;
    return out;
}

}  // namespace flare::renderer
