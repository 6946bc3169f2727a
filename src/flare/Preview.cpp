#include "flare/Preview.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include "flare/Paraxial.h"
#include "flare/SequentialTracer.h"

namespace flare {

namespace {

struct Vertex {
    bool valid = false;
    glm::dvec2 pixel{0.0};  // continuous pixel coordinates in the full image (centres at i + 0.5)
    double throughput = 0.0;
};

// Accumulates irradiance (XYZ) into a crop of the image. Everything here works in continuous pixel
// coordinates; power arrives in W·mm²/m² (irradiance × pupil area) and leaves as W/m².
class Raster {
public:
    Raster(int imageWidth, int imageHeight, double pixelMm, int x0, int y0, int x1, int y1)
        : imageWidth_(imageWidth), imageHeight_(imageHeight), pixelAreaMm2_(pixelMm * pixelMm),
          x0_(x0), y0_(y0), width_(std::max(0, x1 - x0)), height_(std::max(0, y1 - y0)),
          xyz_(static_cast<size_t>(width_) * height_ * 3, 0.0f) {}

    int x0() const { return x0_; }
    int y0() const { return y0_; }
    int width() const { return width_; }
    int height() const { return height_; }
    const std::vector<float>& xyz() const { return xyz_; }

    // Adds power at p, spread bilinearly over the four nearest pixel centres, so that sub-pixel
    // positions are kept and power is conserved.
    void splat(const glm::dvec2& p, const glm::dvec3& power) {
        const double fx = p.x - 0.5, fy = p.y - 0.5;
        const int ix = static_cast<int>(std::floor(fx)), iy = static_cast<int>(std::floor(fy));
        const double tx = fx - ix, ty = fy - iy;
        add(ix, iy, power * ((1 - tx) * (1 - ty)));
        add(ix + 1, iy, power * (tx * (1 - ty)));
        add(ix, iy + 1, power * ((1 - tx) * ty));
        add(ix + 1, iy + 1, power * (tx * ty));
    }

    // Spreads power uniformly over the pixel centres inside the triangle. Small triangles (a few
    // pixels) count their centres exactly, also off the image, so that the share of power that
    // falls off the sensor is dropped rather than piled onto the visible part.
    void triangle(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c, const glm::dvec3& power) {
        const double area = 0.5 * std::abs((b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y));
        const glm::dvec2 lo = glm::min(a, glm::min(b, c)), hi = glm::max(a, glm::max(b, c));
        if (area < 2.0 || hi.x - lo.x < 2.0 || hi.y - lo.y < 2.0) {
            splat((a + b + c) / 3.0, power);
            return;
        }
        const int rowBegin = static_cast<int>(std::ceil(lo.y - 0.5));
        const int rowEnd = static_cast<int>(std::floor(hi.y - 0.5));
        double centres = area;  // large triangles: the centre count equals the area to O(perimeter)
        if (area <= 256.0) {
            centres = 0.0;
            for (int row = rowBegin; row <= rowEnd; ++row) {
                int first = 0, last = -1;
                if (span(a, b, c, row + 0.5, &first, &last)) centres += last - first + 1;
            }
            if (centres == 0.0) {
                splat((a + b + c) / 3.0, power);
                return;
            }
        }
        const glm::dvec3 perCentre = power / centres;
        for (int row = std::max(rowBegin, y0_); row <= std::min(rowEnd, y0_ + height_ - 1); ++row) {
            int first = 0, last = -1;
            if (!span(a, b, c, row + 0.5, &first, &last)) continue;
            for (int column = std::max(first, x0_); column <= std::min(last, x0_ + width_ - 1); ++column)
                add(column, row, perCentre);
        }
    }

private:
    // Pixel columns whose centres lie inside the triangle on the scanline y.
    static bool span(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c, double y, int* first,
                     int* last) {
        double xl = 1e300, xr = -1e300;
        const glm::dvec2* edges[3][2] = {{&a, &b}, {&b, &c}, {&c, &a}};
        for (auto& e : edges) {
            const glm::dvec2 &p = *e[0], &q = *e[1];
            if ((y < p.y) == (y < q.y)) continue;  // the scanline does not cross this edge
            const double x = p.x + (y - p.y) * (q.x - p.x) / (q.y - p.y);
            xl = std::min(xl, x);
            xr = std::max(xr, x);
        }
        if (xl > xr) return false;
        *first = static_cast<int>(std::ceil(xl - 0.5));
        *last = static_cast<int>(std::floor(xr - 0.5));
        return *first <= *last;
    }

