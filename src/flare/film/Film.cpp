#include "flare/film/Film.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <istream>
#include <mutex>
#include <numbers>
#include <ostream>
#include <stdexcept>
#include <type_traits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "flare/core/Replicates.h"
#include "flare/core/Spectrum.h"
#include "flare/film/FilmStores.h"

namespace flare {

namespace {

using film::kTilePx;
using film::readRaw;
using film::writeRaw;
constexpr int kCountBlockPx = 8;
constexpr double kMm2PerM2 = 1e6;

}  // namespace

// Second differences of the running pass's wide kernels over the image padded by `pad` px on every
// side (the parts of a kernel off the image still shape the sums on it), dense, XYZ. Each band
// keeps the box of the entries it wrote, so endPass integrates only that box.
struct Film::WideSplats {
    int pad, width, height;  // padded size
    std::vector<double> deltas;
    struct Box {
        int x0 = INT32_MAX, y0 = INT32_MAX, x1 = -1, y1 = -1;  // inclusive, padded coordinates
    };
    std::vector<Box> boxes;  // per band
    // Between beginEndPass and finishEndPass: the box integrated (empty: none) and the floor
    // below which its values are rounding (integrateWideSplats).
    Box integrated;
    double floor = 0.0;

    WideSplats(int imageWidth, int imageHeight, int padPx, int bands)
        : pad(padPx), width(imageWidth + 2 * padPx), height(imageHeight + 2 * padPx),
          deltas(static_cast<size_t>(width) * height * 3, 0.0), boxes(bands) {}
    double* at(int x, int y) { return &deltas[(static_cast<size_t>(y) * width + x) * 3]; }
};

Film::Film(const FilmSettings& settings, int layerCount) : settings_(settings) {
    if (settings.widthPx <= 0 || settings.heightPx <= 0 || !(settings.widthMm > 0.0) || !(settings.heightMm > 0.0))
        throw std::invalid_argument("Film: sizes must be positive");
    pixelMm_ = settings.widthMm / settings.widthPx;
    if (std::abs(settings.heightMm / settings.heightPx - pixelMm_) > 1e-3 * pixelMm_)
        throw std::invalid_argument("Film: pixels must be square");
    if (!(settings.radiusPx > 0.0) || settings.neighbours < 1 || !(settings.maxRadiusPx >= 1.0) ||
        !(settings.progressiveAlpha > 0.0 && settings.progressiveAlpha < 1.0))
        throw std::invalid_argument("Film: invalid kernel settings");
    for (int l = 0; l < layerCount; ++l) layers_.push_back(std::make_unique<Tiles>(settings.widthPx, settings.heightPx));
    singleLayers_.resize(static_cast<size_t>(layerCount));
    layerKernels_.assign(layerCount, {settings.kernel, settings.neighbours, settings.maxRadiusPx});
    layerGroups_.assign(layerCount, {});
    groups_.emplace_back(settings.widthPx, settings.heightPx, replicates_);
    if (settings.kernel == FilmSettings::Kernel::Adaptive) allocateCounts();
}

void Film::allocateCounts() {
    if (!counts_.empty()) return;
    countW_ = (settings_.widthPx + kCountBlockPx - 1) / kCountBlockPx;
    countH_ = (settings_.heightPx + kCountBlockPx - 1) / kCountBlockPx;
    counts_.assign(layers_.size(), std::vector<std::uint32_t>(static_cast<size_t>(countW_) * countH_, 0));
    pendingCounts_ = counts_;
    powers_.assign(layers_.size(), std::vector<double>(static_cast<size_t>(countW_) * countH_, 0.0));
    pendingPowers_ = powers_;
}

void Film::setLayerKernel(int layer, FilmSettings::Kernel kernel, int neighbours, double maxRadiusPx, bool byPower) {
    if (passes_ > 0) throw std::logic_error("Film::setLayerKernel after the first pass");
    if (layer < 0 || layer >= layerCount()) throw std::invalid_argument("Film::setLayerKernel: no layer " + std::to_string(layer));
    if (neighbours < 1 || !(maxRadiusPx >= 1.0)) throw std::invalid_argument("Film::setLayerKernel: invalid kernel settings");
    layerKernels_[layer] = {kernel, neighbours, maxRadiusPx, byPower && kernel == FilmSettings::Kernel::Adaptive};
    if (kernel == FilmSettings::Kernel::Adaptive) allocateCounts();
}

void Film::setLayerSinglePrecision(int layer) {
    if (passes_ > 0) throw std::logic_error("Film::setLayerSinglePrecision after the first pass");
    if (layer < 0 || layer >= layerCount()) throw std::invalid_argument("Film::setLayerSinglePrecision: no layer " + std::to_string(layer));
    if (singleLayers_[layer]) return;
    singleLayers_[layer] = std::make_unique<SingleTiles>(settings_.widthPx, settings_.heightPx);
    layers_[layer].reset();
}

void Film::clearLayer(int layer) {
    if (singleLayers_[layer]) singleLayers_[layer]->clear();
    else layers_[layer]->clear();
}

Film::~Film() = default;

int Film::varianceGroupCount() const { return static_cast<int>(groups_.size()); }

int Film::addVarianceGroup(const std::vector<int>& layers) {
    if (passes_ > 0) throw std::logic_error("Film::addVarianceGroup after the first pass");
    const int group = static_cast<int>(groups_.size());
    groups_.emplace_back(settings_.widthPx, settings_.heightPx, replicates_);
    for (int l : layers) {
        if (l < 0 || l >= layerCount()) throw std::invalid_argument("Film::addVarianceGroup: no layer " + std::to_string(l));
        layerGroups_[l].push_back(group);
    }
    return group;
}
void Film::setReplicates(int replicates) {
    if (passes_ > 0) throw std::logic_error("Film::setReplicates after the first pass");
    if (replicates != 0 && (replicates < 2 || replicates > kMaxReplicates))
        throw std::invalid_argument("Film::setReplicates: 0 (independent passes) or 2 to " +
                                    std::to_string(kMaxReplicates) + " replicates");
    replicates_ = replicates;
    for (Group& group : groups_) group = Group(settings_.widthPx, settings_.heightPx, replicates_);
}

Film::Film(Film&&) noexcept = default;
Film& Film::operator=(Film&&) noexcept = default;

glm::dvec2 Film::toPixel(const glm::dvec2& sensorMm) const {
    return {(0.5 * settings_.widthMm - sensorMm.x) / pixelMm_, (0.5 * settings_.heightMm + sensorMm.y) / pixelMm_};
}

double Film::radiusPx(int layer, const glm::dvec2& sensorMm, double power) const {
    const LayerKernel& k = layerKernels_[layer];
    switch (k.kernel) {
        case FilmSettings::Kernel::Fixed: return settings_.radiusPx;
        case FilmSettings::Kernel::Progressive:
            return settings_.radiusPx * std::pow(static_cast<double>(passes_ + 1), -0.5 * (1.0 - settings_.progressiveAlpha));
        case FilmSettings::Kernel::Adaptive: {
            const glm::dvec2 pixel = toPixel(sensorMm);
            const int bx = std::clamp(static_cast<int>(pixel.x) / kCountBlockPx, 0, countW_ - 1);
            const int by = std::clamp(static_cast<int>(pixel.y) / kCountBlockPx, 0, countH_ - 1);
            const size_t block = static_cast<size_t>(by) * countW_ + bx;
            // (k photons, or k times this photon's power, expected within π r² at the block's
            // density per px² of the part of the block that lies on the image: blocks at the right
            // and bottom may be cut.)
            const double amount = k.byPower ? powers_[layer][block] : counts_[layer][block];
            if (!(amount > 0.0)) return k.maxRadiusPx;
            const int blockW = std::min(kCountBlockPx, settings_.widthPx - bx * kCountBlockPx);
            const int blockH = std::min(kCountBlockPx, settings_.heightPx - by * kCountBlockPx);
            const double density = amount / (blockW * blockH);
            // By power, the neighbours also grow as passes^(2/3) (the k-nearest-neighbour rule's
            // optimum k ∝ N^(4/(d+4)) in two dimensions): noise and blur then both fall as
            // passes^(−1/3), where a fixed k trades every further photon for sharpness alone.
            const double held = k.byPower ? k.neighbours * neighbourGrowth_ * std::max(power, 0.0) : k.neighbours;
            return std::clamp(std::sqrt(held / (std::numbers::pi * density)), 1.0, k.maxRadiusPx);
        }
    }
    return settings_.radiusPx;
}

void Film::addPixel(int layer, bool inTotal, int x, int y, const double* value) {
    if (SingleTiles* single = singleLayers_[layer].get()) {
        float* p = single->at(x, y);
        for (int c = 0; c < 3; ++c) p[c] = static_cast<float>(p[c] + value[c]);  // one rounding per addition
    } else {
        double* p = layers_[layer]->at(x, y);
        for (int c = 0; c < 3; ++c) p[c] += value[c];
    }
    if (inTotal) {
        double* q = groups_[0].pass->at(x, y);
        for (int c = 0; c < 3; ++c) q[c] += value[c];
    }
    for (int g : layerGroups_[layer]) {
        double* q = groups_[g].pass->at(x, y);
        for (int c = 0; c < 3; ++c) q[c] += value[c];
    }
}

void Film::addRow(int layer, bool inTotal, int y, int xBegin, int xEnd, const double* values) {
    // addPixel for each pixel, a tile's run of the row at a time: its rows in the layer and the
    // groups are found once per run, and a run of zeros allocates nothing. (Adding a zero leaves
    // a sum's bits as they are: the sums start at +0 and never become −0.)
    for (int x0 = xBegin; x0 < xEnd;) {
        const int x1 = std::min(xEnd, (x0 / kTilePx + 1) * kTilePx);
        const double* v = values + static_cast<size_t>(x0 - xBegin) * 3;
        const int n = (x1 - x0) * 3;
        bool any = false;
        for (int i = 0; i < n; ++i) any = any || v[i] != 0.0;
        auto addRun = [&](auto& target) {
            auto* p = target.at(x0, y);
            using Value = std::remove_reference_t<decltype(*p)>;
            for (int i = 0; i < n; ++i) p[i] = static_cast<Value>(p[i] + v[i]);  // (float: one rounding per addition)
        };
        if (any) {
            if (SingleTiles* single = singleLayers_[layer].get()) addRun(*single);
            else addRun(*layers_[layer]);
            if (inTotal) addRun(*groups_[0].pass);
            for (int g : layerGroups_[layer]) addRun(*groups_[g].pass);
        }
        x0 = x1;
    }
}

void Film::addKernel(int layer, bool inTotal, const glm::dvec2& pixel, double radius, const glm::dvec3& value,
                     int rowBegin, int rowEnd) {
    const int w = settings_.widthPx;
    rowBegin = std::max(rowBegin, 0);
    rowEnd = std::min(rowEnd, settings_.heightPx);
    if (radius <= 1.0) {
        // Bilinear tent over the four nearest pixel centres: the weights sum to 1 exactly.
        const double fx = pixel.x - 0.5, fy = pixel.y - 0.5;
        const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
        const double tx = fx - x0, ty = fy - y0;
        const double weight[2][2] = {{(1 - tx) * (1 - ty), tx * (1 - ty)}, {(1 - tx) * ty, tx * ty}};
        for (int dy = 0; dy < 2; ++dy)
            for (int dx = 0; dx < 2; ++dx) {
                const int x = x0 + dx, y = y0 + dy;
                if (x < 0 || y < rowBegin || x >= w || y >= rowEnd || weight[dy][dx] == 0.0) continue;
                const double v[3] = {weight[dy][dx] * value[0], weight[dy][dx] * value[1], weight[dy][dx] * value[2]};
                addPixel(layer, inTotal, x, y, v);
            }
        return;
    }
    // Epanechnikov kernel 1 − d²/r², normalised over the centres it covers (also off the image).
    const int xLo = static_cast<int>(std::floor(pixel.x - radius)), xHi = static_cast<int>(std::ceil(pixel.x + radius));
    const int yLo = static_cast<int>(std::floor(pixel.y - radius)), yHi = static_cast<int>(std::ceil(pixel.y + radius));
    const double inverseR2 = 1.0 / (radius * radius);
    double total = 0.0;
    for (int y = yLo; y <= yHi; ++y)
        for (int x = xLo; x <= xHi; ++x) {
            const double dx = x + 0.5 - pixel.x, dy = y + 0.5 - pixel.y;
            total += std::max(0.0, 1.0 - (dx * dx + dy * dy) * inverseR2);
        }
    if (total <= 0.0) return;
    const glm::dvec3 scaled = value / total;
    for (int y = std::max(yLo, rowBegin); y <= std::min(yHi, rowEnd - 1); ++y)
        for (int x = std::max(xLo, 0); x <= std::min(xHi, w - 1); ++x) {
            const double dx = x + 0.5 - pixel.x, dy = y + 0.5 - pixel.y;
            const double weight = 1.0 - (dx * dx + dy * dy) * inverseR2;
            if (weight <= 0.0) continue;
            const double v[3] = {weight * scaled[0], weight * scaled[1], weight * scaled[2]};
            addPixel(layer, inTotal, x, y, v);
        }
}

void Film::splatRows(int layer, const glm::dvec2& sensorMm, const glm::dvec3& xyzPowerW, bool inTotal, int rowBegin,
                     int rowEnd, bool count) {
    const glm::dvec2 pixel = toPixel(sensorMm);
    // Far off the image (by more than any kernel): nothing to add.
    const double reach = std::max(settings_.radiusPx, layerKernels_[layer].maxRadiusPx) + 1.0;
    if (!(pixel.x > -reach && pixel.y > -reach && pixel.x < settings_.widthPx + reach &&
          pixel.y < settings_.heightPx + reach))
        return;
    const double radius = radiusPx(layer, sensorMm, kernelPower(xyzPowerW));
    if (radius >= kWideKernelPx && layerKernels_[layer].kernel == FilmSettings::Kernel::Adaptive)
        addWideKernel(layer, inTotal, static_cast<int>(std::floor(pixel.x)), static_cast<int>(std::floor(pixel.y)),
                      static_cast<int>(std::lround(radius)), xyzPowerW, rowBegin, rowEnd);
    else
        addKernel(layer, inTotal, pixel, radius, xyzPowerW, rowBegin, rowEnd);
    if (count && layerKernels_[layer].kernel == FilmSettings::Kernel::Adaptive) {
        const int bx = static_cast<int>(pixel.x) / kCountBlockPx, by = static_cast<int>(pixel.y) / kCountBlockPx;
        if (pixel.x >= 0 && pixel.y >= 0 && bx < countW_ && by < countH_) {
            ++pendingCounts_[layer][static_cast<size_t>(by) * countW_ + bx];
            pendingPowers_[layer][static_cast<size_t>(by) * countW_ + bx] += kernelPower(xyzPowerW);
        }
    }
}

void Film::addWideKernel(int layer, bool inTotal, int cx, int cy, int m, const glm::dvec3& value, int rowBegin,
                         int rowEnd) {
    const size_t index = static_cast<size_t>(layer) * 2 + (inTotal ? 1 : 0);
    WideSplats* wide = nullptr;
    {
        std::lock_guard<std::mutex> lock(*wideMutex_);
        if (wide_.empty()) wide_.resize(layers_.size() * 2);
        if (!wide_[index]) {
            // Room for the widest kernel about a photon up to one radius off the image (farther
            // ones are not splatted) on every side.
            const int pad = static_cast<int>(std::ceil(layerKernels_[layer].maxRadiusPx)) * 2 + 4;
            wide_[index] = std::make_unique<WideSplats>(settings_.widthPx, settings_.heightPx, pad, bandCount());
        }
        wide = wide_[index].get();
    }
    // The first band also owns the rows above the image, the last those below.
    const int lo = rowBegin <= 0 ? INT_MIN : rowBegin;
    const int hi = rowEnd >= settings_.heightPx ? INT_MAX : rowEnd;
    const int band = std::clamp(rowBegin / kBandRows, 0, bandCount() - 1);
    WideSplats::Box& box = wide->boxes[band];
    const double weights[3] = {1.0, -2.0, 1.0};
    const glm::dvec3 scaled = value / (static_cast<double>(m) * m * m * m);
    for (int j = 0; j < 3; ++j) {
        const int y = cy - m + 1 + j * m;  // image row
        if (y < lo || y >= hi) continue;
        const int py = std::clamp(y + wide->pad, 0, wide->height - 1);
        for (int i = 0; i < 3; ++i) {
            const int px = std::clamp(cx - m + 1 + i * m + wide->pad, 0, wide->width - 1);
            double* d = wide->at(px, py);
            const double w = weights[i] * weights[j];
            for (int c = 0; c < 3; ++c) d[c] += w * scaled[c];
            box.x0 = std::min(box.x0, px), box.x1 = std::max(box.x1, px);
            box.y0 = std::min(box.y0, py), box.y1 = std::max(box.y1, py);
        }
    }
}

void Film::integrateWideSplats() {
    for (size_t index = 0; index < wide_.size(); ++index) {
        WideSplats* wide = wide_[index].get();
        if (!wide) continue;
        WideSplats::Box box;
        for (const WideSplats::Box& b : wide->boxes) {
            box.x0 = std::min(box.x0, b.x0), box.x1 = std::max(box.x1, b.x1);
            box.y0 = std::min(box.y0, b.y0), box.y1 = std::max(box.y1, b.y1);
        }
        std::fill(wide->boxes.begin(), wide->boxes.end(), WideSplats::Box{});
        wide->integrated = box;
        if (box.x1 < 0) continue;
        // Two running sums along each axis turn the second differences into the tents; every tent
        // ends inside the box (its last difference lies on the box's edge at the latest). Rows
        // in parallel, then the columns in parallel strips walked row by row (each strip's sums
        // in its own order: the result does not depend on the threads).
        const int span = (box.x1 - box.x0 + 1) * 3;
        tbb::parallel_for(tbb::blocked_range<int>(box.y0, box.y1 + 1, 16), [&](const tbb::blocked_range<int>& rows) {
            for (int y = rows.begin(); y != rows.end(); ++y) {
                double first[3] = {0, 0, 0}, second[3] = {0, 0, 0};
                double* d = wide->at(box.x0, y);
                for (int i = 0; i < span; i += 3)
                    for (int c = 0; c < 3; ++c) first[c] += d[i + c], second[c] += first[c], d[i + c] = second[c];
            }
        });
        const double largest = tbb::parallel_reduce(
            tbb::blocked_range<int>(0, span, 384), 0.0,
            [&](const tbb::blocked_range<int>& strip, double largestSoFar) {
                // (The largest value per column, so that the loop has no chain from one element to
                // the next and runs in vector lanes; a maximum is exact in any order.)
                std::vector<double> first(strip.size(), 0.0), second(strip.size(), 0.0), peak(strip.size(), 0.0);
                for (int y = box.y0; y <= box.y1; ++y) {
                    double* d = wide->at(box.x0, y) + strip.begin();
                    for (size_t i = 0; i < strip.size(); ++i) {
                        first[i] += d[i], second[i] += first[i], d[i] = second[i];
                        const double magnitude = std::abs(d[i]);
                        peak[i] = peak[i] < magnitude ? magnitude : peak[i];
                    }
                }
                for (const double v : peak) largestSoFar = std::max(largestSoFar, v);
                return largestSoFar;
            },
            [](double a, double b) { return std::max(a, b); });
        // The sums cancel to zero outside the tents only up to rounding: values below 1e-12 of
        // the largest (and any negative one: every tent and value is non-negative) are that.
        wide->floor = 1e-12 * largest;
    }
}

void Film::addWideSplatsInBand(int band) {
    for (size_t index = 0; index < wide_.size(); ++index) {
        WideSplats* wide = wide_[index].get();
        if (!wide || wide->integrated.x1 < 0) continue;
        const WideSplats::Box& box = wide->integrated;
        const int layer = static_cast<int>(index / 2);
        const bool inTotal = index % 2 == 1;
        const int xBegin = std::max(box.x0, wide->pad), xEnd = std::min(box.x1 + 1, wide->pad + settings_.widthPx);
        if (xBegin >= xEnd) continue;  // all off the image: nothing to add
        const int y0 = std::max({box.y0, wide->pad, band * kBandRows + wide->pad});
        const int y1 = std::min({box.y1 + 1, wide->pad + settings_.heightPx, (band + 1) * kBandRows + wide->pad});
        for (int y = y0; y < y1; ++y) {
            // (In place: the buffer is cleared by finishEndPass.)
            double* row = wide->at(xBegin, y);
            for (int i = 0; i < (xEnd - xBegin) * 3; ++i) row[i] = row[i] > wide->floor ? row[i] : 0.0;
            addRow(layer, inTotal, y - wide->pad, xBegin - wide->pad, xEnd - wide->pad, row);
        }
    }
}

void Film::splat(int layer, const glm::dvec2& sensorMm, const glm::dvec3& xyzPowerW, bool inTotal) {
    splatRows(layer, sensorMm, xyzPowerW, inTotal, 0, settings_.heightPx, true);
}

void Film::splatInBand(int band, int layer, const glm::dvec2& sensorMm, const glm::dvec3& xyzPowerW, bool inTotal) {
    // The band that counts the photon is the one holding its count block (bands are whole blocks).
    static_assert(kBandRows % kCountBlockPx == 0 && kBandRows == kTilePx);
    const double row = toPixel(sensorMm).y;
    const bool count = row >= band * kBandRows && row < (band + 1) * kBandRows;
    splatRows(layer, sensorMm, xyzPowerW, inTotal, band * kBandRows, (band + 1) * kBandRows, count);
}

void Film::addBand(int band, int layer, const double* rows, bool inTotal) {
    addBandColumns(band, layer, rows, inTotal, 0, settings_.widthPx);
}

void Film::addBandColumns(int band, int layer, const double* rows, bool inTotal, int xBegin, int xEnd) {
    const int w = settings_.widthPx;
    xBegin = std::max(xBegin, 0);
    xEnd = std::min(xEnd, w);
    if (xBegin >= xEnd) return;
    const int rowBegin = band * kBandRows, rowEnd = std::min(settings_.heightPx, rowBegin + kBandRows);
    for (int y = rowBegin; y < rowEnd; ++y)
        addRow(layer, inTotal, y, xBegin, xEnd, rows + (static_cast<size_t>(y - rowBegin) * w + xBegin) * 3);
}

void Film::endPass(std::int64_t photons) {
    beginEndPass();
    tbb::parallel_for(tbb::blocked_range<int>(0, bandCount(), 1), [&](const tbb::blocked_range<int>& bands) {
        for (int band = bands.begin(); band != bands.end(); ++band) endPassInBand(band, photons);
    });
    finishEndPass();
}

void Film::beginEndPass() { integrateWideSplats(); }

void Film::endPassInBand(int band, std::int64_t photons) {
    // The wide kernels' rows after every other addition to the band, as one pass adds them.
    addWideSplatsInBand(band);
    const double scale = 1.0 / (static_cast<double>(photons) * pixelMm_ * pixelMm_ / kMm2PerM2);
    const glm::dmat3 toRgb = xyzToLinearSrgbMatrix();
    const int target = replicates_ > 0 ? passes_ % replicates_ : 0;
    for (Group& group : groups_) {
        Tiles& pass = *group.pass;
        // Only the tiles this pass reached, each in one go (a tile's pixels are contiguous in it,
        // and in the sums' tile of the same index): the band's row of tiles. A pixel the pass
        // left at zero adds zeros and is skipped. The pass's tiles are zeroed and kept for the
        // next pass's allocations (fresh ones cost page faults every pass).
        const size_t firstTile = static_cast<size_t>(band) * pass.tilesX;
        for (size_t t = firstTile; t != firstTile + static_cast<size_t>(pass.tilesX); ++t) {
            constexpr int kValues = kTilePx * kTilePx * 3;
            double* p = pass.tiles[t].get();
            if (!p) continue;
            if (std::all_of(p, p + kValues, [](double v) { return v == 0.0; })) {
                pass.recycle(t);
                continue;
            }
            auto tileOf = [&](Tiles& sums) {
                auto& tile = sums.tiles[t];
                if (!tile) tile = std::make_unique<double[]>(kValues);  // zeroed
                return tile.get();
            };
            double* s = tileOf(*group.sums[target]);
            double* q = replicates_ > 0 ? nullptr : tileOf(*group.sums[1]);
            // Every pixel, without a test: a pixel at zero converts to +0 in every channel, which
            // leaves the sums' bits as they are (they start at +0 and never become −0).
            auto accumulate = [&](auto withSquares) {
                for (int i = 0; i < kValues; i += 3) {
                    const glm::dvec3 rgb = toRgb * (glm::dvec3(p[i], p[i + 1], p[i + 2]) * scale);
                    for (int c = 0; c < 3; ++c) {
                        s[i + c] += rgb[c];
                        if constexpr (decltype(withSquares)::value) q[i + c] += rgb[c] * rgb[c];
                    }
                }
            };
            if (q) accumulate(std::true_type{});
            else accumulate(std::false_type{});
            std::fill(p, p + kValues, 0.0);
            pass.recycle(t);
        }
    }
    // The estimates wanted after this pass, this band's tiles (estimateAtPassEnd).
    const int passes = passes_ + 1;
    if (!(replicates_ > 0 ? passes >= replicates_ : passes >= 2)) return;  // (no variance yet: hasVariance)
    for (size_t g = 0; g < passEndEstimates_.size(); ++g) {
        std::vector<ErrorEstimate>& perTile = passEndEstimates_[g];
        if (perTile.empty()) continue;
        const size_t tilesX = static_cast<size_t>(groups_[g].sums[0]->tilesX), firstTile = static_cast<size_t>(band) * tilesX;
        for (size_t t = firstTile; t != firstTile + tilesX; ++t) perTile[t] = tileEstimate(groups_[g], t, passes);
    }
}

void Film::finishEndPass() {
    // The wide kernels' buffers cleared for the next pass (over the box they were integrated in).
    for (const auto& wide : wide_) {
        if (!wide || wide->integrated.x1 < 0) continue;
        const WideSplats::Box box = wide->integrated;
        const int span = (box.x1 - box.x0 + 1) * 3;
        tbb::parallel_for(tbb::blocked_range<int>(box.y0, box.y1 + 1, 16), [&](const tbb::blocked_range<int>& rows) {
            for (int y = rows.begin(); y != rows.end(); ++y) std::fill(wide->at(box.x0, y), wide->at(box.x0, y) + span, 0.0);
        });
        wide->integrated = WideSplats::Box{};
    }
    counts_ = pendingCounts_;
    powers_ = pendingPowers_;
    ++passes_;
    neighbourGrowth_ = std::pow(static_cast<double>(passes_), 2.0 / 3.0);
    // The estimates made band by band, their tiles' parts added in tile order as errorEstimate adds them.
    if (!hasVariance()) return;
    std::lock_guard<std::mutex> lock(*estimateMutex_);
    if (estimates_.size() != groups_.size()) estimates_.assign(groups_.size(), {});
    for (size_t g = 0; g < passEndEstimates_.size(); ++g) {
        if (passEndEstimates_[g].empty()) continue;
        ErrorEstimate e;
        for (const ErrorEstimate& t : passEndEstimates_[g]) e.sumVariance += t.sumVariance, e.squaredNorm += t.squaredNorm;
        estimates_[g] = {passes_, e};
    }
}

std::vector<float> Film::irradianceXyz(int layer, double photonsEmitted) const {
    const int w = settings_.widthPx, h = settings_.heightPx;
    std::vector<float> out(static_cast<size_t>(w) * h * 3, 0.0f);
    if (!(photonsEmitted > 0.0)) return out;
    const double scale = 1.0 / (photonsEmitted * pixelMm_ * pixelMm_ / kMm2PerM2);
    auto read = [&](const auto& tiles) {
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                if (const auto* p = tiles.find(x, y))
                    for (int c = 0; c < 3; ++c)
                        out[(static_cast<size_t>(y) * w + x) * 3 + c] = static_cast<float>(p[c] * scale);
    };
    if (singleLayers_[layer]) read(*singleLayers_[layer]);
    else read(*layers_[layer]);
    return out;
}

FilmWindow Film::irradianceXyzFootprint(int layer, double photonsEmitted) const {
    FilmWindow window;
    if (!(photonsEmitted > 0.0)) return window;
    const double scale = 1.0 / (photonsEmitted * pixelMm_ * pixelMm_ / kMm2PerM2);
    if (singleLayers_[layer]) return footprint(*singleLayers_[layer], scale);
    return footprint(*layers_[layer], scale);
}

template <class Store>
FilmWindow Film::footprint(const Store& tiles, double scale) const {
    FilmWindow window;
    auto value = [&](const auto* p, int c) { return static_cast<float>(p[c] * scale); };
    // The bounding box of the non-zero pixels, from the allocated tiles alone.
    int x0 = INT32_MAX, y0 = INT32_MAX, x1 = -1, y1 = -1;  // inclusive
    for (int ty = 0; ty < tiles.tilesY; ++ty)
        for (int tx = 0; tx < tiles.tilesX; ++tx) {
            if (!tiles.tiles[static_cast<size_t>(ty) * tiles.tilesX + tx]) continue;
            const int yEnd = std::min(tiles.height, (ty + 1) * kTilePx), xEnd = std::min(tiles.width, (tx + 1) * kTilePx);
            for (int y = ty * kTilePx; y < yEnd; ++y)
                for (int x = tx * kTilePx; x < xEnd; ++x) {
                    const auto* p = tiles.find(x, y);
                    if (value(p, 0) == 0.0f && value(p, 1) == 0.0f && value(p, 2) == 0.0f) continue;
                    x0 = std::min(x0, x), x1 = std::max(x1, x);
                    y0 = std::min(y0, y), y1 = std::max(y1, y);
                }
        }
    if (x1 < 0) return window;
    window.x = x0, window.y = y0, window.width = x1 - x0 + 1, window.height = y1 - y0 + 1;
    window.xyz.assign(static_cast<size_t>(window.width) * window.height * 3, 0.0f);
    for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x)
            if (const auto* p = tiles.find(x, y))
                for (int c = 0; c < 3; ++c)
                    window.xyz[(static_cast<size_t>(y - y0) * window.width + (x - x0)) * 3 + c] = value(p, c);
    return window;
}

