#include "flare/optics/AgfCatalog.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <optional>
#include <set>

#include "flare/core/Error.h"
#include "flare/core/TextEncoding.h"
#include "flare/optics/LensLibrary.h"

namespace flare {

namespace fs = std::filesystem;

namespace {

// The catalogues a bare glass name is looked up in first, in this order.
constexpr const char* kPreferredCatalogs[] = {"SCHOTT", "OHARA", "HOYA", "CDGM", "NIKON-HIKARI", "SUMITA"};

bool parseNumber(std::string_view token, double* value) {
    const char* begin = token.data();
    const char* end = begin + token.size();
    if (begin != end && *begin == '+') ++begin;
    const auto [ptr, ec] = std::from_chars(begin, end, *value);
    return ec == std::errc() && ptr == end && std::isfinite(*value);
}

bool isKeyword(std::string_view token) {
    return token.size() == 2 && std::isupper(static_cast<unsigned char>(token[0])) &&
           std::isupper(static_cast<unsigned char>(token[1]));
}

// A record: its keyword line and the values that follow it, including continuation lines.
struct Record {
    std::string_view keyword;
    std::vector<std::string_view> values;
    int line = 0;
};

struct PendingGlass {
    AgfGlass entry;
    bool haveCoefficients = false;
};

constexpr const char* kFormulaNames[] = {"", "Schott", "Sellmeier 1", "Herzberger", "Sellmeier 2", "Conrady",
                                         "Sellmeier 3", "Handbook of Optics 1", "Handbook of Optics 2",
                                         "Sellmeier 4", "Extended 1", "Sellmeier 5", "Extended 2", "Extended 3"};

}  // namespace

int agfCoefficientCount(int formula) {
    constexpr int kCounts[] = {0, 6, 6, 6, 5, 3, 8, 4, 4, 5, 8, 10, 8, 9};
    return formula >= 1 && formula <= 13 ? kCounts[formula] : 0;
}

const CatalogGlass* AgfCatalog::find(std::string_view glassName) const {
    const std::string wanted = asciiUpper(glassName);
    for (const AgfGlass& g : glasses_)
        if (asciiUpper(g.glass.name) == wanted) return &g.glass;
    return nullptr;
}

AgfCatalog AgfCatalog::parse(std::string_view text, const std::string& fileName, const std::string& catalogName) {
    AgfCatalog catalog;
    catalog.path_ = fileName;
    catalog.name_ = &catalog.strings_.emplace_back(catalogName);
    auto fail = [&](int line, const std::string& problem) { throw InputError(fileName, line, problem); };

    // Records, with lines of bare numbers joined to the record before them (catalogues wrap long
    // CD lines).
    std::vector<Record> records;
    int number = 0, lastLine = 0;
    for (size_t start = 0; start <= text.size();) {
        size_t end = text.find('\n', start);
        if (end == std::string_view::npos) end = text.size();
        ++number;
        const std::vector<std::string_view> t = splitWhitespace(text.substr(start, end - start));
        start = end + 1;
        if (t.empty()) continue;
        double ignored = 0.0;
        if (isKeyword(t[0])) {
            records.push_back({t[0], {t.begin() + 1, t.end()}, number});
        } else if (parseNumber(t[0], &ignored) && !records.empty()) {
            records.back().values.insert(records.back().values.end(), t.begin(), t.end());
        }
        // Anything else is read past, as Zemax does (NIKON-HIKARI's 2019 catalogue has a stray "E").
        lastLine = number;
    }

    std::set<std::string> names;
    std::optional<PendingGlass> pending;
    auto finish = [&]() {
        if (!pending) return;
        if (!pending->haveCoefficients)
            fail(pending->entry.line, "glass " + std::string(pending->entry.glass.name) + " has no CD (coefficients) line");
        if (names.insert(asciiUpper(pending->entry.glass.name)).second) catalog.glasses_.push_back(pending->entry);
        pending.reset();
    };
    for (const Record& r : records) {
        if (r.keyword == "NM") {
            finish();
            if (r.values.size() < 5)
                fail(r.line, "NM needs a name, a formula number, a glass code, nd and Vd; found " +
                                 std::to_string(r.values.size()) + " fields");
            double formula = 0.0, nd = 0.0, vd = 0.0;
            // In range before it is converted: a double beyond int's range (1e10) has no int value.
            if (!parseNumber(r.values[1], &formula) || formula != std::floor(formula) || formula < 1.0 || formula > 13.0)
                fail(r.line, "glass " + std::string(r.values[0]) + ": unknown dispersion formula '" +
                                 std::string(r.values[1]) + "' (formulas 1 to 13 are known)");
            if (!parseNumber(r.values[3], &nd) || nd < 1.0 || nd > 5.0)
                fail(r.line, "glass " + std::string(r.values[0]) + ": nd '" + std::string(r.values[3]) +
                                 "' is not a number in [1, 5]");
            if (!parseNumber(r.values[4], &vd) || vd < 0.0)
                fail(r.line, "glass " + std::string(r.values[0]) + ": Vd '" + std::string(r.values[4]) +
                                 "' is not a non-negative number");
            PendingGlass& g = pending.emplace();
            g.entry.glass.name = catalog.strings_.emplace_back(r.values[0]).c_str();
            g.entry.glass.maker = catalog.name_->c_str();
            g.entry.formulaNumber = static_cast<int>(formula);
            g.entry.glass.formula = static_cast<GlassFormula>(static_cast<int>(GlassFormula::AgfSchott) +
                                                              g.entry.formulaNumber - 1);
            g.entry.glass.nd = nd;
            g.entry.glass.vd = vd;
            g.entry.ndText = std::string(r.values[3]);
            g.entry.vdText = std::string(r.values[4]);
            g.entry.line = r.line;
        } else if (r.keyword == "CD" || r.keyword == "LD") {
            if (!pending) fail(r.line, std::string(r.keyword) + " line before any NM (glass) line");
            std::vector<double> values;
            for (std::string_view v : r.values) {
                double x = 0.0;
                if (!parseNumber(v, &x)) fail(r.line, std::string(r.keyword) + ": '" + std::string(v) + "' is not a number");
                values.push_back(x);
            }
            const std::string glass = pending->entry.glass.name;
            if (r.keyword == "LD") {
                if (values.size() != 2 || !(values[0] > 0.0) || !(values[1] > values[0]))
                    fail(r.line, "glass " + glass + ": LD needs the shortest and longest wavelength in µm, increasing");
                pending->entry.minWavelengthUm = values[0];
                pending->entry.maxWavelengthUm = values[1];
                pending->entry.glass.minWavelengthNm = 1e3 * values[0];
                pending->entry.glass.maxWavelengthNm = 1e3 * values[1];
                continue;
            }
            if (pending->haveCoefficients) fail(r.line, "glass " + glass + " has a second CD line");
            const int formula = pending->entry.formulaNumber;
            const int needed = agfCoefficientCount(formula);
            const std::string what = "glass " + glass + ", formula " + std::to_string(formula) + " (" +
                                     kFormulaNames[formula] + ") takes " + std::to_string(needed) + " coefficients";
            if (static_cast<int>(values.size()) < needed || values.size() > static_cast<size_t>(kGlassCoefficients))
                fail(r.line, what + ", the CD line has " + std::to_string(values.size()));
            for (size_t i = needed; i < values.size(); ++i)
                if (values[i] != 0.0)
                    fail(r.line, what + ", but coefficient " + std::to_string(i + 1) + " is " + std::string(r.values[i]) +
                                     " (only zeros may follow)");
            std::fill(std::begin(pending->entry.glass.coefficients), std::end(pending->entry.glass.coefficients), 0.0);
            std::copy(values.begin(), values.begin() + needed, pending->entry.glass.coefficients);
            pending->haveCoefficients = true;
        }
    }
    finish();
    if (catalog.glasses_.empty()) fail(lastLine, "the catalogue holds no glass (no NM line)");
    for (const AgfGlass& g : catalog.glasses_) {
        const double n = catalogIndex(g.glass, kLineDNm);
        const bool covered = g.maxWavelengthUm == 0.0 ||
                             (g.minWavelengthUm <= kLineDNm * 1e-3 && kLineDNm * 1e-3 <= g.maxWavelengthUm);
        if (covered && (!std::isfinite(n) || n < 1.0))
            fail(g.line, "glass " + std::string(g.glass.name) + ": the formula gives no real index at the d line");
    }
    return catalog;
}

AgfCatalog AgfCatalog::load(const std::string& path) {
    const std::string text = decodeText(readFileBytes(path, "glass catalogue"), path);
    return parse(text, path, asciiUpper(fs::path(path).stem().string()));
}

std::vector<std::string> glassCatalogFolders() {
    std::vector<std::string> folders;
    for (const std::string& library : LensLibrary::defaultFolders())
        folders.push_back((fs::path(library) / ".." / "glass").lexically_normal().string());
    return folders;
}

namespace {

struct PrivateCatalogs {
    std::mutex mutex;
    std::deque<AgfCatalog> catalogs;        // a deque keeps every catalogue (and its glasses) in place
    std::vector<std::string> keys;          // each catalogue's canonical path
    std::vector<const AgfCatalog*> order;   // the last given first
};

PrivateCatalogs& privateCatalogs() {
    static PrivateCatalogs catalogs;
    return catalogs;
}

// The catalogue read from `canonical`, moved to the front of the search order; null if not read yet.
// The caller holds the mutex.
const AgfCatalog* useKnown(PrivateCatalogs& p, const std::string& canonical) {
    for (size_t i = 0; i < p.keys.size(); ++i)
        if (p.keys[i] == canonical) {
            const AgfCatalog* c = &p.catalogs[i];
            std::erase(p.order, c);
            p.order.insert(p.order.begin(), c);
            return c;
        }
    return nullptr;
}

}  // namespace

const AgfCatalog& useGlassCatalog(const std::string& path) {
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) throw InputError(path, 0, "no glass catalogue file (.agf) here");
    const std::string canonical = fs::canonical(path, ec).string();
    PrivateCatalogs& p = privateCatalogs();
    {
        const std::lock_guard lock(p.mutex);
        if (const AgfCatalog* known = useKnown(p, canonical)) return *known;
    }
    AgfCatalog catalog = AgfCatalog::load(path);  // outside the lock: reading takes a while
    const std::lock_guard lock(p.mutex);
    if (const AgfCatalog* known = useKnown(p, canonical)) return *known;  // another thread was quicker
    p.catalogs.push_back(std::move(catalog));
    p.keys.push_back(canonical);
    p.order.insert(p.order.begin(), &p.catalogs.back());
    return p.catalogs.back();
}