    void add(int column, int row, const glm::dvec3& power) {
        if (column < x0_ || row < y0_ || column >= x0_ + width_ || row >= y0_ + height_) return;
        if (column >= imageWidth_ || row >= imageHeight_) return;
        float* p = &xyz_[(static_cast<size_t>(row - y0_) * width_ + (column - x0_)) * 3];
        p[0] += static_cast<float>(power.x / pixelAreaMm2_);
        p[1] += static_cast<float>(power.y / pixelAreaMm2_);
        p[2] += static_cast<float>(power.z / pixelAreaMm2_);
    }

    int imageWidth_, imageHeight_;
    double pixelAreaMm2_;
    int x0_, y0_, width_, height_;
    std::vector<float> xyz_;
};

struct PathRenderer {
    const LensSystem& lens;
    const SpectralIndices& indices;
    const PupilGrid& grid;
    SequentialPath path;
    double pixelMm;
    int edgeRefinement;
    Raster& raster;
    glm::dvec3 weight;  // irradiance × XYZ weight of this wavelength
    long traced = 0;

    Vertex trace(double a, double b) {
        ++traced;
        const TraceResult r = tracePath(lens, indices, grid.ray(a, b), path);
        if (!r.ok()) return {};
        const glm::dvec3& p = r.ray.originMm;
        // Camera orientation: the sensor image rotated by 180°.
        const glm::dvec2 pixel((0.5 * lens.sensor().widthMm - p.x) / pixelMm,
                               (0.5 * lens.sensor().heightMm + p.y) / pixelMm);
        return {true, pixel, r.throughput};
    }

    void emit(const Vertex& p, const Vertex& q, const Vertex& s, double pupilAreaMm2) {
        const double throughput = (p.throughput + q.throughput + s.throughput) / 3.0;
        raster.triangle(p.pixel, q.pixel, s.pixel, weight * (throughput * pupilAreaMm2));
    }

    // Cell [a, a + size] × [b, b + size] with its corners traced; subdivided where corners disagree.
    void cell(double a, double b, double size, const Vertex& v00, const Vertex& v10, const Vertex& v01,
              const Vertex& v11, int depth) {
        const int valid = v00.valid + v10.valid + v01.valid + v11.valid;
        if (valid == 0) return;
        const double half = 0.5 * size * size;
        if (valid < 4 && depth < edgeRefinement) {
            const double h = 0.5 * size;
            const Vertex m0 = trace(a + h, b), m1 = trace(a, b + h), mc = trace(a + h, b + h);
            const Vertex m2 = trace(a + size, b + h), m3 = trace(a + h, b + size);
            cell(a, b, h, v00, m0, m1, mc, depth + 1);
            cell(a + h, b, h, m0, v10, mc, m2, depth + 1);
            cell(a, b + h, h, m1, mc, v01, m3, depth + 1);
            cell(a + h, b + h, h, mc, m2, m3, v11, depth + 1);
            return;
        }
        if (valid == 4) {
            emit(v00, v10, v11, half);
            emit(v00, v11, v01, half);
            return;
        }
        // A cell still cut by an edge at the finest level: each valid corner stands for a quarter
        // of the cell (the trapezoid rule), deposited at the valid corners' mean image. This keeps
        // the edge's power unbiased to first order instead of dropping the partial triangles.
        glm::dvec2 centre(0.0);
        double throughput = 0.0;
        for (const Vertex* v : {&v00, &v10, &v01, &v11}) {
            if (!v->valid) continue;
            centre += v->pixel;
            throughput += v->throughput;
        }
        raster.splat(centre / static_cast<double>(valid), weight * (throughput * 0.25 * size * size));
    }