std::size_t Film::layerBytes(int layer) const {
    return singleLayers_[layer] ? singleLayers_[layer]->bytes() : layers_[layer]->bytes();
}

std::size_t Film::layerTilePixels(int layer) const {
    return singleLayers_[layer] ? singleLayers_[layer]->bytes() / (3 * sizeof(float))
                                : layers_[layer]->bytes() / (3 * sizeof(double));
}

bool Film::hasVariance() const { return replicates_ > 0 ? passes_ >= replicates_ : passes_ >= 2; }

bool Film::tileSums(const Group& group, size_t tile, const double** sums) const {
    bool any = false;
    for (size_t k = 0; k < group.sums.size(); ++k) any = (sums[k] = group.sums[k]->tiles[tile].get()) || any;
    return any;
}

// The variance of the mean over passes of values[i] (i a pixel's channel within a tile), where
// sums are the group's running sums of that tile (null where no pass reached it).
double Film::varianceOfMean(const double* const* sums, int i, int passes) const {
    if (replicates_ > 0) return replicateVarianceOfMean(sums, i, replicates_, passes);
    if (!sums[0]) return 0.0;
    // Unbiased sample variance of the pass images, divided by n: the variance of their mean.
    const double n = passes;
    const double mean = sums[0][i] / n;
    return std::max(0.0, (sums[1][i] - n * mean * mean) / (n - 1.0)) / n;
}

