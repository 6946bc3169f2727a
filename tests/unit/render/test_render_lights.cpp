// Beams for every kind of light. A point or disk light's ghosts are rendered by beams whose rays
// fan from the light (PupilGrid::forPoint), each vertex weighted by the point's inverse square and
// obliquity; they must agree with guided photons (an independent estimator of the same paths,
// traced from the light photon by photon) per ghost, per layer and block by block, for a point
// light near the lens, one inside the lens's front focal distance, and a disk light, with the
// uncoated doublet's order-4 chains guided too; a beam power off by 2 % must fail the comparison.
// A point light very far away must give the image a directional light of the same irradiance
// gives.
#include <algorithm>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <boost/math/distributions/students_t.hpp>
#include <gtest/gtest.h>

#include "flare/core/Error.h"
#include "flare/optics/PupilGrid.h"
#include "flare/optics/RealRays.h"
#include "flare/photons/Light.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"
#include "flare/scene/SceneRender.h"
#include "RenderTestUtil.h"

namespace flare {
namespace {

Scene doubletScene(const std::string& lightJson) {
    const std::string lens = test::writeUncoatedDoublet("flare_render_lights_test");
    const std::string text = R"({
  "lens": ")" + lens + R"(",
  "sensor": { "resolution": [150, 100] },
  "lights": [ )" + lightJson + R"( ]
})";
    return parseSceneText(text, "doublet.json", "");
}

RenderOptions optionsFor(const Scene& scene, const LensSystem& lens, RenderOptions::Mode mode) {
    RenderOptions o = test::sceneRenderOptions(scene, lens, mode, 23);
    o.beamsPerPass = 128;
    return o;
}

constexpr int kReplicates = 8;

// Per-path and per-layer powers of a beams render against a guided-photons render, as |difference|
// over the standard error of the difference. The beams' standard errors come from the spread of
// kReplicates replicates (kReplicates − 1 degrees of freedom), which dominates: the critical
// value is Student's t with that many degrees of freedom, Bonferroni-corrected (a normal z would
// reject a correct render now and then: a path drawn less than once a pass has heavy-tailed
// replicate sums).
struct Comparison {
    std::vector<std::string> what;
    std::vector<double> score;
    int beamPaths = 0;
    // The order-2 beam paths' summed power (beams, photons) and its standard errors: the most
    // precise check of the beams' scale.
    double beamsW = 0.0, photonsW = 0.0, beamsVar = 0.0, photonsVar = 0.0;
};

Comparison compare(const Renderer& beams, const Renderer& photons) {
    Comparison c;
    auto add = [&](const std::string& what, const PathTally& a, const PathTally& b) {
        const double pa = beams.tallyPowerW(a), pb = photons.tallyPowerW(b);
        if (pa == 0.0 && pb == 0.0) return;
        const double sa = beams.tallyStandardErrorW(a), sb = photons.tallyStandardErrorW(b);
        EXPECT_GT(std::hypot(sa, sb), 0.0) << what;
        char line[200];
        std::snprintf(line, sizeof line, "%s: %.6g ± %.2g against %.6g ± %.2g", what.c_str(), pa, sa, pb, sb);
        c.what.push_back(line);
        c.score.push_back(std::abs(pa - pb) / std::hypot(sa, sb));
    };
    for (const PathTally& t : beams.tallies()) {
        if (t.kind != PathTally::Kind::Ghost || t.strategy != PathStrategy::Beams) continue;
        ++c.beamPaths;
        // The order-4 chains share a floor of the beams: compared as the `higher` layer.
        if (t.path.reflections.size() != 2) continue;
        for (const PathTally& u : photons.tallies())
            if (u.kind == t.kind && u.light == t.light && u.path == t.path) {
                add(t.path.label(), t, u);
                c.beamsW += beams.tallyPowerW(t);
                c.photonsW += photons.tallyPowerW(u);
                c.beamsVar += std::pow(beams.tallyStandardErrorW(t), 2);
                c.photonsVar += std::pow(photons.tallyStandardErrorW(u), 2);
            }
    }
    for (int l : {kLayerDirect, kLayerGhost, kLayerHigher})
        add(std::string("layer ") + renderLayerName(l), beams.layerTallies()[l], photons.layerTallies()[l]);
    return c;
}

double criticalT(int comparisons) {
    return boost::math::quantile(boost::math::complement(boost::math::students_t(kReplicates - 1), 0.5e-3 / comparisons));
}

