#include "flare/scene/PlateRegions.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include "flare/core/Error.h"
#include "flare/core/Spectrum.h"
#include "flare/ghosts/GhostAnalysis.h"
#include "flare/optics/PupilGrid.h"

namespace flare {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
// The palette's chromaticity step (CIE 1931 xy): pixels of one lamp share its colour; distinct
// lamps (sodium, LED, neon) differ by far more.
constexpr double kPaletteStepXy = 0.005;

double angleBetween(const glm::dvec3& a, const glm::dvec3& b) {
    return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
}

struct Point {
    size_t pixel;  // index into the source pixels
    glm::dvec2 fieldDeg;
    glm::dvec3 direction;
    double weight;  // luminance
};

// The luminance-weighted centre and the largest angle from it.
std::pair<glm::dvec3, double> centreAndRadius(const std::vector<Point>& points) {
    glm::dvec3 sum{0.0};
    for (const Point& p : points) sum += p.weight * p.direction;
    const glm::dvec3 centre = glm::length(sum) > 0.0 ? glm::normalize(sum) : points.front().direction;
    double radius = 0.0;
    for (const Point& p : points) radius = std::max(radius, angleBetween(centre, p.direction));
    return {centre, radius};
}

void split(std::vector<Point> points, double maxRadiusRad, std::vector<std::vector<Point>>& out) {
    if (points.empty()) return;
    if (centreAndRadius(points).second <= maxRadiusRad) {
        out.push_back(std::move(points));
        return;
    }
    glm::dvec2 lo{1e300}, hi{-1e300};
    for (const Point& p : points) lo = glm::min(lo, p.fieldDeg), hi = glm::max(hi, p.fieldDeg);
    const int axis = hi.x - lo.x >= hi.y - lo.y ? 0 : 1;
    const double middle = 0.5 * (lo[axis] + hi[axis]);
    std::vector<Point> below, above;
    for (Point& p : points) (p.fieldDeg[axis] <= middle ? below : above).push_back(p);
    if (below.empty() || above.empty()) {  // (every point at one field angle: radius 0, never here)
        out.push_back(std::move(points));
        return;
    }
    split(std::move(below), maxRadiusRad, out);
    split(std::move(above), maxRadiusRad, out);
}

// The direct path's throughput (mm²: sensor power per unit irradiance normal to the rays) at a
// direction, at the analysis's wavelength; and its spectral ratio for a colour.
struct DirectThroughput {
    GhostEstimate direct;
    PupilGrid grid;
    double areaMm2 = 0.0;
    double mm2() const { return direct.powerFraction * areaMm2; }
};
DirectThroughput directThroughput(const LensSystem& lens, const glm::dvec3& direction) {
    DirectThroughput t;
    const GhostAnalysisOptions options;
    t.grid = PupilGrid::forDirection(lens, direction);
    t.areaMm2 = t.grid.enteringAreaMm2(lens, 512);
    t.direct = estimatePath(lens, lens.indicesAt(options.wavelengthNm), t.grid, t.areaMm2, GhostPath{}, options);
    return t;
}

glm::dvec3 directionAtAngle(const glm::dvec3& centre, double thetaRad) {
    // The direction at angle θ from the axis in the azimuth of `centre`.
    const double azimuth = std::atan2(centre.y, centre.x);
    return {std::sin(thetaRad) * std::cos(azimuth), std::sin(thetaRad) * std::sin(azimuth), std::cos(thetaRad)};
}

}  // namespace

