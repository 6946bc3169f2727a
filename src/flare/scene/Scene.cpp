#include "flare/scene/Scene.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <numbers>
#include <sstream>

#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include "flare/core/Error.h"
#include "flare/optics/EmbeddedLenses.h"
#include "flare/optics/LensFile.h"

namespace flare {

namespace {

// The embedded default scene; docs/examples/default.json is the same text (a test checks it).
constexpr std::string_view kDefaultScene = R"json({
  "description": "Default scene: the 50 mm double Gauss at f/4 with the sun 13.5 deg off axis, up and to the right, so that its ghosts spread across the frame.",
  "lens": "double-gauss-50mm",
  "f_number": 4.0,
  "sensor": { "width_mm": 36, "height_mm": 24, "resolution": [1536, 1024] },
  "lights": [
    {
      "type": "directional",
      "name": "sun",
      "field_deg": [11.0, 8.0],
      "angular_diameter_deg": 0.53,
      "spectrum": { "blackbody_k": 5778 },
      "power": 1.0
    }
  ],
  "render": {
    "preview_wavelengths": 7,
    "ghost_order": 2,
    "prune_keep_share": 0.999,
    "prune_relative_threshold": 1e-5,
    "photons": 10000000,
    "seed": 1,
    "max_bounces": -1,
    "sensor_ghosts": true
  }
}
)json";

constexpr double kMaxFieldDeg = 89.9;
constexpr double kMaxAngularDiameterDeg = 20.0;
constexpr int kMaxResolutionPx = 16384;
constexpr double kPixelAspectTolerance = 1e-3;  // "square within 0.1 %"

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

// ---------------------------------------------------------------------------------------------
// A JSON tree that remembers the line of every value and key. nlohmann's SAX events carry no
// position, so the input iterator records how many bytes the lexer has consumed; at each event
// that is the end of the token just read (plus one look-ahead byte after a number).

struct Member;

struct Node {
    enum class Kind { Null, Boolean, Integer, Unsigned, Float, String, Array, Object };
    Kind kind = Kind::Null;
    int line = 0;
    bool boolean = false;
    std::int64_t integer = 0;
    std::uint64_t unsignedValue = 0;
    double number = 0.0;  // every numeric kind, as a double
    std::string text;
    std::vector<Node> items;
    std::vector<Member> members;

    bool isNumber() const { return kind == Kind::Integer || kind == Kind::Unsigned || kind == Kind::Float; }
};

struct Member {
    std::string key;
    int keyLine = 0;
    Node value;
};

class CountingIterator {
public:
    using iterator_category = std::input_iterator_tag;
    using value_type = char;
    using difference_type = std::ptrdiff_t;
    using pointer = const char*;
    using reference = const char&;

    CountingIterator(const char* p, const char* begin, std::size_t* consumed)
        : p_(p), begin_(begin), consumed_(consumed) {}
    reference operator*() const { return *p_; }
    CountingIterator& operator++() {
        ++p_;
        *consumed_ = static_cast<std::size_t>(p_ - begin_);
        return *this;
    }
    CountingIterator operator++(int) {
        CountingIterator old = *this;
        ++*this;
        return old;
    }
    bool operator==(const CountingIterator& other) const { return p_ == other.p_; }
    bool operator!=(const CountingIterator& other) const { return p_ != other.p_; }

private:
    const char* p_;
    const char* begin_;
    std::size_t* consumed_;
};

class LineIndex {
public:
    explicit LineIndex(std::string_view text) : text_(text) {
        for (std::size_t i = 0; i < text.size(); ++i)
            if (text[i] == '\n') newlines_.push_back(i);
    }
    // 1-based line of byte `offset`.
    int lineOf(std::size_t offset) const {
        return 1 + static_cast<int>(std::lower_bound(newlines_.begin(), newlines_.end(), offset) - newlines_.begin());
    }
    // 1-based column of byte `offset`.
    int columnOf(std::size_t offset) const {
        const auto it = std::lower_bound(newlines_.begin(), newlines_.end(), offset);
        const std::size_t lineStart = it == newlines_.begin() ? 0 : *(it - 1) + 1;
        return 1 + static_cast<int>(offset - lineStart);
    }
    std::string_view text() const { return text_; }

private:
    std::string_view text_;
    std::vector<std::size_t> newlines_;
};

class TreeBuilder {
public:
    using json = nlohmann::json;

    TreeBuilder(const LineIndex& lines, const std::string& file) : lines_(lines), file_(file) {}

    Node& root() { return root_; }

