// First-order (paraxial) optics of a LensSystem: y–nu ray traces, cardinal distances, pupils,
// f-numbers and field of view, at any wavelength.
#pragma once

#include "flare/optics/LensSystem.h"

namespace flare {

// A paraxial ray at axial position zMm (lens space), with height y (mm) and slope u (dy per unit
// of travel along the direction of propagation), in a medium of index n.
struct ParaxialRay {
    double zMm = 0.0;
    double y = 0.0;
    double u = 0.0;
    double n = 1.0;
};

// Traces through surfaces first..last (inclusive, ascending) travelling towards +z. The ray must
// lie at or before surface `first`; the result lies on the vertex plane of `last`, after it.
ParaxialRay paraxialForward(const LensSystem& lens, const SpectralIndices& indices, ParaxialRay ray,
                            int first, int last);
// Traces through surfaces last..first (descending) travelling towards −z; slopes are taken along
// the direction of travel, so the mirrored surface has curvature −c.
ParaxialRay paraxialBackward(const LensSystem& lens, const SpectralIndices& indices,
                             ParaxialRay ray, int last, int first);

struct ParaxialData {
    double wavelengthNm = 0.0;
    double eflMm = 0.0;                // effective focal length
    double bflMm = 0.0;                // last vertex → rear focal point
    double frontFocalDistanceMm = 0.0; // front focal point → first vertex (> 0: in front)
    double imageDistanceMm = 0.0;      // last vertex → paraxial image of the object in focus
    double entrancePupilZMm = 0.0;     // lens space (first vertex at 0, + towards the sensor)
    double entrancePupilDiameterMm = 0.0;
    double exitPupilZMm = 0.0;
    double exitPupilDiameterMm = 0.0;
    double fNumber = 0.0;              // EFL / entrance-pupil diameter
    double workingFNumber = 0.0;       // 1 / (2 n' |u'|) for the object in focus
    double paraxialFieldOfViewDeg = 0.0;  // full diagonal angle, 2·atan(half diagonal / EFL)
    double totalTrackMm = 0.0;         // first vertex → sensor
};

ParaxialData analyseParaxial(const LensSystem& lens, double wavelengthNm);

// Paraxial position (lens-space z) of the image of an axial object at objectDistanceMm in front of
// the first vertex (infinity allowed). Used by the focus solve.
double paraxialImageZMm(const LensSystem& lens, const SpectralIndices& indices,
                        double objectDistanceMm);

// Entrance-pupil radius per unit of stop radius (the stop-to-entrance-pupil magnification).
double pupilMagnification(const LensSystem& lens, const SpectralIndices& indices);

// Paraxial effective focal length at the given indices.
double paraxialEflMm(const LensSystem& lens, const SpectralIndices& indices);

}  // namespace flare
