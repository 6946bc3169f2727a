#include "flare/optics/Paraxial.h"

#include <cmath>
#include <limits>
#include <numbers>

namespace flare {

ParaxialRay paraxialForward(const LensSystem& lens, const SpectralIndices& indices, ParaxialRay ray,
                            int first, int last) {
    for (int k = first; k <= last; ++k) {
        const Surface& s = lens.surface(k);
        ray.y += ray.u * (s.vertexZMm - ray.zMm);
        ray.zMm = s.vertexZMm;
        const double nAfter = indices.n[k + 1];
        ray.u = (ray.n * ray.u - ray.y * s.curvature() * (nAfter - ray.n)) / nAfter;
        ray.n = nAfter;
    }
    return ray;
}

ParaxialRay paraxialBackward(const LensSystem& lens, const SpectralIndices& indices,
                             ParaxialRay ray, int last, int first) {
    for (int k = last; k >= first; --k) {
        const Surface& s = lens.surface(k);
        ray.y += ray.u * (ray.zMm - s.vertexZMm);
        ray.zMm = s.vertexZMm;
        const double nAfter = indices.n[k];
        ray.u = (ray.n * ray.u + ray.y * s.curvature() * (nAfter - ray.n)) / nAfter;
        ray.n = nAfter;
    }
    return ray;
}

namespace {

int lastSurface(const LensSystem& lens) { return lens.surfaceCount() - 1; }

// A ray from the axial object point at objectDistanceMm in front of the first vertex (parallel to
// the axis at unit height for an object at infinity).
ParaxialRay axialObjectRay(const LensSystem& lens, const SpectralIndices& indices, double objectDistanceMm) {
    const double z0 = lens.surface(0).vertexZMm;
    return std::isinf(objectDistanceMm) ? ParaxialRay{z0, 1.0, 0.0, indices.n[0]}
                                        : ParaxialRay{z0 - objectDistanceMm, 0.0, 1.0, indices.n[0]};
}

// Marginal ray from the axial object point, scaled to the edge of the stop.
ParaxialRay marginalRayInImageSpace(const LensSystem& lens, const SpectralIndices& indices,
                                    double objectDistanceMm) {
    ParaxialRay start = axialObjectRay(lens, indices, objectDistanceMm);
    const int stop = lens.stopIndex();
    const ParaxialRay atStop = paraxialForward(lens, indices, start, 0, stop);
    const double scale = atStop.y != 0.0 ? lens.iris().radiusMm() / atStop.y : 0.0;
    start.y *= scale;
    start.u *= scale;
    return paraxialForward(lens, indices, start, 0, lastSurface(lens));
}

}  // namespace

double paraxialEflMm(const LensSystem& lens, const SpectralIndices& indices) {
    const ParaxialRay out = paraxialForward(
        lens, indices, {lens.surface(0).vertexZMm, 1.0, 0.0, indices.n[0]}, 0, lastSurface(lens));
    return -1.0 / (out.n * out.u);
}

double paraxialImageZMm(const LensSystem& lens, const SpectralIndices& indices,
                        double objectDistanceMm) {
    const ParaxialRay out = paraxialForward(lens, indices, axialObjectRay(lens, indices, objectDistanceMm), 0,
                                            lastSurface(lens));
    return out.zMm - out.y / out.u;
}

double pupilMagnification(const LensSystem& lens, const SpectralIndices& indices) {
    const int stop = lens.stopIndex();
    if (stop == 0) return 1.0;
    const double zStop = lens.surface(stop).vertexZMm;
    // Axial ray (image of the stop centre) gives the pupil plane; a ray from the stop edge
    // parallel to the axis gives the height there.
    const ParaxialRay axial =
        paraxialBackward(lens, indices, {zStop, 0.0, 1.0, indices.n[stop]}, stop - 1, 0);
    const ParaxialRay edge =
        paraxialBackward(lens, indices, {zStop, 1.0, 0.0, indices.n[stop]}, stop - 1, 0);
    const double travel = -axial.y / axial.u;  // from the first vertex to the pupil, towards −z
    return std::abs(edge.y + edge.u * travel);
}

ParaxialData analyseParaxial(const LensSystem& lens, double wavelengthNm) {
    const SpectralIndices indices = lens.indicesAt(wavelengthNm);
    const int last = lastSurface(lens);
    const int stop = lens.stopIndex();
    const double z0 = lens.surface(0).vertexZMm;
    const double zLast = lens.surface(last).vertexZMm;
    const double zStop = lens.surface(stop).vertexZMm;
    const double stopRadius = lens.iris().radiusMm();

    ParaxialData data;
    data.wavelengthNm = wavelengthNm;

    const ParaxialRay parallel =
        paraxialForward(lens, indices, {z0, 1.0, 0.0, indices.n[0]}, 0, last);
    data.eflMm = -1.0 / (parallel.n * parallel.u);
    data.bflMm = -parallel.y / parallel.u;

    const ParaxialRay parallelBack =
        paraxialBackward(lens, indices, {zLast, 1.0, 0.0, indices.n[last + 1]}, last, 0);
    data.frontFocalDistanceMm = -parallelBack.y / parallelBack.u;

    data.imageDistanceMm = paraxialImageZMm(lens, indices, lens.objectDistanceMm()) - zLast;

    // Entrance pupil: image of the stop through the surfaces in front of it.
    if (stop == 0) {
        data.entrancePupilZMm = zStop;
        data.entrancePupilDiameterMm = 2.0 * stopRadius;
    } else {
        const ParaxialRay axial =
            paraxialBackward(lens, indices, {zStop, 0.0, 1.0, indices.n[stop]}, stop - 1, 0);
        const double travel = -axial.y / axial.u;
        data.entrancePupilZMm = axial.zMm - travel;
        data.entrancePupilDiameterMm = 2.0 * stopRadius * pupilMagnification(lens, indices);
    }
    // Exit pupil: image of the stop through the surfaces behind it.
    if (stop == last) {
        data.exitPupilZMm = zStop;
        data.exitPupilDiameterMm = 2.0 * stopRadius;
    } else {
        const ParaxialRay axial =
            paraxialForward(lens, indices, {zStop, 0.0, 1.0, indices.n[stop + 1]}, stop + 1, last);
        const ParaxialRay edge = paraxialForward(
            lens, indices, {zStop, stopRadius, 0.0, indices.n[stop + 1]}, stop + 1, last);
        data.exitPupilZMm = axial.zMm - axial.y / axial.u;
        data.exitPupilDiameterMm = 2.0 * std::abs(edge.y + edge.u * (data.exitPupilZMm - edge.zMm));
    }

    data.fNumber = data.eflMm / data.entrancePupilDiameterMm;
    const ParaxialRay marginal = marginalRayInImageSpace(lens, indices, lens.objectDistanceMm());
    data.workingFNumber = 1.0 / (2.0 * marginal.n * std::abs(marginal.u));
    data.paraxialFieldOfViewDeg =
        2.0 * std::atan(lens.sensorHalfDiagonalMm() / std::abs(data.eflMm)) * 180.0 / std::numbers::pi;
    data.totalTrackMm = lens.totalTrackMm();
    return data;
}

}  // namespace flare
