// Ghost ringing (GhostRinging.h, BeamRim.h): the Fresnel integrals against quadrature, the
// paraxial Fresnel distance against a plate's analytic one, and a beam of a circular aperture
// against an independent Fresnel propagation of that aperture (the Fresnel–Kirchhoff integral of
// the disk in Hankel form, by quadrature in this file), plus power, the λ → 0 limit and the switch.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/core/FresnelIntegrals.h"
#include "flare/ghosts/GhostRinging.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/Paraxial.h"
#include "flare/photons/Light.h"
#include "flare/render/GhostBeam.h"
#include "flare/film/Film.h"
#include "flare/scene/Scene.h"
#include "flare/scene/ScenePreview.h"

namespace flare {
namespace {

constexpr double kPi = std::numbers::pi;

// ∫₀ᵘ f(πt²/2) dt by composite Simpson with `intervals` steps.
template <typename F>
double simpson(F f, double u, int intervals) {
    const double h = u / intervals;
    double sum = f(0.0) + f(u);
    for (int i = 1; i < intervals; ++i) sum += (i % 2 ? 4.0 : 2.0) * f(i * h);
    return sum * h / 3.0;
}

TEST(FresnelIntegrals, MatchQuadrature) {
    // Simpson's error, h⁴/180 · max |f⁗| with |f⁗| ≤ (πu)⁴ + …: below 1e-10 at 40 000 steps for
    // |u| ≤ 10; the series and the asymptotic branch meet at u = 3.5, checked on both sides.
    for (double u : {-9.7, -6.1, -3.5001, -3.4999, -1.3, -0.2, 0.0, 0.05, 0.9, 1.7, 2.5, 3.0, 3.4999, 3.5001, 4.8,
                     7.25, 9.9}) {
        const FresnelCS cs = fresnelIntegrals(u);
        const double c = simpson([](double t) { return std::cos(0.5 * kPi * t * t); }, u, 40000);
        const double s = simpson([](double t) { return std::sin(0.5 * kPi * t * t); }, u, 40000);
        EXPECT_NEAR(cs.c, c, 1e-8) << u;
        EXPECT_NEAR(cs.s, s, 1e-8) << u;
    }
    // The limits, and the edge's classic numbers: ¼ on the boundary, the first maximum 1.370 at
    // u = 1.217 (Born & Wolf §8.7).
    EXPECT_NEAR(fresnelIntegrals(1e4).c, 0.5, 1e-4);
    EXPECT_NEAR(fresnelIntegrals(-1e4).s, -0.5, 1e-4);
    EXPECT_DOUBLE_EQ(straightEdgeIntensity(0.0), 0.25);
    double best = 0.0, where = 0.0;
    for (double u = 1.0; u < 1.5; u += 1e-4)
        if (straightEdgeIntensity(u) > best) best = straightEdgeIntensity(u), where = u;
    EXPECT_NEAR(where, 1.2172, 2e-4);
    EXPECT_NEAR(best, 1.3704, 2e-4);
}

TEST(FresnelIntegrals, EdgeExcessIsTheEdgeMinusTheStepAndIntegratesToZero) {
    const FresnelEdgeExcess& excess = FresnelEdgeExcess::instance();
    // The tails beyond ±K return as a constant, about 1/(2π²K²) (the 1/(2π²u²) both sides tend
    // to; the oscillating term's tail, cos(πK²/2 + …)/(π²K²), is of the same order: ±20 %).
    const double k = FresnelEdgeExcess::kReach;
    EXPECT_NEAR(excess.offset() / (1.0 / (2.0 * kPi * kPi * k * k)), 1.0, 0.2);
    double integral = 0.0, worst = 0.0;
    const double h = 1e-4;
    for (double u = -k + 0.5 * h; u < k; u += h) {
        integral += excess(u) * h;
        worst = std::max(worst, std::abs(excess(u) - (straightEdgeIntensity(u) - (u > 0.0 ? 1.0 : 0.0) + excess.offset())));
    }
    EXPECT_LT(std::abs(integral), 1e-6);
    // Linear interpolation at h = 1/256: h²/8 · |I''|, where |I''| ≤ 1 + 2πu grows with the
    // ripples' frequency: 1e-4 at u = 8 (0.3 % of the ripple there).
    EXPECT_LT(worst, 1e-4);
    EXPECT_EQ(excess(k), 0.0);
    EXPECT_EQ(excess(-k - 1.0), 0.0);
}

// The smeared ripples against an independent average: the excess at u₀ + b·x over a sunflower
// lattice of 65 536 points uniform on the unit disk (its x is the semicircle law), the peak over
// u₀ on a 1/50 grid. Both sample the same table; the lattice's error on the excess's unit step
// is about its spacing across the disk, 1/256 of the jump over ~b·256 points of a row: < 1e-3.
TEST(FresnelIntegrals, SmearedPeakIsTheEdgeAveragedOverADisk) {
    const FresnelEdgeExcess& excess = FresnelEdgeExcess::instance();
    const int points = 65536;
    std::vector<double> x(points);
    const double golden = kPi * (3.0 - std::sqrt(5.0));
    for (int i = 0; i < points; ++i) x[i] = std::sqrt((i + 0.5) / points) * std::cos(golden * i);
    for (double b : {0.5, 2.0, 5.0}) {
        double peak = 0.0;
        for (double u0 = -b - 4.0; u0 <= b + 4.0; u0 += 0.02) {
            double sum = 0.0;
            for (double xi : x) sum += excess(u0 + b * xi);
            peak = std::max(peak, std::abs(sum / points));
        }
        EXPECT_NEAR(excess.smearedPeak(b), peak, 1e-3 + 0.02 * peak) << b;
    }
    // Unsmeared, the peak is the excess's own: |¼ − 1| just inside the edge.
    EXPECT_NEAR(excess.smearedPeak(0.0), 0.75, 0.01);
    // Falling past the first w, so that the bisection's answer holds for every larger disk.
    double previous = excess.smearedPeak(1.0);
    for (double b = 1.25; b <= 16.0; b += 0.25) {
        const double peak = excess.smearedPeak(b);
        EXPECT_LE(peak, previous + 1e-6) << b;
        previous = peak;
    }
    const double limit = excess.smearRadiusFor(kMinSmearedRipple);
    EXPECT_LE(excess.smearedPeak(limit), kMinSmearedRipple);
    EXPECT_GT(excess.smearedPeak(limit - 1.0 / 32.0), kMinSmearedRipple);
    EXPECT_GT(limit, 2.0);
    EXPECT_LT(limit, 8.0);
}

// A stop in front of a plane-parallel plate: the ghost between the plate's faces is a collimated
// beam (A' = 1) whose reduced path from the stop to the sensor is 1 + 3·5/n + 10 mm.
TEST(GhostFresnelScale, PlateGhostIsTheReducedPathFromTheStop) {
    const std::string text = R"(name plate
focal_length_mm 1
sensor width_mm=60 height_mm=60 reflectance=0
surfaces
 stop  1    air     10
 inf   5    n=1.5   12
 inf   10   air     12
)";
    const LensSystem lens = LensSystem::build(parseLensText(text, "plate.lens"));
    const SpectralIndices indices = lens.indicesAt(550.0);
    const GhostFresnelScale plate = ghostFresnelScale(lens, indices, GhostPath{{2, 1}});
    ASSERT_TRUE(plate.valid);
    EXPECT_NEAR(plate.magnification, 1.0, 1e-12);
    EXPECT_NEAR(plate.distanceMm, 1.0 + 3.0 * 5.0 / 1.5 + 10.0, 1e-9);
    EXPECT_NEAR(plate.imageRadiusMm, lens.iris().radiusMm(), 1e-12);
    // w = √(λz/2), N = r² / (λz).
    EXPECT_NEAR(plate.edgeScaleMm(550.0), std::sqrt(0.5 * 550e-6 * 21.0), 1e-12);
    EXPECT_NEAR(plate.fresnelNumber(550.0), std::pow(lens.iris().radiusMm(), 2) / (550e-6 * 21.0), 1e-6);
}

// The direct image of a lens focused on infinity is no defocused image: z = 0.
TEST(GhostFresnelScale, DirectImageInFocusHasNoFresnelDistance) {
    const std::string text = "name singlet\nfocal_length_mm 100\nsensor width_mm=10 height_mm=10\nsurfaces\n"
                             " stop 2 air 10\n 60 6 N-BK7 12\n -200 auto air 12\n";
    const LensSystem lens = LensSystem::build(parseLensText(text, "singlet.lens"));
    const GhostFresnelScale direct = ghostFresnelScale(lens, lens.indicesAt(587.6), GhostPath{});
    ASSERT_TRUE(direct.valid);
    EXPECT_LT(direct.distanceMm, 1e-3);  // of a ~100 mm path: the focus solve's precision
    // A ghost of the same lens is defocused by millimetres.
    const GhostFresnelScale ghost = ghostFresnelScale(lens, lens.indicesAt(587.6), GhostPath{{2, 1}});
    ASSERT_TRUE(ghost.valid);
    EXPECT_GT(ghost.distanceMm, 1.0);
}

// How far a rim moves per radian of the light's direction, against 2 × 2 ray-transfer matrices
// multiplied out here: a singlet, the stop 30 mm behind it and the sensor 20 mm short of its
// focus (a defocused image of the stop, as a ghost is), G = T₁₂ − T₁₁·F₁₂ / F₁₁ (F: vertex to
// stop, T: vertex to sensor, on (height, reduced slope)); and for the singlet in focus, G is
// the focal length (the image of a far point moves f per radian whatever the stop).
TEST(GhostFresnelScale, RimMovesWithTheLightAsTheRayTransferMatricesSay) {
    const double r1 = 60.0, r2 = -200.0, thickness = 6.0, stopGap = 30.0, sensorGap = 50.0;
    const std::string text = "name singlet\nfocal_length_mm 100\nsensor width_mm=40 height_mm=40\nsurfaces\n 60 6 N-BK7 12\n"
                             " -200 30 air 12\n stop 50 air 5\n";
    const LensSystem lens = LensSystem::build(parseLensText(text, "singlet.lens"));
    const SpectralIndices indices = lens.indicesAt(587.6);
    const double n = indices.n[1];
    ASSERT_GT(n, 1.4);
    using M = std::array<double, 4>;  // row-major 2 × 2
    auto mul = [](const M& a, const M& b) {
        return M{a[0] * b[0] + a[1] * b[2], a[0] * b[1] + a[1] * b[3], a[2] * b[0] + a[3] * b[2], a[2] * b[1] + a[3] * b[3]};
    };
    auto gap = [](double reducedMm) { return M{1.0, reducedMm, 0.0, 1.0}; };
    auto surface = [](double radiusMm, double nBefore, double nAfter) { return M{1.0, 0.0, -(nAfter - nBefore) / radiusMm, 1.0}; };
    const M toStop = mul(gap(stopGap), mul(surface(r2, n, 1.0), mul(gap(thickness / n), surface(r1, 1.0, n))));
    const M toSensor = mul(gap(sensorGap), toStop);
    const double expected = toSensor[1] - toSensor[0] * toStop[1] / toStop[0];
    const GhostFresnelScale defocused = ghostFresnelScale(lens, indices, GhostPath{});
    ASSERT_TRUE(defocused.valid);
    EXPECT_NEAR(defocused.fieldShiftMmPerRad, expected, 1e-9 * std::abs(expected));
    EXPECT_GT(defocused.distanceMm, 1.0);

    const std::string focused = "name singlet\nfocal_length_mm 100\nsensor width_mm=10 height_mm=10\nsurfaces\n"
                                " stop 2 air 10\n 60 6 N-BK7 12\n -200 auto air 12\n";
    const LensSystem inFocus = LensSystem::build(parseLensText(focused, "singlet.lens"));
    const GhostFresnelScale direct = ghostFresnelScale(inFocus, inFocus.indicesAt(587.6), GhostPath{});
    ASSERT_TRUE(direct.valid);
    const double efl = paraxialEflMm(inFocus, inFocus.indicesAt(587.6));
    EXPECT_NEAR(direct.fieldShiftMmPerRad, efl, 1e-5 * efl);  // the focus solve's precision
}

// The renderer's choice: a point light's beams ring; a light whose disk moves the rim by the
// smear limit's w or more does not, one just inside it does; a ghost near its focus never rings.
TEST(GhostRinging, RipplesAreDrawnUnlessTheLightsDiskWashesThemOut) {
    GhostFresnelScale scale;
    scale.valid = true;
    scale.distanceMm = 10.0;
    scale.imageRadiusMm = 5.0;
    scale.fieldShiftMmPerRad = 40.0;
    const double wavelengthNm = 550.0, w = scale.edgeScaleMm(wavelengthNm);
    ASSERT_GT(scale.fresnelNumber(wavelengthNm), kMinRingingFresnelNumber);
    const double limit = FresnelEdgeExcess::instance().smearRadiusFor(kMinSmearedRipple);
    EXPECT_TRUE(ghostRipplesVisible(scale, wavelengthNm, 0.0));
    EXPECT_TRUE(ghostRipplesVisible(scale, wavelengthNm, 0.99 * limit * w / 40.0));
    EXPECT_FALSE(ghostRipplesVisible(scale, wavelengthNm, 1.01 * limit * w / 40.0));
    scale.fieldShiftMmPerRad = -40.0;  // an inverted image moves the other way, as far
    EXPECT_FALSE(ghostRipplesVisible(scale, wavelengthNm, 1.01 * limit * w / 40.0));
    scale.imageRadiusMm = 0.1;  // N = 1.8
    EXPECT_FALSE(ghostRipplesVisible(scale, wavelengthNm, 0.0));
    // The sun: 0.53° across.
    LightSpec sun;
    sun.angularDiameterDeg = 0.53;
    EXPECT_NEAR(sun.apparentRadiusRad(), 0.265 * kPi / 180.0, 1e-12);
    LightSpec disk;
    disk.type = LightSpec::Type::Disk;
    disk.radiusMm = 100.0;
    disk.positionMm = {0.0, 0.0, -10000.0};
    EXPECT_NEAR(disk.apparentRadiusRad(), std::atan(0.01), 1e-12);
    LightSpec point;
    point.type = LightSpec::Type::Point;
    EXPECT_EQ(point.apparentRadiusRad(), 0.0);
}

// A disk of radius `radiusPx` about `centre`, of unit irradiance, as a fan of `sides` triangles
// whose rim's mid-edges lie on the circle (the polygon's inradius is the radius).
GhostBeam diskBeam(const FilmFrame& frame, glm::dvec2 centre, double radiusPx, int sides) {
    const double circumradius = radiusPx / std::cos(kPi / sides);
    std::vector<glm::dvec2> rim(sides);
    for (int k = 0; k < sides; ++k) {
        const double a = 2.0 * kPi * (k + 0.5) / sides;  // the x axis crosses an edge's middle
        rim[k] = centre + circumradius * glm::dvec2(std::cos(a), std::sin(a));
    }
    std::vector<BeamTriangle> triangles;
    for (int k = 0; k < sides; ++k) {
        BeamTriangle t;
        const glm::dvec2 v[3] = {centre, rim[k], rim[(k + 1) % sides]};
        for (int c = 0; c < 3; ++c) {
            t.pupilMm[c] = v[c] * 0.01;  // any map: the vertices are shared exactly
            t.pixel[c] = v[c];
            t.throughput[c] = 1.0;
            t.irradiance[c] = 1.0;
        }
        t.imageAreaPx2 = 0.5 * std::abs((v[1].x - v[0].x) * (v[2].y - v[0].y) - (v[2].x - v[0].x) * (v[1].y - v[0].y));
        t.pupilAreaMm2 = t.imageAreaPx2 * 1e-4;
        triangles.push_back(t);
    }
    return GhostBeam::fromTriangles(std::move(triangles), frame);
}

// The whole image of a beam (Y of XYZ with scale 1), sampled at pixel centres + jitter.
std::vector<double> image(const GhostBeam& beam, const FilmFrame& frame, glm::dvec2 jitter = glm::dvec2(0.0)) {
    std::vector<double> out(static_cast<size_t>(frame.widthPx) * frame.heightPx, 0.0);
    const int bands = (frame.heightPx + Film::kBandRows - 1) / Film::kBandRows;
    std::vector<double> rows(static_cast<size_t>(Film::kBandRows) * frame.widthPx * 3);
    for (int b = 0; b < bands; ++b) {
        std::fill(rows.begin(), rows.end(), 0.0);
        beam.rasterise(b, jitter, glm::dvec3(1.0), 1, rows.data());
        for (int r = 0; r < Film::kBandRows && b * Film::kBandRows + r < frame.heightPx; ++r)
            for (int x = 0; x < frame.widthPx; ++x)
                out[static_cast<size_t>(b * Film::kBandRows + r) * frame.widthPx + x] =
                    rows[(static_cast<size_t>(r) * frame.widthPx + x) * 3 + 1];
    }
    return out;
}

double total(const std::vector<double>& v) {
    double s = 0.0;
    for (double x : v) s += x;
    return s;
}

// Fresnel diffraction of a uniformly lit disk of radius a at distance z (λz = 2w²), on a line
// through its centre: U(x) = (1/iλz) ∫∫_disk exp(iπ((x − x')² + y'²)/λz) dx' dy'. Across each chord
// (x' = a sin θ, half-length h = a cos θ) the y' integral is 2w (C(h/w) + i S(h/w)); the x'
// integral, in θ (smooth at the disk's ends), by Simpson's rule in steps of at most 0.05 rad of
// phase (a relative error ~1e-7 before the cancellations of the oscillating integrand).
class DiskFresnel {
public:
    DiskFresnel(double radius, double w, double maxX) : w_(w) {
        const double phaseRate = kPi / (w * w) * (radius + maxX) * radius;  // d(phase)/dθ at most
        const int steps = 2 * static_cast<int>(std::ceil(0.5 * kPi * phaseRate / 0.05));
        const double h = kPi / steps;
        for (int i = 0; i <= steps; ++i) {
            const double theta = -0.5 * kPi + i * h;
            const double weight = (i == 0 || i == steps) ? 1.0 : (i % 2 ? 4.0 : 2.0);
            const FresnelCS chord = fresnelIntegrals(radius * std::cos(theta) / w);
            const double factor = weight * h / 3.0 * 2.0 * w * radius * std::cos(theta);
            x_.push_back(radius * std::sin(theta));
            re_.push_back(factor * chord.c);
            im_.push_back(factor * chord.s);
        }
    }
    double intensity(double x) const {
        double re = 0.0, im = 0.0;
        const double k = 0.5 * kPi / (w_ * w_);
        for (size_t i = 0; i < x_.size(); ++i) {
            const double phase = k * (x - x_[i]) * (x - x_[i]);
            const double c = std::cos(phase), s = std::sin(phase);
            re += re_[i] * c - im_[i] * s;
            im += re_[i] * s + im_[i] * c;
        }
        const double scale = 1.0 / (2.0 * w_ * w_);  // |1 / iλz|
        return (re * re + im * im) * scale * scale;
    }

private:
    double w_;
    std::vector<double> x_, re_, im_;
};

struct Extremum {
    double position = 0.0, value = 0.0;
    bool maximum = false;
};

// The local extrema of samples f(x0 + i·dx), refined by a parabola through three samples.
std::vector<Extremum> extrema(const std::vector<double>& f, double x0, double dx) {
    std::vector<Extremum> out;
    for (size_t i = 1; i + 1 < f.size(); ++i) {
        const bool max = f[i] > f[i - 1] && f[i] >= f[i + 1], min = f[i] < f[i - 1] && f[i] <= f[i + 1];
        if (!max && !min) continue;
        const double denominator = f[i - 1] - 2.0 * f[i] + f[i + 1];
        const double shift = denominator != 0.0 ? 0.5 * (f[i - 1] - f[i + 1]) / denominator : 0.0;
        out.push_back({x0 + (i + shift) * dx, f[i] - 0.25 * (f[i - 1] - f[i + 1]) * shift, max});
    }
    return out;
}

// The ripples inside a circular ghost's rim: the first three maxima and minima, in position
// (from the rim, in units of w) and value, against the disk's Fresnel diffraction. The straight-
// edge model leaves out the rim's curvature (its edge wave converges inwards, its amplitude growing
// as √(R/(R − d))) and the wave from the opposite rim (≈ 0.6 w/R of the near one's at the first
// ripple): errors of order w/R in the ripples' amplitude, which the contrast's tolerance allows
// (measured: the model's contrast 4.1 % low at w/R = 0.03, 1.8 % at 0.013, 6 % at 0.063).
void compareRipples(double radiusPx, double w) {
    const int side = static_cast<int>(2.0 * radiusPx + 20.0 * w) | 1;
    const FilmFrame frame{side, side, side * 0.01, side * 0.01, 0.01};
    // The centre on a pixel centre's row: the row through it samples the profile along x, and
    // the jitter moves the samples by quarters of a pixel.
    const glm::dvec2 centre(0.5 * side, 0.5 * side);
    GhostBeam beam = diskBeam(frame, centre, radiusPx, 1024);
    beam.ring(w);
    const int row = side / 2, subSteps = 4;
    const double from = radiusPx - 5.0 * w, to = radiusPx + 1.0 * w;
    std::vector<double> model, reference;
    const double dx = 1.0 / subSteps;
    const DiskFresnel disk(radiusPx, w, to + 1.0);
    const int first = static_cast<int>(std::floor(centre.x + from)), last = static_cast<int>(std::ceil(centre.x + to));
    std::vector<std::vector<double>> images;
    for (int s = 0; s < subSteps; ++s) images.push_back(image(beam, frame, glm::dvec2(-0.5 + s * dx, 0.0)));
    for (int x = first; x <= last; ++x)
        for (int s = 0; s < subSteps; ++s) {
            const double rho = x + 0.5 + (-0.5 + s * dx) - centre.x;
            model.push_back(images[s][static_cast<size_t>(row) * side + x]);
            reference.push_back(disk.intensity(rho));
        }
    const double x0 = first + 0.5 - 0.5 - centre.x;
    const std::vector<Extremum> m = extrema(model, x0, dx), r = extrema(reference, x0, dx);
    // Inside the rim, nearest first.
    auto inside = [&](std::vector<Extremum> e) {
        std::vector<Extremum> out;
        for (auto it = e.rbegin(); it != e.rend(); ++it)
            if (it->position < radiusPx) out.push_back(*it);
        return out;
    };
    const std::vector<Extremum> mi = inside(m), ri = inside(r);
    ASSERT_GE(mi.size(), 6u);
    ASSERT_GE(ri.size(), 6u);
    for (size_t i = 0; i < 6; ++i) {
        SCOPED_TRACE("extremum " + std::to_string(i) + ", R = " + std::to_string(radiusPx) + " px, w = " + std::to_string(w));
        ASSERT_EQ(mi[i].maximum, ri[i].maximum);
        const double depthModel = (radiusPx - mi[i].position) / w, depthReference = (radiusPx - ri[i].position) / w;
        EXPECT_NEAR(depthModel / depthReference, 1.0, 0.02);
        EXPECT_NEAR(mi[i].value / ri[i].value, 1.0, 0.02);
    }
    // The first ripple's contrast, (max − min) / (max + min).
    const double cm = (mi[0].value - mi[1].value) / (mi[0].value + mi[1].value);
    const double cr = (ri[0].value - ri[1].value) / (ri[0].value + ri[1].value);
    EXPECT_NEAR(cm / cr, 1.0, 0.01 + 1.5 * w / radiusPx);
    // The reference itself: a quarter of the light on the rim, as behind a straight edge.
    EXPECT_NEAR(disk.intensity(radiusPx), 0.25, 0.02);
}

TEST(GhostRinging, CircularGhostRipplesMatchFresnelPropagationOfTheDisk) {
    compareRipples(100.0, 3.0);  // N = R² / (2w²) = 556
    compareRipples(150.0, 2.0);  // N = 2812
}

TEST(GhostRinging, ConservesPowerAndVanishesAsTheWavelengthDoes) {
    const int side = 301;
    const FilmFrame frame{side, side, 3.01, 3.01, 0.01};
    const glm::dvec2 centre(150.3, 149.8);
    const GhostBeam geometric = diskBeam(frame, centre, 90.0, 360);
    const std::vector<double> plain = image(geometric, frame);
    const double power = total(plain);
    for (double w : {4.0, 1.5, 0.6}) {
        GhostBeam ringing = diskBeam(frame, centre, 90.0, 360);
        ringing.ring(w);
        EXPECT_NEAR(total(image(ringing, frame)) / power, 1.0, 1e-3) << w;
    }
    // w ∝ √λ → 0: the image tends to the geometric one, its L1 difference like the band of
    // pixels within K·w of the rim (∝ w).
    double previous = 0.0;
    for (double w : {0.1, 0.01, 0.001}) {
        GhostBeam ringing = diskBeam(frame, centre, 90.0, 360);
        ringing.ring(w);
        const std::vector<double> rung = image(ringing, frame);
        double l1 = 0.0;
        for (size_t i = 0; i < rung.size(); ++i) l1 += std::abs(rung[i] - plain[i]);
        EXPECT_LT(l1 / power, 0.5 * w) << w;
        if (previous > 0.0) {
            EXPECT_LT(l1, 0.3 * previous) << w;
        }
        previous = l1;
    }
    // Without ring(), or with w = 0, the image is the geometric one, bit for bit.
    GhostBeam zero = diskBeam(frame, centre, 90.0, 360);
    zero.ring(0.0);
    EXPECT_TRUE(zero.rim().empty());
    EXPECT_EQ(image(zero, frame), plain);
}

// The switch, end to end: the scene's render.ghost_ringing off renders no ripples; on, the
// ghosts' power is unchanged and their rims differ.
TEST(GhostRinging, SceneSwitchKeepsPowerAndChangesOnlyRims) {
    const auto dir = test::freshDir("render", "ghost_ringing");
    Scene scene = loadScene(test::writeTinyScene(dir));
    const LensSystem lens = buildSceneLens(scene);
    scene.render.ghostRinging = false;
    const ScenePreview off = previewScene(scene, lens, false);
    scene.render.ghostRinging = true;
    const ScenePreview on = previewScene(scene, lens, false);
    ASSERT_EQ(off.ghosts.size(), on.ghosts.size());
    double powerOff = 0.0, powerOn = 0.0, changed = 0.0;
    for (size_t i = 1; i < on.ghosts.size(); i += 3) {
        powerOff += off.ghosts[i];
        powerOn += on.ghosts[i];
        changed += std::abs(on.ghosts[i] - off.ghosts[i]);
    }
    ASSERT_GT(powerOff, 0.0);
    EXPECT_NEAR(powerOn / powerOff, 1.0, 1e-3);
    EXPECT_GT(changed / powerOff, 1e-4);
}

}  // namespace
}  // namespace flare
