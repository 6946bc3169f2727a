#include "flare/wave/ApertureTransform.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <glm/geometric.hpp>

namespace flare {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kSmoothBins = 2048;
// A short run's length is spread over the normal angles it stands for (half the turn to each
// neighbour), but never wider than this: next to a blade's corner the turn is the corner's.
constexpr double kMaxSmoothSpreadRad = 2.0 * kPi / 180.0;
// Consecutive spike runs whose normals turn by less than this belong to one (curved) edge.
constexpr double kSameEdgeTurnRad = 5.0 * kPi / 180.0;

double sinc(double x) { return std::abs(x) < 1e-4 ? 1.0 - x * x / 6.0 : std::sin(x) / x; }

// The corner term's profile across an edge's spike, K(u): sin²u/u (the exact average over the
// other edge's fast phase) within kZoneInnerU of the spike, its fringe average 1/(2u) beyond
// kZoneOuterU, blended smoothly between. K is odd; its integral Kc(z) = ∫_0^|z| K is tabulated
// (Simpson) to kZoneOuterU and continued analytically, ½ ln(z/kZoneOuterU), beyond.
constexpr double kZoneInnerU = 0.5 * kCornerZoneU, kZoneOuterU = kCornerZoneU;
constexpr int kCornerStepsPerUnit = 256;

double cornerProfile(double u) {
    const double a = std::abs(u);
    if (a < 1e-8) return u;
    const double t = std::clamp((a - kZoneInnerU) / (kZoneOuterU - kZoneInnerU), 0.0, 1.0);
    const double inner = 1.0 - t * t * (3.0 - 2.0 * t);
    const double s = std::sin(u);
    return inner * s * s / u + (1.0 - inner) / (2.0 * u);
}

const std::vector<double>& cornerCumulativeTable() {
    static const std::vector<double> table = [] {
        const int n = static_cast<int>(std::ceil(kZoneOuterU * kCornerStepsPerUnit));
        const double h = kZoneOuterU / n;
        std::vector<double> c(n + 1, 0.0);
        for (int i = 0; i < n; ++i)
            c[i + 1] = c[i] + h / 6.0 * (cornerProfile(i * h) + 4.0 * cornerProfile((i + 0.5) * h) + cornerProfile((i + 1) * h));
        return c;
    }();
    return table;
}

double cornerCumulative(double z) {
    z = std::abs(z);
    const std::vector<double>& c = cornerCumulativeTable();
    if (z >= kZoneOuterU) return c.back() + 0.5 * std::log(z / kZoneOuterU);
    const double x = z / kZoneOuterU * (c.size() - 1);
    const size_t i = std::min(static_cast<size_t>(x), c.size() - 2);
    return c[i] + (x - i) * (c[i + 1] - c[i]);
}

// The mean of K over [u − span, u + span].
double cornerProfileMean(double u, double span) {
    if (span < 1e-6) return cornerProfile(u);
    return (cornerCumulative(u + span) - cornerCumulative(u - span)) / (2.0 * span);
}

double cross(const glm::dvec2& a, const glm::dvec2& b) { return a.x * b.y - a.y * b.x; }

double wrapAngle(double a) {  // to (−π, π]
    a = std::fmod(a, 2.0 * kPi);
    if (a <= -kPi) a += 2.0 * kPi;
    if (a > kPi) a -= 2.0 * kPi;
    return a;
}

ApertureEdge edgeBetween(const glm::dvec2& a, const glm::dvec2& b) {
    ApertureEdge e;
    e.lengthMm = glm::length(b - a);
    e.tangent = (b - a) / e.lengthMm;
    e.normal = {e.tangent.y, -e.tangent.x};  // outward for a counter-clockwise outline
    e.midpointMm = 0.5 * (a + b);
    return e;
}

// Largest distance of the points strictly between i and j (indices mod n) from the chord i→j.
double sagitta(const std::vector<glm::dvec2>& v, size_t i, size_t j) {
    const size_t n = v.size();
    const glm::dvec2 chord = v[j % n] - v[i % n];
    const double length = glm::length(chord);
    double worst = 0.0;
    for (size_t m = i + 1; m < j; ++m) worst = std::max(worst, std::abs(cross(chord, v[m % n] - v[i % n])) / length);
    return worst;
}

}  // namespace

