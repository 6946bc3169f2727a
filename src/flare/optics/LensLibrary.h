// The lens library (lenses/library, docs/lens-library.md): real prescriptions shipped as files
// beside the program, not compiled into it. A library folder holds `index.json` (one entry per lens:
// id, maker, model, focal length, f-number, patent and example, collection) and the `.lens` files
// it names. Lenses are named by id (`flare lens info nikon-ai-nikkor-50mm-f1.2s`, a scene's "lens").
//
// Where libraries are looked for, in order (every folder found is read; the first with an id wins):
//   1. each folder in the environment variable FLARE_LENS_PATH (':'-separated);
//   2. share/flare/lenses/library beside the running program's bin/ folder (an installed copy);
//   3. the install folder CMake configured (CMAKE_INSTALL_PREFIX/share/flare/lenses/library);
//   4. the source tree's lenses/library (a build that was not installed).
#pragma once

#include <optional>
#include <utility>
#include <string>
#include <string_view>
#include <vector>

namespace flare {

struct LibraryLens {
    std::string id;
    std::string path;       // the .lens file (absolute, or relative to the working folder)
    std::string maker;
    std::string model;      // the product, or "" for a patent example not tied to one
    std::string name;       // the file's display name
    std::string kind;       // "prime" or "zoom"
    std::vector<std::string> tags;  // e.g. "fisheye", "macro", "zoom-wide-only"
    double focalLengthMm = 0.0;     // design focal length (the first zoom position for a zoom)
    double focalMinMm = 0.0, focalMaxMm = 0.0;  // what the file can be set to: its positions' range
    double fNumber = 0.0;
    std::vector<std::string> zoomPositions;  // named positions of a merged zoom
    std::vector<double> zoomFocalLengthsMm;  // their stated focal lengths, in the same order
    // The range of the zoom (as its source names it) of which the file holds only one state, its
    // first; focalMinMm = focalMaxMm = focalLengthMm then: the file can be set to no other.
    std::optional<std::pair<double, double>> zoomRangeMm;
    std::vector<std::string> renamedFrom;  // ids this lens had before (docs/lens-library.md)
    std::string patent;
    int example = 0;
    std::string collection;
};

struct LibraryFilter {
    std::string maker;  // case-insensitive, exact maker name ("" = any)
    std::optional<double> focalMinMm, focalMaxMm;  // a lens matches when its range overlaps
    std::optional<double> maxFNumber;              // lenses at least this fast
};

class LensLibrary {
public:
    // Reads every folder in `folders` that holds an index.json. Throws InputError for a malformed
    // index (naming the file) or an entry whose id repeats within one folder.
    static LensLibrary load(const std::vector<std::string>& folders);
    // The folders searched by default (see the header comment), existing or not.
    static std::vector<std::string> defaultFolders();
    // The library from the default folders, read once per process.
    static const LensLibrary& shared();

    const std::vector<LibraryLens>& lenses() const { return lenses_; }
    const std::vector<std::string>& folders() const { return folders_; }  // those that were read
    const LibraryLens* find(std::string_view id) const;
    // The makers of the library's lenses, sorted, each once.
    std::vector<std::string> makers() const;
    // The lens that had `id` before it was renamed, or nullptr.
    const LibraryLens* renamed(std::string_view id) const;
    // Up to `count` ids (and shipped lens names among `extraNames`) nearest to a mistyped `name`
    // (NearestNames.h).
    std::vector<std::string> nearestIds(std::string_view name, size_t count,
                                        const std::vector<std::string>& extraNames = {}) const;
    // Lenses passing the filter, in index order.
    std::vector<const LibraryLens*> filter(const LibraryFilter& filter) const;
    // Lenses whose id, maker, model, name, patent or tags contain every word of `text`
    // (case-insensitive; "f/2.8" and "f2.8" match alike).
    std::vector<const LibraryLens*> search(std::string_view text) const;

private:
    std::vector<LibraryLens> lenses_;
    std::vector<std::string> folders_;
};

}  // namespace flare
