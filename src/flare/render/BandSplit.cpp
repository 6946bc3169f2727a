#include "flare/render/BandSplit.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>

namespace flare::renderer {

std::vector<int> bandsByRows(int bands, int ranks) {
    std::vector<int> start(static_cast<size_t>(ranks) + 1);
    for (int r = 0; r <= ranks; ++r) start[static_cast<size_t>(r)] = static_cast<int>(static_cast<long>(r) * bands / ranks);
    return start;
}

std::vector<int> balancedBands(std::span<const double> bandCost, std::span<const double> besides) {
    const int bands = static_cast<int>(bandCost.size()), ranks = static_cast<int>(besides.size());
    const double total = std::accumulate(bandCost.begin(), bandCost.end(), 0.0);
    if (!(total > 0.0) || !std::isfinite(total) || ranks < 2) return bandsByRows(bands, ranks);
    const double mean = (total + std::accumulate(besides.begin(), besides.end(), 0.0)) / ranks;
    std::vector<double> budget(static_cast<size_t>(ranks));
    for (int r = 0; r < ranks; ++r)
        budget[static_cast<size_t>(r)] =
            std::max(0.0, mean - besides[static_cast<size_t>(r)] +
                              (r == 0 ? kRootBandLead * mean : -kRootBandLead * mean / (ranks - 1)));
    const double budgets = std::accumulate(budget.begin(), budget.end(), 0.0);
    if (!(budgets > 0.0) || !std::isfinite(budgets)) return bandsByRows(bands, ranks);
    std::vector<int> start(static_cast<size_t>(ranks) + 1, bands);
    start[0] = 0;
    double target = 0.0, running = 0.0;
    int b = 0;
    for (int r = 0; r + 1 < ranks; ++r) {
        target += budget[static_cast<size_t>(r)] / budgets * total;
        // Up to the band whose end is nearest the target.
        while (b < bands && running + 0.5 * bandCost[static_cast<size_t>(b)] < target) running += bandCost[static_cast<size_t>(b++)];
        start[static_cast<size_t>(r) + 1] = b;
    }
    return start;
}

std::vector<double> bandPixels(std::span<const PixelBox> boxes, int heightPx, int bandRows) {
    const int bands = heightPx > 0 && bandRows > 0 ? (heightPx + bandRows - 1) / bandRows : 0;
    std::vector<double> pixels(static_cast<size_t>(bands), 0.0);
    if (bands == 0) return pixels;
    // Per row, the boxes' columns starting and ending there (a difference array).
    std::vector<std::int64_t> columnsFrom(static_cast<size_t>(heightPx) + 1, 0);
    for (const PixelBox& box : boxes) {
        const int y0 = std::clamp(box.y0, 0, heightPx), y1 = std::clamp(box.y1, 0, heightPx);
        if (box.x1 <= box.x0 || y1 <= y0) continue;
        const std::int64_t columns = static_cast<std::int64_t>(box.x1) - box.x0;
        columnsFrom[static_cast<size_t>(y0)] += columns;
        columnsFrom[static_cast<size_t>(y1)] -= columns;
    }
    std::int64_t columns = 0;
    for (int y = 0; y < heightPx; ++y) {
        columns += columnsFrom[static_cast<size_t>(y)];
        pixels[static_cast<size_t>(y / bandRows)] += static_cast<double>(columns);
    }
    return pixels;
}

}  // namespace flare::renderer
