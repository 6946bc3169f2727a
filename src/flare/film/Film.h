// The sensor as a photon-density estimator. Photons that reach the sensor are splatted with a
// reconstruction kernel into layers of accumulated power (CIE XYZ); dividing by the number of
// photons emitted and the pixel area gives irradiance. Three kernels:
//   Fixed        one radius for every photon (≤ 1 px: the bilinear tent, so that power lands
//                exactly where the photon did, split between the four nearest pixel centres);
//   Progressive  the radius shrinks from pass to pass, r_p = r_1 · p^(−(1−α)/2), as in progressive
//                photon mapping: the blur (bias) vanishes while the noise still averages out;
//   Adaptive     a k-nearest-neighbour (balloon) estimate: the radius is chosen so that about k
//                earlier photons of the same layer fall inside it, measured on a coarse count grid
//                of the passes already finished, so sparse regions (scatter, higher orders) get
//                wide kernels and dense ones sharp kernels. From kWideKernelPx on, the kernel is
//                the separable tent (1 − |dx|/m)(1 − |dy|/m)/m², m the radius rounded, about the
//                pixel centre nearest the photon (the same spread, r²/6 per axis, as the radial
//                Epanechnikov kernel of radius r): it is added in constant time as nine second
//                differences into a buffer that endPass integrates (two running sums per axis),
//                where a radial kernel costs its area, r² px, per photon.
// Kernels are normalised over the pixel centres they cover (off-image centres included), so a
// photon's power is conserved exactly on the plane and only the part falling off the image is
// lost. Memory does not depend on the photon count: layers are tiled, and a tile exists only once
// a photon has touched it. Work is organised in passes (a fixed number of photons); the spread of
// the per-pass images gives a per-pixel variance estimate, kept for the total of the splats made
// "in the total" (group 0) and for any further groups of layers (addVarianceGroup), e.g. the flare
// without the direct image, so that a render can estimate its own error.
//
// A pass may be accumulated in parallel by bands of kBandRows rows: the band variants of the
// adding functions write only their band's rows, whose tiles no other band shares, so threads
// working on different bands never touch the same memory, and each band receives its additions
// in the order its caller gives them (the image does not depend on the number of threads).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <mutex>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace flare {

// A window of a layer's image: the pixels [x, x + width) × [y, y + height) of the frame, interleaved
// CIE XYZ, row-major from the window's top row. Empty (width = height = 0) for a layer no light
// reached.
struct FilmWindow {
    int x = 0, y = 0, width = 0, height = 0;
    std::vector<float> xyz;
    bool empty() const { return width == 0 || height == 0; }
};

struct FilmSettings {
    enum class Kernel { Fixed, Progressive, Adaptive };
    int widthPx = 0, heightPx = 0;
    double widthMm = 0.0, heightMm = 0.0;  // the sensor; pixels must be square
    Kernel kernel = Kernel::Fixed;
    double radiusPx = 1.0;           // Fixed: the radius; Progressive: the first pass's radius
    double progressiveAlpha = 2.0 / 3.0;
    int neighbours = 24;             // Adaptive: photons expected inside the kernel
    double maxRadiusPx = 32.0;       // Adaptive: upper bound (and the radius before any count)
};

class Film {
public:
    static constexpr int kBandRows = 32;  // the tile size: a band of rows owns its tiles
    static constexpr double kWideKernelPx = 12.0;  // adaptive radii from here on: the tent, in O(1)

    // `layerCount` layers, each accumulating XYZ power. Throws std::invalid_argument for a
    // malformed setting (non-square pixels, non-positive sizes).
    Film(const FilmSettings& settings, int layerCount);
    ~Film();
    Film(Film&&) noexcept;
    Film& operator=(Film&&) noexcept;

    const FilmSettings& settings() const { return settings_; }
    int layerCount() const { return static_cast<int>(layers_.size()); }
    double pixelMm() const { return pixelMm_; }
    int passes() const { return passes_; }
    int bandCount() const { return (settings_.heightPx + kBandRows - 1) / kBandRows; }