// `detectableBias`: beams that much too bright must fail the comparison (it is 2 % where the
// beams' replicates are precise enough for it in this time, more for the lights whose beams vary
// more).
void expectBeamsAgreeWithPhotons(const std::string& lightJson, int minBeamPaths, double detectableBias) {
    const Scene scene = doubletScene(lightJson);
    const LensSystem lens = buildSceneLens(scene);
    RenderOptions beamOptions = optionsFor(scene, lens, RenderOptions::Mode::Guided);
    beamOptions.beamReplicates = kReplicates;
    Renderer beams(lens, scene.lights, beamOptions);
    ASSERT_FALSE(beams.lights().front().skipped) << beams.lights().front().skipReason;
    ASSERT_TRUE(beams.lights().front().higherOrderGuided);  // uncoated: the order-4 chains are guided
    Renderer photons(lens, scene.lights, optionsFor(scene, lens, RenderOptions::Mode::GuidedPhotons));
    for (int pass = 0; pass < 6 * kReplicates; ++pass) beams.runPass();
    for (int pass = 0; pass < 160; ++pass) photons.runPass();

    const Comparison c = compare(beams, photons);
    EXPECT_GE(c.beamPaths, minBeamPaths);
    const double t = criticalT(static_cast<int>(c.score.size()) + 1);
    for (size_t i = 0; i < c.score.size(); ++i) EXPECT_LT(c.score[i], t) << c.what[i];
    // The beam paths' summed power, and the same for beams too bright by detectableBias (what a
    // render whose every beam carried that much more power would report: with the same seed it
    // draws the same beams, so its powers and standard errors are these times 1 + bias).
    auto score = [&](double scale) {
        return std::abs(scale * c.beamsW - c.photonsW) / std::sqrt(scale * scale * c.beamsVar + c.photonsVar);
    };
    EXPECT_LT(score(1.0), t) << "beam paths: " << c.beamsW << " against " << c.photonsW;
    EXPECT_GT(score(1.0 + detectableBias), t) << "beams too bright went unnoticed: " << c.beamsW << " ± " << std::sqrt(c.beamsVar)
                              << " against " << c.photonsW << " ± " << std::sqrt(c.photonsVar);
}

TEST(RenderLights, PointLightNearTheLensBeamsAgreeWithGuidedPhotons) {
    expectBeamsAgreeWithPhotons(
        R"({ "type": "point", "position_mm": [40, 25, -400], "spectrum": { "blackbody_k": 3000 }, "power": 1 })", 8, 0.02);
}

// 40 mm in front of a 50 mm lens: inside its front focal distance, so the light's direct image is
// virtual (the rays leave the lens diverging) while the ghosts still land.
TEST(RenderLights, PointLightInsideTheFrontFocalDistanceBeamsAgreeWithGuidedPhotons) {
    expectBeamsAgreeWithPhotons(
        R"({ "type": "point", "position_mm": [3, 2, -40], "spectrum": { "blackbody_k": 3000 }, "power": 1 })", 8, 0.04);
}

TEST(RenderLights, DiskLightBeamsAgreeWithGuidedPhotons) {
    expectBeamsAgreeWithPhotons(
        R"({ "type": "disk", "position_mm": [60, -30, -900], "radius_mm": 30, "spectrum": "d65", "power": 1 })", 8, 0.05);
}

// A point light 10⁶ m away along a directional light's direction, with the intensity that gives
// its irradiance (I = E D²): the same beams (the same seed draws the same samples), so the same
// ghost image and powers, within half the beams' estimated error (a fifth, measured). They differ by the fan's 1e-8
// rad, by a window 2.5e-9 wider (which moves the analysis's lattice and so the meshes: a few 1e-6
// of a path's power, the meshes' own error) and by the unguided photons' few roulette decisions
// the far origin changes.
TEST(RenderLights, FarPointLightGivesTheDirectionalLightsImage) {
    const Scene sun = doubletScene(R"({ "type": "directional", "field_deg": [4.0, 2.5], "angular_diameter_deg": 0,
                                       "spectrum": { "blackbody_k": 5778 }, "power": 1 })");
    const LensSystem lens = buildSceneLens(sun);
    std::vector<LightSpec> far = sun.lights;
    const double distanceMm = 1e9;
    far[0].type = LightSpec::Type::Point;
    far[0].positionMm = -distanceMm * sun.lights[0].travelDirection();
    far[0].power = sun.lights[0].power * distanceMm * distanceMm / 1e6;  // W/sr from W/m² at D (mm)
    const RenderOptions options = optionsFor(sun, lens, RenderOptions::Mode::Guided);
    Renderer a(lens, sun.lights, options), b(lens, far, options);
    for (int pass = 0; pass < 8; ++pass) a.runPass(), b.runPass();
    ASSERT_EQ(a.lights()[0].beamGhosts, b.lights()[0].beamGhosts);
    ASSERT_GT(b.lights()[0].beamGhosts, 5);
    for (int l : {kLayerGhost, kLayerHigher}) {
        const std::vector<float> x = a.layerXyz(l), y = b.layerXyz(l);
        double difference = 0.0, norm = 0.0;
        for (size_t i = 0; i < x.size(); ++i) {
            difference += (static_cast<double>(x[i]) - y[i]) * (static_cast<double>(x[i]) - y[i]);
            norm += static_cast<double>(x[i]) * x[i];
        }
        ASSERT_GT(norm, 0.0);
        const double estimated = a.estimatedRelativeError(l == kLayerGhost ? kGroupGhost : kGroupHigher);
        EXPECT_LT(std::sqrt(difference / norm), 0.5 * estimated) << renderLayerName(l);
    }
    for (size_t t = 0; t < a.tallies().size(); ++t) {
        const PathTally &x = a.tallies()[t], &y = b.tallies()[t];
        ASSERT_EQ(x.path, y.path);
        ASSERT_EQ(x.strategy, y.strategy) << x.path.label();
        if (x.strategy != PathStrategy::Beams) continue;
        EXPECT_NEAR(a.tallyPowerW(x), b.tallyPowerW(y), 1e-4 * a.tallyPowerW(x)) << x.path.label();
    }
}

