#include "flare/optics/LensDrawing.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <sstream>

#include "flare/optics/Paraxial.h"
#include "flare/optics/PupilGrid.h"
#include "flare/optics/RealRays.h"
#include "flare/optics/SequentialTracer.h"

namespace flare {

namespace {

constexpr const char* kFieldColours[] = {"#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"};

// Maps lens space (z along the page, x up) to SVG pixels.
struct Frame {
    double zMin, xMax, scale, marginPx;
    double px(double z) const { return marginPx + (z - zMin) * scale; }
    double py(double x) const { return marginPx + (xMax - x) * scale; }
};

std::string point(const Frame& f, double z, double x) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.2f,%.2f ", f.px(z), f.py(x));
    return buffer;
}

// Surface profile z(x) continued flat from the clear aperture to the element edge.
double profileZ(const Surface& s, double x) {
    const double r = std::min(std::abs(x), s.semiApertureMm);
    double sag = 0.0;
    if (!s.sagMm(r * r, &sag)) sag = 0.0;
    return s.vertexZMm + sag;
}

std::string glassFill(const Medium& m) {
    // Denser glass is drawn darker: a quick visual cue of the glass map.
    const double t = std::clamp((m.nd() - 1.4) / 0.6, 0.0, 1.0);
    const int r = static_cast<int>(200 - 90 * t), g = static_cast<int>(225 - 80 * t), b = 245;
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "rgb(%d,%d,%d)", r, g, b);
    return buffer;
}

}  // namespace

std::vector<DrawnRay> traceRayFans(const LensSystem& lens, const LensDrawingOptions& options) {
    std::vector<DrawnRay> rays;
    const SpectralIndices indices = lens.indicesAt(options.wavelengthNm);
    const double stopRadius = lens.iris().radiusMm();
    const double zFront = drawingStartZMm(lens);
    int fieldIndex = 0;
    for (double fieldDeg : options.fieldsDeg) {
        const std::string colour = kFieldColours[fieldIndex++ % std::size(kFieldColours)];
        const double field = fieldDeg * std::numbers::pi / 180.0;
        const std::optional<Ray> chief = aimAtStop(lens, indices, field, 0.0, 0.0);
        const int count = std::max(1, options.raysPerField);
        for (int i = 0; i < count; ++i) {
            const double u = count == 1 ? 0.0 : -1.0 + 2.0 * i / (count - 1);
            const std::optional<Ray> ray =
                aimAtStop(lens, indices, field, 0.98 * u * stopRadius, 0.0, chief ? &*chief : nullptr);
            if (!ray) continue;
            DrawnRay drawn;
            drawn.colour = colour;
            const double back = (ray->originMm.z - zFront) / ray->direction.z;
            drawn.pointsMm.push_back(ray->at(-back));
            TraceOptions traceOptions;
            traceOptions.fresnelWeights = false;
            traceOptions.pathPointsMm = &drawn.pointsMm;
            traceForward(lens, indices, *ray, traceOptions);
            rays.push_back(std::move(drawn));
        }
    }
    return rays;
}

double drawingStartZMm(const LensSystem& lens) { return objectSpaceStartZMm(lens) - 0.15 * lens.totalTrackMm(); }