std::vector<float> Film::varianceRgb(int group) const {
    if (!hasVariance()) return {};
    const int w = settings_.widthPx, h = settings_.heightPx;
    const Group& g = groups_.at(group);
    std::vector<float> out(static_cast<size_t>(w) * h * 3, 0.0f);
    const double* sums[kMaxReplicates];
    for (size_t t = 0; t < g.sums[0]->tiles.size(); ++t) {
        if (!tileSums(g, t, sums)) continue;
        const int tx = static_cast<int>(t % g.sums[0]->tilesX), ty = static_cast<int>(t / g.sums[0]->tilesX);
        const int x1 = std::min((tx + 1) * kTilePx, w), y1 = std::min((ty + 1) * kTilePx, h);
        for (int y = ty * kTilePx; y < y1; ++y)
            for (int x = tx * kTilePx; x < x1; ++x)
                for (int c = 0; c < 3; ++c) {
                    const int i = ((y - ty * kTilePx) * kTilePx + (x - tx * kTilePx)) * 3 + c;
                    out[(static_cast<size_t>(y) * w + x) * 3 + c] = static_cast<float>(varianceOfMean(sums, i, passes_));
                }
    }
    return out;
}

Film::ErrorEstimate Film::errorEstimate(int group) const {
    if (!hasVariance()) return {};
    const Group& g = groups_.at(group);
    // The render loop asks after every pass (to stop, for the progress bar, for the report): the
    // sums are kept until the next pass changes them (or made as it ends, estimateAtPassEnd).
    std::lock_guard<std::mutex> lock(*estimateMutex_);
    if (estimates_.size() != groups_.size()) estimates_.assign(groups_.size(), {});
    if (estimates_[group].passes == passes_) return estimates_[group].estimate;
    // Tile by tile over the tiles that exist (a pixel no pass reached has no variance), the tiles
    // in parallel and their sums added in tile order (the same answer for any thread count).
    const size_t tiles = g.sums[0]->tiles.size();
    std::vector<ErrorEstimate> perTile(tiles);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, tiles, 8), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t t = range.begin(); t != range.end(); ++t) perTile[t] = tileEstimate(g, t, passes_);
    });
    ErrorEstimate e;
    for (const ErrorEstimate& t : perTile) e.sumVariance += t.sumVariance, e.squaredNorm += t.squaredNorm;
    estimates_[group] = {passes_, e};
    return e;
}

