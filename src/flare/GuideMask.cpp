#include "flare/GuideMask.h"

namespace flare {

GuideMask::GuideMask(const LivePupilRegion& region) {
    if (region.empty() || region.liveCount() == 0) return;
    cellMm_ = region.cellMm;
    cellsA_ = region.cellsA + 2;
    cellsB_ = region.cellsB + 2;
    aMinMm_ = region.aMinMm - cellMm_;
    bMinMm_ = region.bMinMm - cellMm_;
    live_.assign(static_cast<size_t>(cellsA_) * cellsB_, 0);
    for (int j = 0; j < region.cellsB; ++j)
        for (int i = 0; i < region.cellsA; ++i) {
            if (!region.live[static_cast<size_t>(j) * region.cellsA + i]) continue;
            for (int dj = 0; dj <= 2; ++dj)
                for (int di = 0; di <= 2; ++di) live_[static_cast<size_t>(j + dj) * cellsA_ + i + di] = 1;
        }
    for (size_t c = 0; c < live_.size(); ++c)
        if (live_[c]) cells_.push_back(static_cast<int>(c));
    areaMm2_ = static_cast<double>(cells_.size()) * cellMm_ * cellMm_;
}

}  // namespace flare