    void render(double a0, double b0, double cellMm, int cellsA, int cellsB) {
        std::vector<Vertex> previous(cellsA + 1), current(cellsA + 1);
        for (int i = 0; i <= cellsA; ++i) previous[i] = trace(a0 + i * cellMm, b0);
        for (int j = 1; j <= cellsB; ++j) {
            for (int i = 0; i <= cellsA; ++i) current[i] = trace(a0 + i * cellMm, b0 + j * cellMm);
            for (int i = 0; i < cellsA; ++i)
                cell(a0 + i * cellMm, b0 + (j - 1) * cellMm, cellMm, previous[i], previous[i + 1], current[i],
                     current[i + 1], 0);
            std::swap(previous, current);
        }
    }
};

struct Crop {
    int x0, y0, x1, y1;
};

// Pixels the estimate's footprint covers, with room for the shift of other wavelengths.
Crop footprintCrop(const GhostEstimate& e, const LensSystem& lens, double pixelMm, int width, int height) {
    const double halfW = 0.5 * lens.sensor().widthMm, halfH = 0.5 * lens.sensor().heightMm;
    double xl = (halfW - e.footprintMaxMm.x) / pixelMm, xr = (halfW - e.footprintMinMm.x) / pixelMm;
    double yt = (halfH + e.footprintMinMm.y) / pixelMm, yb = (halfH + e.footprintMaxMm.y) / pixelMm;
    const double marginX = 0.15 * (xr - xl) + 0.03 * width + 4.0;
    const double marginY = 0.15 * (yb - yt) + 0.03 * height + 4.0;
    return {std::max(0, static_cast<int>(xl - marginX)), std::max(0, static_cast<int>(yt - marginY)),
            std::min(width, static_cast<int>(xr + marginX) + 1), std::min(height, static_cast<int>(yb + marginY) + 1)};
}

struct Rendered {
    Crop crop{0, 0, 0, 0};
    std::vector<float> xyz;
    long traced = 0;
};

Rendered renderEstimate(const LensSystem& lens, const PreviewLight& light, const GhostReport& report,
                        const GhostEstimate& estimate, double importance, const PreviewOptions& options,
                        double pixelMm, bool fullImage) {
    Rendered out;
    if (estimate.pupil.empty() || estimate.powerFraction == 0.0) return out;
    out.crop = fullImage ? Crop{0, 0, options.widthPx, options.heightPx}
                         : footprintCrop(estimate, lens, pixelMm, options.widthPx, options.heightPx);
    Raster raster(options.widthPx, options.heightPx, pixelMm, out.crop.x0, out.crop.y0, out.crop.x1, out.crop.y1);

    // Grid: the live region grown by one analysis cell (other wavelengths shift it slightly), with
    // cells sized so that their images are a few pixels across.
    const LivePupilRegion& region = estimate.pupil;
    const double a0 = region.aMinMm - region.cellMm, b0 = region.bMinMm - region.cellMm;
    const double spanA = (region.cellsA + 2) * region.cellMm, spanB = (region.cellsB + 2) * region.cellMm;
    const double footprintPx = std::max(estimate.footprintMaxMm.x - estimate.footprintMinMm.x,
                                        estimate.footprintMaxMm.y - estimate.footprintMinMm.y) / pixelMm;
    // Resolution follows size and power: a ghost 100× weaker than the strongest gets a coarser grid
    // and one level less of edge refinement (its edges cannot be seen at the same exposure).
    const int maxCells = importance >= 0.01 ? options.maxCells : std::max(options.minCells, options.maxCells / 2);
    const int cells = std::clamp(static_cast<int>(footprintPx / options.pixelsPerCell), options.minCells, maxCells);
    const int refinement = importance >= 0.01 ? options.edgeRefinement : std::max(1, options.edgeRefinement - 1);
    const double cellMm = std::max(spanA, spanB) / cells;
    const int cellsA = std::max(1, static_cast<int>(std::ceil(spanA / cellMm)));
    const int cellsB = std::max(1, static_cast<int>(std::ceil(spanB / cellMm)));

    SequentialPath path;
    path.reflections = estimate.path.reflections;
    for (const SpectralSample& sample : light.spectrum) {
        const SpectralIndices indices = lens.indicesAt(sample.wavelengthNm);
        PathRenderer renderer{lens, indices, report.grid, path, pixelMm, refinement, raster,
                              light.irradiance * sample.xyzWeight};
        renderer.render(a0, b0, cellMm, cellsA, cellsB);
        out.traced += renderer.traced;
    }
    out.xyz = raster.xyz();
    return out;
}

void addCrop(std::vector<float>& image, int width, const Rendered& r) {
    const int cropWidth = r.crop.x1 - r.crop.x0;
    for (int row = r.crop.y0; row < r.crop.y1; ++row)
        for (int column = r.crop.x0; column < r.crop.x1; ++column) {
            const float* src = &r.xyz[(static_cast<size_t>(row - r.crop.y0) * cropWidth + (column - r.crop.x0)) * 3];
            float* dst = &image[(static_cast<size_t>(row) * width + column) * 3];
            dst[0] += src[0];
            dst[1] += src[1];
            dst[2] += src[2];
        }
}

// An extended source (the sun's disk) images as a disk of radius EFL·tan(α/2): convolve the
// point image with it. Only the direct image is treated so; ghosts are far larger than the blur.
void blurDisk(std::vector<float>& xyz, int width, int height, double radiusPx) {
    if (!(radiusPx >= 0.5) || !std::isfinite(radiusPx)) return;  // point-like, or an afocal lens
    const int r = static_cast<int>(std::ceil(radiusPx));
    std::vector<std::pair<int, int>> offsets;
    for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx)
            if (dx * dx + dy * dy <= radiusPx * radiusPx) offsets.emplace_back(dx, dy);
    std::vector<float> out(xyz.size(), 0.0f);
    const float norm = 1.0f / static_cast<float>(offsets.size());
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            const float* p = &xyz[(static_cast<size_t>(y) * width + x) * 3];
            if (p[0] == 0.0f && p[1] == 0.0f && p[2] == 0.0f) continue;
            for (auto [dx, dy] : offsets) {
                const int tx = x + dx, ty = y + dy;
                if (tx < 0 || ty < 0 || tx >= width || ty >= height) continue;
                float* q = &out[(static_cast<size_t>(ty) * width + tx) * 3];
                q[0] += p[0] * norm;
                q[1] += p[1] * norm;
                q[2] += p[2] * norm;
            }
        }
    xyz.swap(out);
}

}  // namespace

