#include "flare/scene/Scene.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "flare/core/Error.h"
#include "flare/optics/AgfCatalog.h"
#include "flare/optics/EmbeddedLenses.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/LensLibrary.h"
#include "flare/optics/RealRays.h"
#include "flare/scene/JsonTree.h"
#include "flare/scene/SceneChecker.h"
#include "flare/scene/SceneLights.h"
#include "flare/scene/SceneScattering.h"

namespace flare {

using namespace scenefile;  // the scene file's tree, checker and block readers

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

constexpr int kMaxResolutionPx = 16384;
constexpr double kPixelAspectTolerance = 1e-3;  // "square within 0.1 %"

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
              "max_bounces", "sensor_ghosts", "diffraction", "diffraction_wavelengths", "beams_per_pass",
              "beams_by_power", "ghost_ringing"});
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
    if (const Member* m = Checker::find(node, "diffraction")) r.diffraction = c.boolean(m->value, "render.diffraction");
    if (const Member* m = Checker::find(node, "diffraction_wavelengths"))
        r.diffractionWavelengths = static_cast<int>(c.integerIn(m->value, "render.diffraction_wavelengths", 1, 256));
    if (const Member* m = Checker::find(node, "beams_per_pass"))
        r.beamsPerPass = static_cast<int>(c.integerIn(m->value, "render.beams_per_pass", 16, 65536));
    if (const Member* m = Checker::find(node, "beams_by_power")) r.beamsByPower = c.boolean(m->value, "render.beams_by_power");
    if (const Member* m = Checker::find(node, "ghost_ringing")) r.ghostRinging = c.boolean(m->value, "render.ghost_ringing");
}

std::string shippedLensNames() {
    std::string names;
    for (const EmbeddedLens& lens : embeddedLenses()) names += (names.empty() ? "" : ", ") + std::string(lens.name);
    return names;
}

// A file relative to the scene's folder, a shipped lens name or a library lens id (the same
// precedence as loadLens: an existing file wins).
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
        if (const LibraryLens* lens = LensLibrary::shared().find(name)) return lens->path;
    }
    const std::string relative = file.string() != value ? " (relative to the scene's folder)" : "";
    if (value.find('/') != std::string::npos)
        c.fail(node.line, "lens",
               "no lens file '" + file.string() + "'" + relative + " (a shipped lens or library id has no '/')");
    std::string name = value;
    if (name.size() > 5 && name.compare(name.size() - 5, 5, ".lens") == 0) name.resize(name.size() - 5);
    c.fail(node.line, "lens", "no lens file '" + file.string() + "'" + relative + "; " + unknownLensProblem(name));
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

// "coating": "NAME" or { "ideal_reflectance": R } or { "ideal_reflectance": [[nm, R], ...] }.
SceneCoating parseCoating(const Checker& c, const Node& node) {
    SceneCoating coating;
    if (node.kind == Node::Kind::String) {
        if (node.text.empty()) c.fail(node.line, "coating", "must name a coating of the lens or be an object");
        coating.name = node.text;
        return coating;
    }
    if (node.kind != Node::Kind::Object)
        c.fail(node.line, "coating",
               "must be a coating name (\"none\", \"mgf2\", one the lens defines) or { \"ideal_reflectance\": R }, got " +
                   describe(node));
    c.object(node, "coating", {"ideal_reflectance"});
    const Member& r = c.require(node, "coating", "ideal_reflectance", " (a reflectance or [[nm, R], ...])");
    IdealReflectance& ideal = coating.ideal.emplace();
    const std::string path = "coating.ideal_reflectance";
    if (r.value.isNumber()) {
        ideal.wavelengthsNm.push_back(550.0);
        ideal.reflectances.push_back(c.numberIn(r.value, path, 0.0, 1.0, ""));
        return coating;
    }
    if (r.value.kind != Node::Kind::Array || r.value.items.empty())
        c.fail(r.value.line, path, "must be a reflectance in [0, 1] or a non-empty array of [nm, R] points, got " +
                                       describe(r.value));
    for (std::size_t i = 0; i < r.value.items.size(); ++i) {
        const std::string point = index(path, i);
        const std::vector<Node>& pair = c.numbers(r.value.items[i], point, 2, "[wavelength_nm, reflectance]");
        const double wavelength = c.numberIn(pair[0], point, 0.0, 1e5, "nm", true);
        if (!ideal.wavelengthsNm.empty() && wavelength <= ideal.wavelengthsNm.back())
            c.fail(pair[0].line, point, "wavelengths must increase");
        ideal.wavelengthsNm.push_back(wavelength);
        ideal.reflectances.push_back(c.numberIn(pair[1], point, 0.0, 1.0, ""));
    }
    return coating;
}

}  // namespace

