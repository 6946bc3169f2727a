#include "flare/optics/ZemaxFile.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <set>

#include "flare/core/Error.h"
#include "flare/core/TextEncoding.h"
#include "flare/core/Warnings.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/LensSystem.h"
#include "flare/optics/Paraxial.h"

namespace flare {

namespace {

// Zemax's AR coating (its COATING.DAT): one layer of MgF2, n = 1.38, a quarter wave thick at the
// primary wavelength. At 550 nm it is flare's built-in mgf2.
constexpr double kMgF2Index = 1.38;
constexpr double kMgF2DesignNm = 550.0;
// The primary wavelength a file without wavelength lines has (OpticStudio's default).
constexpr double kDefaultPrimaryUm = 0.55;

// Keywords that describe what flare does not model or computes itself (fields, wavelengths
// beyond the primary, ray aiming, tolerances, editor state, notes): read past in silence.
const std::set<std::string, std::less<>> kIgnoredSystemKeywords = {
    "VERS", "NOTE", "PFIL", "LANG", "ENPD", "ENVD", "GFAC", "GLRS", "GSTD", "RAIM", "PUSH",
    "SDMA", "FTYP", "ROPD", "PICB", "XFLN", "YFLN", "XFLD", "YFLD", "FWGN", "FWGT", "VDXN", "VDYN",
    "VCXN", "VCYN", "VANN", "ZVDX", "ZVDY", "ZVCX", "ZVCY", "ZVAN", "WWGT", "WWGN", "POLS", "NSCD",
    "COFN", "LUID", "OBNA", "FLOA", "TOL", "DMFS", "EFFL", "BLNK", "TRAC", "RSCE", "MOFF", "CONF",
    "GLCZ", "SWRT", "TCED", "MCOF"};
// Surface keywords without optical meaning for flare: comments, drawing and editor flags, solve
// and variable markers (the values they solve for are saved), the floating aperture (the
// semi-diameter itself), thermal data.
const std::set<std::string, std::less<>> kIgnoredSurfaceKeywords = {
    "COMM", "HIDE", "MIRR", "SLAB", "POPS", "FIMP", "MAZH", "PZUP", "VPAR", "VCON", "VDSZ", "TCE",
    "XDAT", "XDFL", "FLAP", "PPAR", "TEMP", "PRES", "BLNK", "TRAC", "RSCE", "GLCZ", "ISNP"};
// Multi-configuration operands that vary what flare does not model per position (fields,
// wavelengths, vignetting factors, the system aperture: flare's iris is the stop's semi-diameter).
const std::set<std::string, std::less<>> kIgnoredOperands = {
    "APER", "WAVE", "WLWT", "XFIE", "YFIE", "FLWT", "FVDX", "FVDY", "FVCX", "FVCY", "FVAN", "PRWV"};
// Multi-configuration operands that would change the lens between configurations in a way flare's
// zoom positions cannot (they vary thicknesses and the stop's semi-diameter only: THIC, SDIA).
const std::set<std::string, std::less<>> kUnsupportedOperands = {
    "CRVT", "CONN", "GLSS", "PRAM", "PAR1", "PAR2", "PAR3", "PAR4", "PAR5", "PAR6", "PAR7", "PAR8",
    "XDAT", "CADX", "CADY", "CATX", "CATY", "CATZ", "CBDX", "CBDY", "CBTX", "CBTY", "CBTZ",
    "IGNR", "MIND", "MABB", "COTN", "STPS"};

struct GlassSpec {
    std::string name;
    int status = 0;                // 0 catalogue, 1 model glass, 4 catalogue glass with offsets
    std::vector<double> numbers;   // the fields after the status, as written
    int line = 0;
};

struct ZemaxSurface {
    int number = 0;
    int line = 0;  // the SURF line
    std::string type = "STANDARD";
    int typeLine = 0;
    double curvature = 0.0;  // 1 / lens unit
    int curvatureLine = 0;
    std::optional<double> thickness;  // lens units; +inf for INFINITY
    int thicknessLine = 0;
    double conic = 0.0;
    std::map<int, std::pair<double, int>> parms;  // PARM number -> value, line
    std::optional<double> semiDiameter, mechSemiDiameter, clearApertureMax;
    bool stop = false;
    std::optional<GlassSpec> glass;
    std::optional<std::pair<std::string, int>> coating;  // name, line
};

struct ThicknessOperand {
    std::map<int, std::pair<double, int>> values;  // configuration -> value, line
    int line = 0;  // the first line
};

class ZemaxReader {
public:
    ZemaxReader(std::string file, std::vector<std::string>* warnings) : file_(std::move(file)), warnings_(warnings) {}

    LensPrescription read(std::string_view bytes);

private:
    [[noreturn]] void fail(int line, const std::string& problem) const { throw InputError(file_, line, problem); }
    [[noreturn]] void failSurface(int line, int surface, std::string_view keyword, const std::string& problem) const {
        fail(line, "surface " + std::to_string(surface) + ", " + std::string(keyword) + ": " + problem);
    }
    void warn(int line, const std::string& problem) {
        const std::string text = file_ + ":" + std::to_string(line) + ": " + problem;
        if (warnings_) warnings_->push_back(text);
        else flare::warn(text);
    }