std::vector<PlateRegion> plateRegions(const PlateFieldMap& map, const PlateSources& pixels, double maxRadiusDeg) {
    std::vector<Point> points(pixels.cells.size());
    tbb::parallel_for(size_t(0), points.size(), [&](size_t i) {
        const PlateSource& p = pixels.cells[i];
        const glm::dvec2 field = map.fieldDeg(p.centroidPx);
        points[i] = {i, field, directionFromFieldDeg(field.x, field.y), p.xyzSum.y};
    });
    std::vector<std::vector<Point>> parts;
    split(std::move(points), maxRadiusDeg * kDeg, parts);
    std::vector<PlateRegion> regions;
    for (const std::vector<Point>& part : parts) {
        PlateRegion region;
        PlateSource& s = region.summary;
        for (const Point& p : part) {
            const PlateSource& pixel = pixels.cells[p.pixel];
            if (region.pixels.empty()) {
                s.group = pixel.group;
                s.minX = pixel.minX, s.maxX = pixel.maxX, s.minY = pixel.minY, s.maxY = pixel.maxY;
            }
            region.pixels.push_back(pixel);
            s.pixelCount += pixel.pixelCount;
            s.xyzSum += pixel.xyzSum;
            s.centroidPx += pixel.xyzSum.y * pixel.centroidPx;
            s.minX = std::min(s.minX, pixel.minX), s.maxX = std::max(s.maxX, pixel.maxX);
            s.minY = std::min(s.minY, pixel.minY), s.maxY = std::max(s.maxY, pixel.maxY);
        }
        s.centroidPx /= s.xyzSum.y;
        regions.push_back(std::move(region));
    }
    return regions;
}