Scene parseSceneText(std::string_view text, const std::string& fileName, const std::string& baseDir) {
    const Checker c(fileName);
    const Node root = parseTree(text, fileName);
    Scene scene;
    scene.sourceFile = fileName;
    c.object(root, "",
             {"description", "lens", "glass_catalog", "zoom", "focus_distance_mm", "f_number", "coating", "sensor",
              "lights", "render", "scattering"});

    if (const Member* m = Checker::find(root, "description")) scene.description = c.string(m->value, "description");

    const Member& lens = c.require(root, "", "lens", " (a lens file or a shipped lens: " + shippedLensNames() + ")");
    scene.lens = resolveLens(c, lens.value, baseDir);
    scene.lines.lens = lens.value.line;

    if (const Member* m = Checker::find(root, "glass_catalog")) {
        // One .agf file or a list of them, relative to the scene's folder, each checked here.
        const Node& v = m->value;
        scene.lines.glassCatalog = v.line;
        std::vector<const Node*> files;
        if (v.kind == Node::Kind::Array)
            for (const Node& item : v.items) files.push_back(&item);
        else files.push_back(&v);
        if (files.empty()) c.fail(v.line, "glass_catalog", "must name a glass catalogue file (.agf) or a list of them");
        for (const Node* file : files) {
            const std::string& name = c.string(*file, "glass_catalog");
            std::filesystem::path path(name);
            if (path.is_relative() && !baseDir.empty()) path = std::filesystem::path(baseDir) / path;
            std::error_code ec;
            if (!std::filesystem::is_regular_file(path, ec))
                c.fail(file->line, "glass_catalog",
                       "no glass catalogue file '" + path.string() + "'" +
                           (path.string() != name ? " (relative to the scene's folder)" : ""));
            scene.glassCatalogs.push_back(path.string());
        }
    }

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

    if (const Member* m = Checker::find(root, "coating")) {
        scene.lines.coating = m->value.line;
        scene.coating = parseCoating(c, m->value);
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

namespace {

LensSystem buildLensAtSceneState(const Scene& scene) {
    for (const std::string& catalog : scene.glassCatalogs) useGlassCatalog(catalog);  // errors name the .agf file
    LensPrescription prescription = loadLens(scene.lens);  // its own errors name the lens file
    if (scene.coating) {
        // The scene's coating goes on every air–glass surface, replacing the lens's choices.
        std::string name = scene.coating->name;
        if (scene.coating->ideal) {
            name = "(scene ideal)";
            std::erase_if(prescription.coatings, [&](const Coating& c) { return c.name == name; });
            prescription.coatings.push_back(Coating{name, {}, scene.coating->ideal});
        } else if (!prescription.findCoating(name)) {
            std::string known = "none, mgf2";
            for (const Coating& c : prescription.coatings) known += ", " + c.name;
            throw InputError(scene.sourceFile, scene.lines.coating,
                             "coating: the lens has no coating '" + name + "' (known: " + known + ")");
        }
        prescription.defaultCoating = name;
        for (PrescriptionRow& row : prescription.rows) row.coatingName.reset();
    }
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

}  // namespace

LensSystem buildSceneLens(const Scene& scene) {
    LensSystem lens = buildLensAtSceneState(scene);
    // A point or disk light sends its rays from where it is: it must lie in front of the lens's
    // foremost point (a concave front surface's rim reaches ahead of its vertex), where the scene
    // file's own check (z < 0) cannot see.
    const double frontZMm = objectSpaceStartZMm(lens) + 1.0;
    for (size_t k = 0; k < scene.lights.size(); ++k) {
        const LightSpec& light = scene.lights[k];
        if (light.type == LightSpec::Type::Directional) continue;
        const glm::dvec3 n = light.diskNormal();
        const double nearestZMm = light.positionMm.z + light.radiusMm * std::sqrt(std::max(0.0, 1.0 - n.z * n.z));
        if (nearestZMm < frontZMm) continue;
        throw InputError(scene.sourceFile, k < scene.lines.lights.size() ? scene.lines.lights[k] : 0,
                         "lights[" + std::to_string(k) + "]: the light reaches z = " + formatNumber(nearestZMm) +
                             " mm, but the lens's front surface reaches z = " + formatNumber(frontZMm) +
                             " mm; a point or disk light must lie wholly in front of the lens");
    }
    return lens;
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
