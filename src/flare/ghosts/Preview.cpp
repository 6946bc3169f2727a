#include "flare/ghosts/Preview.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <string>

#include <glm/common.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_group.h>

#include "flare/core/RoundingClones.h"
#include "flare/ghosts/PupilMesh.h"
#include "flare/optics/BundleTracer.h"
#include "flare/optics/Paraxial.h"

namespace flare {

namespace {

constexpr int kBandRows = 32;  // image rows per rasterisation task

// A triangle's image ready to rasterise (or, when small, a point spread bilinearly), in continuous
// pixel coordinates (pixel centres at i + 0.5) of the full image. `value` is irradiance per unit
// spectral weight: per covered pixel centre for a triangle, in all for a point.
struct Primitive {
    float x[3], y[3];  // a triangle's vertices sorted by y (a point: its position in x[0], y[0])
    float slope[3];    // dx/dy of the edges 0→2, 0→1 and 1→2
    float value;
    int rowMin, rowMax;  // the rows it touches
    bool point;
};

// Pixel columns whose centres lie inside the triangle on the scanline y: between the long edge
// (0→2) and the short edge the scanline crosses (0→1 above vertex 1, 1→2 below). The same
// function counts a triangle's centres and fills them, so that its power is spread exactly.
[[gnu::always_inline]] inline bool span(const Primitive& p, double y, int* first, int* last) {
    if (!(y >= p.y[0] && y < p.y[2])) return false;
    const double along = p.x[0] + (y - p.y[0]) * p.slope[0];
    const double across = y < p.y[1] ? p.x[0] + (y - p.y[0]) * p.slope[1] : p.x[1] + (y - p.y[1]) * p.slope[2];
    const double xl = std::min(along, across), xr = std::max(along, across);
    *first = static_cast<int>(std::ceil(xl - 0.5));
    *last = static_cast<int>(std::floor(xr - 0.5));
    return *first <= *last;
}

Primitive point(const glm::dvec2& p, double value) {
    Primitive out{{static_cast<float>(p.x), 0.0f, 0.0f}, {static_cast<float>(p.y), 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f},
                  static_cast<float>(value), 0, 0, true};
    out.rowMin = static_cast<int>(std::floor(p.y - 0.5));
    out.rowMax = out.rowMin + 1;
    return out;
}

// Power (irradiance × pupil area / pixel area, per unit spectral weight) spread uniformly over the
// pixel centres inside the triangle. Small triangles (a few pixels) count their centres exactly,
// also off the image, so that the share of power that falls off the sensor is dropped rather than
// piled onto the visible part; tiny ones become points (bilinear splats, which keep sub-pixel
// positions and conserve power).
FLARE_ROUNDING_CLONES
Primitive triangle(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c, double power) {
    const double area = 0.5 * std::abs((b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y));
    const glm::dvec2 lo = glm::min(a, glm::min(b, c)), hi = glm::max(a, glm::max(b, c));
    if (area < 2.0 || hi.x - lo.x < 2.0 || hi.y - lo.y < 2.0) return point((a + b + c) / 3.0, power);
    glm::dvec2 v[3] = {a, b, c};
    std::sort(v, v + 3, [](const glm::dvec2& p, const glm::dvec2& q) { return p.y < q.y; });
    Primitive out{{static_cast<float>(v[0].x), static_cast<float>(v[1].x), static_cast<float>(v[2].x)},
                  {static_cast<float>(v[0].y), static_cast<float>(v[1].y), static_cast<float>(v[2].y)},
                  {0.0f, 0.0f, 0.0f},
                  0.0f, static_cast<int>(std::ceil(lo.y - 0.5)), static_cast<int>(std::floor(hi.y - 0.5)), false};
    auto slope = [&](int from, int to) {
        const double dy = static_cast<double>(out.y[to]) - out.y[from];
        return dy != 0.0 ? static_cast<float>((static_cast<double>(out.x[to]) - out.x[from]) / dy) : 0.0f;
    };
    out.slope[0] = slope(0, 2);
    out.slope[1] = slope(0, 1);
    out.slope[2] = slope(1, 2);
    double centres = area;  // large triangles: the centre count equals the area to O(perimeter)
    if (area <= 256.0) {
        centres = 0.0;
        for (int row = out.rowMin; row <= out.rowMax; ++row) {
            int first = 0, last = -1;
            if (span(out, row + 0.5, &first, &last)) centres += last - first + 1;
        }
        if (centres == 0.0) return point((a + b + c) / 3.0, power);
    }
    out.value = static_cast<float>(power / centres);
    return out;
}

// One band of rows of an XYZ image, accumulated as differences along each row: a span adds its
// value at its first column and subtracts it after its last, so that it costs the same whatever its
// length (the ghosts of a preview cover much of the frame, wavelength after wavelength). The sums
// run in double, and a count of the spans open at each column restarts them at exactly zero where
// none is, so that no rounding residue leaks past a ghost's edge; where some are still open, a
// residue below zero is clamped (the values are never negative).
class BandAccumulator {
public:
    BandAccumulator(int width, int rows)
        : width_(width), columns_(static_cast<size_t>(rows) * (width + 1)), extent_(static_cast<size_t>(rows), {width, -1}) {}

