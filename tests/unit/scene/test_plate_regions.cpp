// Region lights (LightSpec::region, `flare composite`'s extended sources): one ghost analysis and
// plan at the region's centre serve every point of it. Their ghosts must be those of the same
// points as separate directional lights, each analysed and planned at its own direction, within
// the renders' own estimated errors: an analysis whose pupil grid or guide masks did not cover the
// outer points' rays would lose part of their ghosts (a bias far above the noise).
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "flare/core/Spectrum.h"
#include "flare/photons/LightSampler.h"
#include "flare/render/Render.h"
#include "flare/scene/PlateLights.h"
#include "flare/scene/Scene.h"
#include "flare/scene/SceneRender.h"
#include "flare/wave/Starburst.h"

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
    // Each light's beams shared by its own central probes, as the region (one light) shares its
    // own: the comparison is of the region's sampling, not of how beams move between lights
    // (BeamShare.h; with two replicates a path's standard error has one degree of freedom, and the
    // four points' paths at other rates drew a 4.4σ difference on ghost_11_07).
    options.beamVarianceProbes = 0;
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
    constexpr int kPasses = 16;
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
        EXPECT_LT(std::abs(it->second - powerW), 4.0 * s + 1e-3 * b.totalW) << label << ": " << it->second << " vs " << powerW << " ± " << s;
    }
    EXPECT_LT(missingW, 2e-3 * b.totalW);
    // The images: their difference within the two renders' estimated errors (relative L2; 3 × the
    // combined estimate, which rests on a few replicates).
    const double estimated = std::hypot(a.estimatedError, b.estimatedError);
    EXPECT_LT(relativeL2(a.image, b.image), 3.0 * estimated) << "estimated " << a.estimatedError << ", " << b.estimatedError;
}

TEST(PlateRegions, ARegionLightsGhostsAreItsPointsGhostsAtTheBound) {
    // (The points lie up to 1.15 × the radius from their share-weighted centre.)
    expectSameGhosts(regionPoints(9.0, 5.0, kMaxRegionRadiusDeg / 1.15));
}