    bool null() {
        add(Node::Kind::Null, false);
        return true;
    }
    bool boolean(bool value) {
        add(Node::Kind::Boolean, false).boolean = value;
        return true;
    }
    bool number_integer(json::number_integer_t value) {
        Node& n = add(Node::Kind::Integer, true);
        n.integer = value;
        n.number = static_cast<double>(value);
        return true;
    }
    bool number_unsigned(json::number_unsigned_t value) {
        Node& n = add(Node::Kind::Unsigned, true);
        n.unsignedValue = value;
        n.number = static_cast<double>(value);
        return true;
    }
    bool number_float(json::number_float_t value, const json::string_t&) {
        add(Node::Kind::Float, true).number = value;
        return true;
    }
    bool string(json::string_t& value) {
        add(Node::Kind::String, false).text = std::move(value);
        return true;
    }
    bool binary(json::binary_t&) { return true; }  // not produced by the JSON reader
    bool start_object(std::size_t) {
        stack_.push_back(&add(Node::Kind::Object, false));
        return true;
    }
    bool key(json::string_t& key) {
        stack_.back()->members.push_back({std::move(key), tokenLine(false), Node{}});
        return true;
    }
    bool end_object() {
        stack_.pop_back();
        return true;
    }
    bool start_array(std::size_t) {
        stack_.push_back(&add(Node::Kind::Array, false));
        return true;
    }
    bool end_array() {
        stack_.pop_back();
        return true;
    }
    bool parse_error(std::size_t position, const std::string& /*lastToken*/, const nlohmann::detail::exception& ex) {
        // `position` counts the bytes read, the offending one included.
        const std::size_t offset = std::min(position > 0 ? position - 1 : 0, lines_.text().size());
        std::string message = ex.what();
        // "[json.exception.parse_error.101] parse error at line 3, column 5: syntax error while
        // parsing object - unexpected '}'; expected string literal": keep the part after the
        // position, which we give ourselves.
        if (const std::size_t bracket = message.find("] "); message.rfind("[json.exception", 0) == 0 &&
                                                           bracket != std::string::npos)
            message = message.substr(bracket + 2);
        if (message.rfind("parse error", 0) == 0)
            if (const std::size_t colon = message.find(": "); colon != std::string::npos)
                message = message.substr(colon + 2);
        if (message.rfind("syntax error ", 0) == 0) message = message.substr(13);
        std::string hint;
        const std::string_view text = lines_.text();
        if (offset < text.size() && (text[offset] == '}' || text[offset] == ']')) {
            // A comma right before a closing bracket: the most common hand-editing slip.
            std::size_t q = offset;
            while (q > 0 && std::isspace(static_cast<unsigned char>(text[q - 1]))) --q;
            if (q > 0 && text[q - 1] == ',')
                hint = std::string(" (a trailing comma before '") + text[offset] + "'?)";
        }
        if (hint.empty() && (message.find("; expected '}'") != std::string::npos ||
                             message.find("; expected ']'") != std::string::npos))
            hint = " (a missing comma?)";
        const std::size_t reported = std::min(offset, lines_.text().empty() ? 0 : lines_.text().size() - 1);
        throw InputError(file_, lines_.lineOf(reported),
                         "invalid JSON at column " + std::to_string(lines_.columnOf(reported)) + ": " + message +
                             hint);
    }

private:
    // Line of the token the lexer has just read.
    int tokenLine(bool isNumber) const {
        if (consumed == 0) return 1;
        std::size_t q = consumed - 1;
        if (isNumber && q > 0) {
            // The lexer reads one byte past a number to find its end.
            const char c = lines_.text()[q];
            if (!(std::isdigit(static_cast<unsigned char>(c)) || c == '.' || c == 'e' || c == 'E' || c == '+' ||
                  c == '-'))
                --q;
        }
        return lines_.lineOf(q);
    }

    Node& add(Node::Kind kind, bool isNumber) {
        Node* node = nullptr;
        if (stack_.empty()) {
            node = &root_;
        } else if (stack_.back()->kind == Node::Kind::Array) {
            node = &stack_.back()->items.emplace_back();
        } else {
            node = &stack_.back()->members.back().value;
        }
        node->kind = kind;
        node->line = tokenLine(isNumber);
        return *node;
    }

    const LineIndex& lines_;
    const std::string& file_;
    Node root_;
    std::vector<Node*> stack_;

public:
    std::size_t consumed = 0;  // bytes read by the lexer, updated by CountingIterator
};

Node parseTree(std::string_view text, const std::string& file) {
    const LineIndex lines(text);
    TreeBuilder builder(lines, file);
    const CountingIterator first(text.data(), text.data(), &builder.consumed);
    const CountingIterator last(text.data() + text.size(), text.data(), &builder.consumed);
    // Comments (// and /* */) are allowed so that scenes can be annotated.
    nlohmann::json::sax_parse(first, last, &builder, nlohmann::json::input_format_t::json, true, true);
    return std::move(builder.root());
}

// ---------------------------------------------------------------------------------------------
// Checking the tree against the scene layout. Each check names the value's key path.

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

int editDistance(std::string_view a, std::string_view b) {
    std::vector<int> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = static_cast<int>(j);
    for (std::size_t i = 1; i <= a.size(); ++i) {
        int diagonal = row[0];
        row[0] = static_cast<int>(i);
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const int above = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diagonal = above;
        }
    }
    return row[b.size()];
}

