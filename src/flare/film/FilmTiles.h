// The film's pixel storage (internal to Film.cpp): a layer of 3 values per pixel (double, or float
// for layers accumulated in single precision), stored as kTilePx × kTilePx tiles allocated on first
// touch, so that a layer's memory follows the pixels light reached, not the frame.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <istream>
#include <memory>
#include <mutex>
#include <ostream>
#include <stdexcept>
#include <vector>

namespace flare::film {

inline constexpr int kTilePx = 32;
inline constexpr int kTileValues = kTilePx * kTilePx * 3;

template <class T>
void writeRaw(std::ostream& out, const T& value) {
    out.write(reinterpret_cast<const char*>(&value), sizeof(T));
}
template <class T>
T readRaw(std::istream& in) {
    T value{};
    in.read(reinterpret_cast<char*>(&value), sizeof(T));
    if (!in) throw std::runtime_error("checkpoint: truncated film data");
    return value;
}

template <class Value>
struct TileStore {
    int width, height, tilesX, tilesY;
    std::vector<std::unique_ptr<Value[]>> tiles;
    // Zeroed tiles given back (recycle) for the next allocations: a pass's tiles are allocated
    // again every pass, and fresh memory costs page faults. Bands allocate in parallel.
    std::vector<std::unique_ptr<Value[]>> spare;
    std::unique_ptr<std::mutex> spareMutex = std::make_unique<std::mutex>();

    TileStore(int w, int h)
        : width(w), height(h), tilesX((w + kTilePx - 1) / kTilePx), tilesY((h + kTilePx - 1) / kTilePx),
          tiles(static_cast<size_t>(tilesX) * tilesY) {}

    Value* at(int x, int y) {
        auto& tile = tiles[static_cast<size_t>(y / kTilePx) * tilesX + x / kTilePx];
        if (!tile) {
            std::lock_guard<std::mutex> lock(*spareMutex);
            if (spare.empty()) {
                tile = std::make_unique<Value[]>(kTileValues);  // zeroed
            } else {
                tile = std::move(spare.back());
                spare.pop_back();
            }
        }
        return &tile[(static_cast<size_t>(y % kTilePx) * kTilePx + x % kTilePx) * 3];
    }
    // Tile t, which must be all zeros, goes back to the spares.
    void recycle(size_t t) {
        std::lock_guard<std::mutex> lock(*spareMutex);
        spare.push_back(std::move(tiles[t]));
    }
    const Value* find(int x, int y) const {
        const auto& tile = tiles[static_cast<size_t>(y / kTilePx) * tilesX + x / kTilePx];
        return tile ? &tile[(static_cast<size_t>(y % kTilePx) * kTilePx + x % kTilePx) * 3] : nullptr;
    }
    void clear() {
        for (auto& tile : tiles) tile.reset();
        spare.clear();
    }
    std::size_t bytes() const {
        const auto allocated = std::count_if(tiles.begin(), tiles.end(), [](const auto& t) { return t != nullptr; });
        return static_cast<std::size_t>(allocated) * sizeof(Value) * kTileValues;
    }
    void save(std::ostream& out) const {
        for (const auto& tile : tiles) {
            writeRaw<std::uint8_t>(out, tile ? 1 : 0);
            if (tile) out.write(reinterpret_cast<const char*>(tile.get()), sizeof(Value) * kTileValues);
        }
    }
    void load(std::istream& in) {
        for (auto& tile : tiles) {
            tile.reset();
            if (readRaw<std::uint8_t>(in) == 0) continue;
            tile = std::make_unique<Value[]>(kTileValues);
            in.read(reinterpret_cast<char*>(tile.get()), sizeof(Value) * kTileValues);
            if (!in) throw std::runtime_error("checkpoint: truncated film data");
            // A NaN or infinity (a corrupt file) would reach the pixels, which writeExr refuses.
            if (!std::all_of(tile.get(), tile.get() + kTileValues, [](Value v) { return std::isfinite(v); }))
                throw std::runtime_error("checkpoint: non-finite film data");
        }
    }
};

}  // namespace flare::film
