#include "flare/optics/LensFile.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <span>
#include <sstream>
#include <vector>

#include "flare/core/Error.h"
#include "flare/core/TextEncoding.h"
#include "flare/optics/EmbeddedLenses.h"
#include "flare/optics/LensFileParsing.h"
#include "flare/optics/LensLibrary.h"
#include "flare/optics/PbrtLensFile.h"
#include "flare/optics/ZemaxFile.h"

namespace flare {

namespace {

using lensfile::checkAperture;
using lensfile::checkApertures;
using lensfile::Line;
using lensfile::Parser;
using lensfile::splitLines;
using lensfile::trim;
using lensfile::validate;

constexpr const char* kAsphereKeys[kAsphereTerms] = {"a4", "a6", "a8", "a10", "a12", "a14", "a16"};

// A row whose semi-aperture column names an `aperture` line takes as its semiApertureMm the largest
// opening, which the iris mount must hold (LensSystem::build takes the zoom position's value).
void resolveApertures(const Parser& parser, LensPrescription& p) {
    checkApertures(parser, p);
    for (PrescriptionRow& row : p.rows) {
        if (row.semiApertureName.empty()) continue;
        const VariableAperture* aperture = p.findAperture(row.semiApertureName);
        row.semiApertureMm = *std::max_element(aperture->valuesMm.begin(), aperture->valuesMm.end());
    }
}

// Dielectric coating layers have indices of at least 1 (the thin-film code relies on it).
double layerIndex(const Parser& parser, int line, std::string_view token) {
    const double index = parser.positive(line, token, "coating layer index");
    if (index < 1.0) parser.error(line, "coating layer index must be at least 1, got " + std::string(token));
    return index;
}

// `R=0.04` (flat) or `wavelength_nm:R` points in increasing wavelength.
IdealReflectance parseIdealReflectance(const Parser& parser, int line, std::span<const std::string_view> tokens) {
    IdealReflectance ideal;
    for (const std::string_view token : tokens) {
        if (asciiLower(token.substr(0, 2)) == "r=") {
            if (tokens.size() != 1) parser.error(line, "an ideal coating takes either R= or wavelength_nm:R points, not both");
            ideal.wavelengthsNm.push_back(550.0);
            ideal.reflectances.push_back(parser.fraction(line, token.substr(2), "ideal coating reflectance R"));
            continue;
        }
        const size_t colon = token.find(':');
        if (colon == std::string_view::npos)
            parser.error(line, "ideal coating point '" + std::string(token) + "' must be wavelength_nm:R (or give R=)");
        const double wavelength = parser.positive(line, token.substr(0, colon), "ideal coating wavelength");
        if (!ideal.wavelengthsNm.empty() && wavelength <= ideal.wavelengthsNm.back())
            parser.error(line, "ideal coating wavelengths must increase");
        ideal.wavelengthsNm.push_back(wavelength);
        ideal.reflectances.push_back(parser.fraction(line, token.substr(colon + 1), "ideal coating reflectance"));
    }
    if (ideal.wavelengthsNm.empty()) parser.error(line, "an ideal coating needs R= or wavelength_nm:R points");
    return ideal;
}

void parseCoating(const Parser& parser, LensPrescription& p, int line,
                  const std::vector<std::string_view>& tokens) {
    if (tokens.size() < 4)
        parser.error(line, "coating needs a name, a kind (single, stack or ideal) and its layers or reflectance");
    Coating coating;
    coating.name = std::string(tokens[1]);
    if (coating.name == "none" || coating.name == "mgf2")
        parser.error(line, "coating name '" + coating.name + "' is built in and cannot be redefined");
    const std::string kind = asciiLower(tokens[2]);
    if (kind == "single") {
        std::optional<double> index, quarterWaveNm, thicknessNm;
        for (size_t i = 3; i < tokens.size(); ++i) {
            const auto [key, value] = parser.keyValue(line, tokens[i]);
            if (key == "n") index = layerIndex(parser, line, value);
            else if (key == "quarter_wave_nm") quarterWaveNm = parser.positive(line, value, "quarter_wave_nm");
            else if (key == "thickness_nm") thicknessNm = parser.positive(line, value, "thickness_nm");
            else parser.error(line, "unknown coating option '" + key + "'");
        }
        if (!index) parser.error(line, "single-layer coating needs n=");
        if (quarterWaveNm.has_value() == thicknessNm.has_value())
            parser.error(line, "single-layer coating needs exactly one of quarter_wave_nm= or thickness_nm=");
        coating.layers.push_back({*index, thicknessNm ? *thicknessNm : *quarterWaveNm / (4.0 * *index)});
    } else if (kind == "stack") {
        for (size_t i = 3; i < tokens.size(); ++i) {
            const size_t colon = tokens[i].find(':');
            if (colon == std::string_view::npos)
                parser.error(line, "stack layer '" + std::string(tokens[i]) + "' must be index:thickness_nm");
            coating.layers.push_back({layerIndex(parser, line, tokens[i].substr(0, colon)),
                                      parser.positive(line, tokens[i].substr(colon + 1), "layer thickness")});
        }
    } else if (kind == "ideal") {
        coating.ideal = parseIdealReflectance(parser, line, std::span(tokens).subspan(3));
    } else {
        parser.error(line, "unknown coating kind '" + std::string(tokens[2]) + "' (single, stack or ideal)");
    }
    for (const Coating& c : p.coatings)
        if (c.name == coating.name) parser.error(line, "coating '" + coating.name + "' is defined twice");
    p.coatings.push_back(std::move(coating));
}

void parseHeader(const Parser& parser, LensPrescription& p, const Line& line) {
    const std::vector<std::string_view> tokens = splitWhitespace(line.text);
    const std::string key = asciiLower(tokens[0]);
    const std::string_view rest = trim(line.text.substr(tokens[0].size()));
    const int n = line.number;
    auto requireValue = [&] {
        if (tokens.size() < 2) parser.error(n, "'" + key + "' needs a value");
    };
    auto requireSingle = [&] {
        if (tokens.size() != 2) parser.error(n, "'" + key + "' takes exactly one value");
    };
    if (key == "name") {
        requireValue();
        p.name = std::string(rest);
    } else if (key == "source") {
        requireValue();
        p.source = std::string(rest);
    } else if (key == "focal_length_mm") {
        requireSingle();
        p.focalLengthMm = parser.positive(n, tokens[1], "focal_length_mm");
    } else if (key == "f_number") {
        requireValue();
        if (tokens[1].find('=') == std::string_view::npos) {
            requireSingle();
            p.fNumber = parser.positive(n, tokens[1], "f_number");
        } else {
            // A variable-aperture zoom: the stated f-number at each position (as `gap` values).
            if (p.zoomPositions.empty()) parser.error(n, "f_number per zoom position must follow the zoom line");
            std::vector<std::optional<double>> values(p.zoomPositions.size());
            for (size_t i = 1; i < tokens.size(); ++i) {
                const auto [k, v] = parser.keyValue(n, tokens[i]);
                const auto it = std::find_if(p.zoomPositions.begin(), p.zoomPositions.end(),
                                             [&](const ZoomPosition& z) { return z.name == k; });
                if (it == p.zoomPositions.end()) parser.error(n, "f_number: unknown zoom position '" + k + "'");
                std::optional<double>& value = values[it - p.zoomPositions.begin()];
                if (value) parser.error(n, "f_number: zoom position '" + k + "' is given twice");
                value = parser.positive(n, v, "f_number");
            }
            for (size_t i = 0; i < values.size(); ++i) {
                if (!values[i]) parser.error(n, "f_number: no value for zoom position '" + p.zoomPositions[i].name + "'");
                p.zoomPositions[i].fNumber = values[i];
            }
            p.fNumber = p.zoomPositions[0].fNumber;
        }
    } else if (key == "object_distance_mm") {
        requireSingle();
        p.objectDistanceMm = parser.number(n, tokens[1], "object_distance_mm");
        if (!(p.objectDistanceMm > 0.0)) parser.error(n, "object_distance_mm must be positive or inf");
    } else if (key == "iris") {
        for (size_t i = 1; i < tokens.size(); ++i) {
            const auto [k, v] = parser.keyValue(n, tokens[i]);
            if (k == "blades") {
                const double blades = parser.finiteNumber(n, v, "iris blades");
                if (blades != std::floor(blades) || (blades != 0 && blades < 3) || blades > 64)
                    parser.error(n, "iris blades must be 0 (circular) or an integer from 3 to 64");
                p.iris.blades = static_cast<int>(blades);
            } else if (k == "rotation_deg") {
                p.iris.rotationDeg = parser.finiteNumber(n, v, "iris rotation_deg");
            } else if (k == "curvature") {
                p.iris.curvature = parser.finiteNumber(n, v, "iris curvature");
                if (p.iris.curvature < 0.0 || p.iris.curvature > 1.0)
                    parser.error(n, "iris curvature must lie in [0, 1]");
            } else {
                parser.error(n, "unknown iris option '" + k + "'");
            }
        }
    } else if (key == "sensor") {
        for (size_t i = 1; i < tokens.size(); ++i) {
            const auto [k, v] = parser.keyValue(n, tokens[i]);
            if (k == "width_mm") p.sensor.widthMm = parser.positive(n, v, "sensor width_mm");
            else if (k == "height_mm") p.sensor.heightMm = parser.positive(n, v, "sensor height_mm");
            else if (k == "reflectance") {
                p.sensor.reflectance = parser.finiteNumber(n, v, "sensor reflectance");
                if (p.sensor.reflectance < 0.0 || p.sensor.reflectance > 1.0)
                    parser.error(n, "sensor reflectance must lie in [0, 1]");
            } else parser.error(n, "unknown sensor option '" + k + "'");
        }
    } else if (key == "housing") {
        for (size_t i = 1; i < tokens.size(); ++i) {
            const auto [k, v] = parser.keyValue(n, tokens[i]);
            if (k == "margin_mm") {
                p.housingMarginMm = parser.finiteNumber(n, v, "housing margin_mm");
                if (p.housingMarginMm < 0.0) parser.error(n, "housing margin_mm must not be negative");
            } else parser.error(n, "unknown housing option '" + k + "'");
        }
    } else if (key == "zoom") {
        if (!p.zoomPositions.empty()) parser.error(n, "zoom positions are given twice");
        if (tokens.size() < 2) parser.error(n, "zoom needs at least one name=focal_length position");
        for (size_t i = 1; i < tokens.size(); ++i) {
            const auto [k, v] = parser.keyValue(n, tokens[i]);
            const double f = parser.positive(n, v, "zoom focal length");
            for (const ZoomPosition& z : p.zoomPositions)
                if (z.name == k) parser.error(n, "zoom position '" + k + "' is given twice");
            if (!p.zoomPositions.empty() && f <= p.zoomPositions.back().focalLengthMm)
                parser.error(n, "zoom positions must be listed in increasing focal length");
            p.zoomPositions.push_back({k, f});
        }
    } else if (key == "gap" || key == "aperture") {
        // `gap NAME pos=mm ...` (a thickness) or `aperture NAME pos=mm ...` (the stop's
        // semi-aperture): one value per zoom position, every position.
        const bool gapLine = key == "gap";
        if (p.zoomPositions.empty()) parser.error(n, key + " lines must follow the zoom line");
        if (tokens.size() < 2) parser.error(n, key + " needs a name and one value per zoom position");
        VariableGap values;
        values.name = std::string(tokens[1]);
        values.line = n;
        if (!std::isalpha(static_cast<unsigned char>(values.name[0])) && values.name[0] != '_')
            parser.error(n, key + " name '" + values.name + "' must begin with a letter or '_' (a number would be read as a value)");
        if (gapLine ? p.findGap(values.name) != nullptr : p.findAperture(values.name) != nullptr)
            parser.error(n, key + " '" + values.name + "' is defined twice");
        const std::string what = key + " '" + values.name + "'";
        std::vector<std::optional<double>> byPosition(p.zoomPositions.size());
        for (size_t i = 2; i < tokens.size(); ++i) {
            const auto [k, v] = parser.keyValue(n, tokens[i]);
            auto it = std::find_if(p.zoomPositions.begin(), p.zoomPositions.end(),
                                   [&](const ZoomPosition& z) { return z.name == k; });
            if (it == p.zoomPositions.end()) parser.error(n, what + ": unknown zoom position '" + k + "'");
            std::optional<double>& value = byPosition[it - p.zoomPositions.begin()];
            if (value) parser.error(n, what + ": zoom position '" + k + "' is given twice");
            if (gapLine) {
                value = parser.finiteNumber(n, v, "gap value");
                if (*value < 0.0) parser.error(n, what + " is negative at '" + k + "'");
            } else {
                value = parser.finiteNumber(n, v, "aperture value");
                if (!(*value > 0.0)) parser.error(n, what + " must be positive at '" + k + "'");
            }
        }
        for (size_t i = 0; i < byPosition.size(); ++i) {
            if (!byPosition[i])
                parser.error(n, what + " has no value for zoom position '" + p.zoomPositions[i].name + "'");
            values.valuesMm.push_back(*byPosition[i]);
        }
        (gapLine ? p.gaps : p.apertures).push_back(std::move(values));
    } else if (key == "coating") {
        parseCoating(parser, p, n, tokens);
    } else if (key == "default_coating") {
        requireSingle();
        p.defaultCoating = std::string(tokens[1]);
        if (!p.findCoating(p.defaultCoating))
            parser.error(n, "unknown coating '" + p.defaultCoating + "' (define it with a coating line first)");
    } else if (key == "finish") {
        // finish housing|edges|iris diffuse=A glossy=G
        if (tokens.size() < 3) parser.error(n, "finish needs a part (housing, edges or iris) and diffuse=/glossy= values");
        const std::string part = asciiLower(tokens[1]);
        std::optional<FinishSpec>* target = part == "housing" ? &p.housingFinish
                                            : part == "edges" ? &p.edgeFinish
                                            : part == "iris"  ? &p.irisFinish
                                                              : nullptr;
        if (!target) parser.error(n, "unknown finish part '" + std::string(tokens[1]) + "' (housing, edges or iris)");
        if (*target) parser.error(n, "the " + part + " finish is given twice");
        FinishSpec finish;
        for (size_t i = 2; i < tokens.size(); ++i) {
            const auto [k, v] = parser.keyValue(n, tokens[i]);
            if (k == "diffuse") finish.diffuse = parser.fraction(n, v, part + " diffuse");
            else if (k == "glossy") finish.glossy = parser.fraction(n, v, part + " glossy");
            else parser.error(n, "unknown finish option '" + k + "' (diffuse, glossy)");
        }
        if (finish.diffuse + finish.glossy > 1.0)
            parser.error(n, part + " diffuse + glossy must not exceed 1 (energy)");
        *target = finish;
    } else if (key == "gloss_exponent") {
        requireSingle();
        const double exponent = parser.finiteNumber(n, tokens[1], "gloss_exponent");
        if (exponent < 0.0 || exponent > 1e5) parser.error(n, "gloss_exponent must lie in [0, 100000]");
        p.glossExponent = exponent;
    } else {
        parser.error(n, "unknown header keyword '" + std::string(tokens[0]) + "'");
    }
}

PrescriptionRow parseRow(const Parser& parser, const Line& line) {
    const std::vector<std::string_view> tokens = splitWhitespace(line.text);
    const int n = line.number;
    // The material column may itself contain '=' (n=1.67); options follow the fourth column.
    size_t columns = std::min<size_t>(tokens.size(), 4);
    for (size_t i = 4; i < tokens.size(); ++i)
        if (tokens[i].find('=') == std::string_view::npos) ++columns;
    if (columns != 4)
        parser.error(n, "expected 4 columns (radius thickness material semi_aperture) before the options, found " +
                            std::to_string(columns));
    PrescriptionRow row;
    row.line = n;
    const std::string radius = asciiLower(tokens[0]);
    if (radius == "stop") {
        row.isStop = true;
    } else {
        const double r = parser.number(n, tokens[0], "radius");
        row.radiusMm = std::isinf(r) ? 0.0 : r;
    }
    const std::string thickness = asciiLower(tokens[1]);
    if (thickness == "auto") {
        row.thickness.kind = ThicknessSpec::Kind::Auto;
    } else if (std::isalpha(static_cast<unsigned char>(tokens[1][0])) || tokens[1][0] == '_') {
        row.thickness.kind = ThicknessSpec::Kind::Gap;
        row.thickness.gapName = std::string(tokens[1]);
    } else {
        row.thickness.valueMm = parser.finiteNumber(n, tokens[1], "thickness");
        if (row.thickness.valueMm < 0.0) parser.error(n, "thickness must not be negative");
    }
    row.materialText = std::string(tokens[2]);
    row.mediumAfter = parser.material(n, tokens[2]);
    if (std::isalpha(static_cast<unsigned char>(tokens[3][0])) || tokens[3][0] == '_') {
        // A name: the stop's semi-aperture per zoom position (an `aperture` line); resolved, and
        // allowed on the stop row only, once every row is read.
        row.semiApertureName = std::string(tokens[3]);
    } else {
        row.semiApertureMm = parser.positive(n, tokens[3], "semi_aperture");
    }
    bool dustCoverageGiven = false, greaseCoverageGiven = false;
    for (size_t i = 4; i < tokens.size(); ++i) {
        const auto [key, value] = parser.keyValue(n, tokens[i]);
        if (key == "k") {
            row.conic = parser.finiteNumber(n, value, "conic constant k");
            continue;
        }
        if (key == "coating") {
            row.coatingName = std::string(value);
            continue;
        }
        if (key == "mech") {
            row.mechSemiDiameterMm = parser.positive(n, value, "mech");
            continue;
        }
        // Dust and grease: `dust=` / `grease=` give the coverage, the other keys refine it.
        if (key == "dust" || key.rfind("dust_", 0) == 0) {
            RowDust& dust = row.dust ? *row.dust : row.dust.emplace();
            if (key == "dust") dust.coverage = parser.fraction(n, value, "dust coverage"), dustCoverageGiven = true;
            else if (key == "dust_albedo") dust.albedo = parser.fraction(n, value, "dust_albedo");
            else if (key == "dust_diameter_um") {
                dust.diameterUm = parser.positive(n, value, "dust_diameter_um");
                if (dust.diameterUm > 1e4) parser.error(n, "dust_diameter_um must not exceed 10000");
            } else if (key == "dust_sigma") {
                dust.diameterSigma = parser.finiteNumber(n, value, "dust_sigma");
                if (dust.diameterSigma < 0.0 || dust.diameterSigma > 3.0) parser.error(n, "dust_sigma must lie in [0, 3]");
            } else parser.error(n, "unknown surface option '" + key + "' (dust, dust_albedo, dust_diameter_um, dust_sigma)");
            continue;
        }
        if (key == "grease" || key.rfind("grease_", 0) == 0) {
            RowGrease& grease = row.grease ? *row.grease : row.grease.emplace();
            if (key == "grease") grease.coverage = parser.fraction(n, value, "grease coverage"), greaseCoverageGiven = true;
            else if (key == "grease_roughness") {
                grease.roughness = parser.fraction(n, value, "grease_roughness");
                if (!(grease.roughness > 0.0)) parser.error(n, "grease_roughness must be positive");
            } else parser.error(n, "unknown surface option '" + key + "' (grease, grease_roughness)");
            continue;
        }
        const auto* it = std::find(std::begin(kAsphereKeys), std::end(kAsphereKeys), key);
        if (it == std::end(kAsphereKeys)) parser.error(n, "unknown surface option '" + key + "'");
        row.asphere[it - std::begin(kAsphereKeys)] = parser.finiteNumber(n, value, key);
    }
    if (row.isStop && (row.conic != 0.0 || row.mechSemiDiameterMm || row.dust || row.grease))
        parser.error(n, "the stop row takes no surface options");
    if (row.dust && !dustCoverageGiven) parser.error(n, "dust_ options need dust=COVERAGE on the same row");
    if (row.grease && !greaseCoverageGiven) parser.error(n, "grease_ options need grease=COVERAGE on the same row");
    if (row.mechSemiDiameterMm && *row.mechSemiDiameterMm < row.semiApertureMm)
        parser.error(n, "mech must not be smaller than the semi-aperture");
    checkAperture(parser, row);
    return row;
}

std::string readFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(path, 0, std::string("cannot open lens file: ") + std::strerror(errno));
    std::ostringstream buffer;
    buffer << in.rdbuf();
    return buffer.str();
}

}  // namespace

