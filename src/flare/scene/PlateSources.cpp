#include "flare/scene/PlateSources.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>

namespace flare {

double automaticThreshold(const std::vector<float>& luminance, std::string* rule) {
    if (luminance.empty()) return 0.0;
    std::vector<float> sorted = luminance;
    const size_t k = std::min(sorted.size() - 1, static_cast<size_t>(std::floor(0.995 * static_cast<double>(sorted.size()))));
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(k), sorted.end());
    const double percentile = sorted[k];
    const double brightest = *std::max_element(luminance.begin(), luminance.end());
    const double threshold = std::max(percentile, 1e-3 * brightest);
    if (rule) {
        char text[200];
        std::snprintf(text, sizeof text, "automatic: max(99.5th percentile of Y = %.4g, 1e-3 x brightest Y = %.4g)",
                      percentile, 1e-3 * brightest);
        *rule = text;
    }
    return threshold;
}

PlateSources findPlateSources(const Plate& plate, std::optional<double> threshold, int cellPx) {
    const int w = plate.width, h = plate.height;
    const size_t n = static_cast<size_t>(w) * h;
    std::vector<float> luminance(n);
    const glm::dvec3 yRow(plate.space.toXyz[0].y, plate.space.toXyz[1].y, plate.space.toXyz[2].y);
    for (size_t i = 0; i < n; ++i)
        luminance[i] = static_cast<float>(glm::dot(yRow, glm::dvec3(plate.rgb[3 * i], plate.rgb[3 * i + 1], plate.rgb[3 * i + 2])));
    PlateSources out;
    out.maxLuminance = n ? *std::max_element(luminance.begin(), luminance.end()) : 0.0;
    if (threshold) {
        out.threshold = *threshold;
        out.thresholdRule = "given (--threshold)";
    } else {
        out.threshold = automaticThreshold(luminance, &out.thresholdRule);
    }
    // Connected components by a flood fill in scan order: deterministic labels.
    std::vector<int> label(n, -1);
    std::vector<std::vector<size_t>> groups;
    std::vector<size_t> stack;
    for (size_t start = 0; start < n; ++start) {
        if (label[start] >= 0 || !(luminance[start] > out.threshold)) continue;
        const int g = static_cast<int>(groups.size());
        groups.emplace_back();
        label[start] = g;
        stack.assign(1, start);
        while (!stack.empty()) {
            const size_t i = stack.back();
            stack.pop_back();
            groups[g].push_back(i);
            const int x = static_cast<int>(i % w), y = static_cast<int>(i / w);
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const int nx = x + dx, ny = y + dy;
                    if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
                    const size_t j = static_cast<size_t>(ny) * w + nx;
                    if (label[j] < 0 && luminance[j] > out.threshold) {
                        label[j] = g;
                        stack.push_back(j);
                    }
                }
        }
        std::sort(groups[g].begin(), groups[g].end());
    }
    out.groups = static_cast<int>(groups.size());
    // Cells on one grid of the frame: neighbouring pixels merge whether or not they touch (two
    // lamps a pixel apart, the strokes of a neon sign), as their ghosts coincide just as well.
    // Keyed by (row, column) of the grid: ordered, so deterministic.
    const int cell = std::max(1, cellPx);
    std::map<std::pair<int, int>, PlateSource> cells;
    for (int g = 0; g < out.groups; ++g)
        for (size_t i : groups[g]) {
            const int x = static_cast<int>(i % w), y = static_cast<int>(i / w);
            PlateSource& c = cells[{y / cell, x / cell}];
            if (c.pixelCount == 0) {
                c.group = g;
                c.minX = c.maxX = x;
                c.minY = c.maxY = y;
            }
            const glm::dvec3 xyz = plate.space.toXyz * plate.pixel(x, y);
            c.pixelCount += 1;
            c.xyzSum += xyz;
            c.centroidPx += xyz.y * glm::dvec2(x + 0.5, y + 0.5);
            c.minX = std::min(c.minX, x);
            c.maxX = std::max(c.maxX, x);
            c.minY = std::min(c.minY, y);
            c.maxY = std::max(c.maxY, y);
        }
    for (auto& [key, c] : cells) {
        c.centroidPx /= c.xyzSum.y;
        out.sourcePixels += c.pixelCount;
        out.cells.push_back(c);
    }
    return out;
}

}  // namespace flare
