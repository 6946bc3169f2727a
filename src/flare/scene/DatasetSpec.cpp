#include "flare/scene/DatasetSpec.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>

#include "flare/core/Error.h"
#include "flare/core/Random.h"
#include "flare/optics/EmbeddedLenses.h"
#include "flare/optics/LensLibrary.h"
#include "flare/optics/Paraxial.h"
#include "flare/scene/JsonTree.h"
#include "flare/scene/Scene.h"
#include "flare/scene/SceneChecker.h"

namespace flare {

namespace {

using scenefile::Checker;
using scenefile::Member;
using scenefile::Node;

constexpr double kDegrees = 180.0 / std::numbers::pi;
// Field angles a scene accepts (docs/scene-format.md: ±89.9°), with a margin.
constexpr double kMaxFieldDeg = 89.0;

// A range: [lo, hi] (lo ≤ hi) or one number (lo = hi), each in [min, max].
SpecRange range(const Checker& c, const Node& node, const std::string& path, double min, double max,
                const std::string& unit) {
    if (node.isNumber()) {
        const double v = c.numberIn(node, path, min, max, unit);
        return {v, v};
    }
    const std::vector<Node>& items = c.numbers(node, path, 2, "[lo, hi] or one number");
    const double lo = c.numberIn(items[0], path + "[0]", min, max, unit);
    const double hi = c.numberIn(items[1], path + "[1]", min, max, unit);
    if (lo > hi)
        c.fail(node.line, path,
               "impossible range [" + scenefile::formatNumber(lo) + ", " + scenefile::formatNumber(hi) + "]: lo > hi");
    return {lo, hi};
}

std::string lower(std::string s) {
    for (char& ch : s) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    return s;
}

bool isShipped(const std::string& name) {
    return std::any_of(embeddedLenses().begin(), embeddedLenses().end(),
                       [&](const EmbeddedLens& lens) { return name == lens.name; });
}

void readLenses(const Checker& c, const Node& node, DatasetSpec& spec) {
    const LensLibrary& library = LensLibrary::shared();
    if (node.kind == Node::Kind::Array) {
        if (node.items.empty()) c.fail(node.line, "lenses", "must name at least one lens");
        for (size_t i = 0; i < node.items.size(); ++i) {
            const std::string path = scenefile::index("lenses", i);
            const std::string& id = c.string(node.items[i], path);
            if (isShipped(id)) {
                spec.lenses.push_back(id);
            } else if (const LibraryLens* lens = library.find(id)) {
                spec.lenses.push_back(lens->path);
            } else {
                c.fail(node.items[i].line, path,
                       "no lens '" + id + "' in the library or among the shipped lenses (flare lens list)");
            }
            spec.lensIds.push_back(id);
        }
        return;
    }
    // A selection from the library: every lens with all the tags, of the kind and maker.
    c.object(node, "lenses", {"tags", "kind", "maker"});
    std::vector<std::string> tags;
    if (const Member* m = Checker::find(node, "tags")) {
        if (m->value.kind != Node::Kind::Array) c.fail(m->value.line, "lenses.tags", "must be an array of tags");
        for (size_t i = 0; i < m->value.items.size(); ++i)
            tags.push_back(c.string(m->value.items[i], scenefile::index("lenses.tags", i)));
    }
    std::string kind = "any", maker;
    if (const Member* m = Checker::find(node, "kind")) {
        kind = c.string(m->value, "lenses.kind");
        if (kind != "any" && kind != "prime" && kind != "zoom")
            c.fail(m->value.line, "lenses.kind", "must be \"prime\", \"zoom\" or \"any\", got \"" + kind + "\"");
    }
    if (const Member* m = Checker::find(node, "maker")) maker = lower(c.string(m->value, "lenses.maker"));
    for (const LibraryLens& lens : library.lenses()) {
        if (kind != "any" && lens.kind != kind) continue;
        if (!maker.empty() && lower(lens.maker) != maker) continue;
        if (!std::all_of(tags.begin(), tags.end(), [&](const std::string& tag) {
                return std::find(lens.tags.begin(), lens.tags.end(), tag) != lens.tags.end();
            }))
            continue;
        spec.lenses.push_back(lens.path);
        spec.lensIds.push_back(lens.id);
    }
    if (spec.lenses.empty()) c.fail(node.line, "lenses", "no library lens has these tags, kind and maker");
}

void readLights(const Checker& c, const Node& node, DatasetSpec& spec) {
    c.object(node, "lights",
             {"count", "kinds", "outside_frame", "outside_margin", "temperature_k", "power", "angular_diameter_deg",
              "distance_mm", "disk_radius_mm"});
    if (const Member* m = Checker::find(node, "count")) {
        spec.lightCount = range(c, m->value, "lights.count", 1, 16, "");
        if (spec.lightCount.lo != std::floor(spec.lightCount.lo) || spec.lightCount.hi != std::floor(spec.lightCount.hi))
            c.fail(m->value.line, "lights.count", "must be whole numbers of lights");
    }
    if (const Member* m = Checker::find(node, "kinds")) {
        if (m->value.kind != Node::Kind::Array || m->value.items.empty())
            c.fail(m->value.line, "lights.kinds", "must be a non-empty array of \"directional\", \"point\", \"disk\"");
        spec.lightKinds.clear();
        for (size_t i = 0; i < m->value.items.size(); ++i) {
            const std::string path = scenefile::index("lights.kinds", i);
            const std::string& kind = c.string(m->value.items[i], path);
            if (kind != "directional" && kind != "point" && kind != "disk")
                c.fail(m->value.items[i].line, path, "must be \"directional\", \"point\" or \"disk\", got \"" + kind + "\"");
            spec.lightKinds.push_back(kind);
        }
    }
    if (const Member* m = Checker::find(node, "outside_frame"))
        spec.outsideFrameShare = c.numberIn(m->value, "lights.outside_frame", 0.0, 1.0, "");
    if (const Member* m = Checker::find(node, "outside_margin"))
        spec.outsideMargin = c.numberIn(m->value, "lights.outside_margin", 1.1, 20.0, "");
    if (const Member* m = Checker::find(node, "temperature_k"))
        spec.temperatureK = range(c, m->value, "lights.temperature_k", 1000.0, 40000.0, "K");
    if (const Member* m = Checker::find(node, "power")) spec.power = range(c, m->value, "lights.power", 1e-9, 1e9, "");
    if (const Member* m = Checker::find(node, "angular_diameter_deg"))
        spec.angularDiameterDeg = range(c, m->value, "lights.angular_diameter_deg", 0.0, 10.0, "deg");
    if (const Member* m = Checker::find(node, "distance_mm"))
        spec.distanceMm = range(c, m->value, "lights.distance_mm", 10.0, 1e9, "mm");
    if (const Member* m = Checker::find(node, "disk_radius_mm"))
        spec.diskRadiusMm = range(c, m->value, "lights.disk_radius_mm", 1e-3, 1e6, "mm");
}

void readQuality(const Checker& c, const Node& node, DatasetSpec& spec) {
    // Presets: a preview-quality set (10 % error) and a final-quality one (3 %).
    if (node.kind == Node::Kind::String) {
        const std::string& name = c.string(node, "quality");
        if (name == "preview") spec.targetError = 0.1, spec.photons = 2'000'000, spec.beamsPerPass = 256;
        else if (name == "final") spec.targetError = 0.03, spec.photons = 50'000'000, spec.beamsPerPass = 1024;
        else c.fail(node.line, "quality", "must be \"preview\", \"final\" or an object, got \"" + name + "\"");
        return;
    }
    c.object(node, "quality", {"target_error", "photons", "beams_per_pass"});
    if (const Member* m = Checker::find(node, "target_error"))
        spec.targetError = c.numberIn(m->value, "quality.target_error", 0.0, 1.0, "", true);
    if (const Member* m = Checker::find(node, "photons"))
        spec.photons = c.integerIn(m->value, "quality.photons", 1, 10'000'000'000'000);
    if (const Member* m = Checker::find(node, "beams_per_pass"))
        spec.beamsPerPass = static_cast<int>(c.integerIn(m->value, "quality.beams_per_pass", 16, 65536));
}

double drawUniform(Rng& rng, const SpecRange& r) { return r.lo + rng.uniform() * (r.hi - r.lo); }
double drawLog(Rng& rng, const SpecRange& r) {
    return r.lo == r.hi ? r.lo : std::exp(std::log(r.lo) + rng.uniform() * (std::log(r.hi) - std::log(r.lo)));
}

}  // namespace

DatasetSpec parseDatasetSpec(const std::string& text, const std::string& fileName) {
    const Checker c(fileName, "spec");
    const Node root = scenefile::parseTree(text, fileName);
    c.object(root, "",
             {"images", "seed", "lenses", "zoom", "focus_distance_mm", "f_number", "lights", "dust", "grease",
              "resolution", "quality", "per_ghost_layers", "diffraction"});
    DatasetSpec spec;
    spec.file = fileName;
    spec.images = static_cast<int>(c.integerIn(c.require(root, "", "images").value, "images", 1, 10'000'000));
    if (const Member* m = Checker::find(root, "seed"))
        spec.seed = static_cast<std::uint64_t>(c.integerIn(m->value, "seed", 0, std::int64_t(1) << 53));
    readLenses(c, c.require(root, "", "lenses", " (library lens ids, or { \"tags\": [...], \"kind\": ... })").value, spec);
    if (const Member* m = Checker::find(root, "zoom")) spec.zoom = range(c, m->value, "zoom", 0.0, 1.0, "");
    if (const Member* m = Checker::find(root, "focus_distance_mm")) {
        if (m->value.kind == Node::Kind::String) {
            const std::string& v = c.string(m->value, "focus_distance_mm");
            if (v != "infinity" && v != "inf") c.fail(m->value.line, "focus_distance_mm", "must be \"infinity\" or [lo, hi] in mm");
        } else {
            spec.focusAtInfinity = false;
            spec.focusDistanceMm = range(c, m->value, "focus_distance_mm", 10.0, 1e12, "mm");
        }
    }
    if (const Member* m = Checker::find(root, "f_number")) spec.fNumber = range(c, m->value, "f_number", 0.5, 128.0, "");
    if (const Member* m = Checker::find(root, "lights")) readLights(c, m->value, spec);
    if (const Member* m = Checker::find(root, "dust")) spec.dustCoverage = range(c, m->value, "dust", 0.0, 1.0, "");
    if (const Member* m = Checker::find(root, "grease")) spec.greaseCoverage = range(c, m->value, "grease", 0.0, 1.0, "");
    if (const Member* m = Checker::find(root, "resolution")) {
        const std::vector<Node>& wh = c.numbers(m->value, "resolution", 2, "[width, height]");
        spec.widthPx = static_cast<int>(c.integerIn(wh[0], "resolution[0]", 8, 16384));
        spec.heightPx = static_cast<int>(c.integerIn(wh[1], "resolution[1]", 8, 16384));
    }
    if (const Member* m = Checker::find(root, "quality")) readQuality(c, m->value, spec);
    if (const Member* m = Checker::find(root, "per_ghost_layers"))
        spec.perGhostLayers = c.boolean(m->value, "per_ghost_layers");
    if (const Member* m = Checker::find(root, "diffraction")) spec.diffraction = c.boolean(m->value, "diffraction");
    return spec;
}

DatasetSpec loadDatasetSpec(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(path, 0, "cannot open the data set spec");
    std::ostringstream text;
    text << in.rdbuf();
    return parseDatasetSpec(text.str(), path);
}

DatasetImage datasetImage(const DatasetSpec& spec, int k) {
    // Image k's random numbers: stream k of the seed, drawn in a fixed order.
    Rng rng(spec.seed, static_cast<std::uint64_t>(k));
    const size_t lensIndex = std::min(spec.lenses.size() - 1, static_cast<size_t>(rng.uniform() * spec.lenses.size()));
    const std::string& id = spec.lensIds[lensIndex];
    nlohmann::json scene;
    scene["description"] = "flare dataset image " + std::to_string(k) + " (seed " + std::to_string(spec.seed) + ")";
    scene["lens"] = id;
    nlohmann::json drawn;
    drawn["lens"] = id;
    const double zoomShare = drawUniform(rng, spec.zoom);
    if (const LibraryLens* lens = LensLibrary::shared().find(id);
        lens != nullptr && lens->kind == "zoom" && lens->focalMaxMm > lens->focalMinMm) {
        const double focalMm = std::exp(std::log(lens->focalMinMm) + zoomShare * (std::log(lens->focalMaxMm) -
                                                                                   std::log(lens->focalMinMm)));
        scene["zoom"] = focalMm;
    }
    if (!spec.focusAtInfinity) scene["focus_distance_mm"] = drawLog(rng, spec.focusDistanceMm);
    const double fNumberDrawn = drawLog(rng, spec.fNumber);
    const double dust = drawUniform(rng, spec.dustCoverage), grease = drawUniform(rng, spec.greaseCoverage);

    // The lens at this zoom and focus, wide open: its focal length and sensor place the lights, and
    // its f-number bounds the drawn one.
    nlohmann::json probe = scene;
    probe["lights"] = nlohmann::json::array({{{"type", "directional"}, {"field_deg", {0.0, 0.0}}}});
    const Scene probeScene = parseSceneText(probe.dump(), spec.file, "");
    const LensSystem lens = buildSceneLens(probeScene);
    const ParaxialData paraxial = analyseParaxial(lens, 587.56);
    const double fNumber = std::max(fNumberDrawn, paraxial.fNumber * 1.001);
    scene["f_number"] = fNumber;
    const double widthMm = lens.sensor().widthMm, heightMm = widthMm * spec.heightPx / spec.widthPx;
    scene["sensor"] = {{"width_mm", widthMm}, {"resolution", {spec.widthPx, spec.heightPx}}};
    drawn["efl_mm"] = paraxial.eflMm;

    // The frame's half extents in tangent of the field angle (paraxial: a fisheye's frame is wider).
    const double tanX = 0.5 * widthMm / std::abs(paraxial.eflMm), tanY = 0.5 * heightMm / std::abs(paraxial.eflMm);
    const int lights = static_cast<int>(spec.lightCount.lo) +
                       std::min(static_cast<int>(spec.lightCount.hi - spec.lightCount.lo),
                                static_cast<int>(rng.uniform() * (spec.lightCount.hi - spec.lightCount.lo + 1.0)));
    nlohmann::json lightList = nlohmann::json::array(), drawnLights = nlohmann::json::array();
    const double maxTan = std::tan(kMaxFieldDeg / kDegrees);
    for (int i = 0; i < lights; ++i) {
        const std::string kind = spec.lightKinds[std::min(spec.lightKinds.size() - 1,
                                                          static_cast<size_t>(rng.uniform() * spec.lightKinds.size()))];
        const bool outside = rng.uniform() < spec.outsideFrameShare;
        double x = 0.0, y = 0.0;  // tangents of the field angles
        if (!outside) {
            x = (2.0 * rng.uniform() - 1.0) * tanX;
            y = (2.0 * rng.uniform() - 1.0) * tanY;
        } else {
            // Uniform over the margin's box outside the frame, by rejection (at least 17 % of draws
            // land outside for a margin ≥ 1.1), from the image's own stream.
            do {
                x = (2.0 * rng.uniform() - 1.0) * spec.outsideMargin * tanX;
                y = (2.0 * rng.uniform() - 1.0) * spec.outsideMargin * tanY;
            } while (std::abs(x) <= tanX && std::abs(y) <= tanY);
        }
        x = std::clamp(x, -maxTan, maxTan), y = std::clamp(y, -maxTan, maxTan);
        nlohmann::json light;
        light["type"] = kind;
        light["name"] = "light" + std::to_string(i);
        if (kind == "directional") {
            light["field_deg"] = {std::atan(x) * kDegrees, std::atan(y) * kDegrees};
            light["angular_diameter_deg"] = drawUniform(rng, spec.angularDiameterDeg);
        } else {
            const double distance = drawLog(rng, spec.distanceMm);
            const double norm = std::sqrt(x * x + y * y + 1.0);
            light["position_mm"] = {distance * x / norm, distance * y / norm, -distance / norm};
            if (kind == "disk") light["radius_mm"] = std::min(drawLog(rng, spec.diskRadiusMm), 0.5 * distance / norm);
        }
        light["spectrum"] = {{"blackbody_k", drawUniform(rng, spec.temperatureK)}};
        light["power"] = drawLog(rng, spec.power);
        lightList.push_back(light);
        drawnLights.push_back({{"kind", kind}, {"in_frame", !outside}});
    }
    scene["lights"] = lightList;
    drawn["lights"] = drawnLights;
    nlohmann::json scattering;
    if (dust > 0.0) scattering["dust"] = nlohmann::json::array({{{"surface", 1}, {"coverage", dust}}});
    if (grease > 0.0) scattering["grease"] = nlohmann::json::array({{{"surface", 1}, {"coverage", grease}}});
    if (!scattering.empty()) scene["scattering"] = scattering;
    drawn["dust"] = dust;
    drawn["grease"] = grease;
    // The render's seed: image k's own, so that two images never share random numbers.
    scene["render"] = {{"seed", mixBits(spec.seed * 0x9e3779b97f4a7c15ull + static_cast<std::uint64_t>(k)) >> 11},
                       {"photons", spec.photons},
                       {"beams_per_pass", spec.beamsPerPass},
                       {"diffraction", spec.diffraction}};
    return {scene, drawn};
}

}  // namespace flare