std::vector<glm::dvec2> circleOutline(double radiusMm, int segments) {
    std::vector<glm::dvec2> outline(static_cast<size_t>(segments));
    for (int i = 0; i < segments; ++i) {
        const double phi = 2.0 * kPi * i / segments;
        outline[i] = radiusMm * glm::dvec2(std::cos(phi), std::sin(phi));
    }
    return outline;
}

ApertureTransform::ApertureTransform(std::vector<glm::dvec2> outline, const ApertureTransformOptions& options) {
    if (outline.size() < 3) throw std::invalid_argument("aperture outline needs at least 3 vertices");
    double twiceArea = 0.0;
    glm::dvec2 moment{0.0};
    for (size_t i = 0; i < outline.size(); ++i) {
        const glm::dvec2& a = outline[i];
        const glm::dvec2& b = outline[(i + 1) % outline.size()];
        const double c = cross(a, b);
        twiceArea += c;
        moment += c * (a + b);
    }
    if (!(std::abs(twiceArea) > 0.0) || !std::isfinite(twiceArea))
        throw std::invalid_argument("aperture outline has no area");
    if (twiceArea < 0.0) std::reverse(outline.begin(), outline.end());
    areaMm2_ = 0.5 * std::abs(twiceArea);
    centroidMm_ = moment / (3.0 * twiceArea);
    for (glm::dvec2& p : outline) {
        p -= centroidMm_;
        diameterMm_ = std::max(diameterMm_, 2.0 * glm::length(p));
    }

    // Merge into straight runs, starting at the sharpest corner so that no straight edge is cut in
    // two at the start.
    const size_t n = outline.size();
    size_t start = 0;
    double sharpest = -1.0;
    for (size_t i = 0; i < n; ++i) {
        const glm::dvec2 in = glm::normalize(outline[i] - outline[(i + n - 1) % n]);
        const glm::dvec2 out = glm::normalize(outline[(i + 1) % n] - outline[i]);
        const double turn = std::abs(std::atan2(cross(in, out), glm::dot(in, out)));
        if (turn > sharpest) sharpest = turn, start = i;
    }
    for (size_t i = start; i < start + n;) {
        size_t j = i + 1;
        while (j + 1 <= start + n && sagitta(outline, i, j + 1) <= options.straightToleranceMm) ++j;
        runs_.push_back(edgeBetween(outline[i % n], outline[j % n]));
        perimeterMm_ += runs_.back().lengthMm;
        i = j;
    }

    // Long runs are spikes; the rest is spread over the normal angles it covers.
    std::vector<double> mass(kSmoothBins, 0.0);
    const double binRad = 2.0 * kPi / kSmoothBins;
    const size_t runCount = runs_.size();
    for (size_t r = 0; r < runCount; ++r) {
        const ApertureEdge& e = runs_[r];
        auto angleOf = [&](const ApertureEdge& o) { return std::atan2(o.normal.y, o.normal.x); };
        if (e.lengthMm >= options.spikeMinLengthMm) {
            ApertureEdge spike = e;
            const ApertureEdge& previous = runs_[(r + runCount - 1) % runCount];
            const ApertureEdge& next = runs_[(r + 1) % runCount];
            const double turnIn = std::abs(wrapAngle(angleOf(e) - angleOf(previous)));
            const double turnOut = std::abs(wrapAngle(angleOf(next) - angleOf(e)));
            if (previous.lengthMm >= options.spikeMinLengthMm && turnIn < kSameEdgeTurnRad) spike.fanBeforeRad = 0.5 * turnIn;
            if (next.lengthMm >= options.spikeMinLengthMm && turnOut < kSameEdgeTurnRad) spike.fanAfterRad = 0.5 * turnOut;
            spikes_.push_back(spike);
            continue;
        }
        smoothLengthMm_ += e.lengthMm;
        const double beta = angleOf(e);
        const double before = std::min(0.5 * std::abs(wrapAngle(beta - angleOf(runs_[(r + runCount - 1) % runCount]))),
                                       kMaxSmoothSpreadRad);
        const double after = std::min(0.5 * std::abs(wrapAngle(angleOf(runs_[(r + 1) % runCount]) - beta)),
                                      kMaxSmoothSpreadRad);
        const double from = beta - before, to = beta + after;
        if (to - from < binRad) {  // narrower than a bin: into the bins around β, linearly
            const double x = (beta + 2.0 * kPi) / binRad - 0.5;
            const double fl = std::floor(x);
            const int b0 = static_cast<int>(fl);
            mass[((b0 % kSmoothBins) + kSmoothBins) % kSmoothBins] += e.lengthMm * (1.0 - (x - fl));
            mass[(((b0 + 1) % kSmoothBins) + kSmoothBins) % kSmoothBins] += e.lengthMm * (x - fl);
            continue;
        }
        const double density = e.lengthMm / (to - from);
        for (int b = static_cast<int>(std::floor(from / binRad)); b * binRad < to; ++b) {
            const double overlap = std::min(to, (b + 1) * binRad) - std::max(from, b * binRad);
            if (overlap > 0.0) mass[((b % kSmoothBins) + kSmoothBins) % kSmoothBins] += density * overlap;
        }
    }
    mergeCurvedEdges();
    // Corners: consecutive straight edges, neither of them a curved (fanned) one, whose ends meet
    // (or nearly: a gap shorter than a spike is a corner cut by the outline's sampling).
    for (size_t i = 0; spikes_.size() > 1 && i < spikes_.size(); ++i) {
        const size_t j = (i + 1) % spikes_.size();
        const ApertureEdge &a = spikes_[i], &b = spikes_[j];
        if (a.fanBeforeRad > 0.0 || a.fanAfterRad > 0.0 || b.fanBeforeRad > 0.0 || b.fanAfterRad > 0.0) continue;
        const glm::dvec2 end = a.midpointMm + 0.5 * a.lengthMm * a.tangent;
        const glm::dvec2 start = b.midpointMm - 0.5 * b.lengthMm * b.tangent;
        if (glm::length(start - end) < options.spikeMinLengthMm)
            corners_.push_back({static_cast<int>(i), static_cast<int>(j)});
    }
    smoothDensity_.assign(kSmoothBins, 0.0);
    for (int b = 0; b < kSmoothBins; ++b)  // a [1 2 1]/4 filter hides the bins' quantisation
        smoothDensity_[b] = (mass[(b + kSmoothBins - 1) % kSmoothBins] + 2.0 * mass[b] + mass[(b + 1) % kSmoothBins]) /
                            (4.0 * binRad);
}

