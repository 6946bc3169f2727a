// The Fresnel/coating reflectance of every interface of a lens, tabulated over wavelength and
// incidence cosine for the photon tracer. Each photon carries its own wavelength, so the
// per-wavelength InterfaceTables of the bundle tracers do not serve it; evaluating a thin-film
// coating exactly costs a sincos and a dozen complex divisions per interface event, which was
// most of a photon's Fresnel cost.
//
// The table holds R(λ, cos θ) on a regular grid (by default 5 nm from 360 to 830 nm and 256
// intervals in cos θ), interpolated bilinearly. Near the critical angle of total internal
// reflection, where R has a square-root edge that moves with λ, and outside the tabulated
// wavelengths, the exact response is used. The interpolation error is measured against
// interfaceResponse in the tests (every shipped lens; the bound is stated there).
#pragma once

#include <vector>

#include "flare/optics/LensSystem.h"

namespace flare {

class SpectralReflectance {
public:
    SpectralReflectance(const LensSystem& lens, double fromNm = 380.0, double toNm = 780.0, double stepNm = 5.0,
                        int cosIntervals = 256);

    // interfaceResponse(lens, indices, surface, direction, cosThetaI).reflectance(), 1 under
    // total internal reflection (the probability with which a photon reflects), for a photon of
    // wavelength `wavelengthNm` whose indices are `indices` (= lens.indicesAt(wavelengthNm), used
    // where the exact response is evaluated).
    double reflectance(int surface, int direction, double wavelengthNm, const SpectralIndices& indices,
                       double cosThetaI) const;

    double fromNm() const { return fromNm_; }
    double toNm() const { return fromNm_ + stepNm_ * (nodes_ - 3); }

private:
    // One interface in one direction at one wavelength node.
    struct Node {
        double exactFrom = 2.0, exactTo = -1.0;  // evaluate exactly in this range of cosines
    };
    const float* row(int surface, int direction, int node) const {
        return values_.data() + ((static_cast<size_t>(surface) * 2 + (direction > 0 ? 1 : 0)) * nodes_ + node) *
                                    static_cast<size_t>(cosIntervals_ + 1);
    }
    const Node& node(int surface, int direction, int node) const {
        return zones_[(static_cast<size_t>(surface) * 2 + (direction > 0 ? 1 : 0)) * nodes_ + node];
    }

    const LensSystem* lens_;
    double fromNm_, stepNm_;
    int nodes_, cosIntervals_;
    std::vector<float> values_;  // surface × direction × node × cosine
    std::vector<Node> zones_;    // surface × direction × node
};

}  // namespace flare
