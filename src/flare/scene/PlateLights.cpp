#include "flare/scene/PlateLights.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <tbb/parallel_for.h>

#include "flare/core/Error.h"
#include "flare/ghosts/GhostAnalysis.h"
#include "flare/optics/Paraxial.h"
#include "flare/optics/PupilGrid.h"
#include "flare/optics/RealRays.h"

namespace flare {

namespace {
constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kTableStepRad = 0.25 * kDeg;
constexpr double kMaxFieldRad = 89.9 * kDeg;
}  // namespace

PlateFieldMap::PlateFieldMap(const LensSystem& lens, int widthPx, int heightPx, double wavelengthNm)
    : lens_(lens), widthPx_(widthPx), heightPx_(heightPx), pixelMm_(lens.sensor().widthMm / widthPx),
      wavelengthNm_(wavelengthNm) {
    // The chief-ray height on a grid of fields out to the plate's corner (a little beyond, so that
    // every pixel is bracketed), each aim seeded by the last.
    const double cornerMm = 0.5 * pixelMm_ * std::hypot(widthPx, heightPx) * 1.01 + pixelMm_;
    tableRad_.push_back(0.0);
    tableMm_.push_back(0.0);
    for (double theta = kTableStepRad; tableMm_.back() < cornerMm; theta += kTableStepRad) {
        const std::optional<double> h = theta <= kMaxFieldRad ? imageHeightMm(theta) : std::nullopt;
        if (!h || *h <= tableMm_.back()) break;  // beyond the lens's field (or folding back)
        tableRad_.push_back(theta);
        tableMm_.push_back(*h);
    }
}

std::optional<double> PlateFieldMap::imageHeightMm(double thetaRad) const {
    if (thetaRad == 0.0) return 0.0;
    const std::optional<double> h = chiefRayImageHeightMm(lens_, lens_.indicesAt(wavelengthNm_), thetaRad);
    if (!h) return std::nullopt;
    return std::abs(*h);
}

double PlateFieldMap::fieldAngleRad(double heightMm) const {
    if (heightMm <= 0.0) return 0.0;
    const auto it = std::lower_bound(tableMm_.begin(), tableMm_.end(), heightMm);
    if (it == tableMm_.end())
        throw InputError(lens_.name(), 0,
                         "the plate reaches " + std::to_string(heightMm) + " mm from the centre of the sensor, beyond the " +
                             std::to_string(tableMm_.back()) + " mm the lens's chief rays reach (a smaller "
                             "--sensor-width-mm, or a lens with a wider field)");
    const size_t k = static_cast<size_t>(it - tableMm_.begin());
    if (*it == heightMm) return tableRad_[k];
    // Illinois (regula falsi) inside the bracket: h is smooth and increasing there.
    double a = tableRad_[k - 1], b = tableRad_[k];
    double fa = tableMm_[k - 1] - heightMm, fb = tableMm_[k] - heightMm;
    int side = 0;
    for (int iteration = 0; iteration < 100 && b - a > 1e-15; ++iteration) {
        const double c = (a * fb - b * fa) / (fb - fa);
        const std::optional<double> h = imageHeightMm(c);
        if (!h) break;
        const double fc = *h - heightMm;
        if (std::abs(fc) < 1e-9) return c;
        if ((fc < 0.0) == (fa < 0.0)) {
            a = c;
            fa = fc;
            if (side == -1) fb *= 0.5;
            side = -1;
        } else {
            b = c;
            fb = fc;
            if (side == 1) fa *= 0.5;
            side = 1;
        }
    }
    return 0.5 * (a + b);
}

glm::dvec2 PlateFieldMap::pictureMm(const glm::dvec2& px) const {
    return {(px.x - 0.5 * widthPx_) * pixelMm_, (0.5 * heightPx_ - px.y) * pixelMm_};
}

glm::dvec2 PlateFieldMap::pixelOf(const glm::dvec2& mm) const {
    return {mm.x / pixelMm_ + 0.5 * widthPx_, 0.5 * heightPx_ - mm.y / pixelMm_};
}

glm::dvec2 PlateFieldMap::fieldDeg(const glm::dvec2& px) const {
    const glm::dvec2 p = pictureMm(px);
    const double r = std::hypot(p.x, p.y);
    if (r == 0.0) return {0.0, 0.0};
    // A rotationally symmetric lens keeps the azimuth: the light lies in the direction of the pixel.
    const double tanTheta = std::tan(fieldAngleRad(r));
    return {std::atan(tanTheta * p.x / r) / kDeg, std::atan(tanTheta * p.y / r) / kDeg};
}

double PlateFieldMap::pixelSolidAngleSr(double thetaRad) const {
    // Radial: dθ/dh across a pixel; tangential: an arc of one pixel at height h spans p/h of
    // azimuth, sin θ · p/h of angle on the sphere. On the axis both are p/f.
    const double step = std::max(1e-6, 1e-4 * (thetaRad + kDeg));
    const double lo = std::max(0.0, thetaRad - step), hi = thetaRad + step;
    const std::optional<double> hLo = imageHeightMm(lo), hHi = imageHeightMm(hi), h = imageHeightMm(thetaRad);
    if (!hLo || !hHi || !h || !(*hHi > *hLo)) return 0.0;
    const double radial = pixelMm_ * (hi - lo) / (*hHi - *hLo);
    const double tangential = *h > 1e-9 ? pixelMm_ * std::sin(thetaRad) / *h : radial;
    return radial * tangential;
}

PlateLightSet plateLights(const LensSystem& lens, const PlateFieldMap& map, const PlateSources& sources, double cullShare,
                          const std::string& prefix) {
    const size_t n = sources.cells.size();
    std::vector<PlateLight> lights(n);
    // Names: the source (group) of the cell's first pixel, and the cell's count within it.
    std::vector<int> indexInGroup(n, 0);
    std::vector<int> seen(static_cast<size_t>(sources.groups), 0);
    for (size_t i = 0; i < n; ++i) indexInGroup[i] = seen[static_cast<size_t>(sources.cells[i].group)]++;
    const double pixelAreaMm2 = map.pixelMm() * map.pixelMm();
    GhostAnalysisOptions options;
    const SpectralIndices indices = lens.indicesAt(options.wavelengthNm);
    // Each light on its own (deterministic: no shared state but the read-only lens).
    tbb::parallel_for(size_t(0), n, [&](size_t i) {
        const PlateSource& cell = sources.cells[i];
        PlateLight& light = lights[i];
        light.cell = cell;
        LightSpec& spec = light.spec;
        spec.type = LightSpec::Type::Directional;
        spec.name = prefix + std::to_string(cell.group) + "-" + std::to_string(indexInGroup[i]);
        const glm::dvec2 field = map.fieldDeg(cell.centroidPx);
        spec.fieldXDeg = field.x;
        spec.fieldYDeg = field.y;
        // The colour, as linear Rec.709 at unit luminance (the spectrum's shape; power is apart).
        spec.spectrum.kind = SpectrumSpec::Kind::Rgb;
        spec.spectrum.rgb = xyzToLinearSrgb(cell.xyzSum / cell.xyzSum.y);
        // A one-pixel cell is a point the plate does not resolve; a larger one a disk of its solid angle.
        if (cell.pixelCount > 1) {
            const double theta = std::atan(std::hypot(std::tan(field.x * kDeg), std::tan(field.y * kDeg)));
            const double solidAngleSr = cell.pixelCount * map.pixelSolidAngleSr(theta);
            spec.angularDiameterDeg = 2.0 * std::sqrt(solidAngleSr / std::numbers::pi) / kDeg;
        }
        // The power whose direct image holds the cell's energy: the direct path's throughput at the
        // light's direction, in its spectrum (pathSpectrum's ratio to the analysis's wavelength).
        const PupilGrid grid = PupilGrid::forDirection(lens, spec.travelDirection());
        const double enteringAreaMm2 = grid.enteringAreaMm2(lens, 512);
        const GhostEstimate direct = estimatePath(lens, indices, grid, enteringAreaMm2, GhostPath{}, options);
        const double ratio = pathSpectrum(lens, grid, direct, toSpectrum(spec.spectrum), options.wavelengthNm).ratio;
        light.directThroughputMm2 = direct.powerFraction * enteringAreaMm2 * ratio;
        if (!(light.directThroughputMm2 > 0.0))
            throw InputError(lens.name(), 0,
                             "no light of the source at pixel (" + std::to_string(cell.centroidPx.x) + ", " +
                                 std::to_string(cell.centroidPx.y) + ") reaches the sensor through the lens (vignetted)");
        spec.power = cell.xyzSum.y * pixelAreaMm2 / light.directThroughputMm2;
    });
    return cullDimmestLights(std::move(lights), cullShare);
}

PlateLightSet cullDimmestLights(std::vector<PlateLight> lights, double cullShare) {
    std::stable_sort(lights.begin(), lights.end(), [](const PlateLight& a, const PlateLight& b) { return a.spec.power > b.spec.power; });
    PlateLightSet set;
    double total = 0.0;
    for (const PlateLight& l : lights) total += l.spec.power;
    double dropped = 0.0;
    size_t keep = lights.size();
    while (keep > 1 && dropped + lights[keep - 1].spec.power <= cullShare * total) dropped += lights[--keep].spec.power;
    set.culled = static_cast<int>(lights.size() - keep);
    set.culledPowerShare = total > 0.0 ? dropped / total : 0.0;
    lights.resize(keep);
    set.lights = std::move(lights);
    return set;
}

}  // namespace flare
