// Region lights (LightSpec::region, `flare composite`'s extended sources): one ghost analysis and
// plan at the region's centre serve every point of it. Their ghosts must be those of the same
// points as separate directional lights, each analysed and planned at its own direction, within
// the renders' own estimated errors: an analysis whose pupil grid or guide masks did not cover the
// outer points' rays would lose part of their ghosts (a bias far above the noise).
#include <cmath>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "flare/photons/LightSampler.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"
#include "flare/scene/SceneRender.h"

namespace flare {
namespace {

struct TestPoint {
    double xDeg, yDeg, share;
    int colour;
};
const glm::dvec3 kColours[2] = {{1.0, 0.55, 0.12}, {0.3, 0.7, 1.0}};  // a sodium lamp, a cold LED

std::string sceneText(const std::string& lights) {
    return R"({ "lens": "double-gauss-50mm", "f_number": 4, "sensor": { "resolution": [300, 200] },
  "lights": [ )" + lights + R"( ],
  "render": { "diffraction": false, "ghost_ringing": false, "seed": 5 } })";
}

std::string number(double v) {
    std::ostringstream s;
    s.precision(17);
    s << v;
    return s.str();
}

// The points as one region light of total irradiance `power`.
Scene regionScene(const std::vector<TestPoint>& points, double power) {
    std::string text = R"({ "type": "region", "name": "region", "power": )" + number(power) +
                       R"(, "spectrum": { "rgb": [0.8, 0.6, 0.4] }, "colours": [)";
    for (int c = 0; c < 2; ++c)
        text += std::string(c ? ", " : "") + "[" + number(kColours[c].x) + ", " + number(kColours[c].y) + ", " +
                number(kColours[c].z) + "]";
    text += R"(], "points": [)";
    for (size_t i = 0; i < points.size(); ++i)
        text += std::string(i ? ", " : "") + "[" + number(points[i].xDeg) + ", " + number(points[i].yDeg) + ", " +
                number(points[i].share) + ", " + std::to_string(points[i].colour) + "]";
    text += "] }";
    return parseSceneText(sceneText(text), "region.json", "");
}

// The same points as directional lights, each with its share of the power in its own colour.
Scene separateScene(const std::vector<TestPoint>& points, double power) {
    double total = 0.0;
    for (const TestPoint& p : points) total += p.share;
    std::string text;
    for (size_t i = 0; i < points.size(); ++i) {
        const glm::dvec3& c = kColours[points[i].colour];
        text += std::string(i ? ", " : "") + R"({ "type": "directional", "field_deg": [)" + number(points[i].xDeg) + ", " +
                number(points[i].yDeg) + R"(], "power": )" + number(power * points[i].share / total) +
                R"(, "spectrum": { "rgb": [)" + number(c.x) + ", " + number(c.y) + ", " + number(c.z) + "] } }";
    }
    return parseSceneText(sceneText(text), "separate.json", "");
}

struct Ghosts {
    std::vector<float> image;
    double estimatedError = 0.0;
    std::map<std::string, double> powerW, varianceW2;  // per ghost path, summed over the lights
    double totalW = 0.0, totalVarianceW2 = 0.0;
};

Ghosts renderGhosts(const Scene& scene, int passes, int beamsPerPass) {
    const LensSystem lens = buildSceneLens(scene);
    RenderOptions options = sceneRenderOptions(scene, lens, {});
    options.tracePhotons = false;
    options.beamsPerPass = beamsPerPass;
    Renderer renderer(lens, scene.lights, options);
    for (int pass = 0; pass < passes; ++pass) renderer.runPass();
    Ghosts out;
    out.image = renderer.layerXyz(kLayerGhost);
    out.estimatedError = renderer.estimatedRelativeError(kGroupGhost);
    for (const PathTally& t : renderer.tallies()) {
        if (t.kind != PathTally::Kind::Ghost || t.path.reflections.size() != 2 || t.strategy != PathStrategy::Beams) continue;
        const double p = renderer.tallyPowerW(t), e = renderer.tallyStandardErrorW(t);
        out.powerW[t.path.label()] += p;
        out.varianceW2[t.path.label()] += e * e;
        out.totalW += p;
        out.totalVarianceW2 += e * e;
    }
    return out;
}

double relativeL2(const std::vector<float>& a, const std::vector<float>& reference) {
    double difference = 0.0, norm = 0.0;
    for (size_t i = 0; i < a.size(); ++i) {
        difference += (static_cast<double>(a[i]) - reference[i]) * (static_cast<double>(a[i]) - reference[i]);
        norm += static_cast<double>(reference[i]) * reference[i];
    }
    return std::sqrt(difference / norm);
}

// A region of `radiusDeg` about (cx, cy): two far points on opposite sides (no point at the centre:
// the analysis's own direction holds no light), and two nearer, in two colours.
std::vector<TestPoint> regionPoints(double cx, double cy, double radiusDeg) {
    const double d = radiusDeg / std::sqrt(2.0);
    return {{cx + d, cy + d, 0.35, 0},
            {cx - d, cy - d, 0.25, 1},
            {cx + 0.4 * radiusDeg, cy - 0.5 * radiusDeg, 0.25, 1},
            {cx - 0.6 * radiusDeg, cy + 0.2 * radiusDeg, 0.15, 0}};
}