// The runs of one curved edge (consecutive spikes whose fans meet) become one spike with their
// total length and the whole fan: a constant curvature spreads the edge's light evenly over the
// normals it turns through. The spikes are drawn per pixel, so one per edge, not one per run.
void ApertureTransform::mergeCurvedEdges() {
    std::vector<ApertureEdge> merged;
    auto angleOf = [](const ApertureEdge& e) { return std::atan2(e.normal.y, e.normal.x); };
    for (size_t i = 0; i < spikes_.size();) {
        size_t j = i + 1;
        while (j < spikes_.size() && spikes_[j - 1].fanAfterRad > 0.0 && spikes_[j].fanBeforeRad > 0.0) ++j;
        if (j == i + 1) {
            merged.push_back(spikes_[i]);
            i = j;
            continue;
        }
        ApertureEdge edge;
        glm::dvec2 normalSum{0.0}, midpointSum{0.0};
        for (size_t k = i; k < j; ++k) {
            edge.lengthMm += spikes_[k].lengthMm;
            normalSum += spikes_[k].lengthMm * spikes_[k].normal;
            midpointSum += spikes_[k].lengthMm * spikes_[k].midpointMm;
        }
        edge.normal = glm::normalize(normalSum);
        edge.tangent = {-edge.normal.y, edge.normal.x};
        edge.midpointMm = midpointSum / edge.lengthMm;
        const double beta = angleOf(edge);
        edge.fanBeforeRad = std::abs(wrapAngle(beta - (angleOf(spikes_[i]) - spikes_[i].fanBeforeRad)));
        edge.fanAfterRad = std::abs(wrapAngle(angleOf(spikes_[j - 1]) + spikes_[j - 1].fanAfterRad - beta));
        merged.push_back(edge);
        i = j;
    }
    spikes_ = std::move(merged);
}