TEST(PlateRegions, ARegionLightsGhostsAreItsPointsGhostsAtTheLargestRadiusNearACorner) {
    // (The points lie up to 1.15 × the radius from their share-weighted centre.) At 4.35° a ghost of
    // the outer points (ghost_12_09) was nearly lost: 5° is not within the bound.
    expectSameGhosts(regionPoints(13.0, -8.0, kMaxRegionRadiusDeg / 1.15));
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

// The starburst of a region: its pixels diffracted together, as one crop with the PSF of its centre
// (what `flare composite` does: one PSF, one near-field FFT convolution and one far field per
// region), against each pixel diffracted by its own direction's PSF (one light per pixel). They
// differ by how the PSF changes across the region (the pupil's vignetted outline, the lens's
// mapping), which the test measures on its own: one pixel at the region's edge diffracted by the
// centre's PSF and by its own. The region's difference must stay within a few times that.
TEST(PlateRegions, ARegionsStarburstIsItsPixelsStarbursts) {
    const Scene scene = parseSceneText(sceneText(R"({ "type": "directional", "field_deg": [0, 0] })"), "s.json", "");
    const LensSystem lens = buildSceneLens(scene);
    const int w = 300, h = 200;
    const PlateFieldMap map(lens, w, h);
    // A region of 3° radius (about 22 px here) right of and above the centre: pixels of two colours.
    std::vector<std::pair<glm::ivec2, glm::dvec3>> pixels;
    for (int k = 0; k < 12; ++k) {
        const double a = 2.0 * std::numbers::pi * k / 12.0, r = k % 3 == 0 ? 20.0 : 9.0 + k;
        pixels.push_back({{210 + static_cast<int>(std::lround(r * std::cos(a))), 60 + static_cast<int>(std::lround(r * std::sin(a)))},
                          linearSrgbToXyz(k % 2 ? glm::dvec3(900.0, 500.0, 120.0) : glm::dvec3(150.0, 300.0, 800.0))});
    }
    const std::vector<SpectralSample> spectrum = spectralQuadrature(Spectrum::d65(), 8);
    auto image = [&](size_t only) {
        std::vector<float> xyz(3 * static_cast<size_t>(w) * h, 0.0f);
        for (size_t i = 0; i < pixels.size(); ++i) {
            if (only < pixels.size() && i != only) continue;
            const size_t p = static_cast<size_t>(pixels[i].first.y) * w + pixels[i].first.x;
            for (int c = 0; c < 3; ++c) xyz[3 * p + c] = static_cast<float>(pixels[i].second[c]);
        }
        return xyz;
    };
    auto direction = [&](const glm::dvec2& px) {
        const glm::dvec2 field = map.fieldDeg(px);
        return directionFromFieldDeg(field.x, field.y);
    };
    glm::dvec2 centroid{0.0};
    double sumY = 0.0;
    for (const auto& [px, xyz] : pixels) centroid += xyz.y * (glm::dvec2(px) + 0.5), sumY += xyz.y;
    const glm::dvec3 centre = direction(centroid / sumY);
    StarburstOptions options;
    options.maxCropRadiusPx = 64;
    const std::vector<float> all = image(pixels.size());
    const StarburstImage region = renderStarburst(lens, all, w, h, {{"region", centre, spectrum}}, options);
    std::vector<StarburstLight> perPixel;
    for (size_t i = 0; i < pixels.size(); ++i)
        perPixel.push_back({"pixel" + std::to_string(i), direction(glm::dvec2(pixels[i].first) + 0.5), spectrum});
    const StarburstImage separate = renderStarburst(lens, all, w, h, perPixel, options);
    for (const StarburstLightReport& r : separate.lights) ASSERT_TRUE(r.diffracted) << r.name << ": " << r.why;
    ASSERT_TRUE(region.lights[0].diffracted) << region.lights[0].why;
    // The PSF's change across the region: the edge pixel (index 0, 20 px out) by the centre's PSF
    // and by its own.
    const std::vector<float> edge = image(0);
    const StarburstImage edgeByCentre = renderStarburst(lens, edge, w, h, {{"edge", centre, spectrum}}, options);
    const StarburstImage edgeByOwn = renderStarburst(lens, edge, w, h, {{"edge", perPixel[0].direction, spectrum}}, options);
    // Compared where the diffraction moved light: the starburst less the pixels themselves.
    auto spread = [](std::vector<float> s, const std::vector<float>& direct) {
        for (size_t i = 0; i < s.size(); ++i) s[i] -= direct[i];
        return s;
    };
    const double psfChange = relativeL2(spread(edgeByCentre.xyz, edge), spread(edgeByOwn.xyz, edge));
    const double difference = relativeL2(spread(region.xyz, all), spread(separate.xyz, all));
    EXPECT_GT(psfChange, 0.0);
    EXPECT_LT(difference, 2.0 * psfChange + 0.02) << "PSF change across the region " << psfChange;
    std::printf("region starburst vs per-pixel: %.4f; the PSF's change across the region %.4f\n", difference, psfChange);
    // Energy: the same light diffracted (less what leaves the frame), to the float sums' rounding.
    double a = 0.0, b = 0.0;
    for (size_t i = 1; i < all.size(); i += 3) a += region.xyz[i], b += separate.xyz[i];
    EXPECT_NEAR(a, b, 2e-3 * b);
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
    refuse(R"({ "type": "region", "points": [[0, 0, 1], [25, 0, 1]] })", "a region light spans at most 3");
    refuse(R"({ "type": "region", "points": [[0, 0, 1, 2]], "colours": [[1, 1, 1]] })", "points[0][3]");
    refuse(R"({ "type": "region", "points": [[0, 0, 1, 0]] })", "has no \"colours\"");
    refuse(R"({ "type": "region", "points": [[0, 0, 0]] })", "points[0][2]");
}

}  // namespace
}  // namespace flare