void expectSameGhosts(const std::vector<TestPoint>& points) {
    constexpr double kPower = 1000.0;
    constexpr int kPasses = 8;
    const Scene region = regionScene(points, kPower), separate = separateScene(points, kPower);
    ASSERT_TRUE(region.lights[0].isRegion());
    // The same beams per point: the region light gets as many per pass as the points together.
    const Ghosts a = renderGhosts(region, kPasses, 96 * static_cast<int>(points.size()));
    const Ghosts b = renderGhosts(separate, kPasses, 96);
    ASSERT_GT(b.totalW, 0.0);
    // The ghosts' total Y power, within four standard errors of the difference.
    const double sigma = std::sqrt(a.totalVarianceW2 + b.totalVarianceW2);
    EXPECT_LT(std::abs(a.totalW - b.totalW), 4.0 * sigma) << a.totalW << " vs " << b.totalW << " ± " << sigma;
    // Every ghost the separate lights render by beams: the region's, within four standard errors.
    // (A ghost the region pruned at its centre carries at most its share of the pruning.)
    double missingW = 0.0;
    for (const auto& [label, powerW] : b.powerW) {
        const auto it = a.powerW.find(label);
        if (it == a.powerW.end()) {
            missingW += powerW;
            continue;
        }
        const double s = std::sqrt(a.varianceW2.at(label) + b.varianceW2.at(label));
        EXPECT_LT(std::abs(it->second - powerW), 4.0 * s + 1e-3 * b.totalW) << label << ": " << it->second << " vs " << powerW;
    }
    EXPECT_LT(missingW, 2e-3 * b.totalW);
    // The images: their difference within the two renders' estimated errors (relative L2; 3 × the
    // combined estimate, which rests on a few replicates).
    const double estimated = std::hypot(a.estimatedError, b.estimatedError);
    EXPECT_LT(relativeL2(a.image, b.image), 3.0 * estimated) << "estimated " << a.estimatedError << ", " << b.estimatedError;
}

TEST(PlateRegions, ARegionLightsGhostsAreItsPointsGhostsAtTheCompositesBound) {
    expectSameGhosts(regionPoints(9.0, 5.0, 3.0));  // the composite's default radius (kDefaultRegionRadiusDeg)
}

TEST(PlateRegions, ARegionLightsGhostsAreItsPointsGhostsAtTheLargestRadius) {
    expectSameGhosts(regionPoints(6.0, -4.0, kMaxRegionRadiusDeg));
}

// The sampler draws the points by their shares, and the colour factor of a point drawn from the
// light's spectrum averages (over that spectrum's wavelengths, luminance-weighted) to one.
TEST(PlateRegions, TheSamplerDrawsPointsByShareAndReweightsTheirColour) {
    const Scene scene = regionScene(regionPoints(2.0, 1.0, 2.0), 10.0);
    const LensSystem lens = buildSceneLens(scene);
    const LightSampler sampler(scene.lights[0], lens);
    EXPECT_TRUE(sampler.hasExtent());
    std::vector<int> counts(4, 0);
    constexpr int kDraws = 100000;
    for (int i = 0; i < kDraws; ++i) ++counts[static_cast<size_t>(sampler.regionPoint((i + 0.5) / kDraws))];
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(counts[k] / double(kDraws), scene.lights[0].region[k].share, 2.0 / kDraws);
    // Σ over wavelengths drawn from the light's spectrum of factor × xyzWeight.y → 1 (each colour at
    // unit luminance), for a point of either colour.
    const WavelengthSampler wavelengths(toSpectrum(scene.lights[0].spectrum));
    for (double u1 : {0.1, 0.5}) {
        double y = 0.0;
        constexpr int kWavelengths = 20000;
        for (int i = 0; i < kWavelengths; ++i) {
            double pdf = 0.0;
            const double nm = wavelengths.sample((i + 0.5) / kWavelengths, &pdf);
            y += wavelengths.xyzWeight(nm, pdf).y * sampler.colourFactor(u1, nm) / kWavelengths;
        }
        EXPECT_NEAR(y, 1.0, 2e-3) << u1;
    }
    // Rays of a drawn point travel in its direction and carry the light's irradiance times cos θ.
    const EmittedRay ray = sampler.rayThrough(0.0, 0.0, 0.9, 0.0);
    const LightSpec& light = scene.lights[0];
    const RegionPoint& last = light.region[static_cast<size_t>(sampler.regionPoint(0.9))];
    EXPECT_NEAR(glm::dot(ray.ray.direction, directionFromFieldDeg(last.fieldXDeg, last.fieldYDeg)), 1.0, 1e-14);
    EXPECT_NEAR(ray.powerPerMm2, light.power * 1e-6 * glm::dot(ray.ray.direction, light.travelDirection()), 1e-15);
}

TEST(PlateRegions, BadRegionLightsAreRefused) {
    auto refuse = [](const std::string& light, const std::string& message) {
        try {
            parseSceneText(sceneText(light), "bad.json", "");
            ADD_FAILURE() << "accepted " << light;
        } catch (const std::exception& e) {
            EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
        }
    };
    refuse(R"({ "type": "region", "points": [] })", "non-empty array");
    refuse(R"({ "type": "region", "points": [[0, 0, 1], [25, 0, 1]] })", "a region light spans at most 10");
    refuse(R"({ "type": "region", "points": [[0, 0, 1, 2]], "colours": [[1, 1, 1]] })", "points[0][3]");
    refuse(R"({ "type": "region", "points": [[0, 0, 1, 0]] })", "has no \"colours\"");
    refuse(R"({ "type": "region", "points": [[0, 0, 0]] })", "points[0][2]");
}

}  // namespace
}  // namespace flare