void parseLensHeaderLine(LensPrescription& p, std::string_view text, const std::string& fileName, int line) {
    const std::string_view trimmed = trim(text);
    if (trimmed.empty()) throw InputError(fileName, line, "an empty header line");
    parseHeader(Parser(fileName), p, Line{line, trimmed});
}

LensPrescription parseLensText(std::string_view text, const std::string& fileName) {
    const Parser parser(fileName);
    LensPrescription p;
    p.sourceFile = fileName;
    const std::vector<Line> lines = splitLines(text);
    bool inSurfaces = false;
    int lastLine = 0;
    for (const Line& line : lines) {
        lastLine = line.number;
        if (!inSurfaces) {
            if (asciiLower(line.text) == "surfaces" || asciiLower(line.text) == "surfaces:") {
                inSurfaces = true;
                continue;
            }
            parseHeader(parser, p, line);
        } else {
            p.rows.push_back(parseRow(parser, line));
        }
    }
    if (p.name.empty()) parser.error(0, "missing header line 'name'");
    if (!inSurfaces) parser.error(lastLine, "missing the 'surfaces' line that starts the surface table");
    if (!p.focalLengthMm && p.zoomPositions.empty())
        parser.error(0, "missing header line 'focal_length_mm' (or 'zoom')");
    for (const VariableGap& gap : p.gaps) {
        const bool used = std::any_of(p.rows.begin(), p.rows.end(), [&](const PrescriptionRow& r) {
            return r.thickness.kind == ThicknessSpec::Kind::Gap && r.thickness.gapName == gap.name;
        });
        if (!used) parser.error(gap.line, "gap '" + gap.name + "' is defined but no row uses it");
    }
    resolveApertures(parser, p);
    validate(parser, p, lastLine);
    return p;
}