PlateLightSet plateRegionLights(const LensSystem& lens, const PlateFieldMap& map, const std::vector<PlateRegion>& regions,
                                double cullShare, const std::string& prefix) {
    const size_t n = regions.size();
    std::vector<PlateLight> lights(n);
    std::vector<int> indexInGroup(n, 0);
    std::map<int, int> seen;
    for (size_t i = 0; i < n; ++i) indexInGroup[i] = seen[regions[i].summary.group]++;
    const double pixelAreaMm2 = map.pixelMm() * map.pixelMm();
    const GhostAnalysisOptions options;
    tbb::parallel_for(size_t(0), n, [&](size_t r) {
        const PlateRegion& region = regions[r];
        PlateLight& light = lights[r];
        light.cell = region.summary;
        LightSpec& spec = light.spec;
        spec.type = LightSpec::Type::Directional;
        spec.name = prefix + std::to_string(region.summary.group) + "-" + std::to_string(indexInGroup[r]);
        spec.spectrum.kind = SpectrumSpec::Kind::Rgb;
        spec.spectrum.rgb = xyzToLinearSrgb(region.summary.xyzSum / region.summary.xyzSum.y);
        auto refuse = [&](const glm::dvec2& px) {
            throw InputError(lens.name(), 0,
                             "no light of the source at pixel (" + std::to_string(px.x) + ", " + std::to_string(px.y) +
                                 ") reaches the sensor through the lens (vignetted)");
        };
        if (region.pixels.size() == 1) {
            // One pixel: a point the plate does not resolve, as plateLights makes it.
            const glm::dvec2 field = map.fieldDeg(region.summary.centroidPx);
            spec.fieldXDeg = field.x;
            spec.fieldYDeg = field.y;
            const DirectThroughput t = directThroughput(lens, spec.travelDirection());
            const double ratio = pathSpectrum(lens, t.grid, t.direct, toSpectrum(spec.spectrum), options.wavelengthNm).ratio;
            light.directThroughputMm2 = t.mm2() * ratio;
            if (!(light.directThroughputMm2 > 0.0)) refuse(region.summary.centroidPx);
            spec.power = region.summary.xyzSum.y * pixelAreaMm2 / light.directThroughputMm2;
            return;
        }
        // The points at their pixels' field angles, coloured from the region's palette.
        std::map<std::pair<long, long>, int> paletteOf;
        std::vector<glm::dvec3> paletteXyz;
        std::vector<int> colourOf(region.pixels.size());
        for (size_t i = 0; i < region.pixels.size(); ++i) {
            const glm::dvec2 xy = xyChromaticity(region.pixels[i].xyzSum);
            const std::pair<long, long> key{std::lround(xy.x / kPaletteStepXy), std::lround(xy.y / kPaletteStepXy)};
            const auto [it, added] = paletteOf.emplace(key, static_cast<int>(paletteXyz.size()));
            if (added) paletteXyz.emplace_back(0.0);
            paletteXyz[static_cast<size_t>(it->second)] += region.pixels[i].xyzSum;
            colourOf[i] = it->second;
        }
        spec.region.resize(region.pixels.size());
        for (size_t i = 0; i < region.pixels.size(); ++i) {
            const glm::dvec2 field = map.fieldDeg(region.pixels[i].centroidPx);
            spec.region[i] = {field.x, field.y, region.pixels[i].xyzSum.y, colourOf[i]};
        }
        spec.centreOnRegion();  // (by luminance, before the powers replace it)
        for (const glm::dvec3& xyz : paletteXyz) spec.regionColours.push_back(xyzToLinearSrgb(xyz / xyz.y));
        // The direct throughput: at the centre exactly, and its change across the region along the
        // centre's azimuth (the lens is round: the vignetting depends on the field angle) from a
        // parabola through the region's nearest, central and farthest field angles; per colour,
        // its spectral ratio at the centre.
        const glm::dvec3 centre = spec.travelDirection();
        const double thetaC = std::acos(std::clamp(centre.z, -1.0, 1.0));
        double thetaLo = thetaC, thetaHi = thetaC;
        for (const RegionPoint& p : spec.region) {
            const double theta = std::acos(std::clamp(directionFromFieldDeg(p.fieldXDeg, p.fieldYDeg).z, -1.0, 1.0));
            thetaLo = std::min(thetaLo, theta), thetaHi = std::max(thetaHi, theta);
        }
        const DirectThroughput atCentre = directThroughput(lens, centre);
        const double tC = atCentre.mm2();
        if (!(tC > 0.0)) refuse(region.summary.centroidPx);
        const double tLo = thetaLo < thetaC - 1e-9 ? directThroughput(lens, directionAtAngle(centre, thetaLo)).mm2() : tC;
        const double tHi = thetaHi > thetaC + 1e-9 ? directThroughput(lens, directionAtAngle(centre, thetaHi)).mm2() : tC;
        auto relative = [&](double theta) {
            // Lagrange through (θlo, tLo), (θc, tC), (θhi, tHi), over tC; linear where two coincide.
            const double x0 = thetaLo, x1 = thetaC, x2 = thetaHi;
            double t = tC;
            if (x1 - x0 > 1e-9 && x2 - x1 > 1e-9)
                t = tLo * (theta - x1) * (theta - x2) / ((x0 - x1) * (x0 - x2)) +
                    tC * (theta - x0) * (theta - x2) / ((x1 - x0) * (x1 - x2)) +
                    tHi * (theta - x0) * (theta - x1) / ((x2 - x0) * (x2 - x1));
            else if (x1 - x0 > 1e-9)
                t = tC + (tC - tLo) * (theta - x1) / (x1 - x0);
            else if (x2 - x1 > 1e-9)
                t = tC + (tHi - tC) * (theta - x1) / (x2 - x1);
            return t / tC;
        };
        std::vector<double> colourRatio;
        for (const glm::dvec3& rgb : spec.regionColours) {
            SpectrumSpec colour;
            colour.kind = SpectrumSpec::Kind::Rgb;
            colour.rgb = rgb;
            colourRatio.push_back(pathSpectrum(lens, atCentre.grid, atCentre.direct, toSpectrum(colour), options.wavelengthNm).ratio);
        }
        // Each point's irradiance: its pixel's energy over its own direct throughput.
        double total = 0.0;
        for (size_t i = 0; i < spec.region.size(); ++i) {
            RegionPoint& p = spec.region[i];
            const double theta = std::acos(std::clamp(directionFromFieldDeg(p.fieldXDeg, p.fieldYDeg).z, -1.0, 1.0));
            const double throughputMm2 = tC * relative(theta) * colourRatio[static_cast<size_t>(p.colour)];
            if (!(throughputMm2 > 0.0)) refuse(region.pixels[i].centroidPx);
            p.share = region.pixels[i].xyzSum.y * pixelAreaMm2 / throughputMm2;
            total += p.share;
        }
        for (RegionPoint& p : spec.region) p.share /= total;
        spec.centreOnRegion();  // (by power: as a scene file's region light is centred)
        spec.power = total;
        light.directThroughputMm2 = region.summary.xyzSum.y * pixelAreaMm2 / total;
    });
    return cullDimmestLights(std::move(lights), cullShare);
}

}  // namespace flare