std::vector<const AgfCatalog*> privateGlassCatalogs() {
    PrivateCatalogs& p = privateCatalogs();
    const std::lock_guard lock(p.mutex);
    return p.order;
}

std::span<const AgfCatalog> shippedGlassCatalogs() {
    static const std::vector<AgfCatalog> catalogs = [] {
        std::vector<AgfCatalog> out;
        for (const std::string& folder : glassCatalogFolders()) {
            std::error_code ec;
            std::vector<fs::path> files;
            for (const fs::directory_entry& e : fs::directory_iterator(folder, ec)) {
                const std::string extension = asciiUpper(e.path().extension().string());
                if (extension == ".AGF" && e.is_regular_file(ec)) files.push_back(e.path());
            }
            if (files.empty()) continue;
            auto rank = [](const fs::path& p) {
                const std::string stem = asciiUpper(p.stem().string());
                const auto* it = std::find(std::begin(kPreferredCatalogs), std::end(kPreferredCatalogs), stem);
                return std::pair(static_cast<int>(it - std::begin(kPreferredCatalogs)), stem);
            };
            std::sort(files.begin(), files.end(), [&](const fs::path& a, const fs::path& b) { return rank(a) < rank(b); });
            for (const fs::path& file : files) out.push_back(AgfCatalog::load(file.string()));
            break;
        }
        return out;
    }();
    return catalogs;
}

}  // namespace flare