    // A layer's own kernel, replacing the settings' for that layer (e.g. an adaptive kernel for a
    // smooth, sparse layer beside sharp fixed-kernel ones): kernel, neighbours and maxRadiusPx as
    // in FilmSettings. Must be called before the first pass. `byPower` (adaptive only): the
    // kernel holds about `neighbours` times the photon's own power of the earlier photons, not
    // that many photons: where photons of very different weights meet (light ones connected to
    // the sensor beside rare heavy ones), a heavy photon is spread wider and a light one less, so
    // that each adds noise in proportion to its power; with equal weights it is the count rule.
    // The number held also grows as passes^(2/3) (the k-nearest-neighbour optimum, k ∝ N^(2/3)
    // in two dimensions, with the pass count for N): noise and blur both fall as passes^(−1/3).
    void setLayerKernel(int layer, FilmSettings::Kernel kernel, int neighbours, double maxRadiusPx,
                        bool byPower = false);
    FilmSettings::Kernel layerKernel(int layer) const { return layerKernels_[layer].kernel; }

    // Accumulates `layer` in single precision (before the first pass): half the memory of the
    // double sums, for layers that are only read out (per-ghost layers: hundreds of them for a
    // zoom lens, most of the film's memory). Each addition rounds the pixel's sum to float, a
    // relative 2⁻²⁴: after n additions the sum is within about n × 2⁻²⁴ of the double sum (√n
    // for rounding errors of random sign), far below the half precision such layers are written
    // at. Its splats still count towards the total and its groups in double.
    void setLayerSinglePrecision(int layer);
    bool layerSinglePrecision(int layer) const { return singleLayers_[layer] != nullptr; }
    // Frees a layer's pixels: it reads as zero afterwards (a preview takes each per-ghost layer's
    // footprint in turn and frees it, holding one copy of it at a time).
    void clearLayer(int layer);

    // A further variance group: the sum of `layers` (whatever the splats' inTotal). Returns its
    // index (1, 2, ...; group 0 is the total). Must be called before the first pass.
    int addVarianceGroup(const std::vector<int>& layers);
    int varianceGroupCount() const;

    // How the variance is estimated (before the first pass): 0, from the spread of the passes,
    // which must then be independent; K ≥ 2, from the spread of K interleaved replicates (pass p
    // belongs to replicate p mod K; core/Replicates.h), for passes that are correlated within a
    // replicate and independent across them (the beams' continued Sobol' sequences).
    void setReplicates(int replicates);
    int replicates() const { return replicates_; }

    // Adds `xyzPowerW` (W, CIE XYZ) arriving at `sensorMm` (lens space) to a layer. When
    // `inTotal`, the power also counts towards the variance of the total image.
    void splat(int layer, const glm::dvec2& sensorMm, const glm::dvec3& xyzPowerW, bool inTotal = true);
    // The part of that splat that falls in band `band`'s rows. The caller gives the photon to
    // every band within bandReachPx of its row (a kernel near a band's edge reaches two); the
    // adaptive kernel's photon count goes to the band of the photon's row.
    void splatInBand(int band, int layer, const glm::dvec2& sensorMm, const glm::dvec3& xyzPowerW, bool inTotal = true);
    // Adds a band of pixel values (W per pixel, XYZ): `rows` holds kBandRows rows (fewer in the
    // last band) of width × 3 doubles from the band's first row. Zeros are skipped.
    void addBand(int band, int layer, const double* rows, bool inTotal = true);
    // The same over the columns [xBegin, xEnd) alone (`rows` still full rows, of width × 3).
    void addBandColumns(int band, int layer, const double* rows, bool inTotal, int xBegin, int xEnd);
    // Adds values to the pixels [xBegin, xEnd) of row y (3 per pixel): what addBand adds to them
    // (a tile's run of zeros is skipped). Rows of different bands may be added in parallel.
    void addRowPart(int layer, int y, int xBegin, int xEnd, const double* values, bool inTotal = true) {
        addRow(layer, inTotal, y, xBegin, xEnd, values);
    }
    // Ends a pass of `photons` photons (wide kernels' splats reach the layers here) (the divisor of this pass's image in the variance estimate;
    // every pass of a render must have the same count for the variance to be meaningful).
    void endPass(std::int64_t photons);
    // endPass in three steps, for a pass whose bands are complete at different times (a distributed
    // render's rank 0 ends its own bands while the others' images are on their way,
    // RenderDistributed.cpp): beginEndPass once every splat of the pass is made (the wide kernels
    // are integrated down whole columns, and what counts as zero in them follows their largest
    // value anywhere); endPassInBand for every band once it has all its other additions (bands in
    // any order, in parallel: a band's tiles are its own); then finishEndPass. endPass is these
    // three: the film is bitwise the same.
    void beginEndPass();
    void endPassInBand(int band, std::int64_t photons);
    void finishEndPass();

