#include "flare/scene/SceneChecker.h"

#include <algorithm>
#include <charconv>
#include <cmath>

#include "flare/core/Error.h"
#include "flare/core/NearestNames.h"

namespace flare::scenefile {

namespace {

std::string joinKeys(const std::vector<std::string>& keys) {
    std::string out;
    for (const std::string& k : keys) out += (out.empty() ? "" : ", ") + k;
    return out;
}

}  // namespace

std::string formatNumber(double value) {
    if (std::isinf(value)) return value > 0 ? "infinity" : "-infinity";
    char buffer[64];
    const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
    return ec == std::errc() ? std::string(buffer, end) : std::to_string(value);
}

// Six significant digits, for values the parser computed (not echoed from the file).
std::string formatDerived(double value) {
    char buffer[64];
    const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value, std::chars_format::general, 6);
    return ec == std::errc() ? std::string(buffer, end) : std::to_string(value);
}

std::string child(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }
std::string index(const std::string& path, std::size_t i) { return path + "[" + std::to_string(i) + "]"; }

std::string describe(const Node& node) {
    switch (node.kind) {
        case Node::Kind::Null: return "null";
        case Node::Kind::Boolean: return node.boolean ? "true" : "false";
        case Node::Kind::Integer: return std::to_string(node.integer);
        case Node::Kind::Unsigned: return std::to_string(node.unsignedValue);
        case Node::Kind::Float: return formatNumber(node.number);
        case Node::Kind::String: return "the string \"" + node.text + "\"";
        case Node::Kind::Array:
            return "an array of " + std::to_string(node.items.size()) + (node.items.size() == 1 ? " value" : " values");
        case Node::Kind::Object: return "an object";
    }
    return "?";
}

void Checker::fail(int line, const std::string& path, const std::string& problem) const {
    throw InputError(file_, line, (path.empty() ? topName_ : path) + ": " + problem);
}

void Checker::object(const Node& node, const std::string& path, const std::vector<std::string>& allowed,
                     const std::string& allowedFor) const {
    if (node.kind != Node::Kind::Object) fail(node.line, path, "must be an object { ... }, got " + describe(node));
    for (std::size_t i = 0; i < node.members.size(); ++i) {
        const Member& m = node.members[i];
        for (std::size_t j = 0; j < i; ++j)
            if (node.members[j].key == m.key)
                fail(m.keyLine, child(path, m.key),
                     "given twice (first on line " + std::to_string(node.members[j].keyLine) + ")");
        if (std::find(allowed.begin(), allowed.end(), m.key) != allowed.end()) continue;
        std::string problem = "unknown key '" + m.key + "'";
        std::string best;
        int bestDistance = 3;  // suggest only close matches
        for (const std::string& k : allowed) {
            // A close spelling, or the right word without its unit suffix ("power_w", "field").
            const bool prefix = m.key.size() >= 4 && (k.rfind(m.key, 0) == 0 || m.key.rfind(k, 0) == 0);
            const int d = prefix ? 0 : editDistance(m.key, k);
            if (d < bestDistance) bestDistance = d, best = k;
        }
        if (!best.empty()) problem += " (did you mean '" + best + "'?)";
        problem += "; allowed keys" + allowedFor + ": " + joinKeys(allowed);
        fail(m.keyLine, path, problem);
    }
}

const Member* Checker::find(const Node& object, std::string_view key) {
    for (const Member& m : object.members)
        if (m.key == key) return &m;
    return nullptr;
}

const Member& Checker::require(const Node& object, const std::string& path, const std::string& key,
                               const std::string& what) const {
    const Member* m = find(object, key);
    if (!m) fail(object.line, path, "missing required key '" + key + "'" + what);
    return *m;
}

double Checker::number(const Node& node, const std::string& path) const {
    if (!node.isNumber()) fail(node.line, path, "must be a number, got " + describe(node));
    return node.number;
}

double Checker::numberIn(const Node& node, const std::string& path, double lo, double hi, const std::string& unit,
                          bool openLo) const {
    const double v = number(node, path);
    if (openLo ? !(v > lo && v <= hi) : !(v >= lo && v <= hi))
        fail(node.line, path,
             "must lie in " + std::string(openLo ? "(" : "[") + formatNumber(lo) + ", " + formatNumber(hi) +
                 "]" + (unit.empty() ? "" : " " + unit) + ", got " + describe(node));
    return v;
}

std::int64_t Checker::integerIn(const Node& node, const std::string& path, std::int64_t lo, std::int64_t hi) const {
    const double v = number(node, path);
    const bool integral = node.kind != Node::Kind::Float || (std::floor(v) == v && std::abs(v) < 9.0e15);
    const bool inRange = node.kind == Node::Kind::Unsigned
                             ? node.unsignedValue <= static_cast<std::uint64_t>(hi) &&
                                   static_cast<std::int64_t>(node.unsignedValue) >= lo
                             : v >= static_cast<double>(lo) && v <= static_cast<double>(hi);
    if (!integral || !inRange)
        fail(node.line, path,
             "must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                 describe(node));
    if (node.kind == Node::Kind::Unsigned) return static_cast<std::int64_t>(node.unsignedValue);
    if (node.kind == Node::Kind::Integer) return node.integer;
    return static_cast<std::int64_t>(v);
}

const std::string& Checker::string(const Node& node, const std::string& path) const {
    if (node.kind != Node::Kind::String) fail(node.line, path, "must be a string, got " + describe(node));
    return node.text;
}

bool Checker::boolean(const Node& node, const std::string& path) const {
    if (node.kind != Node::Kind::Boolean) fail(node.line, path, "must be true or false, got " + describe(node));
    return node.boolean;
}

const std::vector<Node>& Checker::numbers(const Node& node, const std::string& path, std::size_t count,
                                          const std::string& shape) const {
    if (node.kind != Node::Kind::Array || node.items.size() != count)
        fail(node.line, path, "must be an array of " + std::to_string(count) + " numbers " + shape + ", got " +
                                  describe(node));
    for (std::size_t i = 0; i < count; ++i) number(node.items[i], index(path, i));
    return node.items;
}

}  // namespace flare::scenefile