Film::ErrorEstimate Film::tileEstimate(const Group& g, size_t t, int passes) const {
    // With independent passes, sums[0] holds the pass images' sum; with replicates, every sum does.
    ErrorEstimate e;
    const double* sums[kMaxReplicates];
    if (!tileSums(g, t, sums)) return e;
    const double n = passes;
    constexpr int kValues = kTilePx * kTilePx * 3;
    if (replicates_ == 0) {
        // varianceOfMean's formula with its divisions as multiplications (the loop runs over the
        // whole image, dozens of times in a long render), two sums per quantity.
        if (!sums[0]) return e;  // (the squares exist wherever the sums do)
        const double* sum = sums[0];
        const double* squares = sums[1];
        const double inverseN = 1.0 / n, inverseDegrees = 1.0 / (n - 1.0);
        double variance[2] = {0.0, 0.0}, norm[2] = {0.0, 0.0};
        for (int i = 0; i < kValues; ++i) {
            const double mean = sum[i] * inverseN;
            variance[i & 1] += std::max(0.0, (squares[i] - n * mean * mean) * inverseDegrees) * inverseN;
            norm[i & 1] += mean * mean;
        }
        e.sumVariance = variance[0] + variance[1];
        e.squaredNorm = norm[0] + norm[1];
        return e;
    }
    for (int i = 0; i < kValues; ++i) {
        double total = 0.0;
        for (int k = 0; k < replicates_; ++k) total += sums[k] ? sums[k][i] : 0.0;
        const double mean = total / n;
        e.sumVariance += varianceOfMean(sums, i, passes);
        e.squaredNorm += mean * mean;
    }
    return e;
}

void Film::estimateAtPassEnd(const std::vector<int>& groups) {
    passEndEstimates_.assign(groups_.size(), {});
    for (const int group : groups) {
        if (group < 0 || group >= static_cast<int>(groups_.size()))
            throw std::invalid_argument("Film::estimateAtPassEnd: no group " + std::to_string(group));
        passEndEstimates_[static_cast<size_t>(group)].assign(groups_[group].sums[0]->tiles.size(), ErrorEstimate{});
    }
}

}  // namespace flare