void validatePrescription(const LensPrescription& p, int lastLine) {
    const Parser parser(p.sourceFile);
    for (const PrescriptionRow& row : p.rows) checkAperture(parser, row);
    validate(parser, p, lastLine);
}

std::string unknownLensProblem(const std::string& name) {
    std::vector<std::string> shipped;
    for (const EmbeddedLens& lens : embeddedLenses()) shipped.emplace_back(lens.name);
    std::string shippedText;
    for (const std::string& s : shipped) shippedText += (shippedText.empty() ? "" : ", ") + s;
    const LensLibrary& library = LensLibrary::shared();
    std::string problem = "no lens file, shipped lens (" + shippedText + ") or library lens '" + name + "'";
    if (const LibraryLens* renamed = library.renamed(name))
        return problem + ": that library id was renamed '" + renamed->id + "', " + renamed->name +
               " (its old name did not give its focal length or f-number; docs/lens-library.md)";
    if (library.folders().empty()) {
        std::string searched;
        for (const std::string& folder : LensLibrary::defaultFolders()) searched += (searched.empty() ? "" : ", ") + folder;
        return problem + "; no lens library was found (searched " + searched + "; FLARE_LENS_PATH adds folders)";
    }
    problem += "; the library (" + std::to_string(library.lenses().size()) + " lenses in " + library.folders().front() +
               (library.folders().size() > 1 ? " and " + std::to_string(library.folders().size() - 1) + " more folders" : "") +
               ") was searched";
    const std::vector<std::string> nearest = library.nearestIds(name, 6, shipped);
    if (nearest.empty()) return problem + " (`flare lens search WORDS` finds lenses by maker, model or patent)";
    std::string list;
    for (const std::string& id : nearest) list += (list.empty() ? "" : ", ") + id;
    return problem + "; nearest: " + list;
}

