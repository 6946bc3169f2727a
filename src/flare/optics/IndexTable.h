// Refractive indices of every medium of a lens, tabulated every nanometre over the CIE range so
// that the photon tracer, which draws a new wavelength per photon, interpolates them instead of
// evaluating every glass's dispersion formula per photon. Linear interpolation between 1 nm
// samples errs by at most h²/8 · |n''|: on the shipped lenses' glasses up to 1.7e-6 in n (at the
// blue end, where the curve bends most; test_index_table.cpp), which turns a ray by as much
// relative to its refraction, well under a micrometre on the sensor.
#pragma once

#include <vector>

#include "flare/optics/LensSystem.h"

namespace flare {

class IndexTable {
public:
    explicit IndexTable(const LensSystem& lens, double fromNm = 360.0, double toNm = 830.0);

    // Indices at any wavelength in the table's range (clamped to it outside).
    SpectralIndices at(double wavelengthNm) const;
    // The same into `out`: its wavelength and the lens's media (n[0 .. surfaceCount]), the rest
    // left as it is. (A SpectralIndices holds kMaxSurfaces + 1 media: for a photon per draw, zeroing
    // and copying them all cost more than interpolating the few a lens has.)
    void fill(double wavelengthNm, SpectralIndices& out) const;

private:
    int media_ = 0;     // surfaceCount + 1
    double fromNm_ = 0.0;
    int samples_ = 0;   // one per nanometre, both ends included
    std::vector<double> n_;  // samples_ × media_
};

}  // namespace flare
