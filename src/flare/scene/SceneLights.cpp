#include "flare/scene/SceneLights.h"

#include <algorithm>
#include <cmath>

namespace flare::scenefile {

namespace {

constexpr double kMaxFieldDeg = 89.9;
constexpr double kMaxAngularDiameterDeg = 20.0;

}  // namespace

SpectrumSpec parseSpectrum(const Checker& c, const Node& node, const std::string& path) {
    SpectrumSpec s;
    const char* kinds = "\"d65\", \"equal_energy\", { \"blackbody_k\": T } or { \"rgb\": [r, g, b] }";
    if (node.kind == Node::Kind::String) {
        if (node.text == "d65") s.kind = SpectrumSpec::Kind::D65;
        else if (node.text == "equal_energy") s.kind = SpectrumSpec::Kind::EqualEnergy;
        else if (node.text == "blackbody")
            c.fail(node.line, path, "a blackbody needs its temperature: { \"blackbody_k\": 5778 }");
        else c.fail(node.line, path, "unknown spectrum \"" + node.text + "\" (use " + kinds + ")");
        return s;
    }
    if (node.kind != Node::Kind::Object) c.fail(node.line, path, std::string("must be ") + kinds + ", got " + describe(node));
    c.object(node, path, {"blackbody_k", "rgb"});
    if (const Member* m = Checker::find(node, "rgb")) {
        if (Checker::find(node, "blackbody_k")) c.fail(m->value.line, path, "give either blackbody_k or rgb, not both");
        const std::string rgbPath = child(path, "rgb");
        const auto& rgb = c.numbers(m->value, rgbPath, 3, "[r, g, b] in linear Rec.709");
        s.kind = SpectrumSpec::Kind::Rgb;
        for (int k = 0; k < 3; ++k) s.rgb[k] = c.numberIn(rgb[k], index(rgbPath, k), -1e12, 1e12, "");
        if (!(linearSrgbToXyz(s.rgb).y > 0.0))
            c.fail(m->value.line, rgbPath, "the colour must have a positive luminance (Y > 0)");
        return s;
    }
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

}  // namespace flare::scenefile
