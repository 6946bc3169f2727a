// The film's stores (Film.h), shared by Film.cpp and FilmCheckpoint.cpp: its layers' tiles and
// its variance groups. Internal to the film.
#pragma once

#include <algorithm>
#include <memory>
#include <vector>

#include "flare/film/Film.h"
#include "flare/film/FilmTiles.h"

namespace flare {

// A layer of 3 doubles per pixel (FilmTiles.h); single-precision layers hold floats.
struct Film::Tiles : film::TileStore<double> {
    using TileStore::TileStore;
};
struct Film::SingleTiles : film::TileStore<float> {
    using TileStore::TileStore;
};

// One variance group: the current pass's image and the running sums over passes (RGB): with
// independent passes, the sum of the pass images and the sum of their squares; with K
// replicates, each replicate's sum of its pass images.
struct Film::Group {
    std::unique_ptr<Tiles> pass;
    std::vector<std::unique_ptr<Tiles>> sums;
    Group(int w, int h, int replicates) : pass(std::make_unique<Tiles>(w, h)) {
        for (int i = 0; i < std::max(replicates, 2); ++i) sums.push_back(std::make_unique<Tiles>(w, h));
    }
};

}  // namespace flare
