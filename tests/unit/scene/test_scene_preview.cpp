// The preview is the final render's first passes without photons: its ghost layer is the beams the
// render draws (the same plan, seed and sequences), and it converges to the render's ghost image
// as its passes grow; a preview that treated the sun as a point would not.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "flare/render/Render.h"
#include "flare/scene/Scene.h"
#include "flare/scene/ScenePreview.h"
#include "flare/scene/SceneRender.h"
#include "flare/scene/SceneStarburst.h"
#include "RenderTestUtil.h"

namespace flare {
namespace {

Scene doubletSunScene(double angularDiameterDeg) {
    const std::string lens = test::writeUncoatedDoublet("flare_scene_preview_test");
    const std::string text = R"({
  "lens": ")" + lens + R"(",
  "sensor": { "resolution": [240, 160] },
  "lights": [ { "type": "directional", "field_deg": [4.0, 2.5], "angular_diameter_deg": )" +
                             std::to_string(angularDiameterDeg) + R"(, "spectrum": { "blackbody_k": 5778 } } ],
  "render": { "diffraction": false, "beams_per_pass": 256, "seed": 9 }
})";
    return parseSceneText(text, "doublet.json", "");
}

double relativeL2(const std::vector<float>& a, const std::vector<float>& reference) {
    double difference = 0.0, norm = 0.0;
    for (size_t i = 0; i < a.size(); ++i) {
        difference += (static_cast<double>(a[i]) - reference[i]) * (static_cast<double>(a[i]) - reference[i]);
        norm += static_cast<double>(reference[i]) * reference[i];
    }
    return std::sqrt(difference / norm);
}

// The render's beams do not depend on its photons, and the preview's ghost layer is those beams.
TEST(ScenePreview, GhostLayerIsTheRendersBeams) {
    const Scene scene = doubletSunScene(0.53);
    const LensSystem lens = buildSceneLens(scene);
    RenderOptions withPhotons = sceneRenderOptions(scene, lens, {});
    withPhotons.beamVarianceProbes = 0;  // the preview's shares: each light's central probes (ScenePreview.cpp)
    RenderOptions beamsOnly = withPhotons;
    beamsOnly.tracePhotons = false;
    Renderer full(lens, scene.lights, withPhotons), beams(lens, scene.lights, beamsOnly);
    for (int pass = 0; pass < 3; ++pass) full.runPass(), beams.runPass();
    int beamPaths = 0;
    for (size_t t = 0; t < full.tallies().size(); ++t) {
        const PathTally &a = full.tallies()[t], &b = beams.tallies()[t];
        ASSERT_EQ(a.path, b.path);
        if (a.strategy != PathStrategy::Beams) continue;
        ++beamPaths;
        EXPECT_EQ(a.replicateSums, b.replicateSums) << a.path.label();
    }
    EXPECT_GE(beamPaths, 8);
    EXPECT_EQ(full.statistics().beams, beams.statistics().beams);
    EXPECT_EQ(beams.statistics().photons, 0);

    PreviewBudget budget;
    budget.passes = 3;
    budget.beamsPerPass = withPhotons.beamsPerPass;
    const ScenePreview preview = previewScene(scene, lens, false, budget);
    EXPECT_EQ(preview.passes, 3);
    EXPECT_EQ(preview.ghosts, beams.layerXyz(kLayerGhost));
    // Its film keeps only the ghost group's sums (RenderOptions::ghostGroupsOnly): the same
    // estimate, to the bit, as a film with every group; the groups it leaves out are refused.
    ASSERT_GT(beams.estimatedRelativeError(kGroupGhost), 0.0);
    EXPECT_EQ(preview.ghostEstimatedError, beams.estimatedRelativeError(kGroupGhost));
    RenderOptions ghostGroups = beamsOnly;
    ghostGroups.ghostGroupsOnly = true;
    Renderer lean(lens, scene.lights, ghostGroups);
    for (int pass = 0; pass < 3; ++pass) lean.runPass();
    EXPECT_EQ(lean.layerXyz(kLayerGhost), beams.layerXyz(kLayerGhost));
    EXPECT_EQ(lean.estimatedRelativeError(kGroupGhost), beams.estimatedRelativeError(kGroupGhost));
    EXPECT_THROW(lean.estimatedRelativeError(kGroupTotal), std::logic_error);
    EXPECT_THROW(lean.estimatedRelativeError(kGroupFlare), std::logic_error);

    // The default budget: two passes of half the render's beams (one render pass in all).
    RenderOptions half = beamsOnly;
    half.beamsPerPass = withPhotons.beamsPerPass / 2;
    Renderer halfBeams(lens, scene.lights, half);
    for (int pass = 0; pass < PreviewBudget::kDefaultPasses; ++pass) halfBeams.runPass();
    const ScenePreview byDefault = previewScene(scene, lens, false, {});
    EXPECT_EQ(byDefault.passes, 2);
    EXPECT_EQ(byDefault.beams, halfBeams.statistics().beams);
    EXPECT_EQ(byDefault.ghosts, halfBeams.layerXyz(kLayerGhost));
}

// Against a long render of the beams (the converged ghost image of the 0.53° sun): the preview's
// error falls as its passes grow and stays within a few times its own estimate; a preview of a
// point-like sun (angular diameter 0: hard ghost edges) is farther from the reference than that.
TEST(ScenePreview, ConvergesToTheRendersGhostImageAndIntegratesTheSunsDisk) {
    const Scene sun = doubletSunScene(0.53), point = doubletSunScene(0.0);
    const LensSystem lens = buildSceneLens(sun);
    RenderOptions referenceOptions = sceneRenderOptions(sun, lens, {});
    referenceOptions.tracePhotons = false;
    referenceOptions.seed = 1234;  // independent of the previews' beams
    Renderer reference(lens, sun.lights, referenceOptions);
    for (int pass = 0; pass < 24; ++pass) reference.runPass();
    const std::vector<float> truth = reference.layerXyz(kLayerGhost);
    const double referenceError = reference.estimatedRelativeError(kGroupGhost);

    PreviewBudget few, many;
    few.passes = 2;
    many.passes = 8;
    few.beamsPerPass = many.beamsPerPass = referenceOptions.beamsPerPass;  // the render's passes
    const ScenePreview a = previewScene(sun, lens, false, few), b = previewScene(sun, lens, false, many);
    const double errorFew = relativeL2(a.ghosts, truth), errorMany = relativeL2(b.ghosts, truth);
    EXPECT_LT(errorMany, errorFew);
    ASSERT_GT(b.ghostEstimatedError, 0.0);
    const double bound = 3.0 * std::hypot(b.ghostEstimatedError, referenceError);
    EXPECT_LT(errorMany, bound) << "estimated " << b.ghostEstimatedError << ", reference " << referenceError;
    const ScenePreview p = previewScene(point, lens, false, many);
    EXPECT_GT(relativeL2(p.ghosts, truth), bound) << "a point-like sun's preview passed for the sun's";
}

// The light's own image and its starburst are computed beside the beams' passes (ScenePreview.cpp):
// they are the images the mesh preview and the starburst give on their own, after the passes, and
// every layer is the same bits with one thread as with two.
TEST(ScenePreview, DirectImageAndStarburstBesideThePassesAreTheSequentialOnes) {
    Scene scene = doubletSunScene(0.53);
    scene.render.diffraction = true;
    const LensSystem lens = buildSceneLens(scene);
    RenderOptions options = sceneRenderOptions(scene, lens, {});
    options.tracePhotons = false;
    const Renderer renderer(lens, scene.lights, options);
    GhostReport report = renderer.ghostReport(0);
    for (GhostEstimate& g : report.ghosts) g.pruned = true;
    PreviewOptions directOptions;
    directOptions.widthPx = options.film.widthPx;
    directOptions.heightPx = options.film.heightPx;
    const std::vector<float> direct =
        renderPreview(lens, previewLight(scene.lights[0], scene.render.previewWavelengths), report, directOptions).direct.xyz;
    const StarburstImage starburst = sceneStarburst(scene, lens, direct, options.film.widthPx, options.film.heightPx);

    std::vector<float> ghosts;
    for (int threads : {1, 2}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        const ScenePreview preview = previewScene(scene, lens, false, {});
        EXPECT_EQ(preview.direct, direct) << threads << " thread(s)";
        ASSERT_TRUE(preview.starburst.has_value());
        EXPECT_EQ(preview.starburst->xyz, starburst.xyz) << threads << " thread(s)";
        if (ghosts.empty()) ghosts = preview.ghosts;
        EXPECT_EQ(preview.ghosts, ghosts) << threads << " thread(s)";
    }
    EXPECT_FALSE(ghosts.empty());
}

}  // namespace
}  // namespace flare