std::complex<double> ApertureTransform::transform(const glm::dvec2& k) const {
    const double kk = glm::dot(k, k);
    if (kk == 0.0) return areaMm2_;
    std::complex<double> sum = 0.0;
    for (const ApertureEdge& e : runs_) {
        const double amplitude = glm::dot(k, e.normal) * e.lengthMm * sinc(0.5 * glm::dot(k, e.tangent) * e.lengthMm);
        const double phase = -glm::dot(k, e.midpointMm);
        sum += amplitude * std::complex<double>(std::cos(phase), std::sin(phase));
    }
    return std::complex<double>(0.0, 1.0 / kk) * sum;
}

double ApertureTransform::smoothDensityMmPerRad(double beta) const {
    const double x = wrapAngle(beta) / (2.0 * kPi / kSmoothBins) - 0.5 + kSmoothBins;
    const double fl = std::floor(x);
    const int b0 = static_cast<int>(fl) % kSmoothBins;
    const double f = x - fl;
    return (1.0 - f) * smoothDensity_[b0] + f * smoothDensity_[(b0 + 1) % kSmoothBins];
}

double ApertureTransform::incoherentIntensity(const glm::dvec2& k) const {
    const double kk = glm::dot(k, k);
    if (kk == 0.0) return areaMm2_ * areaMm2_;
    double spikes = 0.0;
    for (const ApertureEdge& e : spikes_) {
        const double kn = glm::dot(k, e.normal);
        const double s = sinc(0.5 * glm::dot(k, e.tangent) * e.lengthMm);
        spikes += kn * kn * e.lengthMm * e.lengthMm * s * s;
    }
    for (const ApertureCorner& c : corners_) spikes += cornerInterference(spikes_[c.in], spikes_[c.out], k, 0.0, 0.0);
    const double beta = std::atan2(k.y, k.x);
    const double smooth = smoothDensityMmPerRad(beta) + smoothDensityMmPerRad(beta + kPi);
    const double kNorm = std::sqrt(kk);
    return spikes / (kk * kk) + 2.0 * kPi * smooth / (kk * kNorm);
}

// Derivation (ApertureTransform.h): the two edges' cross term 2 Re(E_in E_out*) is exactly
// 2 A_in A_out [cos 2u_in + cos 2u_out − 1 − cos 2(u_in + u_out)]; a cosine whose phase varies fast
// averages to 0 (the last one always, far from the centre: its phase spans both edges).
double cornerInterference(const ApertureEdge& in, const ApertureEdge& out, const glm::dvec2& k, double inSpanU,
                          double outSpanU) {
    const double pIn = glm::dot(k, in.normal) * in.lengthMm, pOut = glm::dot(k, out.normal) * out.lengthMm;
    const double uIn = 0.5 * glm::dot(k, in.tangent) * in.lengthMm, uOut = 0.5 * glm::dot(k, out.tangent) * out.lengthMm;
    const bool nearIn = std::abs(uIn) - inSpanU < kZoneOuterU, nearOut = std::abs(uOut) - outSpanU < kZoneOuterU;
    if (nearIn && nearOut) return 2.0 * pIn * pOut * sinc(uIn) * sinc(uOut) * std::cos(uIn + uOut);
    // A = (k·n)/(k·t) = P/(2u).
    if (nearIn) return -2.0 * (pOut / (2.0 * uOut)) * pIn * cornerProfileMean(uIn, inSpanU);
    if (nearOut) return -2.0 * (pIn / (2.0 * uIn)) * pOut * cornerProfileMean(uOut, outSpanU);
    return -2.0 * (pIn / (2.0 * uIn)) * (pOut / (2.0 * uOut));
}

}  // namespace flare