std::string joinKeys(const std::vector<std::string>& keys) {
    std::string out;
    for (const std::string& k : keys) out += (out.empty() ? "" : ", ") + k;
    return out;
}

class Checker {
public:
    explicit Checker(std::string file) : file_(std::move(file)) {}

    const std::string& file() const { return file_; }

    [[noreturn]] void fail(int line, const std::string& path, const std::string& problem) const {
        throw InputError(file_, line, (path.empty() ? std::string("scene") : path) + ": " + problem);
    }

    // Checks that `node` is an object whose keys are all in `allowed` (each given once).
    void object(const Node& node, const std::string& path, const std::vector<std::string>& allowed,
                const std::string& allowedFor = "") const {
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

    static const Member* find(const Node& object, std::string_view key) {
        for (const Member& m : object.members)
            if (m.key == key) return &m;
        return nullptr;
    }

    const Member& require(const Node& object, const std::string& path, const std::string& key,
                          const std::string& what = "") const {
        const Member* m = find(object, key);
        if (!m) fail(object.line, path, "missing required key '" + key + "'" + what);
        return *m;
    }

    double number(const Node& node, const std::string& path) const {
        if (!node.isNumber()) fail(node.line, path, "must be a number, got " + describe(node));
        return node.number;
    }

    // A number in [lo, hi] (`openLo`: (lo, hi]).
    double numberIn(const Node& node, const std::string& path, double lo, double hi, const std::string& unit,
                    bool openLo = false) const {
        const double v = number(node, path);
        if (openLo ? !(v > lo && v <= hi) : !(v >= lo && v <= hi))
            fail(node.line, path,
                 "must lie in " + std::string(openLo ? "(" : "[") + formatNumber(lo) + ", " + formatNumber(hi) +
                     "]" + (unit.empty() ? "" : " " + unit) + ", got " + describe(node));
        return v;
    }

    // An integer (an integral JSON number such as 1e7 counts) in [lo, hi].
    std::int64_t integerIn(const Node& node, const std::string& path, std::int64_t lo, std::int64_t hi) const {
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

    const std::string& string(const Node& node, const std::string& path) const {
        if (node.kind != Node::Kind::String) fail(node.line, path, "must be a string, got " + describe(node));
        return node.text;
    }

    bool boolean(const Node& node, const std::string& path) const {
        if (node.kind != Node::Kind::Boolean) fail(node.line, path, "must be true or false, got " + describe(node));
        return node.boolean;
    }

    // An array of exactly `count` numbers.
    const std::vector<Node>& numbers(const Node& node, const std::string& path, std::size_t count,
                                     const std::string& shape) const {
        if (node.kind != Node::Kind::Array || node.items.size() != count)
            fail(node.line, path, "must be an array of " + std::to_string(count) + " numbers " + shape + ", got " +
                                      describe(node));
        for (std::size_t i = 0; i < count; ++i) number(node.items[i], index(path, i));
        return node.items;
    }

private:
    std::string file_;
};

SpectrumSpec parseSpectrum(const Checker& c, const Node& node, const std::string& path) {
    SpectrumSpec s;
    const char* kinds = "\"d65\", \"equal_energy\" or { \"blackbody_k\": T }";
    if (node.kind == Node::Kind::String) {
        if (node.text == "d65") s.kind = SpectrumSpec::Kind::D65;
        else if (node.text == "equal_energy") s.kind = SpectrumSpec::Kind::EqualEnergy;
        else if (node.text == "blackbody")
            c.fail(node.line, path, "a blackbody needs its temperature: { \"blackbody_k\": 5778 }");
        else c.fail(node.line, path, "unknown spectrum \"" + node.text + "\" (use " + kinds + ")");
        return s;
    }
    if (node.kind != Node::Kind::Object) c.fail(node.line, path, std::string("must be ") + kinds + ", got " + describe(node));
    c.object(node, path, {"blackbody_k"});
    const Member& t = c.require(node, path, "blackbody_k", std::string(" (spectrum objects are ") + kinds + ")");
    s.kind = SpectrumSpec::Kind::Blackbody;
    s.temperatureK = c.numberIn(t.value, child(path, "blackbody_k"), 1000.0, 40000.0, "K");
    return s;
}

LightSpec parseLight(const Checker& c, const Node& node, const std::string& path, std::size_t i) {
    LightSpec light;
    if (node.kind != Node::Kind::Object) c.fail(node.line, path, "must be an object { \"type\": ... }, got " + describe(node));
    const Member& typeMember = c.require(node, path, "type", " (directional, point or disk)");
    const std::string& type = c.string(typeMember.value, child(path, "type"));
    std::vector<std::string> allowed = {"type", "name", "spectrum", "power"};
    if (type == "directional") {
        light.type = LightSpec::Type::Directional;
        allowed.insert(allowed.end(), {"field_deg", "angular_diameter_deg"});
    } else if (type == "point") {
        light.type = LightSpec::Type::Point;
        allowed.insert(allowed.end(), {"position_mm"});
    } else if (type == "disk") {
        light.type = LightSpec::Type::Disk;
        allowed.insert(allowed.end(), {"position_mm", "radius_mm"});
    } else {
        c.fail(typeMember.value.line, child(path, "type"),
               "unknown light type \"" + type + "\" (directional, point or disk)");
    }
    c.object(node, path, allowed, " for a " + type + " light");

    light.name = "light" + std::to_string(i);
    if (const Member* m = Checker::find(node, "name")) {
        light.name = c.string(m->value, child(path, "name"));
        if (light.name.empty()) c.fail(m->value.line, child(path, "name"), "must not be empty");
    }
    if (const Member* m = Checker::find(node, "spectrum")) light.spectrum = parseSpectrum(c, m->value, child(path, "spectrum"));
    if (const Member* m = Checker::find(node, "power")) {
        const char* unit = light.type == LightSpec::Type::Directional ? "W/m^2" : "W/sr";
        light.power = c.numberIn(m->value, child(path, "power"), 0.0, 1e12, unit, true);
    }

    if (light.type == LightSpec::Type::Directional) {
        const Member& field = c.require(node, path, "field_deg", " ([x, y] in degrees)");
        const std::string fieldPath = child(path, "field_deg");
        const auto& xy = c.numbers(field.value, fieldPath, 2, "[x, y] in degrees");
        light.fieldXDeg = c.numberIn(xy[0], index(fieldPath, 0), -kMaxFieldDeg, kMaxFieldDeg, "degrees");
        light.fieldYDeg = c.numberIn(xy[1], index(fieldPath, 1), -kMaxFieldDeg, kMaxFieldDeg, "degrees");
        if (const Member* m = Checker::find(node, "angular_diameter_deg"))
            light.angularDiameterDeg =
                c.numberIn(m->value, child(path, "angular_diameter_deg"), 0.0, kMaxAngularDiameterDeg, "degrees");
        return light;
    }

    const Member& position = c.require(node, path, "position_mm", " ([x, y, z] in mm, z < 0)");
    const std::string positionPath = child(path, "position_mm");
    const auto& xyz = c.numbers(position.value, positionPath, 3, "[x, y, z] in mm");
    for (int k = 0; k < 3; ++k)
        light.positionMm[k] = c.numberIn(xyz[k], index(positionPath, k), -1e9, 1e9, "mm");
    if (!(light.positionMm.z < 0.0))
        c.fail(xyz[2].line, index(positionPath, 2),
               "must be negative (the light must lie in front of the first lens vertex, at z < 0), got " +
                   describe(xyz[2]));
    if (light.type == LightSpec::Type::Disk) {
        const Member& radius = c.require(node, path, "radius_mm");
        light.radiusMm = c.numberIn(radius.value, child(path, "radius_mm"), 0.0, 1e6, "mm", true);
        // The disk faces the first vertex; its rim must stay in front of it too.
        const glm::dvec3 normal = light.diskNormal();
        const double rimZMm = light.positionMm.z + light.radiusMm * std::sqrt(std::max(0.0, 1.0 - normal.z * normal.z));
        if (!(rimZMm < 0.0))
            c.fail(radius.value.line, child(path, "radius_mm"),
                   "the disk's rim reaches z = " + formatDerived(rimZMm) +
                       " mm; the whole disk must lie in front of the first lens vertex (z < 0)");
    }
    return light;
}

void parseSensor(const Checker& c, const Node& node, Scene& scene) {
    const std::string path = "sensor";
    c.object(node, path, {"width_mm", "height_mm", "resolution"});
    SensorSettings& s = scene.sensor;
    scene.lines.sensor = node.line;
    if (const Member* m = Checker::find(node, "width_mm"))
        s.widthMm = c.numberIn(m->value, "sensor.width_mm", 0.0, 1000.0, "mm", true);
    if (const Member* m = Checker::find(node, "height_mm"))
        s.heightMm = c.numberIn(m->value, "sensor.height_mm", 0.0, 1000.0, "mm", true);
    int resolutionLine = node.line;
    if (const Member* m = Checker::find(node, "resolution")) {
        const Node& r = m->value;
        resolutionLine = r.line;
        scene.lines.resolution = r.line;
        const std::string shape = "[width_px, height_px], each a positive integer up to " + std::to_string(kMaxResolutionPx);
        if (r.kind != Node::Kind::Array || r.items.size() != 2)
            c.fail(r.line, "sensor.resolution", "must be 2 integers " + shape + ", got " + describe(r));
        s.widthPx = static_cast<int>(c.integerIn(r.items[0], "sensor.resolution[0]", 1, kMaxResolutionPx));
        s.heightPx = static_cast<int>(c.integerIn(r.items[1], "sensor.resolution[1]", 1, kMaxResolutionPx));
    }
    if (s.widthMm && s.heightMm) {
        const double pitchX = *s.widthMm / s.widthPx, pitchY = *s.heightMm / s.heightPx;
        if (std::abs(pitchX - pitchY) > kPixelAspectTolerance * std::max(pitchX, pitchY))
            c.fail(resolutionLine, path,
                   "pixels are not square: " + formatNumber(*s.widthMm) + " mm / " + std::to_string(s.widthPx) +
                       " px = " + formatDerived(pitchX) + " mm but " + formatNumber(*s.heightMm) + " mm / " +
                       std::to_string(s.heightPx) + " px = " + formatDerived(pitchY) +
                       " mm (they must agree within 0.1 %; give only one of width_mm and height_mm to derive the "
                       "other)");
    } else if (s.widthMm) {
        s.heightMm = *s.widthMm * s.heightPx / s.widthPx;
    } else if (s.heightMm) {
        s.widthMm = *s.heightMm * s.widthPx / s.heightPx;
    }
}

void parseRender(const Checker& c, const Node& node, RenderSettings& r) {
    c.object(node, "render",
             {"preview_wavelengths", "ghost_order", "prune_keep_share", "prune_relative_threshold", "photons", "seed",
              "max_bounces", "sensor_ghosts"});
    if (const Member* m = Checker::find(node, "preview_wavelengths"))
        r.previewWavelengths = static_cast<int>(c.integerIn(m->value, "render.preview_wavelengths", 1, 64));
    if (const Member* m = Checker::find(node, "ghost_order")) {
        const double order = c.number(m->value, "render.ghost_order");
        if (order != 2.0 && order != 4.0)
            c.fail(m->value.line, "render.ghost_order",
                   "must be 2 or 4 (reflections per enumerated ghost path), got " + describe(m->value));
        r.ghostOrder = static_cast<int>(order);
    }
    if (const Member* m = Checker::find(node, "prune_keep_share"))
        r.pruneKeepShare = c.numberIn(m->value, "render.prune_keep_share", 0.0, 1.0, "", true);
    if (const Member* m = Checker::find(node, "prune_relative_threshold")) {
        r.pruneRelativeThreshold = c.number(m->value, "render.prune_relative_threshold");
        if (!(r.pruneRelativeThreshold >= 0.0 && r.pruneRelativeThreshold < 1.0))
            c.fail(m->value.line, "render.prune_relative_threshold", "must lie in [0, 1), got " + describe(m->value));
    }
    if (const Member* m = Checker::find(node, "photons"))
        r.photons = c.integerIn(m->value, "render.photons", 1, 10'000'000'000'000);
    if (const Member* m = Checker::find(node, "seed")) {
        const Node& v = m->value;
        if (v.kind == Node::Kind::Unsigned) r.seed = v.unsignedValue;  // the full 64-bit range
        else r.seed = static_cast<std::uint64_t>(c.integerIn(v, "render.seed", 0, std::int64_t{1} << 53));
    }
    if (const Member* m = Checker::find(node, "max_bounces"))
        r.maxBounces = static_cast<int>(c.integerIn(m->value, "render.max_bounces", -1, 10000));
    if (const Member* m = Checker::find(node, "sensor_ghosts"))
        r.includeSensorGhosts = c.boolean(m->value, "render.sensor_ghosts");
}

FinishSpec parseFinish(const Checker& c, const Node& node, const std::string& path) {
    FinishSpec f;
    c.object(node, path, {"diffuse", "glossy"});
    if (const Member* m = Checker::find(node, "diffuse")) f.diffuse = c.numberIn(m->value, child(path, "diffuse"), 0.0, 1.0, "");
    if (const Member* m = Checker::find(node, "glossy")) f.glossy = c.numberIn(m->value, child(path, "glossy"), 0.0, 1.0, "");
    if (f.diffuse + f.glossy > 1.0)
        c.fail(node.line, path, "diffuse + glossy must not exceed 1 (energy), got " + formatNumber(f.diffuse + f.glossy));
    return f;
}

// A data file named in the scene, relative to the scene's folder (kept as given if that does not
// exist, so that the error names what the user wrote).
std::string resolveDataFile(const std::string& file, const std::string& baseDir) {
    const std::filesystem::path resolved = std::filesystem::path(baseDir) / file;
    return std::filesystem::exists(resolved) || baseDir.empty() ? resolved.string() : file;
}

// The optional "mask", "mask_size_mm" (a width, or [width, height]) and "mask_centre_mm" keys of
// a dust or grease entry.
MaskSpec parseMask(const Checker& c, const Node& item, const std::string& path, const std::string& baseDir) {
    MaskSpec mask;
    const Member* file = Checker::find(item, "mask");
    const Member* size = Checker::find(item, "mask_size_mm");
    const Member* centre = Checker::find(item, "mask_centre_mm");
    if (!file) {
        if (size || centre)
            c.fail((size ? size : centre)->keyLine, child(path, size ? "mask_size_mm" : "mask_centre_mm"),
                   "is only allowed with a 'mask' image");
        return mask;
    }
    mask.keyPath = child(path, "mask");
    mask.line = file->value.line;
    const std::string& name = c.string(file->value, mask.keyPath);
    if (name.empty()) c.fail(mask.line, mask.keyPath, "must name a PNG or EXR image file");
    mask.file = resolveDataFile(name, baseDir);
    if (size) {
        const std::string sizePath = child(path, "mask_size_mm");
        if (size->value.kind == Node::Kind::Array) {
            const auto& wh = c.numbers(size->value, sizePath, 2, "a width, or [width, height], in mm");
            mask.widthMm = c.numberIn(wh[0], index(sizePath, 0), 0.0, 1e4, "mm", true);
            mask.heightMm = c.numberIn(wh[1], index(sizePath, 1), 0.0, 1e4, "mm", true);
        } else {
            mask.widthMm = c.numberIn(size->value, sizePath, 0.0, 1e4, "mm", true);
        }
    }
    if (centre) {
        const std::string centrePath = child(path, "mask_centre_mm");
        const auto& xy = c.numbers(centre->value, centrePath, 2, "[x, y] in mm");
        mask.centreMm = {c.numberIn(xy[0], index(centrePath, 0), -1e4, 1e4, "mm"),
                         c.numberIn(xy[1], index(centrePath, 1), -1e4, 1e4, "mm")};
    }
    return mask;
}

void parseScattering(const Checker& c, const Node& node, const std::string& baseDir, ScatteringSettings& s) {
    c.object(node, "scattering", {"housing", "edges", "iris", "gloss_exponent", "dust", "grease", "bulk"});
    if (const Member* m = Checker::find(node, "housing")) s.housing = parseFinish(c, m->value, "scattering.housing");
    if (const Member* m = Checker::find(node, "edges")) s.edges = parseFinish(c, m->value, "scattering.edges");
    if (const Member* m = Checker::find(node, "iris")) s.iris = parseFinish(c, m->value, "scattering.iris");
    if (const Member* m = Checker::find(node, "gloss_exponent"))
        s.glossExponent = c.numberIn(m->value, "scattering.gloss_exponent", 0.0, 1e5, "");
    auto items = [&](const char* key) -> const std::vector<Node>* {
        const Member* m = Checker::find(node, key);
        if (!m) return nullptr;
        if (m->value.kind != Node::Kind::Array)
            c.fail(m->value.line, child("scattering", key), "must be an array of objects, got " + describe(m->value));
        return &m->value.items;
    };
    auto surfaceNumber = [&](const Node& item, const std::string& path, const char* key) {
        return static_cast<int>(c.integerIn(c.require(item, path, key).value, child(path, key), 1, kMaxSurfaces));
    };
    if (const auto* list = items("dust"))
        for (std::size_t i = 0; i < list->size(); ++i) {
            const Node& item = (*list)[i];
            const std::string path = index("scattering.dust", i);
            c.object(item, path, {"surface", "coverage", "albedo", "diameter_um", "diameter_sigma", "mask", "mask_size_mm",
                                  "mask_centre_mm"});
            DustSpec d;
            d.line = item.line;
            d.surface = surfaceNumber(item, path, "surface");
            d.coverage = c.numberIn(c.require(item, path, "coverage").value, child(path, "coverage"), 0.0, 1.0, "");
            if (const Member* m = Checker::find(item, "albedo")) d.albedo = c.numberIn(m->value, child(path, "albedo"), 0.0, 1.0, "");
            if (const Member* m = Checker::find(item, "diameter_um"))
                d.diameterUm = c.numberIn(m->value, child(path, "diameter_um"), 0.0, 1e4, "um", true);
            if (const Member* m = Checker::find(item, "diameter_sigma"))
                d.diameterSigma = c.numberIn(m->value, child(path, "diameter_sigma"), 0.0, 3.0, "");
            d.mask = parseMask(c, item, path, baseDir);
            s.dust.push_back(d);
        }
    if (const auto* list = items("grease"))
        for (std::size_t i = 0; i < list->size(); ++i) {
            const Node& item = (*list)[i];
            const std::string path = index("scattering.grease", i);
            c.object(item, path, {"surface", "coverage", "roughness", "mask", "mask_size_mm", "mask_centre_mm"});
            GreaseSpec g;
            g.line = item.line;
            g.surface = surfaceNumber(item, path, "surface");
            g.coverage = c.numberIn(c.require(item, path, "coverage").value, child(path, "coverage"), 0.0, 1.0, "");
            if (const Member* m = Checker::find(item, "roughness"))
                g.roughness = c.numberIn(m->value, child(path, "roughness"), 0.0, 1.0, "", true);
            g.mask = parseMask(c, item, path, baseDir);
            s.grease.push_back(g);
        }
    if (const auto* list = items("bulk"))
        for (std::size_t i = 0; i < list->size(); ++i) {
            const Node& item = (*list)[i];
            const std::string path = index("scattering.bulk", i);
            c.object(item, path, {"element", "scattering_per_mm", "absorption_per_mm", "g", "rayleigh", "grid", "grid_name"});
            BulkSpec b;
            b.line = item.line;
            b.element = surfaceNumber(item, path, "element");
            b.scatteringPerMm = c.numberIn(c.require(item, path, "scattering_per_mm").value, child(path, "scattering_per_mm"),
                                           0.0, 100.0, "per mm");
            if (const Member* m = Checker::find(item, "absorption_per_mm"))
                b.absorptionPerMm = c.numberIn(m->value, child(path, "absorption_per_mm"), 0.0, 100.0, "per mm");
            if (const Member* m = Checker::find(item, "g")) b.g = c.numberIn(m->value, child(path, "g"), -0.99, 0.99, "");
            if (const Member* m = Checker::find(item, "rayleigh")) b.rayleigh = c.boolean(m->value, child(path, "rayleigh"));
            if (const Member* m = Checker::find(item, "grid")) {
                b.grid = resolveDataFile(c.string(m->value, child(path, "grid")), baseDir);
            }
            if (const Member* m = Checker::find(item, "grid_name")) b.gridName = c.string(m->value, child(path, "grid_name"));
            s.bulk.push_back(b);
        }
}

std::string shippedLensNames() {
    std::string names;
    for (const EmbeddedLens& lens : embeddedLenses()) names += (names.empty() ? "" : ", ") + std::string(lens.name);
    return names;
}

// A file relative to the scene's folder, or a shipped lens name (the same precedence as loadLens:
// an existing file wins).
std::string resolveLens(const Checker& c, const Node& node, const std::string& baseDir) {
    const std::string& value = c.string(node, "lens");
    if (value.empty()) c.fail(node.line, "lens", "must name a lens file or a shipped lens (" + shippedLensNames() + ")");
    std::filesystem::path file(value);
    if (file.is_relative() && !baseDir.empty()) file = std::filesystem::path(baseDir) / file;
    std::error_code ec;
    if (std::filesystem::is_regular_file(file, ec)) return file.string();
    if (value.find('/') == std::string::npos) {
        std::string name = value;
        if (name.size() > 5 && name.compare(name.size() - 5, 5, ".lens") == 0) name.resize(name.size() - 5);
        for (const EmbeddedLens& lens : embeddedLenses())
            if (name == lens.name) return name;
    }
    c.fail(node.line, "lens",
           "no lens file '" + file.string() + "'" + (file.string() != value ? " (relative to the scene's folder)" : "") +
               " and no shipped lens named '" + value + "' (shipped: " + shippedLensNames() + ")");
}

std::string readFile(const std::string& path) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) throw InputError(path, 0, "cannot open scene file: it is a directory");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(path, 0, std::string("cannot open scene file: ") + std::strerror(errno));
    std::ostringstream buffer;
    buffer << in.rdbuf();
    return buffer.str();
}

}  // namespace