    // Field `index` of a line as a number; `what` names it in errors.
    double number(int line, const std::vector<std::string_view>& tokens, size_t index, const std::string& what,
                  bool infinityAllowed = false) const {
        if (index >= tokens.size()) fail(line, what + " is missing");
        const std::string_view token = tokens[index];
        if (infinityAllowed && (asciiUpper(token) == "INFINITY" || asciiUpper(token) == "INF"))
            return std::numeric_limits<double>::infinity();
        double value = 0.0;
        const char* begin = token.data() + (!token.empty() && token[0] == '+');
        const auto [end, ec] = std::from_chars(begin, token.data() + token.size(), value);
        if (ec != std::errc() || end != token.data() + token.size() || !std::isfinite(value))
            fail(line, what + ": '" + std::string(token) + "' is not a number");
        return value;
    }
    int integer(int line, const std::vector<std::string_view>& tokens, size_t index, const std::string& what) const {
        const double value = number(line, tokens, index, what);
        if (value != std::floor(value) || std::abs(value) > 1e6)
            fail(line, what + ": '" + std::string(tokens[index]) + "' is not a whole number");
        return static_cast<int>(value);
    }

    void readSurfaceLine(ZemaxSurface& s, const std::string& keyword, const std::vector<std::string_view>& tokens, int line);
    void readOperand(const std::string& keyword, const std::vector<std::string_view>& tokens, int line);
    Medium medium(const ZemaxSurface& s, std::string* text) const;
    void buildZoom(LensPrescription& p, const std::vector<int>& rowOfSurface);
    void applyFlareNotes(LensPrescription& p);

