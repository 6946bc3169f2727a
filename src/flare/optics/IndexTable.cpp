#include "flare/optics/IndexTable.h"

#include <algorithm>
#include <cmath>

namespace flare {

IndexTable::IndexTable(const LensSystem& lens, double fromNm, double toNm)
    : media_(lens.surfaceCount() + 1), fromNm_(fromNm),
      samples_(static_cast<int>(std::round(toNm - fromNm)) + 1) {
    n_.resize(static_cast<size_t>(samples_) * media_);
    for (int s = 0; s < samples_; ++s) {
        const SpectralIndices indices = lens.indicesAt(fromNm_ + s);
        std::copy_n(indices.n.begin(), media_, n_.begin() + static_cast<size_t>(s) * media_);
    }
}

SpectralIndices IndexTable::at(double wavelengthNm) const {
    SpectralIndices indices;
    fill(wavelengthNm, indices);
    return indices;
}

void IndexTable::fill(double wavelengthNm, SpectralIndices& out) const {
    const double x = std::clamp(wavelengthNm - fromNm_, 0.0, static_cast<double>(samples_ - 1));
    const int s = std::min(static_cast<int>(x), samples_ - 2);
    const double t = x - s;
    const double* lo = &n_[static_cast<size_t>(s) * media_];
    const double* hi = lo + media_;
    out.wavelengthNm = wavelengthNm;
    for (int m = 0; m < media_; ++m) out.n[m] = lo[m] + t * (hi[m] - lo[m]);
}

}  // namespace flare
