#include "flare/optics/LensCheck.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <numbers>
#include <optional>

#include "flare/core/Error.h"
#include "flare/optics/LensSystem.h"
#include "flare/optics/Paraxial.h"
#include "flare/optics/RealRays.h"
#include "flare/optics/SequentialTracer.h"

namespace flare {

namespace {

std::string format(const char* pattern, double a, double b = 0.0, double c = 0.0) {
    char buffer[200];
    std::snprintf(buffer, sizeof buffer, pattern, a, b, c);
    return buffer;
}

bool finite(const Ray& ray) {
    for (int i = 0; i < 3; ++i)
        if (!std::isfinite(ray.originMm[i]) || !std::isfinite(ray.direction[i])) return false;
    return true;
}

// The problem of one ray from an axial object at infinity aimed at (x, y) mm on the stop: "" when
// it reaches the sensor through every aperture with a finite position and direction.
std::string axialRayProblem(const LensSystem& lens, const SpectralIndices& indices, double x, double y,
                            const std::string& aimedAt) {
    const std::optional<Ray> ray = aimAtStop(lens, indices, 0.0, x, y);
    if (!ray) return format("no axial ray could be aimed at (%.3f, %.3f) mm on the stop", x, y);
    const TraceResult result = traceForward(lens, indices, *ray);
    if (!result.ok())
        return "the axial ray aimed at " + aimedAt + format(" ends at surface %.0f: ", result.surface + 1.0) +
               toString(result.status);
    if (!finite(result.ray)) return "a fan ray reached the sensor with a non-finite position or direction";
    return "";
}

// The first fan ray that does not reach the sensor, described; "" when all do. The fan fills the
// round opening of the iris's (area-equivalent) radius: the beam the f-number describes.
std::string rayFanProblem(const LensSystem& lens) {
    const SpectralIndices indices = lens.indicesAt(kLineDNm);
    const double directions[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
    const double radiusMm = lens.iris().radiusMm();
    for (double fraction : kFanPupilFractions) {
        for (const auto& d : directions) {
            const std::string problem =
                axialRayProblem(lens, indices, fraction * radiusMm * d[0], fraction * radiusMm * d[1],
                                format("%.0f %% of the opening's radius", 100.0 * fraction));
            if (!problem.empty()) return problem;
            if (fraction == 0.0) break;  // the centre ray once
        }
    }
    return "";
}

// For a bladed iris: the first corner of the opening (kFanPupilFractions' outermost share of the way
// out to it) through which no axial ray reaches the sensor, described; "" when all pass or the iris
// is round.
std::string irisCornerProblem(const LensSystem& lens) {
    const Iris& iris = lens.iris();
    if (iris.blades() < 3) return "";
    const SpectralIndices indices = lens.indicesAt(kLineDNm);
    const double outermost = kFanPupilFractions[std::size(kFanPupilFractions) - 1];
    for (int k = 0; k < iris.blades(); ++k) {
        const double angle = iris.rotationRad() + 2.0 * std::numbers::pi * k / iris.blades();
        const double dx = std::cos(angle), dy = std::sin(angle);
        // The opening's radius in this direction: the margin of the unit point d is (1/ρ)² − 1.
        const double openingMm = 1.0 / std::sqrt(iris.margin(dx, dy) + 1.0);
        const std::string problem =
            axialRayProblem(lens, indices, outermost * openingMm * dx, outermost * openingMm * dy,
                            format("corner %.0f of the iris (r = %.3f mm on the stop)", k + 1.0, openingMm));
        if (!problem.empty()) return problem;
    }
    return "";
}

}  // namespace

LensCheckReport checkLens(const LensPrescription& prescription) {
    LensCheckReport report;
    std::vector<std::string> zooms;
    for (const ZoomPosition& z : prescription.zoomPositions) zooms.push_back(z.name);
    if (zooms.empty()) zooms.push_back("");
    const bool statesFocalLength = !prescription.zoomPositions.empty() || prescription.focalLengthMm;
    if (!statesFocalLength)
        report.notes.push_back({"efl", "", "the file states no focal length: the paraxial EFL is reported, not compared"});
    if (!prescription.fNumber)
        report.notes.push_back({"stop", "", "the file states no f-number: the stop is not checked and the ray fan "
                                            "runs at the stop's own wide-open f-number"});
    // The fan's beam is the round one the f-number describes, whatever the iris's shape.
    LensPrescription round = prescription;
    round.iris.blades = 0;
    for (size_t i = 0; i < zooms.size(); ++i) {
        const std::string& zoom = zooms[i];
        const LensSystem open = LensSystem::build(prescription, LensState{zoom, {}, {}});
        const ParaxialData para = analyseParaxial(open, kLineDNm);
        LensCheckPosition position;
        position.zoom = zoom;
        position.statedFocalLengthMm = prescription.zoomPositions.empty() ? prescription.focalLengthMm.value_or(0.0)
                                                                          : prescription.zoomPositions[i].focalLengthMm;
        position.eflMm = para.eflMm;
        position.wideOpenFNumber = para.fNumber;

        const double stated = position.statedFocalLengthMm;
        if (statesFocalLength) {
            const double relative = para.eflMm / stated - 1.0;
            if (!(std::abs(relative) <= kEflRelativeTolerance))
                report.failures.push_back({"efl", zoom,
                                           format("paraxial EFL %.3f mm differs from the stated %.3f mm by %+.2f %%",
                                                  para.eflMm, stated, 100.0 * relative)});
        }
        if (!(para.fNumber > 0.0) || !std::isfinite(para.fNumber)) {
            report.failures.push_back({"stop", zoom, format("the stop opens to no finite f-number (f/%.3f)", para.fNumber)});
            report.positions.push_back(position);
            continue;
        }
        // A stop that opens to the stated f-number up to its rounding is found; the fan then runs
        // at the faster of the two that the lens reaches (wide open without a stated f-number).
        double fanFNumber = para.fNumber * (1.0 + 1e-9);
        if (prescription.fNumber) {
            const double statedFNumber = prescription.zoomPositions.empty()
                                             ? *prescription.fNumber
                                             : prescription.zoomPositions[i].fNumber.value_or(*prescription.fNumber);
            if (para.fNumber > statedFNumber + kFNumberRounding) {
                report.failures.push_back({"stop", zoom,
                                           format("the stop opens to f/%.3f, slower than the stated f/%.2f",
                                                  para.fNumber, statedFNumber)});
                report.positions.push_back(position);
                continue;
            }
            fanFNumber = std::max(statedFNumber, fanFNumber);
        }
        position.fanFNumber = fanFNumber;
        report.positions.push_back(position);
        const LensSystem roundBeam = LensSystem::build(round, LensState{zoom, {}, fanFNumber});
        if (const std::string problem = rayFanProblem(roundBeam); !problem.empty())
            report.failures.push_back({"ray_fan", zoom, format("at f/%.3f, ", fanFNumber) + problem});
        const LensSystem bladed = LensSystem::build(prescription, LensState{zoom, {}, fanFNumber});
        if (const std::string problem = irisCornerProblem(bladed); !problem.empty())
            report.notes.push_back({"ray_fan", zoom,
                                    format("at f/%.3f the %.0f-blade iris's corners reach beyond the round beam of "
                                           "the same area, and light through them is clipped: ",
                                           fanFNumber, static_cast<double>(bladed.iris().blades())) +
                                        problem});
    }
    return report;
}

}  // namespace flare
