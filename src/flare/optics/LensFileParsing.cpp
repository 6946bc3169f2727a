#include "flare/optics/LensFileParsing.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>

#include "flare/core/Error.h"
#include "flare/core/TextEncoding.h"
#include "flare/optics/LensSystem.h"

namespace flare::lensfile {

std::string_view trim(std::string_view s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
    return s;
}

std::vector<Line> splitLines(std::string_view text) {
    std::vector<Line> lines;
    int number = 0;
    size_t start = 0;
    while (start <= text.size()) {
        size_t end = text.find('\n', start);
        if (end == std::string_view::npos) end = text.size();
        ++number;
        std::string_view line = text.substr(start, end - start);
        if (const size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
        line = trim(line);
        if (!line.empty()) lines.push_back({number, line});
        if (end == text.size()) break;
        start = end + 1;
    }
    return lines;
}

void Parser::error(int line, const std::string& problem) const {
    throw InputError(file_, line, problem);
}

double Parser::number(int line, std::string_view token, const std::string& what) const {
    const std::string t = asciiLower(token);
    if (t == "inf" || t == "infinity") return std::numeric_limits<double>::infinity();
    if (t == "-inf" || t == "-infinity") return -std::numeric_limits<double>::infinity();
    double value = 0.0;
    const char* begin = token.data();
    const char* end = token.data() + token.size();
    if (!token.empty() && *begin == '+') ++begin;
    const auto [ptr, ec] = std::from_chars(begin, end, value);
    if (ec != std::errc() || ptr != end || !std::isfinite(value))
        error(line, what + ": '" + std::string(token) + "' is not a number");
    return value;
}

double Parser::finiteNumber(int line, std::string_view token, const std::string& what) const {
    const double value = number(line, token, what);
    if (!std::isfinite(value)) error(line, what + " must be finite");
    return value;
}

double Parser::fraction(int line, std::string_view token, const std::string& what) const {
    const double value = finiteNumber(line, token, what);
    if (value < 0.0 || value > 1.0) error(line, what + " must lie in [0, 1], got " + std::string(token));
    return value;
}

double Parser::positive(int line, std::string_view token, const std::string& what) const {
    const double value = finiteNumber(line, token, what);
    if (!(value > 0.0)) error(line, what + " must be positive, got " + std::string(token));
    return value;
}

std::pair<std::string, std::string_view> Parser::keyValue(int line, std::string_view token) const {
    const size_t eq = token.find('=');
    if (eq == std::string_view::npos || eq == 0 || eq + 1 == token.size())
        error(line, "expected key=value, got '" + std::string(token) + "'");
    return {asciiLower(token.substr(0, eq)), token.substr(eq + 1)};
}

Medium Parser::material(int line, std::string_view token) const {
    const std::string t = asciiLower(token);
    if (t == "air") return Medium::air();
    if (t.rfind("n=", 0) == 0) {
        const double n = positive(line, token.substr(2), "constant index");
        if (n < 1.0) error(line, "constant index must be at least 1, got " + std::string(token.substr(2)));
        return n == 1.0 ? Medium::air() : Medium::constant(n);
    }
    if (const size_t slash = token.find('/'); slash != std::string_view::npos) {
        const double nd = finiteNumber(line, token.substr(0, slash), "material nd");
        const double vd = finiteNumber(line, token.substr(slash + 1), "material Vd");
        if (nd <= 1.0 || nd > 3.0) error(line, "material nd must lie in (1, 3], got " + std::string(token));
        if (vd < 5.0 || vd > 150.0) error(line, "material Vd must lie in [5, 150], got " + std::string(token));
        return Medium::abbe(nd, vd);
    }
    if (const CatalogGlass* glass = findCatalogGlass(token)) {
        if (!coversVisible(*glass))
            error(line, "glass '" + std::string(token) + "' (" + glass->maker +
                        ") is not made for the visible: " + validRangeText(*glass));
        return Medium::catalog(*glass);
    }
    error(line, "unknown glass '" + std::string(token) +
                "' (not in the built-in or the shipped catalogues; give it as nd/Vd, e.g. 1.6700/47.20)");
}

void checkAperture(const Parser& parser, const PrescriptionRow& row) {
    if (row.isStop) return;
    const double c = row.radiusMm == 0.0 ? 0.0 : 1.0 / row.radiusMm;
    const double r = row.semiApertureMm;
    if ((1.0 + row.conic) * c * c * r * r > 1.0) {
        if (row.conic == 0.0)
            parser.error(row.line, "semi-aperture " + std::to_string(r) + " mm is larger than |radius| " +
                                       std::to_string(std::abs(row.radiusMm)) + " mm");
        parser.error(row.line, "semi-aperture " + std::to_string(r) +
                                   " mm lies beyond the extent of the conic surface");
    }
}

namespace {

void unknownAperture(const Parser& parser, const LensPrescription& p, const PrescriptionRow& row) {
    parser.error(row.line, "unknown aperture '" + row.semiApertureName + "' (define it with a line 'aperture " +
                               row.semiApertureName + " " +
                               (p.zoomPositions.empty() ? std::string("POSITION=mm ...") : p.zoomPositions[0].name + "=mm ...") +
                               "' after the zoom line)");
}

}  // namespace

void checkApertures(const Parser& parser, const LensPrescription& p) {
    for (const PrescriptionRow& row : p.rows) {
        if (row.semiApertureName.empty()) continue;
        if (!row.isStop)
            parser.error(row.line, "semi-aperture '" + row.semiApertureName +
                                       "': only the stop row's semi-aperture may change with zoom (an element's clear "
                                       "aperture is fixed)");
        if (!p.findAperture(row.semiApertureName)) unknownAperture(parser, p, row);
    }
    for (const VariableAperture& aperture : p.apertures) {
        const bool used = std::any_of(p.rows.begin(), p.rows.end(),
                                      [&](const PrescriptionRow& r) { return r.semiApertureName == aperture.name; });
        if (!used)
            parser.error(aperture.line, "aperture '" + aperture.name + "' is defined but the stop row does not use it");
    }
}

void validate(const Parser& parser, const LensPrescription& p, int lastLine) {
    if (p.rows.empty()) parser.error(lastLine, "the lens has no surface rows");
    int stops = 0;
    for (const PrescriptionRow& row : p.rows) {
        if (!row.isStop) continue;
        if (++stops > 1) parser.error(row.line, "a second aperture stop row (only one is allowed)");
    }
    if (stops == 0) parser.error(0, "missing aperture stop: one row must have radius 'stop'");
    checkApertures(parser, p);
    for (size_t i = 0; i < p.rows.size(); ++i) {
        const PrescriptionRow& row = p.rows[i];
        if (row.thickness.kind == ThicknessSpec::Kind::Auto && i + 1 != p.rows.size())
            parser.error(row.line, "'auto' thickness is only allowed on the last row");
        if (row.isStop) {
            const Medium& before = i == 0 ? Medium::air() : p.rows[i - 1].mediumAfter;
            const Medium& after = row.mediumAfter;
            if (before.describe() != after.describe())
                parser.error(row.line, "the stop must not change the medium (before: " + before.describe() +
                                           ", after: " + after.describe() + ")");
        }
        if (row.thickness.kind == ThicknessSpec::Kind::Gap && !p.findGap(row.thickness.gapName))
            parser.error(row.line, "unknown variable gap '" + row.thickness.gapName + "'");
        if (row.coatingName && !p.findCoating(*row.coatingName))
            parser.error(row.line, "unknown coating '" + *row.coatingName + "'");
        if (row.dust || row.grease) {
            // Dirt settles on a surface with air on one side (not a cemented one), and only acts
            // where the surface separates two different media.
            const Medium& before = i == 0 ? Medium::air() : p.rows[i - 1].mediumAfter;
            const char* what = row.dust ? "dust" : "grease";
            if (!before.isAir() && !row.mediumAfter.isAir())
                parser.error(row.line, std::string(what) + " on a cemented surface (glass on both sides): nothing can settle there");
            if (before.describe() == row.mediumAfter.describe())
                parser.error(row.line, std::string(what) + " on a surface between equal media (air on both sides)");
        }
    }
    if (!p.rows.back().mediumAfter.isAir())
        parser.error(p.rows.back().line, "the last surface must be followed by air (the sensor side)");
    if (!p.findCoating(p.defaultCoating))
        parser.error(0, "unknown default coating '" + p.defaultCoating + "'");
    // Resolve every zoom position once so that crossing surfaces are reported now.
    if (p.zoomPositions.empty()) {
        LensSystem::build(p);
    } else {
        for (const ZoomPosition& z : p.zoomPositions) LensSystem::build(p, LensState{z.name, {}, {}});
    }
}

}  // namespace flare::lensfile