LensPrescription loadLens(const std::string& pathOrName) {
    if (pathOrName.find('/') == std::string::npos && !std::ifstream(pathOrName).good()) {
        std::string name = pathOrName;
        if (name.size() > 5 && name.compare(name.size() - 5, 5, ".lens") == 0) name.resize(name.size() - 5);
        for (const EmbeddedLens& lens : embeddedLenses())
            if (name == lens.name) return parseLensText(lens.text, "lenses/" + name + ".lens");
        if (const LibraryLens* lens = LensLibrary::shared().find(name)) return loadLensFile(lens->path);
        // Not a file here, nor a name: a pbrt or Zemax file name still reports why it cannot be
        // opened; anything else may have been meant as a name.
        const std::string extension = name.size() >= 4 ? asciiLower(name.substr(name.size() - 4)) : "";
        if (extension != ".zmx" && extension != ".dat") throw InputError(pathOrName, 0, unknownLensProblem(name));
    }
    return loadLensFile(pathOrName);
}

LensPrescription loadLensFile(const std::string& path) {
    const std::string extension = path.size() >= 4 ? asciiLower(path.substr(path.size() - 4)) : "";
    if (extension == ".zmx") return loadZemaxFile(path);
    const std::string text = readFile(path);
    return extension == ".dat" ? parsePbrtLensText(text, path) : parseLensText(text, path);
}

}  // namespace flare