    // Irradiance of a layer, W/m² in XYZ, interleaved, row-major from the top row, after
    // `photonsEmitted` photons in all: accumulated power / (photons · pixel area).
    std::vector<float> irradianceXyz(int layer, double photonsEmitted) const;
    // The same over the layer's footprint: the bounding box of its pixels whose irradiance (as a
    // float) is not zero in every channel; every pixel outside it is zero in irradianceXyz. Its
    // memory and time follow the tiles light reached, not the frame (per-ghost layers).
    FilmWindow irradianceXyzFootprint(int layer, double photonsEmitted) const;
    // The bytes holding a layer's accumulated power: its tiles, allocated where light reached.
    std::size_t layerBytes(int layer) const;
    // The pixels of those tiles (what reading the layer out over its footprint walks).
    std::size_t layerTilePixels(int layer) const;
    // Per-pixel variance of a variance group's irradiance estimate (group 0: the total image;
    // linear Rec.709 RGB, (W/m²)²), from the spread between passes (or replicates). Empty before
    // two passes (before every replicate has one).
    std::vector<float> varianceRgb(int group = 0) const;
    // Whether there is a variance estimate yet: two passes, or a pass in every replicate.
    bool hasVariance() const;
    // The group's estimated relative L2 error: sqrt(Σ variance) / ‖mean image‖ over every pixel
    // and RGB channel, the quantity `flare compare` measures against a reference; with the sum
    // of variances and the squared norm (both in (W/m²)²). Zero while varianceRgb is empty.
    struct ErrorEstimate {
        double sumVariance = 0.0, squaredNorm = 0.0;
        double relative() const { return squaredNorm > 0.0 ? std::sqrt(sumVariance / squaredNorm) : 0.0; }
    };
    ErrorEstimate errorEstimate(int group) const;
    // Groups whose estimate is made as a pass ends, band by band (endPassInBand: each tile's part
    // while the tile is at hand; finishEndPass adds them in tile order), for a caller that asks for
    // it after every pass and has a band's end of the pass to spare (a distributed render's rank
    // 0, waiting for the others' bands): bitwise what errorEstimate makes when asked. The others
    // are made when asked. Replaces the last call's groups; throws std::invalid_argument for a
    // group that does not exist.
    void estimateAtPassEnd(const std::vector<int>& groups);
    // The measure of a photon's power that a kernel by power holds: X + Y + Z, so that a blue
    // or red photon (small Y) is not spread less than a green one of the same energy.
    static double kernelPower(const glm::dvec3& xyzPowerW) { return std::max(xyzPowerW.x + xyzPowerW.y + xyzPowerW.z, 0.0); }
    // Kernel radius (px) a photon of kernelPower `power` landing now at `sensorMm` in `layer`
    // would get (the power matters only to a kernel by power).
    double radiusPx(int layer, const glm::dvec2& sensorMm, double power = 0.0) const;
    // How far (px) from its row that photon's splat writes rows: beyond the radius by the pixel
    // a kernel's centre may be off and the rounding of a wide kernel's half-width.
    double bandReachPx(int layer, const glm::dvec2& sensorMm, double power) const {
        return radiusPx(layer, sensorMm, power) + 2.0;
    }

    // Continuous pixel coordinates (centres at i + 0.5) of a sensor point, as a camera shows the
    // picture: the sensor image turned by 180°.
    glm::dvec2 toPixel(const glm::dvec2& sensorMm) const;

