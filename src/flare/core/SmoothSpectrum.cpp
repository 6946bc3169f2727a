#include "flare/core/SmoothSpectrum.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/matrix.hpp>

#include "flare/core/Spectrum.h"

namespace flare {

namespace {

// The fit's quadrature: Simpson's rule on every 1 nm interval of the CIE range (knots and
// midpoints every 0.5 nm), the rule spectrumXyz integrates with, of D65·(x̄, ȳ, z̄).
struct FitTable {
    std::vector<double> t;           // normalised wavelength of each node
    std::vector<glm::dvec3> weight;  // Simpson weight × D65 × cmf
    glm::dvec3 d65Xyz{0.0};          // Σ weight: the XYZ of σ ≡ 1
};

const FitTable& fitTable() {
    static const FitTable table = [] {
        FitTable f;
        const Spectrum d65 = Spectrum::d65();
        const int intervals = static_cast<int>(kCieMaxNm - kCieMinNm);
        for (int k = 0; k <= 2 * intervals; ++k) {
            const double nm = kCieMinNm + 0.5 * k;
            const double w = (k == 0 || k == 2 * intervals) ? 1.0 / 6.0 : (k % 2 == 1 ? 4.0 / 6.0 : 2.0 / 6.0);
            f.t.push_back((nm - kSmoothSpectrumCentreNm) / kSmoothSpectrumHalfWidthNm);
            f.weight.push_back(w * d65.value(nm) * cieXyzBar(nm));
            f.d65Xyz += f.weight.back();
        }
        return f;
    }();
    return table;
}

double sigmoid(double z) { return 0.5 + 0.5 * z / std::sqrt(1.0 + z * z); }

// The spectrum's colour as the "reflectance" of a surface under D65 in linear Rec.709: grey c = 0
// is (½, ½, ½).
glm::dvec3 fittedRgb(const glm::dvec3& c) {
    const FitTable& f = fitTable();
    glm::dvec3 xyz(0.0);
    for (size_t i = 0; i < f.t.size(); ++i) {
        const double t = f.t[i];
        xyz += f.weight[i] * sigmoid((c.x * t + c.y) * t + c.z);
    }
    return xyzToLinearSrgb(xyz / f.d65Xyz.y);
}

// Damped Gauss–Newton (Levenberg–Marquardt) from `c` towards the reflectance `target`.
glm::dvec3 solve(glm::dvec3 c, const glm::dvec3& target) {
    glm::dvec3 r = fittedRgb(c) - target;
    double damping = 1e-3;
    for (int iteration = 0; iteration < 100 && glm::dot(r, r) > 1e-26; ++iteration) {
        glm::dmat3 j;
        for (int k = 0; k < 3; ++k) {
            glm::dvec3 step(0.0);
            step[k] = 1e-6;
            j[k] = (fittedRgb(c + step) - fittedRgb(c - step)) / 2e-6;
        }
        const glm::dmat3 jt = glm::transpose(j);
        const glm::dmat3 normal = jt * j;
        bool improved = false;
        for (int attempt = 0; attempt < 30 && !improved; ++attempt) {
            glm::dmat3 a = normal;
            for (int k = 0; k < 3; ++k) a[k][k] *= 1.0 + damping;
            if (glm::determinant(a) == 0.0) { damping *= 10.0; continue; }
            const glm::dvec3 trial = c - glm::inverse(a) * (jt * r);
            const glm::dvec3 rt = fittedRgb(trial) - target;
            if (glm::dot(rt, rt) < glm::dot(r, r)) {
                c = trial;
                r = rt;
                damping = std::max(1e-9, damping * 0.3);
                improved = true;
            } else {
                damping *= 10.0;
            }
        }
        if (!improved) break;  // at the best reachable (a colour beyond the locus)
    }
    return c;
}

}  // namespace

double smoothSpectrumShape(const glm::dvec3& c, double wavelengthNm) {
    const double t = (wavelengthNm - kSmoothSpectrumCentreNm) / kSmoothSpectrumHalfWidthNm;
    return sigmoid((c.x * t + c.y) * t + c.z);
}

SmoothSpectrumFit fitSmoothSpectrum(const glm::dvec3& xyz) {
    SmoothSpectrumFit fit;
    const glm::dvec3 rgb = xyzToLinearSrgb(xyz);
    const double peak = std::max({rgb.x, rgb.y, rgb.z});
    if (!(xyz.y > 0.0) || !(peak > 0.0) || !std::isfinite(peak)) return fit;
    // As a surface's colour under D65 scaled to a peak of ½: grey is then exactly σ ≡ ½ (c = 0), and
    // every colour of the Rec.709 gamut lies inside what a reflectance in [0, 1] can reach.
    const glm::dvec3 target = 0.5 * rgb / peak;
    // Continued from grey in steps: each solve starts next to its solution.
    constexpr int kSteps = 8;
    glm::dvec3 c(0.0);
    for (int step = 1; step <= kSteps; ++step) {
        const double s = static_cast<double>(step) / kSteps;
        c = solve(c, glm::dvec3(0.5) * (1.0 - s) + target * s);
    }
    fit.coefficients = c;
    const glm::dvec2 wanted = xyChromaticity(xyz);
    const glm::dvec2 got = xyChromaticity(linearSrgbToXyz(fittedRgb(c)));
    fit.chromaticityError = std::hypot(wanted.x - got.x, wanted.y - got.y);
    return fit;
}

}  // namespace flare
