#include "flare/optics/LensLibrary.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "flare/core/Error.h"
#include "flare/core/NearestNames.h"

#ifndef FLARE_LENS_LIBRARY_INSTALL_DIR
#define FLARE_LENS_LIBRARY_INSTALL_DIR ""
#endif
#ifndef FLARE_LENS_LIBRARY_SOURCE_DIR
#define FLARE_LENS_LIBRARY_SOURCE_DIR ""
#endif

namespace flare {

namespace {

namespace fs = std::filesystem;

// Lower case without '/', so that "f/2.8" and "F2.8" compare alike.
std::string folded(std::string_view s) {
    std::string out;
    for (char c : s)
        if (c != '/') out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return out;
}

LibraryLens readEntry(const nlohmann::json& j, const fs::path& folder) {
    LibraryLens lens;
    lens.id = j.at("id").get<std::string>();
    lens.path = (folder / j.at("file").get<std::string>()).string();
    lens.maker = j.at("maker").get<std::string>();
    lens.model = j.value("model", "");
    lens.name = j.at("name").get<std::string>();
    lens.kind = j.at("kind").get<std::string>();
    lens.tags = j.value("tags", std::vector<std::string>{});
    lens.focalLengthMm = j.at("focal_length_mm").get<double>();
    const std::vector<double> range = j.value("focal_range_mm", std::vector<double>{});
    lens.focalMinMm = range.size() == 2 ? range[0] : lens.focalLengthMm;
    lens.focalMaxMm = range.size() == 2 ? range[1] : lens.focalLengthMm;
    const std::vector<double> product = j.value("zoom_range_mm", std::vector<double>{});
    if (product.size() == 2) lens.zoomRangeMm = std::pair{product[0], product[1]};
    lens.fNumber = j.at("f_number").get<double>();
    lens.zoomPositions = j.value("zoom_positions", std::vector<std::string>{});
    lens.zoomFocalLengthsMm = j.value("zoom_focal_lengths_mm", std::vector<double>{});
    lens.renamedFrom = j.value("renamed_from", std::vector<std::string>{});
    lens.patent = j.value("patent", "");
    lens.example = j.value("example", 0);
    lens.collection = j.value("collection", "");
    return lens;
}

std::string executableFolder() {
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    return ec ? std::string() : exe.parent_path().string();
}

}  // namespace

std::vector<std::string> LensLibrary::defaultFolders() {
    std::vector<std::string> folders;
    if (const char* path = std::getenv("FLARE_LENS_PATH")) {
        std::stringstream list(path);
        for (std::string folder; std::getline(list, folder, ':');)
            if (!folder.empty()) folders.push_back(folder);
    }
    if (const std::string bin = executableFolder(); !bin.empty())
        folders.push_back((fs::path(bin) / ".." / "share" / "flare" / "lenses" / "library").lexically_normal().string());
    for (const char* configured : {FLARE_LENS_LIBRARY_INSTALL_DIR, FLARE_LENS_LIBRARY_SOURCE_DIR})
        if (*configured) folders.push_back(configured);
    return folders;
}

LensLibrary LensLibrary::load(const std::vector<std::string>& folders) {
    LensLibrary library;
    std::set<std::string> seen;
    std::set<fs::path> readFolders;
    for (const std::string& folder : folders) {
        const fs::path index = fs::path(folder) / "index.json";
        std::error_code ec;
        if (!fs::is_regular_file(index, ec)) continue;
        const fs::path canonical = fs::weakly_canonical(folder, ec);
        if (!readFolders.insert(canonical).second) continue;  // the same folder named twice
        std::ifstream in(index);
        nlohmann::json j;
        try {
            j = nlohmann::json::parse(in);
        } catch (const nlohmann::json::exception& e) {
            throw InputError(index.string(), 0, std::string("malformed lens library index: ") + e.what());
        }
        std::set<std::string> ids;
        try {
            for (const nlohmann::json& entry : j.at("lenses")) {
                LibraryLens lens = readEntry(entry, folder);
                if (!ids.insert(lens.id).second)
                    throw InputError(index.string(), 0, "lens id '" + lens.id + "' appears twice");
                if (seen.insert(lens.id).second) library.lenses_.push_back(std::move(lens));
            }
        } catch (const nlohmann::json::exception& e) {
            throw InputError(index.string(), 0, std::string("malformed lens library entry: ") + e.what());
        }
        library.folders_.push_back(folder);
    }
    return library;
}

const LensLibrary& LensLibrary::shared() {
    static const LensLibrary library = load(defaultFolders());
    return library;
}

const LibraryLens* LensLibrary::find(std::string_view id) const {
    for (const LibraryLens& lens : lenses_)
        if (lens.id == id) return &lens;
    return nullptr;
}

std::vector<std::string> LensLibrary::makers() const {
    std::set<std::string> makers;
    for (const LibraryLens& lens : lenses_) makers.insert(lens.maker);
    return {makers.begin(), makers.end()};
}

const LibraryLens* LensLibrary::renamed(std::string_view id) const {
    for (const LibraryLens& lens : lenses_)
        if (std::find(lens.renamedFrom.begin(), lens.renamedFrom.end(), id) != lens.renamedFrom.end()) return &lens;
    return nullptr;
}

std::vector<std::string> LensLibrary::nearestIds(std::string_view name, size_t count,
                                                 const std::vector<std::string>& extraNames) const {
    std::vector<std::string> names = extraNames;
    for (const LibraryLens& lens : lenses_) names.push_back(lens.id);
    return nearestNames(name, names, count);
}

std::vector<const LibraryLens*> LensLibrary::filter(const LibraryFilter& f) const {
    std::vector<const LibraryLens*> out;
    const std::string maker = folded(f.maker);
    for (const LibraryLens& lens : lenses_) {
        if (!maker.empty() && folded(lens.maker) != maker) continue;
        if (f.focalMinMm && lens.focalMaxMm < *f.focalMinMm) continue;
        if (f.focalMaxMm && lens.focalMinMm > *f.focalMaxMm) continue;
        if (f.maxFNumber && lens.fNumber > *f.maxFNumber) continue;
        out.push_back(&lens);
    }
    return out;
}

std::vector<const LibraryLens*> LensLibrary::search(std::string_view text) const {
    std::vector<std::string> words;
    std::istringstream in{std::string(text)};
    for (std::string word; in >> word;) words.push_back(folded(word));
    std::vector<const LibraryLens*> out;
    for (const LibraryLens& lens : lenses_) {
        std::string haystack = lens.id + " " + lens.maker + " " + lens.model + " " + lens.name + " " + lens.patent;
        for (const std::string& tag : lens.tags) haystack += " " + tag;
        haystack = folded(haystack);
        const bool all = std::all_of(words.begin(), words.end(),
                                     [&](const std::string& w) { return haystack.find(w) != std::string::npos; });
        if (all) out.push_back(&lens);
    }
    return out;
}

}  // namespace flare
