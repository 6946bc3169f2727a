#include "flare/wave/DiffractionPsf.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <glm/vec4.hpp>
#include <tbb/parallel_for.h>

namespace flare {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kTableSamplesPerFringe = 8.0;
constexpr double kBlendStart = 0.7;
constexpr size_t kFarBandMerge = 4;     // of the coherent range: the asymptote starts to take over
constexpr double kRadialSubsampleRadiusPx = 8.0;  // 1/r² varies too fast across a pixel nearer
constexpr double kSubcellsPerFringe = 4.0;        // in the exact core, each with 2 × 2 Gauss nodes
constexpr double kSplitSubcellsPerFringe = 2.0;   // the second split (cellEnergy)

// C(z) = ∫_{−∞}^{z} sinc²(πx) dx, which rises from 0 to 1: a table on [0, kCumulativeEnd] by
// Simpson's rule, the fringe-averaged tail 1/(2π²z) beyond (sin² averages 1/2), and C(−z) =
// 1 − C(z). The spike's fringes are kept to four widths out, as far as the corners' exact
// profile across it (ApertureTransform: |u| < 4π); beyond both are fringe averages, so that their
// sum, the fringe-averaged |F|², stays positive pixel by pixel.
constexpr double kCumulativeEnd = 4.0;
constexpr int kCumulativeStepsPerUnit = 128;

const std::vector<double>& cumulativeTable() {
    static const std::vector<double> table = [] {
        auto f = [](double x) {
            if (std::abs(x) < 1e-6) return 1.0;
            const double s = std::sin(kPi * x) / (kPi * x);
            return s * s;
        };
        const int n = static_cast<int>(kCumulativeEnd * kCumulativeStepsPerUnit);
        const double h = 1.0 / kCumulativeStepsPerUnit;
        std::vector<double> c(n + 1);
        c[0] = 0.5;
        for (int i = 0; i < n; ++i) {
            const double a = i * h;
            c[i + 1] = c[i] + h / 6.0 * (f(a) + 4.0 * f(a + 0.5 * h) + f(a + h));
        }
        // The table's end must meet the tail: shift the small quadrature remainder out.
        const double tailAtEnd = 1.0 - 1.0 / (2.0 * kPi * kPi * kCumulativeEnd);
        const double shift = tailAtEnd - c[n];
        for (int i = 0; i <= n; ++i) c[i] += shift * i / n;
        return c;
    }();
    return table;
}

double smoothstep(double t) {
    t = std::clamp(t, 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

// Largest and smallest singular values of a 2×2 matrix.
glm::dvec2 singularValues(const glm::dmat2& m) {
    const glm::dmat2 mtm = glm::transpose(m) * m;
    const double tr = mtm[0][0] + mtm[1][1];
    const double det = glm::determinant(mtm);
    const double disc = std::sqrt(std::max(0.0, 0.25 * tr * tr - det));
    return {std::sqrt(0.5 * tr + disc), std::sqrt(std::max(0.0, 0.5 * tr - disc))};
}

}  // namespace

double sincSquaredCumulative(double z) {
    if (z < 0.0) return 1.0 - sincSquaredCumulative(-z);
    if (z >= kCumulativeEnd) return 1.0 - 1.0 / (2.0 * kPi * kPi * z);
    const std::vector<double>& c = cumulativeTable();
    const double x = z * kCumulativeStepsPerUnit;
    const int i = static_cast<int>(x);
    return c[i] + (x - i) * (c[i + 1] - c[i]);
}

DiffractionPsf::DiffractionPsf(const ApertureTransform& aperture, std::vector<SpectralSample> spectrum,
                               const glm::dmat2& pxPerRad, const DiffractionPsfOptions& options)
    : aperture_(&aperture), pxPerRad_(pxPerRad), options_(options) {
    for (const SpectralSample& s : spectrum)
        if (s.xyzWeight.x + s.xyzWeight.y + s.xyzWeight.z > 0.0) spectrum_.push_back(s);
    if (spectrum_.empty()) throw std::invalid_argument("diffraction PSF: the spectrum has no weight");
    for (const SpectralSample& s : spectrum_) channelWeight_ += s.xyzWeight;
    for (int c = 0; c < 3; ++c)
        if (channelWeight_[c] <= 0.0) channelWeight_[c] = 1.0;  // an empty channel stays empty
    const double det = glm::determinant(pxPerRad_);
    if (!(std::abs(det) > 0.0) || !std::isfinite(det))
        throw std::invalid_argument("diffraction PSF: the pupil-to-pixel map is singular");
    radPerPx_ = glm::inverse(pxPerRad_);
    pixelSolidAngle_ = std::abs(glm::determinant(radPerPx_));

    double lambdaMin = 1e9, lambdaMax = 0.0;
    for (const SpectralSample& s : spectrum_) {
        lambdaMin = std::min(lambdaMin, s.wavelengthNm * 1e-6);
        lambdaMax = std::max(lambdaMax, s.wavelengthNm * 1e-6);
    }
    lambdaMaxMm_ = lambdaMax;
    const double diameter = aperture.diameterMm();
    const glm::dvec2 sigma = singularValues(pxPerRad_);
    coherentK_ = options_.coherentFringes * 2.0 * kPi / diameter;
    coherentRadiusPx_ = sigma.x * coherentK_ * lambdaMax / (2.0 * kPi);
    fringePx_ = sigma.y * lambdaMin / diameter;

    // The exact transform on a grid of kTableSamplesPerFringe samples per fringe, interpolated:
    // F (not |F|²) is smooth, and with the centroid as origin a symmetric aperture's F is real, so
    // its zeros are placed by interpolation to a small fraction of a sample.
    tableStep_ = 2.0 * kPi / diameter / kTableSamplesPerFringe;
    tableHalf_ = static_cast<int>(std::ceil(coherentK_ / tableStep_)) + 3;
    const int side = 2 * tableHalf_ + 1;
    table_.assign(static_cast<size_t>(side) * side, 0.0);
    // The pupil function is real, so F(−k) = F̄(k): the rows up to the centre's are transformed
    // and the rest conjugated through the centre. (ApertureTransform::transform gives exactly
    // that, bit for bit: each edge's term at −k is the negated conjugate of its term at k.)
    tbb::parallel_for(0, tableHalf_ + 1, [&](int row) {
        for (int col = 0; col < side; ++col)
            table_[static_cast<size_t>(row) * side + col] =
                aperture.transform({(col - tableHalf_) * tableStep_, (row - tableHalf_) * tableStep_});
    });
    for (int row = tableHalf_ + 1; row < side; ++row)
        for (int col = 0; col < side; ++col)
            table_[static_cast<size_t>(row) * side + col] =
                std::conj(table_[static_cast<size_t>(side - 1 - row) * side + (side - 1 - col)]);

    // The asymptote is smooth in λ (no fringes): a quarter of the wavelengths, each band merged
    // into one sample at its weighted mean wavelength, carries it.
    for (size_t i = 0; i < spectrum_.size(); i += kFarBandMerge) {
        SpectralSample band{0.0, glm::dvec3(0.0)};
        double weight = 0.0;
        for (size_t j = i; j < std::min(spectrum_.size(), i + kFarBandMerge); ++j) {
            const double w = spectrum_[j].xyzWeight.x + spectrum_[j].xyzWeight.y + spectrum_[j].xyzWeight.z;
            band.xyzWeight += spectrum_[j].xyzWeight;
            band.wavelengthNm += w * spectrum_[j].wavelengthNm;
            weight += w;
        }
        band.wavelengthNm /= weight;
        farSpectrum_.push_back(band);
    }
    for (const SpectralSample& s : spectrum_) {
        lambdaMeanMm_ += s.xyzWeight * (s.wavelengthNm * 1e-6);
        lambdaRmsMm_ += s.xyzWeight * (s.wavelengthNm * s.wavelengthNm * 1e-12);
    }
    lambdaMeanMm_ /= channelWeight_;
    lambdaRmsMm_ = glm::sqrt(lambdaRmsMm_ / channelWeight_);
    const double area = aperture.areaMm2();
    for (const ApertureEdge& e : aperture.spikeEdges()) {
        Spike spike;
        const glm::dvec2 along = pxPerRad_ * e.normal;
        const double alongLength = glm::length(along);
        spike.directionPx = along / alongLength;
        spike.transversePx = {-spike.directionPx.y, spike.directionPx.x};
        // Energy per unit a (radians along n): L λ/(4π² a² A); per pixel along the line, with
        // a = r/|M n|: L λ |M n| / (4π² A r²).
        const double across = std::abs(glm::dot(pxPerRad_ * e.tangent, spike.transversePx));
        // The pupil's normal angle turns the pixel direction the same way, or the other way when
        // the map mirrors (the camera orientation).
        const double sense = glm::determinant(pxPerRad_) > 0.0 ? 1.0 : -1.0;
        spike.fanFromRad = std::min(-sense * e.fanBeforeRad, sense * e.fanAfterRad);
        spike.fanToRad = std::max(-sense * e.fanBeforeRad, sense * e.fanAfterRad);
        for (int c = 0; c < 3; ++c) {
            spike.lineDensity[c] = e.lengthMm * lambdaMeanMm_[c] * alongLength / (4.0 * kPi * kPi * area);
            spike.transverseWidthPx[c] = lambdaMeanMm_[c] / e.lengthMm * across;
        }
        spikes_.push_back(spike);
    }
}

double DiffractionPsf::coherentIntensity(const glm::dvec2& k) const {
    const double x = k.x / tableStep_ + tableHalf_, y = k.y / tableStep_ + tableHalf_;
    const int side = 2 * tableHalf_ + 1;
    const int i = static_cast<int>(std::floor(x)), j = static_cast<int>(std::floor(y));
    if (i < 1 || j < 1 || i + 2 >= side || j + 2 >= side) return std::norm(aperture_->transform(k));
    // Catmull-Rom in both directions: F oscillates with the fringes, and linear interpolation
    // would lose a few per cent of |F|² between the nodes.
    auto weights = [](double t) {
        const double t2 = t * t, t3 = t2 * t;
        return glm::dvec4(-0.5 * t3 + t2 - 0.5 * t, 1.5 * t3 - 2.5 * t2 + 1.0, -1.5 * t3 + 2.0 * t2 + 0.5 * t,
                          0.5 * t3 - 0.5 * t2);
    };
    const glm::dvec4 wx = weights(x - i), wy = weights(y - j);
    std::complex<double> f = 0.0;
    for (int b = 0; b < 4; ++b) {
        std::complex<double> row = 0.0;
        for (int a = 0; a < 4; ++a) row += wx[a] * table_[static_cast<size_t>(j - 1 + b) * side + (i - 1 + a)];
        f += wy[b] * row;
    }
    return std::norm(f);
}

// Energy (before normalisation, per unit power) of every spike in a cell of α-space centred at
// `alpha` and spanned by ±axisA ± axisB, at one wavelength: the 1/a² envelope at the centre, the
// sinc² integrated exactly across the cell's width.
double DiffractionPsf::spikeCellEnergy(const glm::dvec2& alpha, const glm::dvec2& axisA, const glm::dvec2& axisB,
                                       double lambdaMm) const {
    const double alpha2 = glm::dot(alpha, alpha);
    if (alpha2 == 0.0) return 0.0;
    const double area = 4.0 * std::abs(axisA.x * axisB.y - axisA.y * axisB.x);
    double sum = 0.0;
    for (const ApertureEdge& e : aperture_->spikeEdges()) {
        const double a = glm::dot(alpha, e.normal), b = glm::dot(alpha, e.tangent);
        const double width = 2.0 * (std::abs(glm::dot(axisA, e.tangent)) + std::abs(glm::dot(axisB, e.tangent)));
        const double scale = e.lengthMm / lambdaMm;
        const double across = lambdaMm / e.lengthMm *
                              (sincSquaredCumulative((b + 0.5 * width) * scale) -
                               sincSquaredCumulative((b - 0.5 * width) * scale));
        sum += e.lengthMm * e.lengthMm * a * a / (alpha2 * alpha2) * across * (area / width);
    }
    // The corners (ApertureTransform.h): X/|k|⁴ per λ²A per steradian is X λ²/((2π)⁴|α|⁴ A); in
    // the units of the sum above (which carry 1/(4π² A)), X λ²/(4π² α⁴) per unit cell area.
    const std::vector<ApertureEdge>& edges = aperture_->spikeEdges();
    if (!aperture_->corners().empty()) {
        const glm::dvec2 k = (2.0 * kPi / lambdaMm) * alpha;
        auto spanU = [&](const ApertureEdge& e) {
            return kPi * e.lengthMm / lambdaMm * (std::abs(glm::dot(axisA, e.tangent)) + std::abs(glm::dot(axisB, e.tangent)));
        };
        double corners = 0.0;
        for (const ApertureCorner& c : aperture_->corners())
            corners += cornerInterference(edges[c.in], edges[c.out], k, spanU(edges[c.in]), spanU(edges[c.out]));
        sum += corners * lambdaMm * lambdaMm / (4.0 * kPi * kPi * alpha2 * alpha2) * area;
    }
    return sum / (4.0 * kPi * kPi * aperture_->areaMm2());
}

glm::dvec3 DiffractionPsf::cellEnergy(const glm::dvec2& offsetPx, double halfPx) const {
    const double nearest = std::max(0.0, glm::length(offsetPx) - halfPx * std::sqrt(2.0));
    int n = 1;
    if (nearest < coherentRadiusPx_)
        n = std::clamp(static_cast<int>(std::ceil(kSubcellsPerFringe * 2.0 * halfPx / fringePx_)), 1, options_.maxSubsamples);
    else if (nearest < kRadialSubsampleRadiusPx)
        n = 4;
    const double sub = halfPx / n;
    // Where maxSubsamples leaves the sub-cells wider than a fringe (a fast lens on large pixels:
    // f/2.8 on 47 µm pixels has 0.02–0.04 px per fringe, the whole exact core inside the centre
    // pixel), those that reach the exact core are split again to half a fringe: on cells wider
    // than the peak the 2 × 2 Gauss nodes misjudge its energy (the Airy pattern's centre pixel by
    // +10 % on cells of 1.25 fringes; the dusty double Gauss's model by +19 % in Z). On cells of
    // half a fringe that pixel is good to 4e-6, up to a fringe to 4e-4 (2e-5 on the default
    // scene's 0.69 fringe, which is left as it was); half a fringe rather than the quarter above
    // costs a quarter of the time. The rest of the pixel keeps the coarser cells.
    const int refine = nearest < coherentRadiusPx_ && 2.0 * sub > fringePx_
                           ? static_cast<int>(std::ceil(kSplitSubcellsPerFringe * 2.0 * sub / fringePx_))
                           : 1;
    glm::dvec3 energy{0.0};
    for (int sy = 0; sy < n; ++sy)
        for (int sx = 0; sx < n; ++sx) {
            const glm::dvec2 o = offsetPx + glm::dvec2((2 * sx + 1 - n) * sub, (2 * sy + 1 - n) * sub);
            if (refine == 1 || glm::length(o) - sub * std::sqrt(2.0) >= coherentRadiusPx_) {
                addSubcellEnergy(o, sub, energy);
                continue;
            }
            const double fine = sub / refine;
            for (int fy = 0; fy < refine; ++fy)
                for (int fx = 0; fx < refine; ++fx)
                    addSubcellEnergy(o + glm::dvec2((2 * fx + 1 - refine) * fine, (2 * fy + 1 - refine) * fine), fine, energy);
        }
    return energy / channelWeight_;
}

// Adds to `energy` that of the square sub-cell of half-size `halfPx` centred `centrePx` from the
// point image (before normalisation, Σ_λ w_c(λ) times it).
void DiffractionPsf::addSubcellEnergy(const glm::dvec2& centrePx, double halfPx, glm::dvec3& energy) const {
    const glm::dvec2 axisA = radPerPx_ * glm::dvec2(halfPx, 0.0), axisB = radPerPx_ * glm::dvec2(0.0, halfPx);
    const double cellSolidAngle = 4.0 * halfPx * halfPx * pixelSolidAngle_;
    const double area = aperture_->areaMm2();
    // The exact core is integrated over each sub-cell by the 2 × 2 Gauss–Legendre rule (exact for
    // cubics): the midpoint rule on the peak's curvature overstated it (+0.65 % on 2 × 2 samples).
    const double node = halfPx / std::sqrt(3.0);
    const glm::dvec2 nodes[4] = {radPerPx_ * glm::dvec2(-node, -node), radPerPx_ * glm::dvec2(node, -node),
                                 radPerPx_ * glm::dvec2(-node, node), radPerPx_ * glm::dvec2(node, node)};
    const glm::dvec2 alpha = radPerPx_ * centrePx;
    const double alphaNorm = glm::length(alpha);
    const double beta = std::atan2(alpha.y, alpha.x);
    const double rho =
        alphaNorm > 0.0 ? aperture_->smoothDensityMmPerRad(beta) + aperture_->smoothDensityMmPerRad(beta + kPi) : 0.0;
    // Wholly beyond the coherent range even at the longest wavelength: the asymptote alone, on the
    // merged bands.
    const bool far = (2.0 * kPi / (lambdaMaxMm_)) * alphaNorm >= coherentK_;
    for (const SpectralSample& s : far ? farSpectrum_ : spectrum_) {
        const double lambda = s.wavelengthNm * 1e-6;
        const double toK = 2.0 * kPi / lambda;
        const double w = smoothstep((toK * alphaNorm / coherentK_ - kBlendStart) / (1.0 - kBlendStart));
        double value = 0.0;
        if (w < 1.0) {
            double exact = 0.0;
            for (const glm::dvec2& d : nodes) exact += coherentIntensity(toK * (alpha + d));
            value += (1.0 - w) * 0.25 * exact / (lambda * lambda * area) * cellSolidAngle;
        }
        if (w > 0.0) {
            const double smooth = lambda * rho / (4.0 * kPi * kPi * alphaNorm * alphaNorm * alphaNorm * area);
            value += w * (spikeCellEnergy(alpha, axisA, axisB, lambda) + smooth * cellSolidAngle);
        }
        energy += value * s.xyzWeight;
    }
}

glm::dvec3 DiffractionPsf::cornerPerPixel(const glm::dvec2& offsetPx) const {
    const std::vector<ApertureCorner>& corners = aperture_->corners();
    const glm::dvec2 alpha = radPerPx_ * offsetPx;
    const double alpha2 = glm::dot(alpha, alpha);
    if (corners.empty() || alpha2 == 0.0) return glm::dvec3(0.0);
    const std::vector<ApertureEdge>& edges = aperture_->spikeEdges();
    const glm::dvec2 axisA = radPerPx_ * glm::dvec2(0.5, 0.0), axisB = radPerPx_ * glm::dvec2(0.0, 0.5);
    const glm::dvec3 n = normalisation_ == glm::dvec3(0.0) ? glm::dvec3(1.0) : normalisation_;
    const double scale = pixelSolidAngle_ / (16.0 * kPi * kPi * kPi * kPi * alpha2 * alpha2 * aperture_->areaMm2());
    // Away from every spike's zone (the usual case) the term is −2 A_in A_out, a function of the
    // direction alone, times λ²: the channel's mean λ² carries it. The zones are widest at the
    // longest wavelength (u ∝ 1/λ).
    const double lambdaLongest = std::max({lambdaRmsMm_.x, lambdaRmsMm_.y, lambdaRmsMm_.z});
    bool inZone = false;
    for (const ApertureEdge& e : edges) {
        const double span = std::abs(glm::dot(axisA, e.tangent)) + std::abs(glm::dot(axisB, e.tangent));
        inZone = inZone || kPi * e.lengthMm * (std::abs(glm::dot(alpha, e.tangent)) - span) / lambdaLongest < kCornerZoneU;
    }
    if (!inZone) {
        double x = 0.0;
        for (const ApertureCorner& c : corners)
            x -= 2.0 * glm::dot(alpha, edges[c.in].normal) / glm::dot(alpha, edges[c.in].tangent) *
                 glm::dot(alpha, edges[c.out].normal) / glm::dot(alpha, edges[c.out].tangent);
        return x * scale * lambdaRmsMm_ * lambdaRmsMm_ * n;
    }
    glm::dvec3 energy{0.0};
    for (int c = 0; c < 3; ++c) {
        const double lambda = lambdaRmsMm_[c];
        const glm::dvec2 k = (2.0 * kPi / lambda) * alpha;
        auto spanU = [&](const ApertureEdge& e) {
            return kPi * e.lengthMm / lambda * (std::abs(glm::dot(axisA, e.tangent)) + std::abs(glm::dot(axisB, e.tangent)));
        };
        double x = 0.0;
        for (const ApertureCorner& corner : corners)
            x += cornerInterference(edges[corner.in], edges[corner.out], k, spanU(edges[corner.in]), spanU(edges[corner.out]));
        energy[c] = x * lambda * lambda * scale;
    }
    return energy * n;
}

glm::dvec3 DiffractionPsf::smoothPerPixel(const glm::dvec2& offsetPx) const {
    const glm::dvec2 alpha = radPerPx_ * offsetPx;
    const double alphaNorm = glm::length(alpha);
    if (alphaNorm == 0.0 || aperture_->smoothLengthMm() == 0.0) return glm::dvec3(0.0);
    const double beta = std::atan2(alpha.y, alpha.x);
    const double rho = aperture_->smoothDensityMmPerRad(beta) + aperture_->smoothDensityMmPerRad(beta + kPi);
    // λ ρ / (4π² |α|³ A) per steradian, averaged over the channel's wavelengths (it is linear in λ).
    const glm::dvec3 n = normalisation_ == glm::dvec3(0.0) ? glm::dvec3(1.0) : normalisation_;
    return lambdaMeanMm_ * (rho * pixelSolidAngle_ /
                            (4.0 * kPi * kPi * alphaNorm * alphaNorm * alphaNorm * aperture_->areaMm2())) * n;
}

// The asymptote's energy outside the square window |x|, |y| ≤ h + ½: each spike beyond the
// distance where its line leaves the window (∫ D/r² dr = D/r), and the halo, whose energy per
// pixel falls as 1/r³, over every direction beyond the window's edge in that direction.
double DiffractionPsf::outsideWindowEnergy(int halfPx, int channel) const {
    const double edge = halfPx + 0.5;
    double energy = 0.0;
    for (const Spike& s : spikes_) {
        const double exitR = edge / std::max(std::abs(s.directionPx.x), std::abs(s.directionPx.y));
        energy += 2.0 * s.lineDensity[channel] / exitR;
    }
    if (aperture_->smoothLengthMm() > 0.0) {
        const int steps = 1440;
        for (int i = 0; i < steps; ++i) {
            const double phi = 2.0 * kPi * (i + 0.5) / steps;
            const glm::dvec2 u{std::cos(phi), std::sin(phi)};
            const double exitR = edge / std::max(std::abs(u.x), std::abs(u.y));
            // per pixel at r: S(1)/r³ → ∫ r dr S(1)/r³ = S(1)/exitR
            energy += smoothPerPixel(u)[channel] / exitR * (2.0 * kPi / steps);
        }
    }
    if (!aperture_->corners().empty()) {
        // Per pixel the corners fall as 1/r⁴ (their profile across a spike narrows as 1/r but keeps
        // its integral): ∫_R^∞ r dr E(R)(R/r)⁴ = E(R) R²/2, on a grid that resolves the spikes' zones.
        const int steps = 8 * 1440;
        for (int i = 0; i < steps; ++i) {
            const double phi = 2.0 * kPi * (i + 0.5) / steps;
            const glm::dvec2 u{std::cos(phi), std::sin(phi)};
            const double exitR = edge / std::max(std::abs(u.x), std::abs(u.y));
            energy += cornerPerPixel(exitR * u)[channel] * exitR * exitR / 2.0 * (2.0 * kPi / steps);
        }
    }
    return energy;
}

std::vector<float> DiffractionPsf::window(int halfPx) {
    const int side = 2 * halfPx + 1;
    std::vector<glm::dvec3> cells(static_cast<size_t>(side) * side);
    // The PSF is point-symmetric: the pupil function is real, so F(−k) is F(k)'s conjugate and
    // |F|² the same, and every term of the asymptote (each spike's sinc² about its line, the
    // corners' products of ratios even in α, the halo's ρ(β) + ρ(β + π)) is even in α; the linear
    // map to pixels keeps that. The rows up to the centre's are evaluated, the rest mirrored
    // through the centre (half the work; the two halves agree to rounding, tested).
    tbb::parallel_for(0, halfPx + 1, [&](int row) {
        for (int col = 0; col < side; ++col)
            cells[static_cast<size_t>(row) * side + col] = cellEnergy({col - halfPx, row - halfPx}, 0.5);
    });
    for (int row = halfPx + 1; row < side; ++row)
        for (int col = 0; col < side; ++col)
            cells[static_cast<size_t>(row) * side + col] = cells[static_cast<size_t>(side - 1 - row) * side + (side - 1 - col)];
    if (normalisation_ == glm::dvec3(0.0)) {
        glm::dvec3 total{0.0};
        for (const glm::dvec3& c : cells) total += c;
        for (int c = 0; c < 3; ++c) total[c] += outsideWindowEnergy(halfPx, c);
        parsevalTotal_ = total;
        normalisation_ = 1.0 / total;
        for (Spike& s : spikes_) s.lineDensity *= normalisation_;
    }
    std::vector<float> xyz(cells.size() * 3);
    for (size_t i = 0; i < cells.size(); ++i)
        for (int c = 0; c < 3; ++c) xyz[3 * i + c] = static_cast<float>(cells[i][c] * normalisation_[c]);
    return xyz;
}

double DiffractionPsf::parsevalError() const {
    double worst = 0.0;
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(parsevalTotal_[c] - 1.0));
    return worst;
}

}  // namespace flare
