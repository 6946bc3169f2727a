// Seeds of the zmx and agf fuzz targets (FuzzTargets.h, writeGeneratedSeeds), generated rather
// than copied: the repository ships no .zmx file, and its .agf catalogues are 400-640 kB each,
// far more than a mutation can usefully touch. Each writer checks that every seed it writes parses
// (a seed the reader refuses would start the fuzzer off the paths it is meant to reach) and throws
// std::runtime_error when one does not.
#pragma once

#include <filesystem>

namespace flare::fuzz {

// The shipped lenses (two of them also in UTF-16 LE) and the library's first zoom, model-glass and
// aspheric lens (it has none today) as writeZemax writes them, and hand-written files that use what the writer
// never writes (inches and centimetres, odd aspheres, CLAP, glass status 4, a stop on a lens
// surface, a thickness solve, WAVL and WAVM, a UTF-8 byte-order mark, ignored and unknown
// keywords, focus configurations). Returns the number of files written.
int writeZmxSeeds(const std::filesystem::path& dir);

// An excerpt of each shipped catalogue, in its own encoding (a few glasses, among them the first
// of every formula it uses, each with at most three transmission lines) and one glass of every
// formula 1-13. Returns the number of files written.
int writeAgfSeeds(const std::filesystem::path& dir);

}  // namespace flare::fuzz
