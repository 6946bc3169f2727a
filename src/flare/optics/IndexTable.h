// Refractive indices of every medium of a lens, tabulated every nanometre over the CIE range so
// that the photon tracer, which draws a new wavelength per photon, interpolates them instead of
// evaluating every glass's dispersion formula per photon. Linear interpolation between 1 nm
// samples of a smooth dispersion curve is accurate to ~1e-9 in n (the second derivative of n(λ)
// is below 1e-5 per nm² in the visible), far below any effect on a flare.
#pragma once

#include <vector>

#include "flare/optics/LensSystem.h"

namespace flare {

class IndexTable {
public:
    explicit IndexTable(const LensSystem& lens, double fromNm = 360.0, double toNm = 830.0);

    // Indices at any wavelength in the table's range (clamped to it outside).
    SpectralIndices at(double wavelengthNm) const;

private:
    int media_ = 0;     // surfaceCount + 1
    double fromNm_ = 0.0;
    int samples_ = 0;   // one per nanometre, both ends included
    std::vector<double> n_;  // samples_ × media_
};

}  // namespace flare
