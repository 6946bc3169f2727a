// Film::save and Film::load (Film.h): the film's layers, variance sums and adaptive-kernel counts in
// a render checkpoint, read into fresh buffers first so that a bad file leaves the film untouched.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <istream>
#include <mutex>
#include <ostream>
#include <stdexcept>

#include "flare/film/FilmStores.h"

namespace flare {

namespace {
using film::readRaw;
using film::writeRaw;
constexpr std::uint64_t kFilmMagic = 0x36464c4946524c46ull;  // "FLRFILF6"
}  // namespace

void Film::save(std::ostream& out) const {
    writeRaw(out, kFilmMagic);
    writeRaw<std::int32_t>(out, settings_.widthPx);
    writeRaw<std::int32_t>(out, settings_.heightPx);
    writeRaw<std::int32_t>(out, static_cast<std::int32_t>(settings_.kernel));
    writeRaw<std::int32_t>(out, layerCount());
    writeRaw<std::int32_t>(out, varianceGroupCount());
    writeRaw<std::int32_t>(out, replicates_);
    writeRaw<std::int32_t>(out, passes_);
    for (const LayerKernel& k : layerKernels_) {
        writeRaw<std::int32_t>(out, static_cast<std::int32_t>(k.kernel));
        writeRaw<std::int32_t>(out, k.neighbours);
        writeRaw<double>(out, k.maxRadiusPx);
        writeRaw<std::uint8_t>(out, k.byPower ? 1 : 0);
    }
    for (int l = 0; l < layerCount(); ++l) writeRaw<std::uint8_t>(out, singleLayers_[l] ? 1 : 0);
    for (int l = 0; l < layerCount(); ++l) {
        if (singleLayers_[l]) singleLayers_[l]->save(out);
        else layers_[l]->save(out);
    }
    for (const Group& group : groups_)
        for (const auto& sums : group.sums) sums->save(out);
    for (const auto& counts : counts_) out.write(reinterpret_cast<const char*>(counts.data()), sizeof(std::uint32_t) * counts.size());
    for (const auto& powers : powers_) out.write(reinterpret_cast<const char*>(powers.data()), sizeof(double) * powers.size());
}

void Film::load(std::istream& in) {
    if (readRaw<std::uint64_t>(in) != kFilmMagic) throw std::runtime_error("checkpoint: not a film");
    const int w = readRaw<std::int32_t>(in), h = readRaw<std::int32_t>(in);
    const int kernel = readRaw<std::int32_t>(in), layers = readRaw<std::int32_t>(in);
    const int groups = readRaw<std::int32_t>(in);
    const int replicates = readRaw<std::int32_t>(in);
    if (w != settings_.widthPx || h != settings_.heightPx || kernel != static_cast<int>(settings_.kernel) ||
        layers != layerCount() || groups != varianceGroupCount() || replicates != replicates_)
        throw std::runtime_error(
            "checkpoint: the film's size, kernel, layers, variance groups or replicates differ from this render's");
    const int passes = readRaw<std::int32_t>(in);
    if (passes < 0) throw std::runtime_error("checkpoint: negative pass count");
    for (const LayerKernel& k : layerKernels_) {
        const int kernel = readRaw<std::int32_t>(in), neighbours = readRaw<std::int32_t>(in);
        const double maxRadiusPx = readRaw<double>(in);
        const bool byPower = readRaw<std::uint8_t>(in) != 0;
        if (kernel != static_cast<int>(k.kernel) || neighbours != k.neighbours || maxRadiusPx != k.maxRadiusPx ||
            byPower != k.byPower)
            throw std::runtime_error("checkpoint: a layer's kernel differs from this render's");
    }
    for (int l = 0; l < layers; ++l)
        if ((readRaw<std::uint8_t>(in) != 0) != layerSinglePrecision(l))
            throw std::runtime_error("checkpoint: a layer's precision differs from this render's");
    // Read everything into fresh buffers first: a bad file leaves this film untouched.
    std::vector<std::unique_ptr<Tiles>> loaded;
    std::vector<std::unique_ptr<SingleTiles>> loadedSingle(static_cast<size_t>(layers));
    const int sumsPerGroup = static_cast<int>(groups_[0].sums.size());
    for (int l = 0; l < layers + sumsPerGroup * groups; ++l) {
        if (l < layers && layerSinglePrecision(l)) {
            loadedSingle[l] = std::make_unique<SingleTiles>(w, h);
            loadedSingle[l]->load(in);
            loaded.emplace_back();
            continue;
        }
        loaded.push_back(std::make_unique<Tiles>(w, h));
        loaded.back()->load(in);
    }
    auto counts = counts_;
    for (auto& c : counts) {
        in.read(reinterpret_cast<char*>(c.data()), sizeof(std::uint32_t) * c.size());
        if (!in) throw std::runtime_error("checkpoint: truncated film data");
    }
    auto powers = powers_;
    for (auto& p : powers) {
        in.read(reinterpret_cast<char*>(p.data()), sizeof(double) * p.size());
        if (!in) throw std::runtime_error("checkpoint: truncated film data");
        if (!std::all_of(p.begin(), p.end(), [](double v) { return std::isfinite(v) && v >= 0.0; }))
            throw std::runtime_error("checkpoint: invalid film data");
    }
    // With independent passes, a group's pass sums and their squares are written together: a tile
    // in one is a tile in the other (replicates' tiles are independent).
    if (replicates_ == 0)
        for (int g = 0; g < groups; ++g) {
            const Tiles& sums = *loaded[layers + 2 * g];
            const Tiles& squares = *loaded[layers + 2 * g + 1];
            for (size_t t = 0; t < sums.tiles.size(); ++t)
                if (static_cast<bool>(sums.tiles[t]) != static_cast<bool>(squares.tiles[t]))
                    throw std::runtime_error("checkpoint: inconsistent variance data");
        }

    for (int l = 0; l < layers; ++l) {
        layers_[l] = std::move(loaded[l]);
        singleLayers_[l] = std::move(loadedSingle[l]);
    }
    for (int g = 0; g < groups; ++g) {
        for (int k = 0; k < sumsPerGroup; ++k) groups_[g].sums[k] = std::move(loaded[layers + sumsPerGroup * g + k]);
        groups_[g].pass->clear();
    }
    counts_ = std::move(counts);
    pendingCounts_ = counts_;
    powers_ = std::move(powers);
    pendingPowers_ = powers_;
    passes_ = passes;
    neighbourGrowth_ = std::pow(static_cast<double>(std::max(passes_, 1)), 2.0 / 3.0);
    std::lock_guard<std::mutex> lock(*estimateMutex_);
    estimates_.clear();
}

}  // namespace flare
