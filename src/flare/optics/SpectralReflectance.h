// The Fresnel/coating reflectance of a lens's multilayer-coated interfaces, tabulated over
// wavelength and incidence cosine for the photon tracer. Each photon carries its own wavelength,
// so the per-wavelength InterfaceTables of the bundle tracers do not serve it. A stack of several
// thin films costs a complex 2×2 matrix product per layer at every interface event: about 100 ns
// for four layers against about 47 ns for a lookup in the table, whose scattered cache lines are
// most of its cost (`flare_bench --benchmark_filter=Reflectance`, one thread). A single layer
// costs 41 ns exactly, no more than a lookup, so single-layer and bare interfaces, ideal
// coatings (cheap, and kinked at their own wavelengths) and the iris are left exact.
//
// A tabulated interface holds R(λ, cos θ) on a regular grid (by default 5 nm from 380 to 780 nm
// and 256 intervals in cos θ), interpolated by Catmull-Rom splines in both. The exact response
// is used where a table would err: near the critical angle of total internal reflection (a
// square-root edge that moves with λ), at grazing incidence (cos θ < 0.03) and outside the
// tabulated wavelengths. Measured against interfaceResponse (test_spectral_reflectance.cpp):
// at most 2e-5 absolute and 4e-4 relative on a four-layer stack and on every shipped lens with
// its surfaces forced into the table.
#pragma once

#include <vector>

#include "flare/optics/LensSystem.h"

namespace flare {

class SpectralReflectance {
public:
    // Which interfaces get a table: those whose coating has at least two thin films, or all of
    // them (for tests of the table itself).
    enum class Tabulate { Multilayer, All };

    explicit SpectralReflectance(const LensSystem& lens, Tabulate which = Tabulate::Multilayer, double fromNm = 380.0,
                                 double toNm = 780.0, double stepNm = 5.0, int cosIntervals = 256);

    // interfaceResponse(lens, indices, surface, direction, cosThetaI).reflectance(), 1 under
    // total internal reflection (the probability with which a photon reflects), for a photon of
    // wavelength `wavelengthNm` whose indices are `indices` (= lens.indicesAt(wavelengthNm), used
    // where the exact response is evaluated).
    double reflectance(int surface, int direction, double wavelengthNm, const SpectralIndices& indices,
                       double cosThetaI) const;

    // Interfaces (surface and direction) with a table.
    int tabulatedInterfaces() const { return tabulated_; }
    double fromNm() const { return fromNm_; }
    double toNm() const { return fromNm_ + stepNm_ * (nodes_ - 3); }

private:
    // One tabulated interface in one direction: its cosines' rows, one per wavelength node, and
    // per node the range of cosines evaluated exactly.
    struct Interface {
        std::vector<float> values;  // node × cosine
        std::vector<double> exactFrom, exactTo;  // per node
    };
    // Per surface × direction, the index into interfaces_ or −1 (exact).
    int slot(int surface, int direction) const { return slots_[static_cast<size_t>(surface) * 2 + (direction > 0 ? 1 : 0)]; }

    const LensSystem* lens_;
    double fromNm_, stepNm_;
    int nodes_, cosIntervals_;
    int tabulated_ = 0;
    std::vector<int> slots_;
    std::vector<Interface> interfaces_;
};

}  // namespace flare