// Rays fan from the point through their plane points, start in front of the lens, and cover its
// whole front aperture; a far point's rays are the directional light's.
TEST(RenderLights, PointGridRaysFanFromTheSource) {
    const Scene scene = doubletScene(R"({ "type": "point", "position_mm": [40, 25, -400] })");
    const LensSystem lens = buildSceneLens(scene);
    const glm::dvec3 source(40.0, 25.0, -400.0);
    const PupilGrid grid = PupilGrid::forPoint(lens, source);
    for (double a : {-grid.halfSizeMm, 0.0, 0.7 * grid.halfSizeMm})
        for (double b : {-0.3 * grid.halfSizeMm, grid.halfSizeMm}) {
            const Ray r = grid.ray(a, b);
            const glm::dvec3 onPlane = grid.centreMm + a * grid.e1 + b * grid.e2;
            EXPECT_LT(glm::length(glm::cross(r.direction, glm::normalize(onPlane - source))), 1e-12);
            EXPECT_LT(glm::length(glm::cross(r.direction, glm::normalize(r.originMm - source))), 1e-9);
            // In front of the lens's foremost point (1 mm ahead of it), or at the source.
            EXPECT_LE(r.originMm.z, objectSpaceStartZMm(lens) + 1e-9);
        }
    // Every ray that enters the front aperture crosses the plane inside the window: the entering
    // area counted on the window equals the aperture's solid angle seen from the source, projected.
    const double area = grid.enteringAreaMm2(lens, 512);
    const double r0 = lens.surface(0).semiApertureMm;
    EXPECT_GT(area, 0.9 * std::numbers::pi * r0 * r0);
    const PupilGrid wider = [&] {
        PupilGrid g = grid;
        g.halfSizeMm *= 1.5;
        return g;
    }();
    EXPECT_NEAR(wider.enteringAreaMm2(lens, 768), area, 0.01 * area);

    const glm::dvec3 direction = glm::normalize(glm::dvec3(0.1, -0.05, 1.0));
    const PupilGrid parallel = PupilGrid::forDirection(lens, direction);
    const PupilGrid far = PupilGrid::forPoint(lens, -1e9 * direction);
    const Ray p = parallel.ray(3.0, -2.0), q = far.ray(3.0, -2.0);
    EXPECT_LT(glm::length(p.direction - q.direction), 1e-8);
    // A source behind the front vertex is refused (a scene cannot place one there: buildSceneLens
    // checks the light against the lens's foremost point).
    EXPECT_THROW(PupilGrid::forPoint(lens, glm::dvec3(0.0, 0.0, 0.5)), std::invalid_argument);
}

// A point light between a concave front surface's rim and its vertex (z < 0, so the scene's own
// check passes) is refused once the lens is known, naming the scene file and the light's line.
TEST(RenderLights, LightWithinTheFrontSurfaceIsRefusedWithItsLine) {
    const auto dir = test::processTempDir("flare_render_lights_test");
    std::filesystem::create_directories(dir);
    const std::string lens = (dir / "concave.lens").string();
    std::ofstream(lens) << R"(name concave front
focal_length_mm 50
sensor width_mm=36 height_mm=24
surfaces
  -35.0    6.0    n=1.62     13
  -20.0    3.0    air        13
   stop    40     air        9
)";
    const std::string text = R"({
  "lens": ")" + lens + R"(",
  "sensor": { "resolution": [150, 100] },
  "lights": [
    { "type": "directional", "field_deg": [1, 1] },
    { "type": "point", "position_mm": [0, 0, -1] }
  ]
})";
    const Scene scene = parseSceneText(text, "concave.json", "");
    try {
        buildSceneLens(scene);
        FAIL() << "a light behind the front surface's rim was accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.line(), 6) << e.what();
        EXPECT_NE(std::string(e.what()).find("front surface"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace flare
