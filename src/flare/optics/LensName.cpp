#include "flare/optics/LensName.h"

#include <regex>
#include <string>

namespace flare {

namespace {

constexpr const char* kNumber = R"((\d+(?:\.\d+)?))";

NamedRange range(const std::ssub_match& a, const std::ssub_match& b, double scale = 1.0) {
    const double lo = scale * std::stod(a.str());
    const double hi = b.matched ? scale * std::stod(b.str()) : lo;
    return hi >= lo ? NamedRange{lo, hi} : NamedRange{hi, lo};
}

// The f-number at the first match of the f-number pattern in `text`, if any.
std::optional<NamedRange> fNumberIn(const std::string& text) {
    static const std::regex pattern(std::string(R"((?:^|-|mm)[ft]-?)") + kNumber + "(?:-" + kNumber +
                                    R"()?(?=[a-z]*(?:-|$)))");
    std::smatch m;
    if (!std::regex_search(text, m, pattern)) return std::nullopt;
    const double first = std::stod(m[1].str());
    // "f2.8-2x" and "f2.8-1-5x": a magnification after the f-number, not the slow end of a range.
    if (m[2].matched && std::stod(m[2].str()) > first) return NamedRange{first, std::stod(m[2].str())};
    return NamedRange{first, first};
}

}  // namespace

LensNameValues parseLensName(std::string_view idView) {
    const std::string id(idView);
    const std::string number = kNumber;
    static const std::regex mm("(?:^|[^\\d.])" + number + "(?:-" + number + ")?-?mm");
    static const std::regex cm("(?:^|[^\\d.])" + number + "cm");
    static const std::regex beforeF("(?:^|[^\\d.])" + number + "(?:-" + number + ")?-f-?\\d");
    static const std::regex xf("-xf" + number);
    static const std::regex fNumberFirst("-" + number + "-(\\d+)(?:-(\\d+))?(?=[a-z]?(?:-|$))");
    static const std::regex fNumberBeforeFocal("-(\\d+\\.\\d+)-\\d+(?:\\.\\d+)?mm");
    LensNameValues values;
    std::smatch m;
    // Where the focal length's last number ends: its f-number is looked for after it first.
    size_t focalEnd = std::string::npos;
    auto end = [&](int group) { return static_cast<size_t>(m.position(group) + m.length(group)); };
    if (std::regex_search(id, m, mm) || std::regex_search(id, m, beforeF)) {
        values.focalLengthMm = range(m[1], m[2]);
        focalEnd = end(m[2].matched ? 2 : 1);
    } else if (std::regex_search(id, m, cm)) {
        values.focalLengthMm = range(m[1], m[1], 10.0);
        focalEnd = end(1);
    } else if (std::regex_search(id, m, xf)) {
        values.focalLengthMm = range(m[1], m[1]);
        focalEnd = end(1);
    } else if (std::regex_search(id, m, fNumberFirst) && std::stod(m[1].str()) <= 32.0) {
        values.focalLengthMm = range(m[2], m[3]);
        values.fNumber = range(m[1], m[1]);
        return values;
    }
    if (focalEnd != std::string::npos && (values.fNumber = fNumberIn(id.substr(focalEnd)))) return values;
    if ((values.fNumber = fNumberIn(id))) return values;
    if (std::regex_search(id, m, fNumberBeforeFocal)) values.fNumber = range(m[1], m[1]);
    return values;
}

}  // namespace flare