    // The rows [rowBegin, rowEnd] (no more than the constructor's count) to accumulate next.
    void start(int rowBegin, int rowEnd) {
        rowBegin_ = rowBegin;
        rowEnd_ = rowEnd;
    }
    int rowBegin() const { return rowBegin_; }
    int rowEnd() const { return rowEnd_; }

    // Adds `value` (XYZ) to columns [first, last] of `row`, all within the band and the image.
    void addSpan(int row, int first, int last, const float value[3]) {
        const int r = row - rowBegin_;
        Column* line = &columns_[static_cast<size_t>(r) * (width_ + 1)];
        Column &open = line[first], &close = line[last + 1];
        for (int c = 0; c < 3; ++c) {
            open.difference[c] += value[c];
            close.difference[c] -= value[c];
        }
        ++open.spans;
        --close.spans;
        extent_[r].first = std::min(extent_[r].first, first);
        extent_[r].second = std::max(extent_[r].second, last + 1);
    }

    // Adds the band's sums to the image's rows (nothing where no span was open) and clears the
    // band for the next start().
    void flushInto(std::vector<float>& xyz) {
        for (int row = rowBegin_; row <= rowEnd_; ++row) {
            auto& [from, to] = extent_[row - rowBegin_];
            if (from > to) continue;
            Column* column = &columns_[static_cast<size_t>(row - rowBegin_) * (width_ + 1) + from];
            float* q = &xyz[(static_cast<size_t>(row) * width_ + from) * 3];
            double sum[3] = {0.0, 0.0, 0.0};
            int spans = 0;
            for (int x = from; x <= to; ++x, ++column, q += 3) {
                spans += column->spans;
                if (spans == 0) {
                    sum[0] = sum[1] = sum[2] = 0.0;
                } else {
                    // Every span's value is non-negative, so a negative sum is the rounding of
                    // a larger span that closed here (about 1e-16 of it): zero.
                    for (int c = 0; c < 3; ++c) {
                        sum[c] += column->difference[c];
                        q[c] += static_cast<float>(std::max(sum[c], 0.0));
                    }
                }
                *column = Column{};
            }
            from = width_;
            to = -1;
        }
    }

private:
    // Per column: the XYZ added there minus the XYZ that stops there, and likewise the spans.
    struct alignas(32) Column {
        double difference[3] = {0.0, 0.0, 0.0};
        int spans = 0;
    };
    int width_, rowBegin_ = 0, rowEnd_ = -1;
    std::vector<Column> columns_;              // rows × (width + 1)
    std::vector<std::pair<int, int>> extent_;  // per row, the columns touched (first > last: none)
};

// Adds a primitive's rows within the band to it, times the spectral weight.
[[gnu::always_inline]] inline void rasterise(const Primitive& p, const glm::dvec3& weight, int width, int height,
                                             BandAccumulator& band) {
    auto add = [&](int column, int row, double value) {
        if (column < 0 || row < band.rowBegin() || column >= width || row > band.rowEnd() || row >= height || row < 0)
            return;
        const float v[3] = {static_cast<float>(value * weight.x), static_cast<float>(value * weight.y),
                            static_cast<float>(value * weight.z)};
        band.addSpan(row, column, column, v);
    };
    if (p.point) {
        const double fx = p.x[0] - 0.5, fy = p.y[0] - 0.5;
        const int ix = static_cast<int>(std::floor(fx)), iy = static_cast<int>(std::floor(fy));
        const double tx = fx - ix, ty = fy - iy;
        add(ix, iy, p.value * ((1 - tx) * (1 - ty)));
        add(ix + 1, iy, p.value * (tx * (1 - ty)));
        add(ix, iy + 1, p.value * ((1 - tx) * ty));
        add(ix + 1, iy + 1, p.value * (tx * ty));
        return;
    }
    const float v[3] = {static_cast<float>(p.value * weight.x), static_cast<float>(p.value * weight.y),
                        static_cast<float>(p.value * weight.z)};
    const int top = std::max({p.rowMin, band.rowBegin(), 0}), bottom = std::min({p.rowMax, band.rowEnd(), height - 1});
    for (int row = top; row <= bottom; ++row) {
        int first = 0, last = -1;
        if (!span(p, row + 0.5, &first, &last)) continue;
        first = std::max(first, 0);
        last = std::min(last, width - 1);
        if (first <= last) band.addSpan(row, first, last, v);
    }
}

// One ghost (or the direct image) at one wavelength: its primitives bucketed by the band of their
// first row, so that a band task finds the primitives touching it without scanning all of them.
struct Job {
    const GhostEstimate* estimate = nullptr;
    size_t wavelength = 0;
    double importance = 1.0;
    double cost = 0.0;
    std::vector<Primitive> primitives;
    std::vector<int> bandStart;  // primitives of band b: [bandStart[b], bandStart[b + 1])
    int maxBandSpan = 0;
    long traced = 0;
};

void bucket(Job& job, int height) {
    const int bands = (height + kBandRows - 1) / kBandRows;
    std::erase_if(job.primitives, [&](const Primitive& p) { return p.rowMax < 0 || p.rowMin >= height; });
    auto band = [&](int row) { return std::clamp(row / kBandRows, 0, bands - 1); };
    std::vector<int> counts(bands + 1, 0);
    for (const Primitive& p : job.primitives) {
        ++counts[band(p.rowMin) + 1];
        job.maxBandSpan = std::max(job.maxBandSpan, band(p.rowMax) - band(std::max(p.rowMin, 0)));
    }
    for (int b = 0; b < bands; ++b) counts[b + 1] += counts[b];
    job.bandStart = counts;
    std::vector<Primitive> sorted(job.primitives.size());
    for (const Primitive& p : job.primitives) sorted[counts[band(p.rowMin)]++] = p;  // stable
    job.primitives.swap(sorted);
}

// Adds the job's primitives touching the band's rows to it.
FLARE_ROUNDING_CLONES
void rasteriseBand(const Job& job, const glm::dvec3& weight, int width, int height, BandAccumulator& band) {
    if (job.primitives.empty()) return;
    const int index = band.rowBegin() / kBandRows;
    for (int b = std::max(0, index - job.maxBandSpan); b <= index; ++b)
        for (int k = job.bandStart[b]; k < job.bandStart[b + 1]; ++k) {
            const Primitive& p = job.primitives[k];
            if (p.rowMax >= band.rowBegin()) rasterise(p, weight, width, height, band);
        }
}

// The grid level whose cells, across the region's larger side, number at least `cells`/√2: levels
// go in factors of two, and the nearest level (in ratio) costs up to four times fewer rays than
// the next finer one for a look that differs little.
int levelFor(const PupilLattice& lattice, int cells) {
    if (lattice.empty()) return 0;
    long iMin = 1L << 40, iMax = -1, jMin = 1L << 40, jMax = -1;
    int deepest = 0;
    for (const PupilLattice::Leaf& l : lattice.leaves) deepest = std::max(deepest, l.level);
    for (const PupilLattice::Leaf& l : lattice.leaves) {
        const int shift = deepest - l.level;
        iMin = std::min(iMin, l.i << shift), iMax = std::max(iMax, ((l.i + 1) << shift) - 1);
        jMin = std::min(jMin, l.j << shift), jMax = std::max(jMax, ((l.j + 1) << shift) - 1);
    }
    const double spanMm = static_cast<double>(std::max(iMax - iMin, jMax - jMin) + 1) * lattice.cellMm(deepest);
    int level = 0;
    while (spanMm / lattice.cellMm(level) < cells * std::sqrt(0.5) && level < 16) ++level;
    return level;
}

// Rays a job will trace, for ordering the jobs (largest first balances the threads).
double estimatedRays(const PupilLattice& lattice, int level) {
    double rays = 0.0;
    for (const PupilLattice::Leaf& l : lattice.leaves) rays += std::ldexp(1.0, 2 * std::max(0, level - l.level));
    return rays;
}

void render(Job& job, const LensSystem& lens, const GhostReport& report, const std::vector<SpectralIndices>& indices,
            const std::vector<std::unique_ptr<InterfaceTables>>& tables, const PreviewOptions& options, double pixelMm) {
    const GhostEstimate& e = *job.estimate;
    const BundleTracer tracer(lens, indices[job.wavelength], e.path.reflections, true, tables[job.wavelength].get());
    const double footprintPx =
        std::max(e.footprintMaxMm.x - e.footprintMinMm.x, e.footprintMaxMm.y - e.footprintMinMm.y) / pixelMm;
    // Resolution follows size and power: a ghost 100× weaker than the strongest gets a coarser grid
    // (its edges cannot be seen at the same exposure); its power stays exact to second order.
    const int maxCells = job.importance >= 0.01 ? options.maxCells : std::max(options.minCells, options.maxCells / 2);
    const int cells = std::clamp(static_cast<int>(footprintPx / options.pixelsPerCell), options.minCells, maxCells);
    PupilRemeshOptions remesh;
    remesh.minLevel = levelFor(e.lattice, cells);
    remesh.bisections = options.edgeRefinement;
    remesh.requireOnSensor = true;
    const PupilMesh mesh = remeshLiveRegion(tracer, report.grid, e.lattice, remesh);
    job.traced = mesh.tracedRays;

    // Camera orientation: the sensor image rotated by 180°.
    const double halfW = 0.5 * lens.sensor().widthMm, halfH = 0.5 * lens.sensor().heightMm;
    auto pixel = [&](const glm::dvec2& p) { return glm::dvec2((halfW - p.x) / pixelMm, (halfH + p.y) / pixelMm); };
    const double pixelAreaMm2 = pixelMm * pixelMm;
    job.primitives.reserve(mesh.triangles.size());
    for (const PupilTriangle& t : mesh.triangles)
        job.primitives.push_back(triangle(pixel(t.v[0].sensorMm), pixel(t.v[1].sensorMm), pixel(t.v[2].sensorMm),
                                          t.power() / pixelAreaMm2));
    bucket(job, options.heightPx);
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
    const int width = options.widthPx, height = options.heightPx;
    const size_t size = static_cast<size_t>(width) * height * 3;

    std::vector<const GhostEstimate*> kept;
    for (const GhostEstimate& g : report.ghosts)
        if (!g.pruned) kept.push_back(&g);
    const double strongest = kept.empty() ? 0.0 : kept.front()->powerFraction;

    // The indices of every medium, once per wavelength.
    std::vector<SpectralIndices> indices;
    std::vector<glm::dvec3> weights;  // irradiance × XYZ weight of each wavelength
    for (const SpectralSample& s : light.spectrum) {
        indices.push_back(lens.indicesAt(s.wavelengthNm));
        weights.push_back(light.irradiance * s.xyzWeight);
    }
    const size_t lambdas = indices.size();
    std::vector<std::unique_ptr<InterfaceTables>> tables(lambdas);
    tbb::parallel_for(size_t{0}, lambdas, [&](size_t w) { tables[w] = std::make_unique<InterfaceTables>(lens, indices[w]); });

    // Jobs: (kept ghost or the direct image) × wavelength; jobs[k * lambdas + w], the direct
    // image last. Each traces its own mesh and stores its primitives.
    std::vector<Job> jobs((kept.size() + 1) * lambdas);
    for (size_t k = 0; k <= kept.size(); ++k)
        for (size_t w = 0; w < lambdas; ++w) {
            Job& job = jobs[k * lambdas + w];
            job.estimate = k == kept.size() ? &report.direct : kept[k];
            job.wavelength = w;
            job.importance = k == kept.size() || !(strongest > 0.0) ? 1.0 : job.estimate->powerFraction / strongest;
            const int steps = static_cast<int>(job.estimate->path.reflections.size() + 1) * lens.surfaceCount();
            job.cost = estimatedRays(job.estimate->lattice, 0) * steps;
        }
    // The two images (zeroed pages, milliseconds of page faults each) are allocated alongside the
    // jobs.
    tbb::task_group allocation;
    allocation.run([&] { image.direct = {"direct", std::vector<float>(size, 0.0f)}; });
    allocation.run([&] { image.ghosts = {"ghost", std::vector<float>(size, 0.0f)}; });
    std::vector<size_t> order(jobs.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return jobs[a].cost > jobs[b].cost; });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, order.size(), 1), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t i = range.begin(); i != range.end(); ++i) {
            Job& job = jobs[order[i]];
            if (job.estimate->lattice.empty() || job.estimate->powerFraction == 0.0) continue;
            render(job, lens, report, indices, tables, options, image.pixelMm);
        }
    }, tbb::simple_partitioner());

    // Rasterisation, in bands of rows: each pixel receives its additions in one fixed order
    // (ghost, wavelength, primitive) whatever the number of threads, so the image is the same.
    const int bands = (height + kBandRows - 1) / kBandRows;
    allocation.wait();
    auto startBand = [&](BandAccumulator& rows, int b) { rows.start(b * kBandRows, std::min(height, (b + 1) * kBandRows) - 1); };
    tbb::parallel_for(tbb::blocked_range<int>(0, bands, 1), [&](const tbb::blocked_range<int>& range) {
        BandAccumulator direct(width, kBandRows), ghosts(width, kBandRows);
        for (int b = range.begin(); b != range.end(); ++b) {
            startBand(direct, b);
            startBand(ghosts, b);
            for (size_t w = 0; w < lambdas; ++w)
                rasteriseBand(jobs[kept.size() * lambdas + w], weights[w], width, height, direct);
            for (size_t k = 0; k < kept.size(); ++k)
                for (size_t w = 0; w < lambdas; ++w)
                    rasteriseBand(jobs[k * lambdas + w], weights[w], width, height, ghosts);
            direct.flushInto(image.direct.xyz);
            ghosts.flushInto(image.ghosts.xyz);
        }
    }, tbb::simple_partitioner());
    const double efl = std::abs(analyseParaxial(lens, kLineDNm).eflMm);
    blurDisk(image.direct.xyz, width, height,
             efl * std::tan(0.5 * light.angularDiameterDeg * std::numbers::pi / 180.0) / image.pixelMm);

    for (size_t k = 0; k < kept.size(); ++k) {
        long traced = 0;
        for (size_t w = 0; w < lambdas; ++w) traced += jobs[k * lambdas + w].traced;
        image.tracedRays.push_back(traced);
    }
    if (options.perGhostLayers) {
        image.perGhost.resize(kept.size());
        tbb::parallel_for(tbb::blocked_range<size_t>(0, kept.size(), 1), [&](const tbb::blocked_range<size_t>& range) {
            for (size_t k = range.begin(); k != range.end(); ++k) {
                XyzLayer& layer = image.perGhost[k];
                layer.name = kept[k]->path.label();
                layer.xyz.assign(size, 0.0f);
                BandAccumulator rows(width, kBandRows);
                for (int b = 0; b < bands; ++b) {
                    startBand(rows, b);
                    for (size_t w = 0; w < lambdas; ++w) rasteriseBand(jobs[k * lambdas + w], weights[w], width, height, rows);
                    rows.flushInto(layer.xyz);
                }
            }
        }, tbb::simple_partitioner());
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
