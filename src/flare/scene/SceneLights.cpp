#include "flare/scene/SceneLights.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace flare::scenefile {

namespace {

constexpr double kMaxFieldDeg = 89.9;
constexpr double kMaxAngularDiameterDeg = 20.0;

// A region light's points ([x_deg, y_deg, share] or [x_deg, y_deg, share, colour]) and colours
// ([r, g, b] each); centred on its points, within kMaxRegionRadiusDeg of the centre.
void parseRegion(const Checker& c, const Node& node, const std::string& path, LightSpec& light) {
    const Member& points = c.require(node, path, "points", " ([[x_deg, y_deg, share], ...])");
    const std::string pointsPath = child(path, "points");
    if (points.value.kind != Node::Kind::Array || points.value.items.empty())
        c.fail(points.value.line, pointsPath, "must be a non-empty array of [x_deg, y_deg, share] or [x_deg, y_deg, share, colour], got " +
                                                  describe(points.value));
    std::size_t colours = 0;
    if (const Member* m = Checker::find(node, "colours")) {
        const std::string coloursPath = child(path, "colours");
        if (m->value.kind != Node::Kind::Array || m->value.items.empty())
            c.fail(m->value.line, coloursPath, "must be a non-empty array of [r, g, b], got " + describe(m->value));
        for (std::size_t k = 0; k < m->value.items.size(); ++k) {
            const std::string colourPath = index(coloursPath, k);
            const auto& rgb = c.numbers(m->value.items[k], colourPath, 3, "[r, g, b] in linear Rec.709");
            glm::dvec3 colour;
            for (int j = 0; j < 3; ++j) colour[j] = c.numberIn(rgb[j], index(colourPath, j), -1e12, 1e12, "");
            if (!(linearSrgbToXyz(colour).y > 0.0))
                c.fail(m->value.items[k].line, colourPath, "the colour must have a positive luminance (Y > 0)");
            light.regionColours.push_back(colour);
        }
        colours = light.regionColours.size();
    }
    double total = 0.0;
    for (std::size_t k = 0; k < points.value.items.size(); ++k) {
        const Node& item = points.value.items[k];
        const std::string pointPath = index(pointsPath, k);
        const std::size_t size = item.kind == Node::Kind::Array ? item.items.size() : 0;
        const auto& values = c.numbers(item, pointPath, size == 4 ? 4 : 3,
                                       colours ? "[x_deg, y_deg, share, colour]" : "[x_deg, y_deg, share]");
        RegionPoint p;
        p.fieldXDeg = c.numberIn(values[0], index(pointPath, 0), -kMaxFieldDeg, kMaxFieldDeg, "degrees");
        p.fieldYDeg = c.numberIn(values[1], index(pointPath, 1), -kMaxFieldDeg, kMaxFieldDeg, "degrees");
        p.share = c.numberIn(values[2], index(pointPath, 2), 0.0, 1e12, "", true);
        if (size == 4) {
            if (!colours) c.fail(item.line, pointPath, "names a colour, but the light has no \"colours\"");
            p.colour = static_cast<int>(c.integerIn(values[3], index(pointPath, 3), 0, static_cast<std::int64_t>(colours) - 1));
        } else if (colours > 1) {
            c.fail(item.line, pointPath, "must name its colour ([x_deg, y_deg, share, colour]): the light has " +
                                             std::to_string(colours) + " colours");
        }
        total += p.share;
        light.region.push_back(p);
    }
    for (RegionPoint& p : light.region) p.share /= total;
    light.centreOnRegion();
    const double radiusDeg = light.apparentRadiusRad() * 180.0 / std::numbers::pi;
    if (radiusDeg > kMaxRegionRadiusDeg)
        c.fail(points.value.line, pointsPath,
               "the points reach " + formatDerived(radiusDeg) + " degrees from their centre; a region light spans at most " +
                   formatNumber(kMaxRegionRadiusDeg) + " (one ghost analysis serves all its points): split it");
    // (No colours: every point shines in the light's spectrum.)
}

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
    const Member& typeMember = c.require(node, path, "type", " (directional, region, point or disk)");
    const std::string& type = c.string(typeMember.value, child(path, "type"));
    std::vector<std::string> allowed = {"type", "name", "spectrum", "power"};
    if (type == "directional") {
        light.type = LightSpec::Type::Directional;
        allowed.insert(allowed.end(), {"field_deg", "angular_diameter_deg"});
    } else if (type == "region") {
        light.type = LightSpec::Type::Directional;
        allowed.insert(allowed.end(), {"points", "colours"});
    } else if (type == "point") {
        light.type = LightSpec::Type::Point;
        allowed.insert(allowed.end(), {"position_mm"});
    } else if (type == "disk") {
        light.type = LightSpec::Type::Disk;
        allowed.insert(allowed.end(), {"position_mm", "radius_mm"});
    } else {
        c.fail(typeMember.value.line, child(path, "type"),
               "unknown light type \"" + type + "\" (directional, region, point or disk)");
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

    if (type == "region") {
        parseRegion(c, node, path, light);
        return light;
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
