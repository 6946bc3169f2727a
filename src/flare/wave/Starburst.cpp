#include "flare/wave/Starburst.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <tbb/parallel_for.h>

#include "flare/wave/DiffractionPsf.h"
#include "flare/wave/DustGlow.h"
#include "flare/wave/FarFieldRow.h"
#include "flare/wave/KissFft.h"
#include "flare/wave/PsfGroups.h"

namespace flare {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kProfileBinPx = 0.25;  // bins of the far part's transverse profiles

double smoothstep(double t) {
    t = std::clamp(t, 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

// Complex 2-D transforms (kiss_fftnd): Debian's KissFFT 131.1.0 cannot allocate its real
// N-dimensional transform (kiss_fftndr_alloc returns null), and the images here are small.
struct FftPlan {
    int rows = 0, cols = 0;
    KissFft2d forward, inverse;
    FftPlan(int r, int c) : rows(r), cols(c), forward(r, c, false), inverse(r, c, true) {}
};

// Linear convolution of a (2a+1)² image with a (2b+1)² kernel, both zero-padded into the plan's
// grid (large enough that nothing wraps): the (2a+2b+1)² result, row-major.
std::vector<float> convolve(const FftPlan& plan, const std::vector<float>& image, int imageSide,
                            const std::vector<float>& kernel, int kernelSide) {
    const size_t size = static_cast<size_t>(plan.rows) * plan.cols;
    std::vector<kiss_fft_cpx> a(size, kiss_fft_cpx{0.0f, 0.0f}), b(size, kiss_fft_cpx{0.0f, 0.0f});
    std::vector<kiss_fft_cpx> fa(size), fb(size);
    for (int y = 0; y < imageSide; ++y)
        for (int x = 0; x < imageSide; ++x) a[static_cast<size_t>(y) * plan.cols + x].r = image[static_cast<size_t>(y) * imageSide + x];
    for (int y = 0; y < kernelSide; ++y)
        for (int x = 0; x < kernelSide; ++x)
            b[static_cast<size_t>(y) * plan.cols + x].r = kernel[static_cast<size_t>(y) * kernelSide + x];
    plan.forward(a.data(), fa.data());
    plan.forward(b.data(), fb.data());
    const float scale = 1.0f / static_cast<float>(size);
    for (size_t i = 0; i < size; ++i)
        fa[i] = {(fa[i].r * fb[i].r - fa[i].i * fb[i].i) * scale, (fa[i].r * fb[i].i + fa[i].i * fb[i].r) * scale};
    plan.inverse(fa.data(), a.data());
    const int side = imageSide + kernelSide - 1;
    std::vector<float> out(static_cast<size_t>(side) * side);
    for (int y = 0; y < side; ++y)
        for (int x = 0; x < side; ++x)  // float round-off leaves ~1e-7 of the peak, of either sign
            out[static_cast<size_t>(y) * side + x] = std::max(0.0f, a[static_cast<size_t>(y) * plan.cols + x].r);
    return out;
}

// The crop's energy projected across a spike, convolved with the spike's sinc² profile and the
// receiving pixel's width: a density per pixel across the line, on bins of kProfileBinPx, over a
// band reaching kernelExtent beyond the crop. Every crop point's whole sinc² reaches every bin of
// the band (not renormalised: the sinc²'s share beyond the band is the far tail's, pixelTail).
struct TransverseProfile {
    double originPx = 0.0;  // the first bin's centre
    std::vector<double> density;

    std::vector<double> cumulative;  // ∫ density up to each bin's centre

    // Where the density is complete (the box filter leaves the two end bins at each side empty).
    double bandLo() const { return originPx + 2.0 * kProfileBinPx; }
    double bandHi() const { return originPx + (density.size() - 3.0) * kProfileBinPx; }
    double at(double t) const {
        const double x = (t - originPx) / kProfileBinPx;
        if (x <= 0.0 || x >= density.size() - 1.0) return 0.0;
        const size_t i = static_cast<size_t>(x);
        return density[i] + (x - i) * (density[i + 1] - density[i]);
    }
    // ∫_{−∞}^{t} of at().
    double integral(double t) const {
        const double x = (t - originPx) / kProfileBinPx;
        if (x <= 0.0) return 0.0;
        if (x >= density.size() - 1.0) return cumulative.back();
        const size_t i = static_cast<size_t>(x);
        const double u = x - i;
        return cumulative[i] + kProfileBinPx * u * (density[i] + 0.5 * u * (density[i + 1] - density[i]));
    }
    // The mean of at() over the transverse offsets of a fan: the line at distance `along` turned
    // by angles in [from, to] passes at along·φ.
    double fanned(double t, double along, double from, double to) const {
        const double spread = along * (to - from);
        if (std::abs(spread) < kProfileBinPx) return at(t - along * 0.5 * (from + to));
        return (integral(t - along * from) - integral(t - along * to)) / spread;
    }
};

TransverseProfile transverseProfile(const std::vector<glm::dvec2>& pointsPx, const std::vector<double>& energies,
                                    const glm::dvec2& acrossDir, double sincWidthPx) {
    double extent = 0.0;
    for (const glm::dvec2& p : pointsPx) extent = std::max(extent, std::abs(glm::dot(p, acrossDir)));
    const double kernelExtent = std::min(64.0, 40.0 * sincWidthPx) + 1.0;
    const int half = static_cast<int>(std::ceil((extent + kernelExtent + 1.0) / kProfileBinPx)) + 4;
    const int kernelHalf = 2 * half;  // from any crop point to any bin of the band
    std::vector<double> histogram(2 * half + 1, 0.0);
    for (size_t i = 0; i < pointsPx.size(); ++i) {
        const double x = glm::dot(pointsPx[i], acrossDir) / kProfileBinPx + half;
        const size_t b = static_cast<size_t>(x);
        histogram[b] += energies[i] * (1.0 - (x - b));
        histogram[b + 1] += energies[i] * (x - b);
    }
    // sinc² across the spike, integrated over each bin exactly; then the pixel's width (a box of
    // four bins, its ends linearly shared).
    std::vector<double> kernel(2 * kernelHalf + 1);
    for (int j = -kernelHalf; j <= kernelHalf; ++j)
        kernel[j + kernelHalf] = sincSquaredCumulative((j + 0.5) * kProfileBinPx / sincWidthPx) -
                                 sincSquaredCumulative((j - 0.5) * kProfileBinPx / sincWidthPx);
    const double box[5] = {0.125, 0.25, 0.25, 0.25, 0.125};
    const int bins = static_cast<int>(histogram.size());
    std::vector<double> blurred(histogram.size(), 0.0), density(histogram.size(), 0.0);
    for (int i = 0; i < bins; ++i) {
        if (histogram[i] == 0.0) continue;
        for (int j = 0; j < bins; ++j) blurred[j] += histogram[i] * kernel[j - i + kernelHalf];
    }
    for (int i = 2; i + 2 < bins; ++i)
        for (int j = -2; j <= 2; ++j) density[i] += blurred[i + j] * box[j + 2];
    for (double& d : density) d /= kProfileBinPx;
    std::vector<double> cumulative(density.size(), 0.0);
    for (size_t i = 1; i < density.size(); ++i)
        cumulative[i] = cumulative[i - 1] + 0.5 * kProfileBinPx * (density[i - 1] + density[i]);
    return {-half * kProfileBinPx, std::move(density), std::move(cumulative)};
}

// Beyond the band the crop is a point: the share of a unit sinc² of width `widthPx` in the pixel
// whose centre lies t px across the line (its width one pixel, as the box above). Beyond four
// widths sincSquaredCumulative is the fringe average 1 − 1/(2π²z), which gives w/(2π²(t² − ¼)).
double pixelTail(double t, double widthPx) {
    if (std::abs(t) - 0.5 > detail::kAveragedTailWidths * widthPx) return widthPx / (2.0 * kPi * kPi * (t * t - 0.25));
    return sincSquaredCumulative((t + 0.5) / widthPx) - sincSquaredCumulative((t - 0.5) / widthPx);
}
// The mean over the lines of a fan passing at offsets from tA to tB (all on one side, beyond four
// widths) of that averaged tail, without its factor w/(2π²): of 1/(y² − ¼), whose primitive is
// ln|(y − ½)/(y + ½)|; a narrow fan (most of the frame) by the midpoint and its curvature term,
// f'' Δ²/24 (the next term is below 1e-4 of f for Δ < |y|/5).
double fannedTailShape(double tA, double tB) {
    const double spread = std::abs(tB - tA), mid = 0.5 * (tA + tB);
    const double y2 = mid * mid, inverse = 1.0 / (y2 - 0.25);
    if (spread < 0.2 * (std::min(std::abs(tA), std::abs(tB)) - 0.5))
        return inverse + (6.0 * y2 + 0.5) * inverse * inverse * inverse * spread * spread / 24.0;
    return std::log(std::abs((tB - 0.5) * (tA + 0.5) / ((tB + 0.5) * (tA - 0.5)))) / (tB - tA);
}

// A light's far part is its crop convolved with the PSF's rest beyond its near window: the window's
// taper about the crop's centre (0 within half the window, 1 beyond it) times the far field.
struct FarTaper {
    glm::dvec2 centrePx{0.0};
    double startPx = 0.0, widthPx = 1.0;
    double weight = 1.0;  // of the far field evaluated: the light's share of the cluster's energy (Y)
};

// The spike shares FarFieldRow's lanes leave to scalar code (a pixel near a spike's band, or in a
// wide fan), and the halo and the corners, for one far field's rows.
class FarFieldTerms final : public detail::FarRowTerms {
public:
    FarFieldTerms(const DiffractionPsf& psf, const std::vector<std::array<TransverseProfile, 3>>& profiles,
                  const std::vector<detail::FarSpike>& spikes, const glm::dvec3& cropEnergy, const glm::dvec2& cropCentre,
                  double pixelY, bool halo, bool corners)
        : psf_(psf), profiles_(profiles), spikes_(spikes), cropEnergy_(cropEnergy), cropCentre_(cropCentre),
          pixelY_(pixelY), halo_(halo), corners_(corners) {}

    void spikeShare(int x, size_t s, glm::dvec3& value) const override {
        const DiffractionPsf::Spike& spike = psf_.spikes()[s];
        const detail::FarSpike& far = spikes_[s];
        const double dx = x + 0.5 - cropCentre_.x, dy = pixelY_ - cropCentre_.y;
        const double r2 = dx * dx + dy * dy;
        const double inverseR4 = 1.0 / (r2 * r2);
        const double fanWidth = spike.fanToRad - spike.fanFromRad;
        const double along = dx * spike.directionPx.x + dy * spike.directionPx.y;
        const double t = dx * spike.transversePx.x + dy * spike.transversePx.y;
        const double tA = t - along * spike.fanFromRad, tB = t - along * spike.fanToRad;
        const bool beyondBand = std::min(tA, tB) > far.bandHiPx || std::max(tA, tB) < far.bandLoPx;
        const double envelope = along * along * inverseR4;
        // Wholly beyond the band: the averaged tail's mean over a wide fan (closed form); wholly
        // inside it: the profile's; across the band's edge, the fan in pieces of at most 4 px of
        // transverse offset, each from the profile where it lies in the band, else from the point
        // tail.
        if (beyondBand && std::min(std::abs(tA), std::abs(tB)) - 0.5 > detail::kAveragedTailWidths * far.widestPx) {
            value += far.tailScale * (envelope * fannedTailShape(tA, tB));
            return;
        }
        constexpr int kMaxPieces = 16;
        const int pieces = std::clamp(static_cast<int>(std::ceil(std::abs(along * fanWidth) / 4.0)), 1, kMaxPieces);
        const double step = fanWidth / pieces;
        // The pieces' turns and transverse offsets, the same for the three channels.
        double from[kMaxPieces], to[kMaxPieces], centre[kMaxPieces];
        for (int p = 0; p < pieces; ++p) {
            from[p] = spike.fanFromRad + p * step, to[p] = from[p] + step;
            centre[p] = t - along * 0.5 * (from[p] + to[p]);
        }
        for (int c = 0; c < 3; ++c) {
            const TransverseProfile& profile = profiles_[s][c];
            const double bandLo = profile.bandLo(), bandHi = profile.bandHi();
            if (std::min(tA, tB) > bandLo && std::max(tA, tB) < bandHi) {
                value[c] += spike.lineDensity[c] * envelope * profile.fanned(t, along, spike.fanFromRad, spike.fanToRad);
                continue;
            }
            double share = 0.0;
            for (int p = 0; p < pieces;) {
                if (!(centre[p] > bandLo && centre[p] < bandHi)) {
                    share += cropEnergy_[c] * pixelTail(centre[p], spike.transverseWidthPx[c]);
                    ++p;
                    continue;
                }
                // A run of pieces in the band: their means over equal turns add up to the run's
                // mean times their number (the integrals at the pieces' shared ends cancel), two
                // integrals for the run rather than two a piece; the same sum to rounding.
                int end = p + 1;
                while (end < pieces && centre[end] > bandLo && centre[end] < bandHi) ++end;
                share += (end - p) * profile.fanned(t, along, from[p], to[end - 1]);
                p = end;
            }
            value[c] += spike.lineDensity[c] * envelope * share / pieces;
        }
    }

    void haloAndCorners(int x, glm::dvec3& value) const override {
        const glm::dvec2 offset = glm::dvec2(x + 0.5, pixelY_) - cropCentre_;
        if (halo_) value += psf_.smoothPerPixel(offset) * cropEnergy_;
        if (corners_) value += psf_.cornerPerPixel(offset) * cropEnergy_;
    }

private:
    const DiffractionPsf& psf_;
    const std::vector<std::array<TransverseProfile, 3>>& profiles_;
    const std::vector<detail::FarSpike>& spikes_;
    glm::dvec3 cropEnergy_;
    glm::dvec2 cropCentre_;
    double pixelY_;
    bool halo_, corners_;
};

// Adds the far field of the crop whose pixels (`cropPoints`, relative to `cropCentre`) carry
// `cropEnergies` per channel (summing to `cropEnergy`) to `xyz`, times the tapers' weighted sum,
// and each row's Y to `inFrameRows`: the spikes' envelopes times the crop's transverse profiles,
// the spikes' tails, the corners' interference and the halo, over every pixel of the frame.
void addFarField(const DiffractionPsf& psf, const ApertureTransform& aperture, const std::vector<glm::dvec2>& cropPoints,
                 const std::vector<double> (&cropEnergies)[3], const glm::dvec3& cropEnergy, const glm::dvec2& cropCentre,
                 const std::vector<FarTaper>& tapers, int width, int height, std::vector<float>& xyz,
                 std::vector<double>& inFrameRows) {
    const std::vector<DiffractionPsf::Spike>& spikes = psf.spikes();
    std::vector<std::array<TransverseProfile, 3>> profiles(spikes.size());
    for (size_t s = 0; s < spikes.size(); ++s)
        for (int c = 0; c < 3; ++c)
            profiles[s][c] = transverseProfile(cropPoints, cropEnergies[c], spikes[s].transversePx,
                                               spikes[s].transverseWidthPx[c]);
    // Per spike: its line, its fan, the band any channel's profile covers, the widest sinc², and
    // the averaged tail's factor w/(2π²) with the line's density and the crop's energy.
    std::vector<detail::FarSpike> far(spikes.size());
    for (size_t s = 0; s < spikes.size(); ++s) {
        const DiffractionPsf::Spike& spike = spikes[s];
        detail::FarSpike& f = far[s];
        f.directionX = spike.directionPx.x, f.directionY = spike.directionPx.y;
        f.transverseX = spike.transversePx.x, f.transverseY = spike.transversePx.y;
        f.fanFromRad = spike.fanFromRad, f.fanToRad = spike.fanToRad;
        f.bandLoPx = 1e300, f.bandHiPx = -1e300;
        for (int c = 0; c < 3; ++c) {
            f.bandLoPx = std::min(f.bandLoPx, profiles[s][c].bandLo());
            f.bandHiPx = std::max(f.bandHiPx, profiles[s][c].bandHi());
        }
        f.widestPx = std::max({spike.transverseWidthPx.x, spike.transverseWidthPx.y, spike.transverseWidthPx.z});
        f.tailScale = spike.lineDensity * cropEnergy * spike.transverseWidthPx / (2.0 * kPi * kPi);
    }
    std::vector<detail::FarTaperRing> rings;
    for (const FarTaper& t : tapers) rings.push_back({t.centrePx.x, t.centrePx.y, t.startPx, t.widthPx, t.weight});
    // Row by row, every pixel of the frame (FarFieldRow.h: the narrow fans' tails in SIMD lanes,
    // the rest in FarFieldTerms), each pixel's additions in a fixed order: deterministic. The
    // spikes' tails and the corners are what lights the frame between the spikes: they fall as
    // 1/r⁴ and reach every pixel, none is cut off.
    const bool halo = aperture.smoothLengthMm() > 0.0;
    const bool corners = !aperture.corners().empty();
    tbb::parallel_for(0, height, [&](int y) {
        const FarFieldTerms terms(psf, profiles, far, cropEnergy, cropCentre, y + 0.5, halo, corners);
        detail::FarRow row;
        row.pixelY = y + 0.5;
        row.centreX = cropCentre.x, row.centreY = cropCentre.y;
        row.width = width;
        row.spikes = far.data(), row.spikeCount = far.size();
        row.tapers = rings.data(), row.taperCount = rings.size();
        row.terms = &terms;
        row.xyz = xyz.data() + 3 * static_cast<size_t>(y) * width;
        row.rowY = &inFrameRows[y];
        detail::addFarRow(row);
    });
}

}  // namespace

StarburstImage renderStarburst(const LensSystem& lens, const std::vector<float>& directXyz, int width, int height,
                               const std::vector<StarburstLight>& lights, const StarburstOptions& options,
                               const std::vector<StarburstDust>& dust) {
    StarburstImage result;
    result.xyz = directXyz;
    using Clock = std::chrono::steady_clock;
    auto since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
    Clock::time_point stage = Clock::now();
    const size_t pixels = static_cast<size_t>(width) * height;

    PupilOutlineOptions outlineOptions;
    outlineOptions.widthPx = width;
    outlineOptions.heightPx = height;
    // (Each light's outline on its own: traced side by side.)
    std::vector<PupilOutline> outlines(lights.size());
    tbb::parallel_for(size_t{0}, lights.size(), size_t{1},
                      [&](size_t l) { outlines[l] = tracePupilOutline(lens, lights[l].direction, outlineOptions); });
    for (size_t l = 0; l < lights.size(); ++l) {
        StarburstLightReport report;
        report.name = lights[l].name;
        if (!outlines[l].found) report.why = "no ray of the light reaches the sensor";
        result.lights.push_back(report);
    }

    // Each pixel of the direct image belongs to the nearest light's image.
    std::vector<int> owner(pixels, -1);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            const size_t i = static_cast<size_t>(y) * width + x;
            if (directXyz[3 * i] == 0.0f && directXyz[3 * i + 1] == 0.0f && directXyz[3 * i + 2] == 0.0f) continue;
            double best = 1e300;
            for (size_t l = 0; l < lights.size(); ++l) {
                if (!outlines[l].found) continue;
                const double d = glm::length(glm::dvec2(x + 0.5, y + 0.5) - outlines[l].imagePx);
                if (d < best) best = d, owner[i] = static_cast<int>(l);
            }
        }

    // Each light's crop: the square about its image's energy centroid holding cropEnergy of it.
    struct Crop {
        double energyY = 0.0;
        int cx = 0, cy = 0, radius = 0;
    };
    std::vector<Crop> cropOf(lights.size());
    for (size_t l = 0; l < lights.size(); ++l) {
        if (!outlines[l].found) continue;
        Crop& k = cropOf[l];
        glm::dvec2 centroid{0.0};
        for (size_t i = 0; i < pixels; ++i)
            if (owner[i] == static_cast<int>(l)) {
                const double y = directXyz[3 * i + 1];
                centroid += y * glm::dvec2(i % width + 0.5, i / width + 0.5);
                k.energyY += y;
            }
        result.lights[l].directEnergyY = k.energyY;
        if (!(k.energyY > 0.0)) continue;
        centroid /= k.energyY;
        k.cx = static_cast<int>(std::floor(centroid.x)), k.cy = static_cast<int>(std::floor(centroid.y));
        std::vector<double> byRing(options.maxCropRadiusPx + 1, 0.0);
        for (size_t i = 0; i < pixels; ++i)
            if (owner[i] == static_cast<int>(l)) {
                const int ring = std::max(std::abs(static_cast<int>(i % width) - k.cx), std::abs(static_cast<int>(i / width) - k.cy));
                if (ring <= options.maxCropRadiusPx) byRing[ring] += directXyz[3 * i + 1];
            }
        for (double sum = byRing[0]; k.radius < options.maxCropRadiusPx && sum < options.cropEnergy * k.energyY;)
            sum += byRing[++k.radius];
    }

    result.stages.outlines = since(stage);
    stage = Clock::now();
    // The PSFs: one per light, or with psfGroupTolerance one per group of lights whose pupils
    // agree (PsfGroups.h), the founder's, its window evaluated once at the largest its lights need.
    // A degenerate pupil or map (a light at the edge of a fisheye's field) leaves the group's
    // lights undiffracted, with the reason, rather than failing the whole image.
    std::vector<int> groupOf(lights.size()), founders;
    std::vector<double> differenceOf(lights.size(), 0.0);
    if (options.psfGroupTolerance > 0.0) {
        std::vector<PsfShape> shapes(lights.size());
        tbb::parallel_for(size_t{0}, lights.size(), size_t{1},
                          [&](size_t l) { shapes[l] = psfShape(outlines[l], lights[l].spectrum); });
        groupOf = groupByPsf(shapes, options.psfGroupTolerance, &founders);
        for (size_t l = 0; l < lights.size(); ++l)
            if (shapes[l].found) differenceOf[l] = psfShapeDifference(shapes[l], shapes[static_cast<size_t>(founders[groupOf[l]])]);
    } else {
        for (size_t l = 0; l < lights.size(); ++l) groupOf[l] = static_cast<int>(l), founders.push_back(static_cast<int>(l));
    }
    struct GroupPsf {
        std::optional<ApertureTransform> aperture;
        std::optional<DiffractionPsf> psf;
        std::string why;
        int window = 0;
        std::vector<float> kernelXyz;  // the PSF on (2·window + 1)² pixels
    };
    std::vector<GroupPsf> groups(founders.size());
    // Each light's window: several crop radii, and the coherent core's.
    auto windowFor = [&](const DiffractionPsf& psf, int radius) {
        return std::max({options.minWindowPx, static_cast<int>(std::ceil(psf.coherentRadiusPx())) + 4,
                         std::min(options.maxWindowPx, static_cast<int>(std::ceil(options.windowPerCropRadius * radius)))});
    };
    for (size_t g = 0; g < groups.size(); ++g) {
        const size_t f = static_cast<size_t>(founders[g]);
        if (!outlines[f].found) continue;
        GroupPsf& group = groups[g];
        try {
            group.aperture.emplace(outlines[f].outlineMm);
            group.psf.emplace(*group.aperture, lights[f].spectrum, outlines[f].pxPerRad);
        } catch (const std::invalid_argument& e) {
            group.why = std::string("no diffraction PSF: ") + e.what();
            continue;
        }
        for (size_t l = 0; l < lights.size(); ++l)
            if (groupOf[l] == static_cast<int>(g) && outlines[l].found && cropOf[l].energyY > 0.0)
                group.window = std::max(group.window, windowFor(*group.psf, cropOf[l].radius));
        if (group.window > 0) group.kernelXyz = group.psf->window(group.window);
    }

    result.stages.psfs = since(stage);
    // With clusterFarFields, each light's crop for its cluster's far field.
    struct FarSource {
        bool used = false;
        std::vector<glm::dvec2> points;  // pixel centres (absolute)
        std::vector<double> energies[3];
        glm::dvec3 energy{0.0};
        FarTaper taper;
        double nearInFrame = 0.0;        // Y of the near part on the sensor
    };
    std::vector<FarSource> farSources(options.clusterFarFields > 0.0 ? lights.size() : 0);
    for (size_t l = 0; l < lights.size(); ++l) {
        StarburstLightReport& report = result.lights[l];
        if (!outlines[l].found) continue;
        const auto start = std::chrono::steady_clock::now();
        const double energyY = cropOf[l].energyY;
        if (!(energyY > 0.0)) {
            report.why = "its direct image has no energy on the sensor";
            continue;
        }
        GroupPsf& group = groups[static_cast<size_t>(groupOf[l])];
        if (!group.psf) {
            report.why = group.why;
            continue;
        }
        const int cx = cropOf[l].cx, cy = cropOf[l].cy, radius = cropOf[l].radius;
        const int cropSide = 2 * radius + 1;
        std::vector<float> crop[3];
        for (auto& c : crop) c.assign(static_cast<size_t>(cropSide) * cropSide, 0.0f);
        std::vector<glm::dvec2> cropPoints;
        std::vector<double> cropEnergies[3];
        glm::dvec3 cropEnergy{0.0};
        glm::dvec2 cropCentre{0.0};
        for (int y = cy - radius; y <= cy + radius; ++y)
            for (int x = cx - radius; x <= cx + radius; ++x) {
                if (x < 0 || y < 0 || x >= width || y >= height) continue;
                const size_t i = static_cast<size_t>(y) * width + x;
                if (owner[i] != static_cast<int>(l)) continue;
                const size_t j = static_cast<size_t>(y - cy + radius) * cropSide + (x - cx + radius);
                for (int c = 0; c < 3; ++c) {
                    crop[c][j] = directXyz[3 * i + c];
                    cropEnergy[c] += directXyz[3 * i + c];
                    result.xyz[3 * i + c] = 0.0f;
                }
                cropCentre += double(directXyz[3 * i + 1]) * glm::dvec2(x + 0.5, y + 0.5);
                cropPoints.emplace_back(x + 0.5, y + 0.5);
                for (int c = 0; c < 3; ++c) cropEnergies[c].push_back(directXyz[3 * i + c]);
            }
        cropCentre /= cropEnergy.y;
        for (glm::dvec2& p : cropPoints) p -= cropCentre;
        report.cropRadiusPx = radius;
        report.diffractedShare = cropEnergy.y / energyY;

        const ApertureTransform& aperture = *group.aperture;
        const DiffractionPsf& psf = *group.psf;
        const int window = windowFor(psf, radius);
        // The group's window cut to this light's (the same PSF on fewer pixels).
        const int kernelSide = 2 * window + 1;
        std::vector<float> kernelXyz(3 * static_cast<size_t>(kernelSide) * kernelSide);
        for (int y = 0; y < kernelSide; ++y)
            std::copy_n(&group.kernelXyz[3 * ((static_cast<size_t>(y) + group.window - window) * (2 * group.window + 1) +
                                              (group.window - window))],
                        3 * kernelSide, &kernelXyz[3 * static_cast<size_t>(y) * kernelSide]);
        const double taperWidth = 0.5 * window, taperStart = window - taperWidth;
        report.psfLight = founders[static_cast<size_t>(groupOf[l])];
        report.psfDifference = differenceOf[l];
        report.pupilAreaMm2 = aperture.areaMm2();
        report.spikeEdges = static_cast<int>(aperture.spikeEdges().size());
        report.smoothOutlineShare = aperture.smoothLengthMm() / aperture.perimeterMm();
        report.wavelengths = static_cast<int>(psf.spectrum().size());
        report.windowRadiusPx = window;
        report.coherentRadiusPx = psf.coherentRadiusPx();
        report.parsevalError = psf.parsevalError();

        // Near: the tapered window convolved with the crop, the three channels in parallel (each
        // writes its own channel; the row sums are the Y channel's).
        const int outSide = kernelSide + cropSide - 1;
        std::vector<double> inFrameRows(height, 0.0);
        stage = Clock::now();
        // The window's taper, the same for the three channels.
        std::vector<double> nearTaper(static_cast<size_t>(kernelSide) * kernelSide);
        tbb::parallel_for(0, kernelSide, [&](int y) {
            for (int x = 0; x < kernelSide; ++x)
                nearTaper[static_cast<size_t>(y) * kernelSide + x] =
                    1.0 - smoothstep((std::hypot(x - window, y - window) - taperStart) / taperWidth);
        });
        tbb::parallel_for(0, 3, [&](int c) {
            // (A plan per channel: KissFFT's plan holds its scratch buffer.)
            const FftPlan plan(KissFft2d::nextFastSize(outSide), KissFft2d::nextFastSize(outSide));
            std::vector<float> kernel(static_cast<size_t>(kernelSide) * kernelSide);
            for (size_t i = 0; i < kernel.size(); ++i)
                kernel[i] = static_cast<float>(kernelXyz[3 * i + c] * nearTaper[i]);
            const std::vector<float> near = convolve(plan, crop[c], cropSide, kernel, kernelSide);
            for (int y = 0; y < outSide; ++y)
                for (int x = 0; x < outSide; ++x) {
                    const int px = cx - radius - window + x, py = cy - radius - window + y;
                    if (px < 0 || py < 0 || px >= width || py >= height) continue;
                    const float v = near[static_cast<size_t>(y) * outSide + x];
                    result.xyz[3 * (static_cast<size_t>(py) * width + px) + c] += v;
                    if (c == 1) inFrameRows[py] += v;
                }
        });

        result.stages.near += since(stage);
        stage = Clock::now();
        // Far: the spikes' envelopes times the crop's transverse profiles, and the halo; now, or
        // with the light's cluster (clusterFarFields) once every light's near part is in.
        if (options.clusterFarFields > 0.0) {
            FarSource& far = farSources[l];
            far.points = std::move(cropPoints);
            for (glm::dvec2& p : far.points) p += cropCentre;  // (absolute: the cluster centres them again)
            for (int c = 0; c < 3; ++c) far.energies[c] = std::move(cropEnergies[c]);
            far.energy = cropEnergy;
            far.taper = {cropCentre, taperStart, taperWidth, 1.0};
            for (double r : inFrameRows) far.nearInFrame += r;
            far.used = true;
        } else {
            addFarField(psf, aperture, cropPoints, cropEnergies, cropEnergy, cropCentre,
                        {FarTaper{cropCentre, taperStart, taperWidth, 1.0}}, width, height, result.xyz, inFrameRows);
            ++result.farFields;
            double inFrame = 0.0;
            for (double r : inFrameRows) inFrame += r;
            report.outsideFrameShare = std::max(0.0, 1.0 - inFrame / cropEnergy.y);
        }

        // Dust: each dusty surface's glow, from the crop's centre, through the lens behind it.
        for (const StarburstDust& layer : dust) {
            if (!(layer.coverage > 0.0)) continue;
            const SurfaceDeflection deflection = traceSurfaceDeflection(lens, lights[l].direction, layer.surface, outlineOptions);
            if (!deflection.found || std::abs(glm::determinant(deflection.pxPerRad)) == 0.0) continue;
            const DustGlow glow(layer.medianDiameterUm, layer.diameterSigma, lights[l].spectrum, deflection.mediumIndex);
            const glm::dmat2 radPerPx = glm::inverse(deflection.pxPerRad);
            const glm::dvec3 scale = layer.coverage * std::abs(glm::determinant(radPerPx)) * cropEnergy;
            std::vector<double> glowRows(height, 0.0);
            tbb::parallel_for(0, height, [&](int y) {
                for (int x = 0; x < width; ++x) {
                    const double theta = glm::length(radPerPx * (glm::dvec2(x + 0.5, y + 0.5) - cropCentre));
                    const glm::dvec3 value = glow.perSteradian(theta) * scale;
                    const size_t i = static_cast<size_t>(y) * width + x;
                    for (int c = 0; c < 3; ++c) result.xyz[3 * i + c] += static_cast<float>(value[c]);
                    glowRows[y] += value.y;
                }
            });
            double glowInFrame = 0.0;
            for (double r : glowRows) glowInFrame += r;
            ++report.dustSurfaces;
            report.dustGlowShare += layer.coverage;
            report.dustGlowInFrameShare += glowInFrame / cropEnergy.y;
        }
        if (report.dustGlowShare > 0.0) report.dustGlowInFrameShare /= report.dustGlowShare;
        result.stages.far += since(stage);
        report.diffracted = true;
        report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }

    // Clustered far fields: lights that share a PSF and lie close together have, beyond their near
    // windows, nearly the far field of one light whose crop holds all their pixels. A light joins
    // the first cluster of its PSF group whose energy centroid, with it, stays within
    // clusterFarFields × its taper's start (half its window) of every member's crop centre: the
    // envelope (1/r², 1/r⁴ about the centroid rather than about each crop) then moves by at most
    // about 2 × that (4 × for the tails) where a member's far part begins, and far less beyond.
    // Each member keeps its own taper, weighted by its share of the cluster's energy, so the near
    // and far parts still partition every light's PSF.
    if (options.clusterFarFields > 0.0) {
        stage = Clock::now();
        struct Cluster {
            int group = 0;
            std::vector<size_t> members;
            glm::dvec2 centroid{0.0};
            double energyY = 0.0;
        };
        std::vector<Cluster> clusters;
        for (size_t l = 0; l < lights.size(); ++l) {
            const FarSource& f = farSources[l];
            if (!f.used) continue;
            bool joined = false;
            for (Cluster& c : clusters) {
                if (c.group != groupOf[l]) continue;
                const double energyY = c.energyY + f.energy.y;
                const glm::dvec2 centroid = (c.energyY * c.centroid + f.energy.y * f.taper.centrePx) / energyY;
                bool fits = glm::length(f.taper.centrePx - centroid) <= options.clusterFarFields * f.taper.startPx;
                for (size_t m : c.members)
                    fits = fits && glm::length(farSources[m].taper.centrePx - centroid) <=
                                       options.clusterFarFields * farSources[m].taper.startPx;
                if (!fits) continue;
                c.members.push_back(l), c.centroid = centroid, c.energyY = energyY;
                joined = true;
                break;
            }
            if (!joined) clusters.push_back({groupOf[l], {l}, f.taper.centrePx, f.energy.y});
        }
        for (Cluster& c : clusters) {
            const GroupPsf& group = groups[static_cast<size_t>(c.group)];
            std::vector<glm::dvec2> points;
            std::vector<double> energies[3];
            glm::dvec3 energy{0.0};
            std::vector<FarTaper> tapers;
            for (size_t m : c.members) {
                const FarSource& f = farSources[m];
                for (const glm::dvec2& p : f.points) points.push_back(p - c.centroid);
                for (int k = 0; k < 3; ++k) energies[k].insert(energies[k].end(), f.energies[k].begin(), f.energies[k].end());
                energy += f.energy;
                tapers.push_back(f.taper);
                tapers.back().weight = c.members.size() == 1 ? 1.0 : f.energy.y / c.energyY;
            }
            std::vector<double> inFrameRows(height, 0.0);
            addFarField(*group.psf, *group.aperture, points, energies, energy, c.centroid, tapers, width, height, result.xyz,
                        inFrameRows);
            ++result.farFields;
            double farInFrame = 0.0;
            for (double r : inFrameRows) farInFrame += r;
            for (size_t m : c.members) {
                const FarSource& f = farSources[m];
                const double inFrame = f.nearInFrame + farInFrame * f.energy.y / c.energyY;
                result.lights[m].outsideFrameShare = std::max(0.0, 1.0 - inFrame / f.energy.y);
                result.lights[m].farCluster = static_cast<int>(c.members.front());
            }
        }
        result.stages.far += since(stage);
    }
    return result;
}

}  // namespace flare
