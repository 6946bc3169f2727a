#include "FuzzTextSeeds.h"

#include <algorithm>
#include <fstream>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "flare/core/Error.h"
#include "flare/core/TextEncoding.h"
#include "flare/optics/AgfCatalog.h"
#include "flare/optics/EmbeddedLenses.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/LensLibrary.h"
#include "flare/optics/ZemaxFile.h"

namespace flare::fuzz {

namespace fs = std::filesystem;

namespace {

void writeBytes(const fs::path& path, std::string_view bytes) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out) throw std::runtime_error("cannot write " + path.string());
}

// Reading past what the writer never writes: lens units of inches, a UTF-8 byte-order mark free
// file with the usual OpticStudio preamble, both asphere types, a clear aperture, a model glass, a
// catalogue glass with status 4 (zero offsets) found through GCAT, a coating flare does not know,
// ignored and unknown keywords, and three configurations that vary the object distance (focus: a
// warning) and two air gaps (a zoom of three positions).
constexpr std::string_view kInchZoom = R"(VERS 190513 80 123457 L123457
MODE SEQ
NAME Hand-written seed: inches, model and offset glasses, both aspheres, a zoom
PFIL 0 0 0
LANG 0
UNIT IN X W X CM MR CPMM
ENPD 0.4
FNUM 4 0
GCAT OHARA SCHOTT
WAVL 0.4861327 0.5875618 0.6562725
PWAV 2
RAIM 0 0 1 1 0 0 0 0 0
SURF 0
  TYPE STANDARD
  CURV 0.0 0 0 0 0 ""
  HIDE 0 0 0 0 0 0 0 0 0 0
  MIRR 2 0
  DISZ INFINITY
SURF 1
  TYPE EVENASPH
  CURV 0.4 0 0 0 0 ""
  CONI -0.25
  PARM 1 0
  PARM 2 1E-4
  PARM 3 -2E-6
  COAT AR
  DISZ 0.2
  GLAS S-LAH66 0 0 1.77250 49.60 0 0 0 0 0 0
  DIAM 0.5 1 0 0 1 ""
  MEMA 0.6 0 0 0 1 ""
SURF 2
  TYPE ODDASPH
  CURV -0.3
  PARM 1 0
  PARM 4 3E-5
  DISZ 0.1
  GLAS ___BLANK 1 0 1.62 36.4 0 0 0 0 0 0
  CLAP 0 0.48 0
  DIAM 0.5
SURF 3
  CURV 0.05
  COAT NONE
  DISZ 0.3
  DIAM 0.5
SURF 4
  STOP
  TYPE STANDARD
  CURV 0
  DISZ 0.4
  DIAM 0.25
  FLAP 0 0.25 0
SURF 5
  CURV 0.3
  DISZ 0.15
  GLAS N-BK7 4 0 1.5168 64.17 0 0 0 0 0 0 0 0
  DIAM 0.45
  TILT 0 0 0
  DECX 0
SURF 6
  CURV -0.3
  COAT HEA2
  DISZ 1.8
  DIAM 0.45
  XYZZ 1 2 3
SURF 7
  TYPE STANDARD
  CURV 0
  DISZ 0
  DIAM 0.8
MNUM 3 2
APER 0
THIC 0 1 1000
THIC 0 2 2000
THIC 0 3 INFINITY
THIC 4 1 0.2
THIC 4 2 0.4
THIC 4 3 0.6
THIC 6 1 1.7
THIC 6 2 1.8
THIC 6 3 1.9
WAVE 1 1 0.4861327
)";

// Centimetres, numbered wavelengths (WAVM) with a primary other than 550 nm (so COAT AR becomes a
// quarter wave of its own), the stop on a convex lens surface, and a thickness solve (TCOM) in a
// single configuration.
constexpr std::string_view kCentimetreSinglet = R"(MODE SEQ
NAME Hand-written seed: centimetres, a stop on a lens surface, a thickness solve, WAVM
UNIT CM X W X CM MR CPMM
FNUM 2.8 0
GCAT HOYA
WAVM 1 0.4861327 1
WAVM 2 0.5875618 1
WAVM 3 0.6562725 1
PWAV 2
SURF 0
  CURV 0
  DISZ 100
SURF 1
  STOP
  CURV 0.25
  COAT AR
  DISZ 0.5
  GLAS FCD1 0 0 1.4970 81.61 0 0 0 0 0 0
  DIAM 1.2
