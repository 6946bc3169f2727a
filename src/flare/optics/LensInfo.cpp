#include "flare/optics/LensInfo.h"

#include <cmath>

#include "flare/optics/Paraxial.h"
#include "flare/optics/RealRays.h"

namespace flare {

namespace {

nlohmann::json jsonNumber(double value) {
    return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

}  // namespace

nlohmann::json lensInfoJson(const LensPrescription& prescription, const LensSystem& lens,
                            double wavelengthNm) {
    const ParaxialData para = analyseParaxial(lens, wavelengthNm);
    const RealFieldOfView realFov = realFieldOfView(lens, wavelengthNm);
    const SpectralIndices indices = lens.indicesAt(wavelengthNm);
    nlohmann::json j;
    j["name"] = lens.name();
    j["source"] = prescription.source;
    j["file"] = lens.sourceFile();
    j["wavelength_nm"] = wavelengthNm;
    if (prescription.focalLengthMm) j["nominal_focal_length_mm"] = *prescription.focalLengthMm;
    if (prescription.fNumber) j["nominal_f_number"] = *prescription.fNumber;
    if (!prescription.zoomPositions.empty()) {
        j["zoom"] = {{"position", lens.zoomName().empty() ? nlohmann::json(nullptr) : nlohmann::json(lens.zoomName())},
                     {"nominal_focal_length_mm", *lens.zoomFocalLengthMm()}};
        nlohmann::json positions = nlohmann::json::array();
        for (const ZoomPosition& z : prescription.zoomPositions) {
            const std::optional<double> fNumber = z.fNumber ? z.fNumber : prescription.fNumber;
            positions.push_back({{"name", z.name},
                                 {"focal_length_mm", z.focalLengthMm},
                                 {"f_number", fNumber ? nlohmann::json(*fNumber) : nlohmann::json(nullptr)}});
        }
        j["zoom_positions"] = positions;
    }
    j["efl_mm"] = para.eflMm;
    j["bfl_mm"] = para.bflMm;
    j["front_focal_distance_mm"] = para.frontFocalDistanceMm;
    j["object_distance_mm"] = jsonNumber(lens.objectDistanceMm());
    j["image_distance_mm"] = para.imageDistanceMm;
    j["entrance_pupil_z_mm"] = para.entrancePupilZMm;
    j["entrance_pupil_diameter_mm"] = para.entrancePupilDiameterMm;
    j["exit_pupil_z_mm"] = para.exitPupilZMm;
    j["exit_pupil_diameter_mm"] = para.exitPupilDiameterMm;
    j["f_number"] = para.fNumber;
    j["working_f_number"] = para.workingFNumber;
    j["field_of_view_deg"] = para.paraxialFieldOfViewDeg;
    // null unless the real chief ray reaches the sensor corner below a 90° field; fisheyes that
    // cover more than 180° say so with the chief-ray height at 89.9°.
    j["real_field_of_view_deg"] = realFov.kind == RealFieldOfView::Kind::Reached
                                      ? nlohmann::json(realFov.fullAngleDeg)
                                      : nlohmann::json(nullptr);
    j["real_field_of_view_beyond_180"] = realFov.kind == RealFieldOfView::Kind::Beyond180;
    if (realFov.kind == RealFieldOfView::Kind::Beyond180)
        j["chief_ray_height_at_89_9_deg_mm"] = realFov.maxFieldImageHeightMm;
    j["total_track_mm"] = para.totalTrackMm;
    j["sensor"] = {{"width_mm", lens.sensor().widthMm},
                   {"height_mm", lens.sensor().heightMm},
                   {"reflectance", lens.sensor().reflectance},
                   {"z_mm", lens.sensorZMm()}};
    j["iris"] = {{"blades", lens.iris().blades()}, {"radius_mm", lens.iris().radiusMm()}};
    j["surfaces"] = lens.surfaceCount();
    int reflecting = 0;
    nlohmann::json rows = nlohmann::json::array();
    for (int i = 0; i < lens.surfaceCount(); ++i) {
        const Surface& s = lens.surface(i);
        if (lens.isReflecting(i)) ++reflecting;
        const double next = i + 1 < lens.surfaceCount() ? lens.surface(i + 1).vertexZMm : lens.sensorZMm();
        const Coating* coating = lens.coating(i);
        rows.push_back({{"number", i + 1},
                        {"stop", s.isStop},
                        {"radius_mm", s.radiusMm == 0.0 ? nlohmann::json(nullptr) : nlohmann::json(s.radiusMm)},
                        {"thickness_mm", next - s.vertexZMm},
                        {"material", lens.mediumBefore(i + 1).describe()},
                        {"index", indices.n[i + 1]},
                        {"semi_aperture_mm", s.semiApertureMm},
                        {"coating", coating ? coating->name : "none"},
                        {"aspheric", s.hasPolynomial() || s.conic != 0.0}});
    }
    j["reflecting_surfaces"] = reflecting;
    j["surface_rows"] = rows;
    return j;
}

}  // namespace flare
