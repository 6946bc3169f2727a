// A flare data set's specification (docs/dataset.md): how `flare dataset` draws its N scenes —
// lenses from the library (by id, or by tags, kind and maker), zoom, focus and f-number ranges,
// light counts, kinds, spectra, powers and positions inside or outside the frame, dust and grease
// levels, resolution and quality. Image k's scene is a function of the spec's seed and k alone
// (its random numbers are the stream k of the seed), so whichever process, rank or shard makes
// image k makes the same image. Every problem in a spec raises InputError naming the file, the
// line and the key path, before anything is written.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace flare {

// A closed range [lo, hi] of a spec value, drawn uniformly or log-uniformly (positive quantities
// that span decades: powers, distances, f-numbers).
struct SpecRange {
    double lo = 0.0, hi = 0.0;
};

struct DatasetSpec {
    std::string file;
    int images = 0;
    std::uint64_t seed = 1;
    std::vector<std::string> lenses;     // resolved: shipped lens names or library lens files
    std::vector<std::string> lensIds;    // as the index names them (the id, or the shipped name)
    SpecRange zoom{0.0, 1.0};            // share of a zoom's focal range (log-spaced); primes ignore it
    bool focusAtInfinity = true;
    SpecRange focusDistanceMm{};         // log-uniform, when not at infinity
    SpecRange fNumber{2.8, 11.0};        // log-uniform; raised to the lens's wide-open f-number
    SpecRange lightCount{1, 1};          // integers, uniform
    std::vector<std::string> lightKinds{"directional"};
    double outsideFrameShare = 0.0;      // probability that a light is outside the frame
    double outsideMargin = 2.0;          // outside: field angles up to this × the frame's half angles
    SpecRange temperatureK{5778.0, 5778.0};  // black-body spectra
    SpecRange power{1.0, 1.0};           // log-uniform, the scene's light units
    SpecRange angularDiameterDeg{0.53, 0.53};  // directional lights
    SpecRange distanceMm{2000.0, 20000.0};     // point and disk lights, log-uniform
    SpecRange diskRadiusMm{10.0, 50.0};        // disk lights
    SpecRange dustCoverage{0.0, 0.0};    // on the front surface, uniform
    SpecRange greaseCoverage{0.0, 0.0};  // on the front surface, uniform
    int widthPx = 256, heightPx = 170;
    double targetError = 0.1;            // the render's stop (flare render --target-error)
    std::int64_t photons = 2'000'000;    // ... and its photon cap
    int beamsPerPass = 256;
    bool perGhostLayers = false;
    bool diffraction = true;
};

// Reads and checks a spec file (JSON with comments, as scenes).
DatasetSpec loadDatasetSpec(const std::string& path);
DatasetSpec parseDatasetSpec(const std::string& text, const std::string& fileName);

// Image k's scene (the scene format, docs/scene-format.md), and what was drawn for it (lens id,
// focal length, f-number, each light's kind and whether it is in the frame). Builds the lens to
// place the lights against its field of view.
struct DatasetImage {
    nlohmann::json scene;
    nlohmann::json drawn;
};
DatasetImage datasetImage(const DatasetSpec& spec, int k);

}  // namespace flare