SURF 2
  CURV -0.05
  COAT AR
  DISZ 5
  TCOM 2 0 0 0 0 0 0
  DIAM 1.2
SURF 3
  CURV 0
  DISZ 0
  DIAM 1.5
)";

// One glass of every formula (1-13), each with a coefficient set that gives n = 1.5 plus a little
// dispersion, with the records a catalogue carries besides (CC, GC, ED, TD, OD, IT), a CD line run
// on over two lines, a glass without an LD range and a name given twice (the first one counts).
constexpr std::string_view kEveryFormula = R"(CC Hand-written seed: one glass of every formula
NM F1-SCHOTT 1 0 1.5 60 0 1
GC a comment on the glass
ED 7.1 8.2 2.5 0.0002 0
CD 2.25 0 0.01 0 0 0
TD 1e-06 1e-08 0 1e-06 1e-09 0.25 20
OD 1 1 0 1 2.3 1.3
LD 0.3 2.5
IT 0.32 0.5 25
IT 0.40 0.99 25
NM F2-SELLMEIER1 2 0 1.5 60 0 1
CD 1.25 0.01 0 0 0 0
LD 0.3 2.5
NM F3-HERZBERGER 3 0 1.5 60 0 1
CD 1.5 0.001 0 0 0 0
LD 0.3 2.5
NM F4-SELLMEIER2 4 0 1.5 60 0 1
CD 1.25 0 0 0.005 0
NM F5-CONRADY 5 0 1.5 60 0 1
CD 1.49 0.005 0
LD 0.3 2.5
NM F6-SELLMEIER3 6 0 1.5 60 0 1
CD 1.25 0.01 0 0
0 0 0 0
LD 0.3 2.5
NM F7-HANDBOOK1 7 0 1.5 60 0 1
CD 2.25 0.01 0 0
LD 0.3 2.5
NM F8-HANDBOOK2 8 0 1.5 60 0 1
CD 2.25 0.01 0.01 0
LD 0.3 2.5
NM F9-SELLMEIER4 9 0 1.5 60 0 1
CD 2.25 0.01 0.01 0 0
LD 0.3 2.5
NM F10-EXTENDED1 10 0 1.5 60 0 1
CD 2.25 0 0.01 0 0 0 0 0
LD 0.3 2.5
NM F11-SELLMEIER5 11 0 1.5 60 0 1
CD 1.25 0.01 0 0 0 0 0 0 0 0
LD 0.3 2.5
NM F12-EXTENDED2 12 0 1.5 60 0 1
CD 2.25 0 0.01 0 0 0 0 0
LD 0.3 2.5
NM F13-EXTENDED3 13 0 1.5 60 0 1
CD 2.25 0 0 0.01 0 0 0 0 0
LD 0.3 2.5
NM f1-schott 1 0 1.6 40 0 1
CD 2.56 0 0.01 0 0 0
)";

void checkZmx(std::string_view bytes, const std::string& name) {
    try {
        std::vector<std::string> warnings;
        parseZemaxText(bytes, name, &warnings);
    } catch (const InputError& e) {
        throw std::runtime_error("zmx seed " + name + " does not parse: " + e.what());
    }
}

void checkAgf(std::string_view bytes, const std::string& name) {
    try {
        AgfCatalog::parse(decodeText(bytes, name), name, "SEED");
    } catch (const InputError& e) {
        throw std::runtime_error("agf seed " + name + " does not parse: " + e.what());
    }
}

// Lines of `text` (each without its '\n'; a '\r' stays).
std::vector<std::string_view> lines(std::string_view text) {
    std::vector<std::string_view> out;
    for (size_t start = 0; start < text.size();) {
        size_t end = text.find('\n', start);
        if (end == std::string_view::npos) end = text.size();
        out.push_back(text.substr(start, end - start));
        start = end + 1;
    }
    return out;
}

std::string_view keywordOf(std::string_view line) {
    const std::vector<std::string_view> tokens = splitWhitespace(line);
    return tokens.empty() ? std::string_view() : tokens[0];
}