std::string drawLensSvg(const LensSystem& lens, const std::vector<DrawnRay>& rays,
                        const LensDrawingOptions& options) {
    const int n = lens.surfaceCount();
    double xMax = lens.sensorHalfDiagonalMm();
    for (const HousingSection& h : lens.housing()) xMax = std::max(xMax, h.innerRadiusMm + 2.0);
    const double zMin = drawingStartZMm(lens);
    const double zMax = lens.sensorZMm() + 4.0;
    const double widthPx = 1100.0;
    const Frame f{zMin, xMax + 2.0, widthPx / (zMax - zMin), 40.0};
    const double heightPx = 2.0 * (xMax + 2.0) * f.scale + 2.0 * f.marginPx + 30.0;

    std::ostringstream svg;
    svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << widthPx + 2.0 * f.marginPx
        << "\" height=\"" << heightPx << "\" font-family=\"sans-serif\">\n";
    svg << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";

    // Optical axis.
    svg << "<line x1=\"" << f.px(zMin) << "\" y1=\"" << f.py(0) << "\" x2=\"" << f.px(zMax)
        << "\" y2=\"" << f.py(0) << "\" stroke=\"#999\" stroke-dasharray=\"6,4\"/>\n";

    // Barrel: the housing sections' inner wall, above and below the axis.
    for (int side : {1, -1}) {
        std::string wall;
        for (const HousingSection& h : lens.housing()) {
            wall += point(f, h.zStartMm, side * h.innerRadiusMm);
            wall += point(f, h.zEndMm, side * h.innerRadiusMm);
        }
        svg << "<polyline points=\"" << wall << "\" fill=\"none\" stroke=\"#444\" stroke-width=\"3\"/>\n";
    }

    // Elements: each glass-filled space between surface i and i+1, closed by its edge.
    constexpr int kSteps = 48;
    for (int i = 0; i + 1 < n; ++i) {
        const Medium& glass = lens.mediumBefore(i + 1);
        if (glass.isAir()) continue;
        const Surface& a = lens.surface(i);
        const Surface& b = lens.surface(i + 1);
        const double edge = std::max(a.mechSemiDiameterMm, b.mechSemiDiameterMm);
        std::string outline;
        for (int k = 0; k <= kSteps; ++k) {
            const double x = -edge + 2.0 * edge * k / kSteps;
            outline += point(f, profileZ(a, x), x);
        }
        for (int k = kSteps; k >= 0; --k) {
            const double x = -edge + 2.0 * edge * k / kSteps;
            outline += point(f, profileZ(b, x), x);
        }
        svg << "<polygon points=\"" << outline << "\" fill=\"" << glassFill(glass)
            << "\" stroke=\"#234\" stroke-width=\"1\"><title>" << glass.describe() << "</title></polygon>\n";
    }

    // Iris blades at the stop, from the opening to the barrel.
    const Surface& stop = lens.surface(lens.stopIndex());
    const double outer = lens.housing()[lens.stopIndex()].innerRadiusMm;
    for (int side : {1, -1}) {
        svg << "<line x1=\"" << f.px(stop.vertexZMm) << "\" y1=\"" << f.py(side * lens.iris().radiusMm())
            << "\" x2=\"" << f.px(stop.vertexZMm) << "\" y2=\"" << f.py(side * outer)
            << "\" stroke=\"black\" stroke-width=\"3\"/>\n";
    }

    // Sensor.
    const double half = 0.5 * lens.sensor().widthMm;
    svg << "<line x1=\"" << f.px(lens.sensorZMm()) << "\" y1=\"" << f.py(half) << "\" x2=\""
        << f.px(lens.sensorZMm()) << "\" y2=\"" << f.py(-half)
        << "\" stroke=\"#2a2\" stroke-width=\"4\"><title>sensor</title></line>\n";

    for (const DrawnRay& ray : rays) {
        std::string line;
        for (const glm::dvec3& p : ray.pointsMm) line += point(f, p.z, p.x);
        svg << "<polyline points=\"" << line << "\" fill=\"none\" stroke=\"" << ray.colour
            << "\" stroke-width=\"0.8\" stroke-opacity=\"0.85\"/>\n";
    }

    // Surface numbers (1-based, file order, counting the stop) above each vertex.
    for (int i = 0; i < n; ++i) {
        svg << "<text x=\"" << f.px(lens.surface(i).vertexZMm) << "\" y=\"" << f.marginPx - 8
            << "\" font-size=\"10\" text-anchor=\"middle\" fill=\"#555\">" << i + 1 << "</text>\n";
    }

    const ParaxialData para = analyseParaxial(lens, kLineDNm);
    char caption[256];
    std::snprintf(caption, sizeof caption, "%s — EFL %.2f mm, f/%.2f, track %.1f mm",
                  options.title.empty() ? lens.name().c_str() : options.title.c_str(), para.eflMm,
                  para.fNumber, para.totalTrackMm);
    svg << "<text x=\"" << f.marginPx << "\" y=\"" << heightPx - 12 << "\" font-size=\"14\">" << caption
        << "</text>\n";
    svg << "</svg>\n";
    return svg.str();
}

}  // namespace flare