    std::string file_;
    std::vector<std::string>* warnings_;
    std::set<std::string> warnedKeywords_;
    double mmPerUnit_ = 1.0;
    std::vector<std::string> catalogs_;  // GCAT, in order
    std::map<int, double> wavelengthsUm_;
    std::vector<double> wavelengthListUm_;  // WAVL
    int primaryWavelength_ = 1;
    int primaryLine_ = 0;
    std::optional<double> fNumber_;
    std::string name_;
    std::vector<ZemaxSurface> surfaces_;
    int configurations_ = 1, activeConfiguration_ = 1, configurationLine_ = 0;
    std::map<int, ThicknessOperand> thicknessOperands_;  // by surface
    std::map<int, ThicknessOperand> semiDiameterOperands_;  // SDIA, by surface (the stop's only)
    // flare's own lines in the file's notes (`NOTE 0 flare: iris blades=7`, written by writeZemax):
    // what a .zmx file cannot say, kept where Zemax keeps and ignores it. Text after "flare:", line.
    std::vector<std::pair<std::string, int>> flareNotes_;
    std::vector<ZoomPosition> notedPositions_;  // from a `flare: zoom` note, in configuration order
    int notedPositionsLine_ = 0;
    std::vector<std::pair<int, int>> thicknessSolves_;    // TCOM: surface, line
};

void ZemaxReader::readSurfaceLine(ZemaxSurface& s, const std::string& keyword,
                                  const std::vector<std::string_view>& tokens, int line) {
    const int n = s.number;
    if (keyword == "TYPE") {
        if (tokens.size() < 2) failSurface(line, n, keyword, "the surface type is missing");
        s.type = asciiUpper(tokens[1]);
        s.typeLine = line;
    } else if (keyword == "CURV") {
        s.curvature = number(line, tokens, 1, "surface " + std::to_string(n) + ", CURV");
        s.curvatureLine = line;
    } else if (keyword == "DISZ") {
        s.thickness = number(line, tokens, 1, "surface " + std::to_string(n) + ", DISZ", true);
        s.thicknessLine = line;
    } else if (keyword == "CONI") {
        s.conic = number(line, tokens, 1, "surface " + std::to_string(n) + ", CONI");
    } else if (keyword == "PARM") {
        const int index = integer(line, tokens, 1, "surface " + std::to_string(n) + ", PARM number");
        s.parms[index] = {number(line, tokens, 2, "surface " + std::to_string(n) + ", PARM " + std::to_string(index)), line};
    } else if (keyword == "DIAM") {
        s.semiDiameter = number(line, tokens, 1, "surface " + std::to_string(n) + ", DIAM");
    } else if (keyword == "MEMA") {
        s.mechSemiDiameter = number(line, tokens, 1, "surface " + std::to_string(n) + ", MEMA");
    } else if (keyword == "CLAP") {
        // CLAP minimum-radius maximum-radius: a circular hard aperture.
        const double inner = number(line, tokens, 1, "surface " + std::to_string(n) + ", CLAP minimum radius");
        if (inner != 0.0) failSurface(line, n, keyword, "an annular aperture (minimum radius " + std::string(tokens[1]) + ") is not supported");
        s.clearApertureMax = number(line, tokens, 2, "surface " + std::to_string(n) + ", CLAP maximum radius");
    } else if (keyword == "OBDC") {
        for (size_t i = 1; i < tokens.size(); ++i)
            if (number(line, tokens, i, "surface " + std::to_string(n) + ", OBDC") != 0.0)
                failSurface(line, n, keyword, "a decentred aperture is not supported (flare's lenses are rotationally symmetric)");
    } else if (keyword == "SQAP" || keyword == "ELAP" || keyword == "OBSC" || keyword == "SQOB" || keyword == "ELOB") {
        failSurface(line, n, keyword, "this aperture type is not supported (only circular apertures: DIAM or CLAP)");
    } else if (keyword == "SCBD" || keyword.rfind("DEC", 0) == 0 || keyword.rfind("TILT", 0) == 0) {
        for (size_t i = 1; i < tokens.size(); ++i)
            if (number(line, tokens, i, "surface " + std::to_string(n) + ", " + keyword) != 0.0)
                failSurface(line, n, keyword, "tilts and decentres are not supported (flare's lenses are rotationally symmetric)");
    } else if (keyword == "IGNR") {
        if (tokens.size() > 1 && number(line, tokens, 1, "surface " + std::to_string(n) + ", IGNR") != 0.0)
            failSurface(line, n, keyword, "an ignored surface is not supported (delete it from the file)");
    } else if (keyword == "TCOM") {
        // A thickness solve: the saved DISZ holds the solved value of the active configuration,
        // which is all a single configuration needs; with several it is an error (checked once
        // the whole file, MNUM included, is read).
        thicknessSolves_.push_back({s.number, line});
    } else if (keyword == "STOP") {
        s.stop = true;
    } else if (keyword == "GLAS") {
        if (tokens.size() < 2) failSurface(line, n, keyword, "the glass name is missing");
        GlassSpec glass;
        glass.name = std::string(tokens[1]);
        glass.line = line;
        if (tokens.size() > 2) glass.status = integer(line, tokens, 2, "surface " + std::to_string(n) + ", GLAS status");
        for (size_t i = 3; i < tokens.size(); ++i)
            glass.numbers.push_back(number(line, tokens, i, "surface " + std::to_string(n) + ", GLAS field " + std::to_string(i)));
        s.glass = std::move(glass);
    } else if (keyword == "COAT") {
        if (tokens.size() >= 2) s.coating = {{std::string(tokens[1]), line}};
    } else if (kIgnoredSurfaceKeywords.count(keyword) == 0) {
        if (warnedKeywords_.insert(keyword).second)
            warn(line, "unknown keyword '" + keyword + "' in surface " + std::to_string(n) + " ignored (and wherever it occurs again)");
    }
}

void ZemaxReader::readOperand(const std::string& keyword, const std::vector<std::string_view>& tokens, int line) {
    if (kIgnoredOperands.count(keyword)) return;
    if (kUnsupportedOperands.count(keyword))
        fail(line, "multi-configuration operand " + keyword +
                       " is not supported (flare's zoom positions differ in thicknesses and the stop's semi-diameter "
                       "only: THIC, SDIA)");
    // THIC (or SDIA) surface configuration value ...
    const int surface = integer(line, tokens, 1, keyword + " surface");
    if (surface < 0) fail(line, keyword + ": surface " + std::to_string(surface) + " does not exist");
    const int configuration = integer(line, tokens, 2, keyword + " configuration");
    const double value = number(line, tokens, 3, keyword + " value", true);
    if (configuration < 1 || configuration > configurations_)
        fail(line, keyword + ": configuration " + std::to_string(configuration) + " is outside 1.." +
                       std::to_string(configurations_) + " (MNUM)");
    ThicknessOperand& op = (keyword == "SDIA" ? semiDiameterOperands_ : thicknessOperands_)[surface];
    if (op.values.empty()) op.line = line;
    if (!op.values.emplace(configuration, std::pair{value, line}).second)
        fail(line, keyword + ": surface " + std::to_string(surface) + " is given twice for configuration " +
                       std::to_string(configuration));
}

Medium ZemaxReader::medium(const ZemaxSurface& s, std::string* text) const {
    if (!s.glass) {
        *text = "air";
        return Medium::air();
    }
    const GlassSpec& g = *s.glass;
    const std::string name = asciiUpper(g.name);
    if (name == "MIRROR") failSurface(g.line, s.number, "GLAS", "mirrors are not supported (flare's lenses refract only)");
    if (g.status == 1 || name == "___BLANK") {
        // Model glass: GLAS name 1 0 nd vd dPgF ...
        if (g.numbers.size() < 3) failSurface(g.line, s.number, "GLAS", "a model glass needs nd and Vd");
        const double nd = g.numbers[1], vd = g.numbers[2];
        if (nd <= 1.0 || nd > 3.0) failSurface(g.line, s.number, "GLAS", "model glass nd must lie in (1, 3], got " + shortestNumberText(nd));
        // Vd = 0: no dispersion (how the writer states a constant index).
        if (vd == 0.0) {
            *text = "n=" + shortestNumberText(nd);
            return Medium::constant(nd);
        }
        if (vd < 5.0 || vd > 150.0) failSurface(g.line, s.number, "GLAS", "model glass Vd must lie in [5, 150], got " + shortestNumberText(vd));
        *text = shortestNumberText(nd) + "/" + shortestNumberText(vd);
        return Medium::abbe(nd, vd);
    }
    if (g.status == 4) {
        // Catalogue glass with offsets: the last two fields are Δnd and ΔVd.
        const bool offset = g.numbers.size() >= 2 && (g.numbers[g.numbers.size() - 2] != 0.0 || g.numbers.back() != 0.0);
        if (offset) failSurface(g.line, s.number, "GLAS", "glass offsets (Δnd, ΔVd) are not supported; give the glass as a model glass");
    } else if (g.status != 0) {
        failSurface(g.line, s.number, "GLAS", "glass status " + std::to_string(g.status) +
                                                  " is not supported (0 catalogue glass, 1 model glass)");
    }
    // The file's catalogues (GCAT) first, in its order, then every catalogue flare knows.
    const CatalogGlass* glass = nullptr;
    for (const std::string& catalog : catalogs_)
        if (!glass) glass = findCatalogGlass(catalog + ":" + g.name);
    if (!glass) glass = findCatalogGlass(g.name);
    if (!glass)
        failSurface(g.line, s.number, "GLAS", "unknown glass '" + g.name +
                                                  "' (not in the built-in, the shipped or a private catalogue; lenses/glass/README.md; "
                                                  "a catalogue of your own: --glass-catalog FILE.agf)");
    if (!coversVisible(*glass))
        failSurface(g.line, s.number, "GLAS", "glass '" + g.name + "' (" + glass->maker + ") is not made for the visible: " +
                                                  validRangeText(*glass));
    *text = g.name;
    return Medium::catalog(*glass);
}

LensPrescription ZemaxReader::read(std::string_view bytes) {
    const std::string text = decodeText(bytes, file_);
    int lineNumber = 0, lastLine = 0;
    bool inConfigurations = false;  // MNUM seen: operand lines follow
    size_t start = 0;
    while (start <= text.size()) {
        size_t end = text.find('\n', start);
        if (end == std::string::npos) end = text.size();
        ++lineNumber;
        std::string_view lineText(text.data() + start, end - start);
        start = end + 1;
        const std::vector<std::string_view> tokens = splitWhitespace(lineText);
        if (!tokens.empty()) {
            lastLine = lineNumber;
            const std::string keyword = asciiUpper(tokens[0]);
            const int line = lineNumber;
            if (keyword == "SURF") {
                const int number = integer(line, tokens, 1, "SURF number");
                if (number != static_cast<int>(surfaces_.size()))
                    fail(line, "SURF " + std::to_string(number) + ": expected surface " +
                                   std::to_string(surfaces_.size()) + " (surfaces are numbered from 0 in order)");
                ZemaxSurface s;
                s.number = number;
                s.line = s.typeLine = line;
                surfaces_.push_back(s);
            } else if (keyword == "MODE") {
                if (tokens.size() < 2 || asciiUpper(tokens[1]) != "SEQ")
                    fail(line, "MODE: only sequential files (MODE SEQ) can be read; non-sequential (NSC) systems are not lenses flare can trace");
            } else if (keyword == "UNIT") {
                const std::string unit = tokens.size() > 1 ? asciiUpper(tokens[1]) : "";
                if (unit == "MM") mmPerUnit_ = 1.0;
                else if (unit == "CM") mmPerUnit_ = 10.0;
                else if (unit == "IN") mmPerUnit_ = 25.4;
                else if (unit == "METER") mmPerUnit_ = 1000.0;
                else fail(line, "UNIT: unknown lens unit '" + unit + "' (MM, CM, IN or METER)");
            } else if (keyword == "NAME") {
                std::string_view rest = lineText.substr(tokens[0].data() + tokens[0].size() - lineText.data());
                while (!rest.empty() && std::isspace(static_cast<unsigned char>(rest.front()))) rest.remove_prefix(1);
                while (!rest.empty() && std::isspace(static_cast<unsigned char>(rest.back()))) rest.remove_suffix(1);
                name_ = std::string(rest);
            } else if (keyword == "FNUM") {
                fNumber_ = number(line, tokens, 1, "FNUM");
                if (!(*fNumber_ > 0.0)) fail(line, "FNUM: the f-number must be positive");
            } else if (keyword == "GCAT") {
                for (size_t i = 1; i < tokens.size(); ++i) catalogs_.push_back(asciiUpper(tokens[i]));
            } else if (keyword == "WAVM") {
                const int index = integer(line, tokens, 1, "WAVM number");
                wavelengthsUm_[index] = number(line, tokens, 2, "WAVM wavelength");
            } else if (keyword == "WAVL") {
                for (size_t i = 1; i < tokens.size(); ++i) wavelengthListUm_.push_back(number(line, tokens, i, "WAVL wavelength"));
            } else if (keyword == "PWAV") {
                primaryWavelength_ = integer(line, tokens, 1, "PWAV");
                primaryLine_ = line;
            } else if (keyword == "MNUM") {
                configurations_ = integer(line, tokens, 1, "MNUM configurations");
                if (configurations_ < 1) fail(line, "MNUM: at least one configuration");
                if (tokens.size() > 2) activeConfiguration_ = integer(line, tokens, 2, "MNUM active configuration");
                if (activeConfiguration_ < 1 || activeConfiguration_ > configurations_)
                    fail(line, "MNUM: the active configuration must lie in 1.." + std::to_string(configurations_));
                configurationLine_ = line;
                inConfigurations = true;
            } else if ((keyword == "THIC" || keyword == "SDIA") && !inConfigurations) {
                fail(line, keyword + ": a multi-configuration operand before MNUM");
            } else if (inConfigurations && (keyword == "THIC" || keyword == "SDIA" || kIgnoredOperands.count(keyword) || kUnsupportedOperands.count(keyword))) {
                readOperand(keyword, tokens, line);
            } else if (keyword == "NOTE") {
                // NOTE n text: a note, read past unless it is one of flare's own.
                std::string_view rest = lineText;
                for (int field = 0; field < 2 && !rest.empty(); ++field) {
                    while (!rest.empty() && std::isspace(static_cast<unsigned char>(rest.front()))) rest.remove_prefix(1);
                    while (!rest.empty() && !std::isspace(static_cast<unsigned char>(rest.front()))) rest.remove_prefix(1);
                }
                while (!rest.empty() && std::isspace(static_cast<unsigned char>(rest.front()))) rest.remove_prefix(1);
                if (rest.substr(0, 6) == "flare:") flareNotes_.push_back({std::string(rest.substr(6)), line});
            } else if (kIgnoredSystemKeywords.count(keyword)) {
                // read past
            } else if (!surfaces_.empty() && !inConfigurations) {
                readSurfaceLine(surfaces_.back(), keyword, tokens, line);
            } else if (warnedKeywords_.insert(keyword).second) {
                warn(line, "unknown keyword '" + keyword + "' ignored (and wherever it occurs again)");
            }
        }
        if (end == text.size()) break;
    }

    if (surfaces_.size() < 3)
        fail(lastLine, "a lens needs an object surface, at least one lens surface and an image surface (SURF 0, 1, 2)");
    if (configurations_ > 1)
        for (const auto& [surface, line] : thicknessSolves_)
            failSurface(line, surface, "TCOM",
                        "a thickness solve is not supported with several configurations (its value in each would have to be solved)");

    // Surface types: the same checks for every surface, with the object and image included.
    for (const ZemaxSurface& s : surfaces_) {
        if (s.type == "STANDARD" || s.type == "EVENASPH" || s.type == "ODDASPH") continue;
        if (s.type == "COORDBRK")
            failSurface(s.typeLine, s.number, "TYPE", "coordinate breaks (tilts and decentres) are not supported");
        if (s.type.rfind("GRIN", 0) == 0 || s.type.rfind("GRAD", 0) == 0)
            failSurface(s.typeLine, s.number, "TYPE", "gradient-index surfaces (" + s.type + ") are not supported");
        if (s.type == "NONSEQCO")
            failSurface(s.typeLine, s.number, "TYPE", "non-sequential components are not supported");
        failSurface(s.typeLine, s.number, "TYPE", "surface type " + s.type +
                                                      " is not supported (STANDARD, EVENASPH, or ODDASPH with even terms only)");
    }

    const ZemaxSurface& object = surfaces_.front();
    const ZemaxSurface& image = surfaces_.back();
    if (object.curvature != 0.0) failSurface(object.curvatureLine, 0, "CURV", "a curved object surface is not supported");
    if (object.glass) failSurface(object.glass->line, 0, "GLAS", "object space must be air");
    if (image.curvature != 0.0) failSurface(image.curvatureLine, image.number, "CURV", "a curved image surface (sensor) is not supported");

    double primaryUm = kDefaultPrimaryUm;
    if (!wavelengthsUm_.empty() || !wavelengthListUm_.empty()) {
        const auto it = wavelengthsUm_.find(primaryWavelength_);
        if (it != wavelengthsUm_.end()) primaryUm = it->second;
        else if (primaryWavelength_ >= 1 && primaryWavelength_ <= static_cast<int>(wavelengthListUm_.size()))
            primaryUm = wavelengthListUm_[primaryWavelength_ - 1];
        else fail(primaryLine_, "PWAV: no wavelength number " + std::to_string(primaryWavelength_));
        if (!(primaryUm > 0.0)) fail(primaryLine_, "PWAV: the primary wavelength must be positive");
    }

    LensPrescription p;
    p.sourceFile = file_;
    if (name_.empty()) {
        const size_t slash = file_.find_last_of('/');
        name_ = slash == std::string::npos ? file_ : file_.substr(slash + 1);
    }
    p.name = name_;
    p.source = "Zemax OpticStudio file " + file_;
    p.fNumber = fNumber_;
    if (object.thickness) {
        p.objectDistanceMm = *object.thickness * mmPerUnit_;
        if (!(p.objectDistanceMm > 0.0)) failSurface(object.thicknessLine, 0, "DISZ", "the object distance must be positive or INFINITY");
    }

    applyFlareNotes(p);  // before the rows: a note's coating is what a COAT line names

    int stops = 0;
    std::vector<int> rowOfSurface(surfaces_.size(), -1);
    Medium before = Medium::air();  // the medium in front of the surface being read
    for (size_t k = 1; k + 1 < surfaces_.size(); ++k) {
        const ZemaxSurface& s = surfaces_[k];
        const int n = s.number;
        PrescriptionRow row;
        row.line = s.line;
        row.radiusMm = s.curvature == 0.0 ? 0.0 : mmPerUnit_ / s.curvature;
        if (!s.thickness) failSurface(s.line, n, "DISZ", "the thickness is missing");
        if (std::isinf(*s.thickness)) failSurface(s.thicknessLine, n, "DISZ", "INFINITY is only allowed on the object surface");
        if (*s.thickness < 0.0) failSurface(s.thicknessLine, n, "DISZ", "negative thicknesses are not supported");
        row.thickness.valueMm = *s.thickness * mmPerUnit_;
        row.conic = s.conic;
        // PARM i of an even asphere is the coefficient of r^(2i); of an odd asphere, of r^i. flare's
        // surfaces carry r⁴ … r¹⁶; a coefficient in lens units scales as length^(1 − power).
        for (const auto& [index, entry] : s.parms) {
            const auto [value, line] = entry;
            if (value == 0.0) continue;
            const int power = s.type == "EVENASPH" ? 2 * index : s.type == "ODDASPH" ? index : 0;
            if (power == 0) continue;  // PARM of a STANDARD surface means nothing
            if (power < 4 || power > 16 || power % 2 != 0)
                failSurface(line, n, "PARM " + std::to_string(index),
                            "the r^" + std::to_string(power) + " aspheric term is not supported (flare's aspheres have r^4 to r^16)");
            row.asphere[power / 2 - 2] = value * std::pow(mmPerUnit_, 1 - power);
        }
        if (!s.semiDiameter || !(*s.semiDiameter > 0.0))
            failSurface(s.line, n, "DIAM", "the surface needs a positive semi-diameter (its clear aperture)");
        row.semiApertureMm = *s.semiDiameter * mmPerUnit_;
        if (s.clearApertureMax) row.semiApertureMm = std::min(row.semiApertureMm, *s.clearApertureMax * mmPerUnit_);
        // Zemax's mechanical semi-diameter is at least the clear one; only a larger one says
        // more than flare's default edge (the element's larger clear radius).
        if (s.mechSemiDiameter && *s.mechSemiDiameter * mmPerUnit_ > row.semiApertureMm)
            row.mechSemiDiameterMm = *s.mechSemiDiameter * mmPerUnit_;
        row.mediumAfter = medium(s, &row.materialText);
        if (s.coating) {
            const auto& [coatingName, line] = *s.coating;
            const std::string upper = asciiUpper(coatingName);
            if (p.findCoating(coatingName) && upper != "MGF2") {
                // One a flare note defined (or flare's own `none` / `mgf2` as written).
                row.coatingName = coatingName;
            } else if (upper == "AR" || upper == "MGF2") {
                // Zemax's AR is one quarter-wave layer of MgF2 at the primary wavelength, and a
                // material named as a coating is one quarter-wave layer of that material: COAT
                // MGF2 is the same layer. At 550 nm it is flare's mgf2.
                const double primaryNm = primaryUm * 1000.0;
                if (primaryNm == kMgF2DesignNm) {
                    row.coatingName = "mgf2";
                } else {
                    if (!p.findCoating(upper)) p.coatings.push_back(Coating::quarterWave(upper, kMgF2Index, primaryNm));
                    row.coatingName = upper;
                }
            } else if (upper == "NONE") {
                row.coatingName = "none";
            } else {
                warn(line, "surface " + std::to_string(n) + ", COAT: coating '" + coatingName +
                               "' is not one flare knows (AR, MGF2, NONE, or one a `flare: coating` note defines): the "
                               "surface is left uncoated");
            }
        }
        if (s.stop && ++stops > 1) failSurface(s.line, n, "STOP", "a second aperture stop");
        const bool plainStop = s.stop && row.radiusMm == 0.0 && row.asphere == decltype(row.asphere){} &&
                               before.describe() == row.mediumAfter.describe();
        if (plainStop) {
            row.isStop = true;
            row.coatingName.reset();
            row.conic = 0.0;
        } else if (s.stop) {
            // A stop on a lens surface: flare's stop is a plane of its own, put at the surface's
            // vertex on the side where the surface does not cross it.
            Surface surface;
            surface.radiusMm = row.radiusMm;
            surface.conic = row.conic;
            surface.asphere = row.asphere;
            bool ahead = true, behind = true;
            for (int i = 1; i <= 16; ++i) {
                double sag = 0.0;
                const double r = row.semiApertureMm * i / 16.0;
                if (!surface.sagMm(r * r, &sag)) break;
                ahead &= sag >= 0.0;
                behind &= sag <= 0.0;
            }
            if (!ahead && !behind)
                failSurface(s.line, n, "STOP", "the stop lies on a surface that bends both ways; put it on a flat surface of its own");
            PrescriptionRow stop;
            stop.isStop = true;
            stop.line = s.line;
            stop.semiApertureMm = row.semiApertureMm;
            stop.materialText = "(stop)";
            if (ahead) {
                stop.mediumAfter = before;
                p.rows.push_back(stop);
            } else {
                // Behind the surface, the stop row takes over its thickness (and THIC operand).
                stop.mediumAfter = row.mediumAfter;
                stop.thickness = row.thickness;
                row.thickness.valueMm = 0.0;
                p.rows.push_back(row);
                p.rows.push_back(stop);
                rowOfSurface[k] = static_cast<int>(p.rows.size()) - 1;
                before = row.mediumAfter;
                continue;
            }
        }
        rowOfSurface[k] = static_cast<int>(p.rows.size());
        p.rows.push_back(row);
        before = row.mediumAfter;
    }
    if (stops == 0) fail(lastLine, "no surface is marked STOP (the aperture stop)");

    buildZoom(p, rowOfSurface);
    validatePrescription(p, lastLine);
    return p;
}

// flare's notes: iris and coating lines as in a .lens file; a zoom line's names and focal lengths,
// applied to the configurations by buildZoom. Anything else is a warning (a newer flare's note).
void ZemaxReader::applyFlareNotes(LensPrescription& p) {
    for (const auto& [text, line] : flareNotes_) {
        const std::vector<std::string_view> tokens = splitWhitespace(text);
        const std::string key = tokens.empty() ? "" : asciiLower(tokens[0]);
        if (key == "iris" || key == "coating") {
            parseLensHeaderLine(p, text, file_, line);
        } else if (key == "zoom") {
            if (!notedPositions_.empty()) fail(line, "flare: zoom: given twice");
            LensPrescription names;  // the .lens reader checks the zoom line (names, increasing focal lengths)
            parseLensHeaderLine(names, text, file_, line);
            notedPositions_ = names.zoomPositions;
            notedPositionsLine_ = line;
        } else {
            warn(line, "a flare note '" + key + "' this flare does not know: ignored");
        }
    }
}

// Configurations whose thicknesses differ become zoom positions, in increasing focal length
// (their EFL at the d line), each varying thickness a gap named after its surface (d5: the
// thickness after surface 5).
void ZemaxReader::buildZoom(LensPrescription& p, const std::vector<int>& rowOfSurface) {
    if (configurations_ == 1) return;
    const int last = static_cast<int>(surfaces_.size()) - 1;
    for (const auto& [surface, op] : thicknessOperands_) {
        if (surface < 0) continue;
        if (surface > last) fail(op.line, "THIC: surface " + std::to_string(surface) + " does not exist");
        for (int c = 1; c <= configurations_; ++c)
            if (!op.values.count(c))
                fail(op.line, "THIC: surface " + std::to_string(surface) + " has no value for configuration " + std::to_string(c));
        const double first = op.values.begin()->second.first;
        const bool varies = std::any_of(op.values.begin(), op.values.end(), [&](const auto& v) { return v.second.first != first; });
        if (surface == last) continue;  // beyond the image: no meaning
        if (surface == 0) {
            // Focus configurations: flare focuses with a state (--focus), not per zoom position.
            const double active = op.values.at(activeConfiguration_).first * mmPerUnit_;
            if (varies)
                warn(op.line, "THIC 0: the object distance varies between configurations; flare keeps configuration " +
                                  std::to_string(activeConfiguration_) + "'s (focus with --focus or a scene's focus)");
            p.objectDistanceMm = active;
            continue;
        }
        PrescriptionRow& row = p.rows[rowOfSurface[surface]];
        if (!varies) {
            row.thickness.valueMm = first * mmPerUnit_;
            continue;
        }
        VariableGap gap;
        gap.name = "d" + std::to_string(surface);
        gap.line = op.line;
        for (const auto& [c, entry] : op.values) {
            const auto [value, line] = entry;
            if (!std::isfinite(value) || value < 0.0)
                fail(line, "THIC: surface " + std::to_string(surface) + " needs a finite thickness of at least 0 in every configuration");
            gap.valuesMm.push_back(value * mmPerUnit_);
        }
        row.thickness.kind = ThicknessSpec::Kind::Gap;
        row.thickness.gapName = gap.name;
        p.gaps.push_back(std::move(gap));
    }
    // SDIA: the stop's semi-diameter per configuration, a zoom's iris that opens as it zooms (an
    // `aperture` line of a .lens file). Only a flat STOP surface of its own may vary.
    for (const auto& [surface, op] : semiDiameterOperands_) {
        if (surface < 1 || surface >= last)
            fail(op.line, "SDIA: surface " + std::to_string(surface) + " is not a lens surface");
        for (int c = 1; c <= configurations_; ++c)
            if (!op.values.count(c))
                fail(op.line, "SDIA: surface " + std::to_string(surface) + " has no value for configuration " + std::to_string(c));
        const double first = op.values.begin()->second.first;
        if (std::all_of(op.values.begin(), op.values.end(), [&](const auto& v) { return v.second.first == first; }))
            continue;  // the same in every configuration: DIAM says it
        PrescriptionRow& row = p.rows[rowOfSurface[surface]];
        if (!row.isStop)
            fail(op.line, "SDIA: the semi-diameter of surface " + std::to_string(surface) +
                              " varies between configurations; flare varies only the aperture stop's (a flat STOP "
                              "surface of its own): an element's clear aperture does not change with zoom");
        VariableAperture aperture;
        aperture.name = "stop" + std::to_string(surface);
        aperture.line = op.line;
        for (const auto& [c, entry] : op.values) {
            const auto [value, line] = entry;
            if (!std::isfinite(value) || !(value > 0.0))
                fail(line, "SDIA: surface " + std::to_string(surface) + " needs a positive semi-diameter in every configuration");
            aperture.valuesMm.push_back(value * mmPerUnit_);
        }
        row.semiApertureName = aperture.name;
        row.semiApertureMm = *std::max_element(aperture.valuesMm.begin(), aperture.valuesMm.end());
        p.apertures.push_back(std::move(aperture));
    }
    if (p.gaps.empty()) {
        // The configurations differ in nothing flare models as a zoom (no thickness varies): the
        // active configuration's stop is kept.
        for (VariableAperture& aperture : p.apertures) {
            for (PrescriptionRow& row : p.rows) {
                if (row.semiApertureName != aperture.name) continue;
                warn(aperture.line, "SDIA: the stop's semi-diameter varies between configurations whose thicknesses "
                                    "do not; flare keeps configuration " + std::to_string(activeConfiguration_) + "'s");
                row.semiApertureName.clear();
                row.semiApertureMm = aperture.valuesMm[activeConfiguration_ - 1];
            }
        }
        p.apertures.clear();
        return;
    }

    // Name the configurations, find their focal lengths and order them by it.
    for (int c = 1; c <= configurations_; ++c) p.zoomPositions.push_back({"config" + std::to_string(c), static_cast<double>(c)});
    std::vector<std::pair<double, int>> efl;
    for (int c = 0; c < configurations_; ++c) {
        const LensSystem lens = LensSystem::build(p, LensState{p.zoomPositions[c].name, {}, {}});
        efl.push_back({paraxialEflMm(lens, lens.indicesAt(kLineDNm)), c});
    }
    std::sort(efl.begin(), efl.end());
    for (size_t i = 0; i < efl.size(); ++i) {
        if (!(efl[i].first > 0.0))
            fail(configurationLine_, "configuration " + std::to_string(efl[i].second + 1) +
                                         " has no positive focal length (EFL " + shortestNumberText(efl[i].first) + " mm)");
        if (i > 0 && efl[i].first == efl[i - 1].first)
            fail(configurationLine_, "configurations " + std::to_string(efl[i - 1].second + 1) + " and " +
                                         std::to_string(efl[i].second + 1) +
                                         " have the same focal length: flare's zoom positions must differ in it");
    }
    // A `flare: zoom` note names the configurations (in their order) with their published focal
    // lengths; without one they are config1, config2, ... at their EFL.
    if (!notedPositions_.empty() && notedPositions_.size() != static_cast<size_t>(configurations_)) {
        warn(notedPositionsLine_, "flare: zoom: " + std::to_string(notedPositions_.size()) + " position(s) for " +
                                      std::to_string(configurations_) + " configurations: the names are left out");
        notedPositions_.clear();
    }
    std::vector<ZoomPosition> positions;
    for (const auto& [focal, c] : efl)
        positions.push_back(notedPositions_.empty() ? ZoomPosition{"config" + std::to_string(c + 1), focal}
                                                    : notedPositions_[c]);
    for (size_t i = 1; i < positions.size(); ++i)
        if (!notedPositions_.empty() && positions[i].focalLengthMm <= positions[i - 1].focalLengthMm)
            fail(notedPositionsLine_, "flare: zoom: the positions' focal lengths do not increase with the "
                                      "configurations' EFLs");
    for (std::vector<VariableGap>* values : {&p.gaps, &p.apertures}) {
        for (VariableGap& value : *values) {
            std::vector<double> ordered;
            for (const auto& [focal, c] : efl) ordered.push_back(value.valuesMm[c]);
            value.valuesMm = std::move(ordered);
        }
    }
    p.zoomPositions = std::move(positions);
}

}  // namespace

LensPrescription parseZemaxText(std::string_view bytes, const std::string& fileName, std::vector<std::string>* warnings) {
    return ZemaxReader(fileName, warnings).read(bytes);
}

LensPrescription loadZemaxFile(const std::string& path, std::vector<std::string>* warnings) {
    return parseZemaxText(readFileBytes(path, "lens file"), path, warnings);
}

}  // namespace flare
