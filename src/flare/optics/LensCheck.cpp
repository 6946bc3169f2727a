#include "flare/optics/LensCheck.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
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

// The first fan ray that does not reach the sensor, described; "" when all do.
std::string rayFanProblem(const LensSystem& lens) {
    const SpectralIndices indices = lens.indicesAt(kLineDNm);
    const double directions[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
    for (double fraction : kFanPupilFractions) {
        for (const auto& d : directions) {
            // The opening's radius in this direction (a bladed iris is not round): the margin of
            // the unit point d is (1/ρ)² − 1.
            const double openingMm = 1.0 / std::sqrt(lens.iris().margin(d[0], d[1]) + 1.0);
            const double x = fraction * openingMm * d[0], y = fraction * openingMm * d[1];
            const std::optional<Ray> ray = aimAtStop(lens, indices, 0.0, x, y);
            if (!ray) return format("no axial ray could be aimed at (%.3f, %.3f) mm on the stop", x, y);
            const TraceResult result = traceForward(lens, indices, *ray);
            if (!result.ok())
                return format("the axial ray aimed at %.0f %% of the iris radius ends at surface %.0f: ",
                              100.0 * fraction, result.surface + 1.0) +
                       toString(result.status);
            if (!finite(result.ray)) return "a fan ray reached the sensor with a non-finite position or direction";
            if (fraction == 0.0) break;  // the centre ray once
        }
    }
    return "";
}

}  // namespace

LensCheckReport checkLens(const LensPrescription& prescription) {
    LensCheckReport report;
    std::vector<std::string> zooms;
    for (const ZoomPosition& z : prescription.zoomPositions) zooms.push_back(z.name);
    if (zooms.empty()) zooms.push_back("");
    if (!prescription.fNumber)
        report.failures.push_back({"f_number", "", "the file states no f_number to check the stop and the fan at"});
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
        report.positions.push_back(position);

        const double stated = position.statedFocalLengthMm;
        const double relative = stated > 0.0 ? para.eflMm / stated - 1.0 : INFINITY;
        if (!(std::abs(relative) <= kEflRelativeTolerance))
            report.failures.push_back({"efl", zoom,
                                       format("paraxial EFL %.3f mm differs from the stated %.3f mm by %+.2f %%",
                                              para.eflMm, stated, 100.0 * relative)});
        if (!prescription.fNumber) continue;
        // A stop that opens to the stated f-number up to its rounding is found; the fan then runs
        // at the faster of the two that the lens reaches.
        const double statedFNumber = *prescription.fNumber;
        if (!(para.fNumber > 0.0) || para.fNumber > statedFNumber + kFNumberRounding) {
            report.failures.push_back({"stop", zoom,
                                       format("the stop opens to f/%.3f, slower than the stated f/%.2f", para.fNumber,
                                              statedFNumber)});
            continue;
        }
        const double fanFNumber = std::max(statedFNumber, para.fNumber * (1.0 + 1e-9));
        const LensSystem stopped = LensSystem::build(prescription, LensState{zoom, {}, fanFNumber});
        if (const std::string problem = rayFanProblem(stopped); !problem.empty())
            report.failures.push_back({"ray_fan", zoom, format("at f/%.3f, ", fanFNumber) + problem});
    }
    return report;
}

}  // namespace flare
