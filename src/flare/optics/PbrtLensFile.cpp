#include "flare/optics/PbrtLensFile.h"

#include <vector>

#include "flare/core/TextEncoding.h"
#include "flare/optics/LensFileParsing.h"

namespace flare {

namespace {

// The file's name without its directory and ".dat": pbrt's files carry no name of their own.
std::string stem(const std::string& path) {
    const size_t slash = path.find_last_of('/');
    std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
    if (const size_t dot = name.rfind(".dat"); dot != std::string::npos && dot + 4 == name.size())
        name.resize(dot);
    return name;
}

}  // namespace

LensPrescription parsePbrtLensText(std::string_view text, const std::string& fileName) {
    const lensfile::Parser parser(fileName);
    LensPrescription p;
    p.sourceFile = fileName;
    p.name = stem(fileName);
    p.source = "pbrt lens file " + fileName;
    const std::vector<lensfile::Line> lines = lensfile::splitLines(text);
    int lastLine = 0;
    for (const lensfile::Line& line : lines) {
        lastLine = line.number;
        const std::vector<std::string_view> tokens = splitWhitespace(line.text);
        const int n = line.number;
        if (tokens.size() != 4)
            parser.error(n, "expected 4 columns (radius thickness index aperture-diameter), found " +
                                std::to_string(tokens.size()));
        PrescriptionRow row;
        row.line = n;
        row.radiusMm = parser.finiteNumber(n, tokens[0], "radius");
        row.isStop = row.radiusMm == 0.0;
        row.thickness.valueMm = parser.finiteNumber(n, tokens[1], "thickness");
        if (row.thickness.valueMm < 0.0) parser.error(n, "thickness must not be negative");
        const double index = parser.finiteNumber(n, tokens[2], "index");
        row.semiApertureMm = 0.5 * parser.positive(n, tokens[3], "aperture diameter");
        if (row.isStop) {
            // pbrt writes 0 (or the surrounding index) for the stop: the medium does not change.
            row.mediumAfter = p.rows.empty() ? Medium::air() : p.rows.back().mediumAfter;
            row.materialText = "(stop)";
        } else if (index == 0.0 || index == 1.0) {
            row.mediumAfter = Medium::air();
            row.materialText = "air";
        } else {
            if (index < 1.0) parser.error(n, "index must be 0 or 1 (air) or above 1, got " + std::string(tokens[2]));
            row.mediumAfter = Medium::constant(index);
            row.materialText = "n=" + std::string(tokens[2]);
        }
        lensfile::checkAperture(parser, row);
        p.rows.push_back(row);
    }
    if (p.rows.empty()) parser.error(lastLine, "the lens has no surface rows");
    // The last thickness in a pbrt file is not a sensor distance: focus at infinity instead.
    p.rows.back().thickness.kind = ThicknessSpec::Kind::Auto;
    lensfile::validate(parser, p, lastLine);
    return p;
}

}  // namespace flare