Scene parseSceneText(std::string_view text, const std::string& fileName, const std::string& baseDir) {
    const Checker c(fileName);
    const Node root = parseTree(text, fileName);
    Scene scene;
    scene.sourceFile = fileName;
    c.object(root, "",
             {"description", "lens", "zoom", "focus_distance_mm", "f_number", "sensor", "lights", "render", "scattering"});

    if (const Member* m = Checker::find(root, "description")) scene.description = c.string(m->value, "description");

    const Member& lens = c.require(root, "", "lens", " (a lens file or a shipped lens: " + shippedLensNames() + ")");
    scene.lens = resolveLens(c, lens.value, baseDir);
    scene.lines.lens = lens.value.line;

    if (const Member* m = Checker::find(root, "zoom")) {
        const Node& v = m->value;
        scene.lines.zoom = v.line;
        if (v.kind == Node::Kind::String) {
            if (v.text.empty()) c.fail(v.line, "zoom", "must be a zoom position name or a focal length in mm");
            scene.lensState.zoom = v.text;
        } else if (v.isNumber()) {
            scene.lensState.zoom = formatNumber(c.numberIn(v, "zoom", 0.0, 100000.0, "mm", true));
        } else {
            c.fail(v.line, "zoom", "must be a zoom position name (e.g. \"tele\") or a focal length in mm, got " +
                                       describe(v));
        }
    }
    if (const Member* m = Checker::find(root, "focus_distance_mm")) {
        const Node& v = m->value;
        scene.lines.focus = v.line;
        if (v.kind == Node::Kind::String) {
            if (v.text != "infinity" && v.text != "inf")
                c.fail(v.line, "focus_distance_mm", "must be a positive number of mm or \"infinity\", got " + describe(v));
            scene.lensState.objectDistanceMm = std::numeric_limits<double>::infinity();
        } else {
            if (!v.isNumber())
                c.fail(v.line, "focus_distance_mm", "must be a positive number of mm or \"infinity\", got " + describe(v));
            scene.lensState.objectDistanceMm = c.numberIn(v, "focus_distance_mm", 0.0, 1e12, "mm", true);
        }
    }
    if (const Member* m = Checker::find(root, "f_number")) {
        scene.lines.fNumber = m->value.line;
        scene.lensState.fNumber = c.numberIn(m->value, "f_number", 0.5, 128.0, "");
    }

    if (const Member* m = Checker::find(root, "sensor")) parseSensor(c, m->value, scene);

    const Member& lights = c.require(root, "", "lights", " (an array with at least one light)");
    if (lights.value.kind != Node::Kind::Array)
        c.fail(lights.value.line, "lights", "must be an array of lights [ { \"type\": ... } ], got " + describe(lights.value));
    if (lights.value.items.empty()) c.fail(lights.value.line, "lights", "must hold at least one light");
    for (std::size_t i = 0; i < lights.value.items.size(); ++i) {
        const Node& node = lights.value.items[i];
        const std::string path = index("lights", i);
        scene.lights.push_back(parseLight(c, node, path, i));
        scene.lines.lights.push_back(node.line);
        for (std::size_t j = 0; j < i; ++j)
            if (scene.lights[j].name == scene.lights[i].name) {
                const Member* name = Checker::find(node, "name");
                c.fail(name ? name->value.line : node.line, child(path, "name"),
                       "\"" + scene.lights[i].name + "\" is already the name of lights[" + std::to_string(j) +
                           "] (names must be unique)");
            }
    }

    if (const Member* m = Checker::find(root, "render")) parseRender(c, m->value, scene.render);
    if (const Member* m = Checker::find(root, "scattering")) parseScattering(c, m->value, baseDir, scene.scattering);
    return scene;
}