PreviewImage renderPreview(const LensSystem& lens, const PreviewLight& light, const GhostReport& report,
                           const PreviewOptions& options) {
    PreviewImage image;
    image.widthPx = options.widthPx;
    image.heightPx = options.heightPx;
    image.pixelMm = lens.sensor().widthMm / options.widthPx;
    // The picture is the sensor: pixels must be square so that its rows span the sensor's height.
    if (std::abs(image.pixelMm * options.heightPx / lens.sensor().heightMm - 1.0) > 1e-3)
        throw std::invalid_argument("preview: " + std::to_string(options.widthPx) + "×" +
                                    std::to_string(options.heightPx) + " pixels do not match the " +
                                    std::to_string(lens.sensor().widthMm) + "×" +
                                    std::to_string(lens.sensor().heightMm) + " mm sensor with square pixels");
    const size_t size = static_cast<size_t>(options.widthPx) * options.heightPx * 3;

    std::vector<const GhostEstimate*> kept;
    for (const GhostEstimate& g : report.ghosts)
        if (!g.pruned) kept.push_back(&g);

    const double strongest = kept.empty() ? 0.0 : kept.front()->powerFraction;
    std::vector<Rendered> rendered(kept.size() + 1);
    tbb::parallel_for(size_t{0}, kept.size() + 1, [&](size_t i) {
        const GhostEstimate& e = i == kept.size() ? report.direct : *kept[i];
        const double importance = i == kept.size() ? 1.0 : e.powerFraction / strongest;
        rendered[i] = renderEstimate(lens, light, report, e, importance, options, image.pixelMm, false);
    });

    image.direct = {"direct", std::vector<float>(size, 0.0f)};
    addCrop(image.direct.xyz, options.widthPx, rendered.back());
    const double efl = std::abs(analyseParaxial(lens, kLineDNm).eflMm);
    blurDisk(image.direct.xyz, options.widthPx, options.heightPx,
             efl * std::tan(0.5 * light.angularDiameterDeg * std::numbers::pi / 180.0) / image.pixelMm);

    image.ghosts = {"ghost", std::vector<float>(size, 0.0f)};
    for (size_t i = 0; i < kept.size(); ++i) {
        addCrop(image.ghosts.xyz, options.widthPx, rendered[i]);
        image.tracedRays.push_back(rendered[i].traced);
        if (options.perGhostLayers) {
            XyzLayer layer{kept[i]->path.label(), std::vector<float>(size, 0.0f)};
            addCrop(layer.xyz, options.widthPx, rendered[i]);
            image.perGhost.push_back(std::move(layer));
        }
    }
    return image;
}

double layerPowerFraction(const PreviewImage& image, const XyzLayer& layer, const GhostReport& report,
                          double irradiance) {
    double sum = 0.0;
    for (size_t i = 1; i < layer.xyz.size(); i += 3) sum += layer.xyz[i];
    return sum * image.pixelMm * image.pixelMm / (irradiance * report.enteringAreaMm2);
}

}  // namespace flare
