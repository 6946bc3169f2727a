// Zemax glass catalogues (.agf): the format optical-glass makers publish their data in. A catalogue
// is named like its file (`SCHOTT.agf` is the catalogue a .zmx file's `GCAT SCHOTT` means). Each
// glass is an `NM` record (name, formula number, glass code, nd, Vd, ...) followed by its `CD`
// coefficients (which may run on over lines of numbers) and its `LD` wavelength range; the other
// records (comments, thermal data, transmission) are read past. Formula numbers 1–13 are known
// (Glass.h, GlassFormula::Agf*). Problems raise InputError naming the file and line.
//
// Shipped catalogues (lenses/glass/*.agf, lenses/glass/README.md) are found in the folder `glass`
// beside each lens-library folder (LensLibrary::defaultFolders, so FLARE_LENS_PATH=DIR/library also
// finds DIR/glass); the first such folder holding .agf files is read once per process.
#pragma once

#include <deque>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "flare/optics/Glass.h"

namespace flare {

struct AgfGlass {
    CatalogGlass glass;  // name and maker (the catalogue's name) point into the catalogue
    int formulaNumber = 0;
    double minWavelengthUm = 0.0, maxWavelengthUm = 0.0;  // LD: where the formula is valid (0, 0: not given)
    std::string ndText, vdText;  // nd and Vd as printed (their digits say their precision)
    int line = 0;                // the NM record
};

class AgfCatalog {
public:
    AgfCatalog() = default;
    AgfCatalog(AgfCatalog&&) = default;  // moving keeps every glass's address
    AgfCatalog& operator=(AgfCatalog&&) = default;
    AgfCatalog(const AgfCatalog&) = delete;
    AgfCatalog& operator=(const AgfCatalog&) = delete;

    const std::string& name() const { return *name_; }
    const std::string& path() const { return path_; }
    const std::vector<AgfGlass>& glasses() const { return glasses_; }
    // Case-insensitive; the first record of a name that the catalogue repeats.
    const CatalogGlass* find(std::string_view glassName) const;

    // `text` is decoded (UTF-8); `catalogName` names the catalogue (e.g. "SCHOTT").
    static AgfCatalog parse(std::string_view text, const std::string& fileName, const std::string& catalogName);
    // Reads a file in either encoding Zemax writes; the catalogue is named by the file's stem in
    // upper case.
    static AgfCatalog load(const std::string& path);

private:
    std::deque<std::string> strings_;  // the glasses' names; a deque keeps them in place
    const std::string* name_ = nullptr;
    std::string path_;
    std::vector<AgfGlass> glasses_;
};

// Coefficients formula number `formula` uses (1–13), or 0 for an unknown number.
int agfCoefficientCount(int formula);

// The shipped catalogues, SCHOTT, OHARA, HOYA, CDGM, NIKON-HIKARI, SUMITA first (the order in
// which a bare glass name is looked up), then any other .agf in the folder by name.
std::span<const AgfCatalog> shippedGlassCatalogs();
// The folders looked in for shipped catalogues, in order, existing or not.
std::vector<std::string> glassCatalogFolders();

// A private catalogue (`--glass-catalog FILE.agf`, a scene's `glass_catalog`, the Python module's
// glass_catalog=): read once per file (by its canonical path) and, from then on for the rest of the
// process, searched before the built-in and shipped glasses by every lens read (findCatalogGlass),
// the last one given first; a .zmx file's `GCAT NAME` finds it by its name (the file's stem in
// upper case). Kept for the process's lifetime: the media of the lenses read point into it. A
// missing or malformed file raises InputError naming it. Thread-safe.
const AgfCatalog& useGlassCatalog(const std::string& path);
// The private catalogues given so far, the last given first.
std::vector<const AgfCatalog*> privateGlassCatalogs();

}  // namespace flare