Scene loadScene(const std::string& path) {
    const std::string text = readFile(path);
    return parseSceneText(text, path, std::filesystem::path(path).parent_path().string());
}

std::string_view defaultSceneText() { return kDefaultScene; }

Scene defaultScene() { return parseSceneText(kDefaultScene, "<default scene>", ""); }

LensSystem buildSceneLens(const Scene& scene) {
    LensPrescription prescription = loadLens(scene.lens);  // its own errors name the lens file
    const glm::dvec2 sensor = sensorSizeMm(scene, prescription.sensor);  // the scene's sensor wins
    prescription.sensor.widthMm = sensor.x;
    prescription.sensor.heightMm = sensor.y;
    // Add one setting at a time so that a failure can be pinned on the scene key that caused it
    // (the lens file was already checked at every zoom position when it was read).
    LensState state;
    auto build = [&](int line, const char* key) {
        try {
            return LensSystem::build(prescription, state);
        } catch (const InputError& e) {
            if (line == 0) throw;
            throw InputError(scene.sourceFile, line,
                             std::string(key) + ": " + e.problem() + " (lens " + e.file() + ")");
        }
    };
    if (!scene.lensState.zoom.empty()) {
        state.zoom = scene.lensState.zoom;
        build(scene.lines.zoom, "zoom");
    }
    if (scene.lensState.objectDistanceMm) {
        state.objectDistanceMm = scene.lensState.objectDistanceMm;
        if (!scene.lensState.fNumber) return build(scene.lines.focus, "focus_distance_mm");
        build(scene.lines.focus, "focus_distance_mm");
    }
    state.fNumber = scene.lensState.fNumber;
    return build(scene.lensState.fNumber ? scene.lines.fNumber : 0, "f_number");
}

glm::dvec2 sensorSizeMm(const Scene& scene, const SensorSpec& lensSensor) {
    const SensorSettings& s = scene.sensor;
    if (s.widthMm && s.heightMm) return {*s.widthMm, *s.heightMm};
    const double pitchX = lensSensor.widthMm / s.widthPx, pitchY = lensSensor.heightMm / s.heightPx;
    if (std::abs(pitchX - pitchY) > kPixelAspectTolerance * std::max(pitchX, pitchY))
        throw InputError(scene.sourceFile, scene.lines.resolution ? scene.lines.resolution : scene.lines.sensor,
                         "sensor: the lens's sensor is " + formatNumber(lensSensor.widthMm) + " x " +
                             formatNumber(lensSensor.heightMm) + " mm, which at " + std::to_string(s.widthPx) +
                             " x " + std::to_string(s.heightPx) +
                             " px gives pixels that are not square; give sensor.width_mm or a resolution with the "
                             "same aspect ratio");
    return {lensSensor.widthMm, lensSensor.heightMm};
}

}  // namespace flare