// The catalogue's preamble, its first three glasses, the first glass of each formula (as written:
// SCHOTT writes formula 2 both as "2" and as "2.00000E+00") and its last glass; each glass with at
// most three IT (transmission) lines.
std::string agfExcerpt(std::string_view text) {
    const std::vector<std::string_view> all = lines(text);
    std::vector<size_t> starts;  // NM lines
    for (size_t i = 0; i < all.size(); ++i)
        if (keywordOf(all[i]) == "NM") starts.push_back(i);
    std::string out;
    for (size_t i = 0; i < (starts.empty() ? all.size() : starts.front()); ++i) out.append(all[i]).append("\n");
    std::set<std::string> formulas;
    for (size_t g = 0; g < starts.size(); ++g) {
        const std::vector<std::string_view> nm = splitWhitespace(all[starts[g]]);
        const std::string formula = nm.size() > 2 ? std::string(nm[2]) : "";
        const bool newFormula = formulas.insert(formula).second;
        if (!(g < 3 || newFormula || g + 1 == starts.size())) continue;
        const size_t end = g + 1 < starts.size() ? starts[g + 1] : all.size();
        int transmissionLines = 0;
        for (size_t i = starts[g]; i < end; ++i) {
            if (keywordOf(all[i]) == "IT" && ++transmissionLines > 3) continue;
            out.append(all[i]).append("\n");
        }
    }
    return out;
}

bool hasAsphere(const LensPrescription& p) {
    return std::any_of(p.rows.begin(), p.rows.end(), [](const PrescriptionRow& r) {
        return std::any_of(r.asphere.begin(), r.asphere.end(), [](double a) { return a != 0.0; });
    });
}

bool hasModelGlass(const LensPrescription& p) {
    return std::any_of(p.rows.begin(), p.rows.end(), [](const PrescriptionRow& r) {
        const Medium::Kind kind = r.mediumAfter.kind();
        return kind == Medium::Kind::AbbeMatched || kind == Medium::Kind::Cauchy || kind == Medium::Kind::Constant;
    });
}

}  // namespace

int writeZmxSeeds(const fs::path& dir) {
    fs::create_directories(dir);
    int written = 0;
    auto write = [&](const std::string& file, std::string_view bytes) {
        checkZmx(bytes, file);
        writeBytes(dir / file, bytes);
        ++written;
    };
    for (const EmbeddedLens& lens : embeddedLenses()) {
        const std::string text = writeZemax(parseLensText(lens.text, std::string(lens.name) + ".lens"));
        write(std::string(lens.name) + ".zmx", text);
        if (std::string_view(lens.name) == "double-gauss-50mm" || std::string_view(lens.name) == "zoom-24-70mm")
            write(std::string(lens.name) + "-utf16.zmx", encodeUtf16Le(text));
    }
    // The first library lens (in the library's order) of each kind the shipped ones may lack.
    std::map<std::string, std::string> picked;  // kind -> library id
    for (const LibraryLens& lens : LensLibrary::shared().lenses()) {
        const LensPrescription p = loadLensFile(lens.path);
        for (const auto& [kind, has] : {std::pair{"zoom", !p.zoomPositions.empty()}, std::pair{"asphere", hasAsphere(p)},
                                        std::pair{"model-glass", hasModelGlass(p)}}) {
            if (!has || picked.count(kind)) continue;
            picked[kind] = lens.id;
            write("library-" + std::string(kind) + ".zmx", writeZemax(p));
        }
        if (picked.size() == 3) break;
    }
    write("hand-written-inch-zoom.zmx", kInchZoom);
    write("hand-written-centimetre-singlet.zmx", kCentimetreSinglet);
    write("hand-written-centimetre-singlet-utf8-bom.zmx", "\xEF\xBB\xBF" + std::string(kCentimetreSinglet));
    return written;
}

int writeAgfSeeds(const fs::path& dir) {
    fs::create_directories(dir);
    int written = 0;
    auto write = [&](const std::string& file, std::string_view bytes) {
        checkAgf(bytes, file);
        writeBytes(dir / file, bytes);
        ++written;
    };
    for (const AgfCatalog& catalog : shippedGlassCatalogs()) {
        const std::string bytes = readFileBytes(catalog.path(), "glass catalogue");
        const bool utf16 = bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == 0xFF &&
                           static_cast<unsigned char>(bytes[1]) == 0xFE;
        const std::string excerpt = agfExcerpt(decodeText(bytes, catalog.path()));
        write(catalog.name() + "-excerpt.agf", utf16 ? encodeUtf16Le(excerpt) : excerpt);
    }
    write("hand-written-every-formula.agf", kEveryFormula);
    return written;
}

}  // namespace flare::fuzz