    // Checkpoints: the whole accumulated state in binary (host byte order, checked on load).
    void save(std::ostream& out) const;
    // Throws std::runtime_error if the stream does not hold a film of the same settings and layers.
    void load(std::istream& in);

private:
    struct Tiles;
    struct SingleTiles;
    struct Group;
    struct WideSplats;
    // Adds the kernel's weights × value for the pixels of rows [rowBegin, rowEnd) to `layer` and
    // its groups (the total if inTotal).
    void addKernel(int layer, bool inTotal, const glm::dvec2& pixel, double radius, const glm::dvec3& value,
                   int rowBegin, int rowEnd);
    void addPixel(int layer, bool inTotal, int x, int y, const double* value);
    // addPixel for the pixels [xBegin, xEnd) of row y with non-zero values (3 per pixel).
    void addRow(int layer, bool inTotal, int y, int xBegin, int xEnd, const double* values);
    void splatRows(int layer, const glm::dvec2& sensorMm, const glm::dvec3& xyzPowerW, bool inTotal, int rowBegin,
                   int rowEnd, bool count);

    struct LayerKernel {
        FilmSettings::Kernel kernel = FilmSettings::Kernel::Fixed;
        int neighbours = 0;
        double maxRadiusPx = 0.0;
        bool byPower = false;
    };
    void allocateCounts();
    // The tent of half-width m about pixel centre (cx, cy), as its nine second differences, the
    // part of them in rows [rowBegin, rowEnd) (the first band also takes the rows above the
    // image, the last those below).
    void addWideKernel(int layer, bool inTotal, int cx, int cy, int m, const glm::dvec3& value, int rowBegin,
                       int rowEnd);
    // beginEndPass: the wide kernels' second differences integrated (not yet added to the layers);
    // endPassInBand: their rows of one band added.
    void integrateWideSplats();
    void addWideSplatsInBand(int band);
    // irradianceXyzFootprint of one layer's tiles (double or float), `scale` from power to irradiance.
    template <class Store>
    FilmWindow footprint(const Store& tiles, double scale) const;
    // A tile's running sums in `group` (null where that sum has no tile); false if none has.
    bool tileSums(const Group& group, size_t tile, const double** sums) const;
    double varianceOfMean(const double* const* sums, int i, int passes) const;
    // A tile's part of a group's errorEstimate after `passes` passes (zero where it has no sums).
    ErrorEstimate tileEstimate(const Group& group, size_t tile, int passes) const;

    FilmSettings settings_;
    std::vector<LayerKernel> layerKernels_;
    double pixelMm_ = 0.0;
    int passes_ = 0;
    int replicates_ = 0;
    double neighbourGrowth_ = 1.0;  // max(passes, 1)^(2/3): kernels by power hold that many times more
    std::vector<std::unique_ptr<Tiles>> layers_;  // null for a single-precision layer
    std::vector<std::unique_ptr<SingleTiles>> singleLayers_;  // per layer: its float tiles, or null
    std::vector<Group> groups_;                 // 0: the total
    std::vector<std::vector<int>> layerGroups_; // per layer: the groups ≥ 1 it belongs to
    // Adaptive kernel: photon counts per layer on a grid of kCountBlock² pixel blocks.
    std::vector<std::vector<std::uint32_t>> counts_, pendingCounts_;
    std::vector<std::vector<double>> powers_, pendingPowers_;  // Y power per block (kernels by power)
    int countW_ = 0, countH_ = 0;
    // errorEstimate's last answer per group, valid while `passes` equals passes_.
    struct CachedEstimate {
        int passes = -1;
        ErrorEstimate estimate;
    };
    mutable std::vector<CachedEstimate> estimates_;
    std::vector<std::vector<ErrorEstimate>> passEndEstimates_;  // per group: per tile, or empty (estimateAtPassEnd)
    std::unique_ptr<std::mutex> estimateMutex_ = std::make_unique<std::mutex>();  // (movable)
    // Per layer and inTotal (0, 1): the wide kernels' second differences of the running pass,
    // allocated by the first wide splat (under wideMutex_: bands run in parallel).
    std::vector<std::unique_ptr<WideSplats>> wide_;
    std::unique_ptr<std::mutex> wideMutex_ = std::make_unique<std::mutex>();
};

}  // namespace flare
