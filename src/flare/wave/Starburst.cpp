#include "flare/wave/Starburst.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <stdexcept>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <kiss_fftnd.h>
#include <tbb/parallel_for.h>

#include "flare/wave/DiffractionPsf.h"
#include "flare/wave/DustGlow.h"

namespace flare {

namespace {

constexpr double kProfileBinPx = 0.25;  // bins of the far part's transverse profiles

double smoothstep(double t) {
    t = std::clamp(t, 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

// Complex 2-D transforms (kiss_fftnd): Debian's KissFFT 131.1.0 cannot allocate its real
// N-dimensional transform (kiss_fftndr_alloc returns null), and the images here are small.
struct FftPlan {
    kiss_fftnd_cfg forward = nullptr, inverse = nullptr;
    int rows = 0, cols = 0;
    FftPlan(int r, int c) : rows(r), cols(c) {
        const int dims[2] = {r, c};
        forward = kiss_fftnd_alloc(dims, 2, 0, nullptr, nullptr);
        inverse = kiss_fftnd_alloc(dims, 2, 1, nullptr, nullptr);
        if (!forward || !inverse) throw std::runtime_error("starburst: cannot allocate a KissFFT plan");
    }
    ~FftPlan() {
        kiss_fft_free(forward);
        kiss_fft_free(inverse);
    }
    FftPlan(const FftPlan&) = delete;
    FftPlan& operator=(const FftPlan&) = delete;
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
    kiss_fftnd(plan.forward, a.data(), fa.data());
    kiss_fftnd(plan.forward, b.data(), fb.data());
    const float scale = 1.0f / static_cast<float>(size);
    for (size_t i = 0; i < size; ++i)
        fa[i] = {(fa[i].r * fb[i].r - fa[i].i * fb[i].i) * scale, (fa[i].r * fb[i].i + fa[i].i * fb[i].r) * scale};
    kiss_fftnd(plan.inverse, fa.data(), a.data());
    const int side = imageSide + kernelSide - 1;
    std::vector<float> out(static_cast<size_t>(side) * side);
    for (int y = 0; y < side; ++y)
        for (int x = 0; x < side; ++x)  // float round-off leaves ~1e-7 of the peak, of either sign
            out[static_cast<size_t>(y) * side + x] = std::max(0.0f, a[static_cast<size_t>(y) * plan.cols + x].r);
    return out;
}

// The crop's energy projected across a spike, convolved with the spike's sinc² profile and the
// receiving pixel's width: a density per pixel across the line, on bins of kProfileBinPx.
struct TransverseProfile {
    double originPx = 0.0;  // the first bin's centre
    std::vector<double> density;

    std::vector<double> cumulative;  // ∫ density up to each bin's centre

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
    const int kernelHalf = static_cast<int>(std::ceil(kernelExtent / kProfileBinPx));
    const int half = static_cast<int>(std::ceil((extent + 1.0) / kProfileBinPx)) + kernelHalf + 4;
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
    double sum = 0.0;
    for (int j = -kernelHalf; j <= kernelHalf; ++j) {
        kernel[j + kernelHalf] = sincSquaredCumulative((j + 0.5) * kProfileBinPx / sincWidthPx) -
                                 sincSquaredCumulative((j - 0.5) * kProfileBinPx / sincWidthPx);
        sum += kernel[j + kernelHalf];
    }
    for (double& k : kernel) k /= sum;
    const double box[5] = {0.125, 0.25, 0.25, 0.25, 0.125};
    std::vector<double> blurred(histogram.size(), 0.0), density(histogram.size(), 0.0);
    for (int i = 0; i < static_cast<int>(histogram.size()); ++i) {
        if (histogram[i] == 0.0) continue;
        for (int j = -kernelHalf; j <= kernelHalf; ++j)
            if (i + j >= 0 && i + j < static_cast<int>(blurred.size())) blurred[i + j] += histogram[i] * kernel[j + kernelHalf];
    }
    for (int i = 2; i + 2 < static_cast<int>(blurred.size()); ++i)
        for (int j = -2; j <= 2; ++j) density[i] += blurred[i + j] * box[j + 2];
    for (double& d : density) d /= kProfileBinPx;
    std::vector<double> cumulative(density.size(), 0.0);
    for (size_t i = 1; i < density.size(); ++i)
        cumulative[i] = cumulative[i - 1] + 0.5 * kProfileBinPx * (density[i - 1] + density[i]);
    return {-half * kProfileBinPx, std::move(density), std::move(cumulative)};
}

}  // namespace

StarburstImage renderStarburst(const LensSystem& lens, const std::vector<float>& directXyz, int width, int height,
                               const std::vector<StarburstLight>& lights, const StarburstOptions& options,
                               const std::vector<StarburstDust>& dust) {
    StarburstImage result;
    result.xyz = directXyz;
    const size_t pixels = static_cast<size_t>(width) * height;

    PupilOutlineOptions outlineOptions;
    outlineOptions.widthPx = width;
    outlineOptions.heightPx = height;
    std::vector<PupilOutline> outlines;
    for (const StarburstLight& light : lights) {
        outlines.push_back(tracePupilOutline(lens, light.direction, outlineOptions));
        StarburstLightReport report;
        report.name = light.name;
        if (!outlines.back().found) report.why = "no ray of the light reaches the sensor";
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

    for (size_t l = 0; l < lights.size(); ++l) {
        StarburstLightReport& report = result.lights[l];
        if (!outlines[l].found) continue;
        const auto start = std::chrono::steady_clock::now();

        // The crop: the square about the image's energy centroid holding cropEnergy of it.
        glm::dvec2 centroid{0.0};
        double energyY = 0.0;
        for (size_t i = 0; i < pixels; ++i)
            if (owner[i] == static_cast<int>(l)) {
                const double y = directXyz[3 * i + 1];
                centroid += y * glm::dvec2(i % width + 0.5, i / width + 0.5);
                energyY += y;
            }
        report.directEnergyY = energyY;
        if (!(energyY > 0.0)) {
            report.why = "its direct image has no energy on the sensor";
            continue;
        }
        centroid /= energyY;
        const int cx = static_cast<int>(std::floor(centroid.x)), cy = static_cast<int>(std::floor(centroid.y));
        std::vector<double> byRing(options.maxCropRadiusPx + 1, 0.0);
        for (size_t i = 0; i < pixels; ++i)
            if (owner[i] == static_cast<int>(l)) {
                const int ring = std::max(std::abs(static_cast<int>(i % width) - cx), std::abs(static_cast<int>(i / width) - cy));
                if (ring <= options.maxCropRadiusPx) byRing[ring] += directXyz[3 * i + 1];
            }
        int radius = 0;
        for (double sum = byRing[0]; radius < options.maxCropRadiusPx && sum < options.cropEnergy * energyY;)
            sum += byRing[++radius];
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

        // A degenerate pupil or map (a light at the edge of a fisheye's field) leaves the light
        // undiffracted, with the reason, rather than failing the whole image.
        std::optional<ApertureTransform> aperture;
        std::optional<DiffractionPsf> psfStorage;
        try {
            aperture.emplace(outlines[l].outlineMm);
            psfStorage.emplace(*aperture, lights[l].spectrum, outlines[l].pxPerRad);
        } catch (const std::invalid_argument& e) {
            report.why = std::string("no diffraction PSF: ") + e.what();
            for (size_t i = 0; i < pixels; ++i)  // put the crop back
                if (owner[i] == static_cast<int>(l)) std::copy_n(&directXyz[3 * i], 3, &result.xyz[3 * i]);
            continue;
        }
        DiffractionPsf& psf = *psfStorage;
        const int window = std::max({options.minWindowPx, static_cast<int>(std::ceil(psf.coherentRadiusPx())) + 4,
                                     std::min(options.maxWindowPx,
                                              static_cast<int>(std::ceil(options.windowPerCropRadius * radius)))});
        const std::vector<float> kernelXyz = psf.window(window);
        const double taperWidth = 0.5 * window, taperStart = window - taperWidth;
        report.pupilAreaMm2 = aperture->areaMm2();
        report.spikeEdges = static_cast<int>(aperture->spikeEdges().size());
        report.smoothOutlineShare = aperture->smoothLengthMm() / aperture->perimeterMm();
        report.wavelengths = static_cast<int>(psf.spectrum().size());
        report.windowRadiusPx = window;
        report.coherentRadiusPx = psf.coherentRadiusPx();
        report.parsevalError = psf.parsevalError();

        // Near: the tapered window convolved with the crop.
        const int kernelSide = 2 * window + 1;
        const int outSide = kernelSide + cropSide - 1;
        const FftPlan plan(kiss_fft_next_fast_size(outSide), kiss_fft_next_fast_size(outSide));
        std::vector<double> inFrameRows(height, 0.0);
        for (int c = 0; c < 3; ++c) {
            std::vector<float> kernel(static_cast<size_t>(kernelSide) * kernelSide);
            for (int y = 0; y < kernelSide; ++y)
                for (int x = 0; x < kernelSide; ++x) {
                    const double r = std::hypot(x - window, y - window);
                    kernel[static_cast<size_t>(y) * kernelSide + x] =
                        static_cast<float>(kernelXyz[3 * (static_cast<size_t>(y) * kernelSide + x) + c] *
                                           (1.0 - smoothstep((r - taperStart) / taperWidth)));
                }
            const std::vector<float> near = convolve(plan, crop[c], cropSide, kernel, kernelSide);
            for (int y = 0; y < outSide; ++y)
                for (int x = 0; x < outSide; ++x) {
                    const int px = cx - radius - window + x, py = cy - radius - window + y;
                    if (px < 0 || py < 0 || px >= width || py >= height) continue;
                    const float v = near[static_cast<size_t>(y) * outSide + x];
                    result.xyz[3 * (static_cast<size_t>(py) * width + px) + c] += v;
                    if (c == 1) inFrameRows[py] += v;
                }
        }

        // Far: the spikes' envelopes times the crop's transverse profiles, and the halo.
        const std::vector<DiffractionPsf::Spike>& spikes = psf.spikes();
        std::vector<std::array<TransverseProfile, 3>> profiles(spikes.size());
        for (size_t s = 0; s < spikes.size(); ++s)
            for (int c = 0; c < 3; ++c)
                profiles[s][c] = transverseProfile(cropPoints, cropEnergies[c], spikes[s].transversePx,
                                                   spikes[s].transverseWidthPx[c]);
        // Row by row (each row's pixels get their additions in a fixed order: deterministic): the
        // halo everywhere, then each spike over the band of the row where its profile is not zero.
        const bool halo = aperture->smoothLengthMm() > 0.0;
        tbb::parallel_for(0, height, [&](int y) {
            double rowY = 0.0;
            const size_t row = static_cast<size_t>(y) * width;
            auto add = [&](int x, const glm::dvec3& value) {
                for (int c = 0; c < 3; ++c) result.xyz[3 * (row + x) + c] += static_cast<float>(value[c]);
                rowY += value.y;
            };
            auto taper = [&](const glm::dvec2& offset) {
                return smoothstep((glm::length(offset) - taperStart) / taperWidth);
            };
            if (halo)
                for (int x = 0; x < width; ++x) {
                    const glm::dvec2 offset = glm::dvec2(x + 0.5, y + 0.5) - cropCentre;
                    const double w = taper(offset);
                    if (w > 0.0) add(x, w * psf.smoothPerPixel(offset) * cropEnergy);
                }
            for (size_t s = 0; s < spikes.size(); ++s) {
                const glm::dvec2 across = spikes[s].transversePx;
                // The pixels of this row that a line of the fan passes within the profiles' reach
                // of: across(x) = (x + ½ − c.x)·t.x + (y + ½ − c.y)·t.y inside [lo, hi] for the
                // fan's two extreme lines (t turned by φ), and everything between them.
                double lo = 1e300, hi = -1e300;
                for (int c = 0; c < 3; ++c) {
                    lo = std::min(lo, profiles[s][c].originPx);
                    hi = std::max(hi, profiles[s][c].originPx + kProfileBinPx * profiles[s][c].density.size());
                }
                double from = 1e300, to = -1e300;
                bool wholeRow = false;
                for (const double phi : {spikes[s].fanFromRad, spikes[s].fanToRad}) {
                    const glm::dvec2 t = std::cos(phi) * across - std::sin(phi) * spikes[s].directionPx;
                    const double rowPart = (y + 0.5 - cropCentre.y) * t.y;
                    if (std::abs(t.x) < 1e-9) {
                        wholeRow = wholeRow || (rowPart >= lo && rowPart <= hi);
                        continue;
                    }
                    const double a = cropCentre.x - 0.5 + (lo - rowPart) / t.x;
                    const double b = cropCentre.x - 0.5 + (hi - rowPart) / t.x;
                    from = std::min(from, std::min(a, b));
                    to = std::max(to, std::max(a, b));
                }
                int x0 = 0, x1 = width - 1;
                if (!wholeRow) {
                    if (from > to) continue;
                    x0 = std::max(0, static_cast<int>(std::floor(from)));
                    x1 = std::min(width - 1, static_cast<int>(std::ceil(to)));
                }
                for (int x = x0; x <= x1; ++x) {
                    const glm::dvec2 offset = glm::dvec2(x + 0.5, y + 0.5) - cropCentre;
                    const double w = taper(offset);
                    if (w <= 0.0) continue;
                    // The envelope (k·n)²/|k|⁴: 1/r² along the line, falling to 0 across it.
                    const double along = glm::dot(offset, spikes[s].directionPx);
                    const double t = glm::dot(offset, across);
                    const double r2 = glm::dot(offset, offset);
                    const double envelope = w * along * along / (r2 * r2);
                    glm::dvec3 value;
                    for (int c = 0; c < 3; ++c)
                        value[c] = spikes[s].lineDensity[c] * envelope *
                                   profiles[s][c].fanned(t, along, spikes[s].fanFromRad, spikes[s].fanToRad);
                    add(x, value);
                }
            }
            inFrameRows[y] += rowY;
        });
        double inFrame = 0.0;
        for (double r : inFrameRows) inFrame += r;
        report.outsideFrameShare = std::max(0.0, 1.0 - inFrame / cropEnergy.y);

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
        report.diffracted = true;
        report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    return result;
}

}  // namespace flare
