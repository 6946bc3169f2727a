// Per-ghost layers over their footprints (issue 28): each ghost's layer holds the bounding box of
// the pixels it reaches, their sum is the ghost layer, the film's memory for them follows the
// footprints, and --layers top:N / share:F keep the strongest ghosts, the rest in ghost_other.
#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/film/LayerSelection.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"
#include "flare/scene/ScenePreview.h"
#include "flare/scene/SceneRender.h"

namespace flare {
namespace {

constexpr int kWidthPx = 240, kHeightPx = 160;
constexpr int kTilePx = 32;  // the film's tiles (FilmTiles.h)

// The double Gauss stopped down to f/8 with the sun off axis: dozens of ghosts, each covering a part
// of the frame (at full aperture most of them cover nearly all of it).
Scene doubleGaussScene() {
    return parseSceneText(R"({
  "lens": ")" + test::sourcePath("lenses/double-gauss-50mm.lens") + R"(",
  "f_number": 8.0,
  "sensor": { "resolution": [240, 160] },
  "lights": [ { "type": "directional", "field_deg": [6.0, 4.0], "angular_diameter_deg": 0.53,
                "spectrum": { "blackbody_k": 5778 } } ],
  "render": { "diffraction": false, "seed": 3 }
})",
                          "double-gauss.json", "");
}

std::unique_ptr<Renderer> beamsRenderer(const Scene& scene, const LensSystem& lens, const LayerSelection& selection,
                                        int passes) {
    SceneRenderOverrides overrides;
    overrides.perGhostLayers = true;
    overrides.ghostLayers = selection;
    RenderOptions options = sceneRenderOptions(scene, lens, overrides);
    options.tracePhotons = false;  // the preview's passes: the beams alone
    auto renderer = std::make_unique<Renderer>(lens, scene.lights, options);
    for (int pass = 0; pass < passes; ++pass) renderer->runPass();
    return renderer;
}

std::vector<int> perGhostLayers(const Renderer& renderer) {
    std::vector<int> layers;
    for (int l = kFixedLayerCount; l < static_cast<int>(renderer.layerNames().size()); ++l)
        if (renderer.layerNames()[l].starts_with("ghost_")) layers.push_back(l);
    return layers;
}

// The preview's per-ghost layers: each over the bounding box of its lit pixels, and together the
// ghost layer (every kept ghost here is an order-2 one) to float rounding.
TEST(GhostLayers, PreviewFootprintsAreTightAndAddUpToTheGhostLayer) {
    // Geometric rims: the rounding bound below takes each layer's pixel as a sum of non-negative
    // beams, which ringing's signed excess (negative just inside a rim) is not.
    Scene scene = doubleGaussScene();
    scene.render.ghostRinging = false;
    const LensSystem lens = buildSceneLens(scene);
    PreviewBudget budget;
    budget.passes = 3;
    budget.beamsPerPass = sceneRenderOptions(scene, lens, {}).beamsPerPass;  // the render's passes
    ScenePreview preview = previewScene(scene, lens, true, budget);
    const std::vector<ImageLayer> layers = previewLayers(preview, true);
    const auto ghost = std::find_if(layers.begin(), layers.end(), [](const ImageLayer& l) { return l.name == "ghost"; });
    ASSERT_NE(ghost, layers.end());
    std::vector<double> sum(ghost->rgb.size(), 0.0), magnitude(ghost->rgb.size(), 0.0);
    int perGhost = 0;
    size_t windowPixels = 0;
    for (const ImageLayer& layer : layers) {
        if (!layer.name.starts_with("ghost_")) continue;
        ++perGhost;
        windowPixels += static_cast<size_t>(layer.width) * layer.height;
        ASSERT_GE(layer.x, 0);
        ASSERT_GE(layer.y, 0);
        ASSERT_LE(layer.x + layer.width, kWidthPx);
        ASSERT_LE(layer.y + layer.height, kHeightPx);
        // Tight: a lit pixel on every edge of the window.
        auto lit = [&](int x, int y) {
            const float* p = &layer.rgb[(static_cast<size_t>(y) * layer.width + x) * 3];
            return p[0] != 0.0f || p[1] != 0.0f || p[2] != 0.0f;
        };
        bool top = false, bottom = false, left = false, right = false;
        for (int x = 0; x < layer.width; ++x) top = top || lit(x, 0), bottom = bottom || lit(x, layer.height - 1);
        for (int y = 0; y < layer.height; ++y) left = left || lit(0, y), right = right || lit(layer.width - 1, y);
        EXPECT_TRUE(top && bottom && left && right) << layer.name;
        for (int y = 0; y < layer.height; ++y)
            for (int x = 0; x < layer.width; ++x)
                for (int c = 0; c < 3; ++c) {
                    const size_t frame = (static_cast<size_t>(y + layer.y) * kWidthPx + (x + layer.x)) * 3 + c;
                    const float v = layer.rgb[(static_cast<size_t>(y) * layer.width + x) * 3 + c];
                    sum[frame] += v;
                    magnitude[frame] += std::abs(v);
                }
    }
    EXPECT_GE(perGhost, 20);
    EXPECT_LT(windowPixels, static_cast<size_t>(perGhost) * kWidthPx * kHeightPx / 2) << "footprints, not frames";
    // Each layer's pixel: a float sum over the passes (one rounding, 2⁻²⁴ relative, per pass), then
    // float irradiance XYZ and float RGB (two more), where RGB mixes XYZ with weights of at most 3.3
    // in magnitude (at most 5.3 per row): per pixel and layer within (passes + 2) · 2⁻²⁴ · 5.3 of
    // the layer's magnitude summed over its XYZ channels, bounded here by 3 × its largest RGB...
    // taken generously as 6 × its RGB magnitude; the ghost layer's own float rounding adds 2⁻²⁴.
    const double unit = std::ldexp(1.0, -24);
    double largest = 0.0;
    for (size_t i = 0; i < sum.size(); ++i) {
        const double tolerance = (budget.passes + 2) * unit * 6.0 * 5.3 * magnitude[i] + unit * std::abs(ghost->rgb[i]);
        ASSERT_LE(std::abs(sum[i] - ghost->rgb[i]), tolerance) << "pixel value " << i;
        largest = std::max(largest, std::abs(sum[i]));
    }
    EXPECT_GT(largest, 0.0);
}

// The film holds a per-ghost layer in single-precision tiles where its ghost's light landed: its
// bytes are those of the tiles its footprint covers at most, in proportion to the footprints and
// not to the number of ghosts times the frame.
TEST(GhostLayers, FilmMemoryFollowsTheFootprints) {
    const Scene scene = doubleGaussScene();
    const LensSystem lens = buildSceneLens(scene);
    const auto renderer = beamsRenderer(scene, lens, {}, 2);
    const std::vector<int> layers = perGhostLayers(*renderer);
    ASSERT_GE(layers.size(), 20u);
    const size_t tileBytes = static_cast<size_t>(kTilePx) * kTilePx * 3 * sizeof(float);
    size_t bytes = 0, footprintTiles = 0;
    for (int l : layers) {
        EXPECT_TRUE(renderer->film().layerSinglePrecision(l));
        const FilmWindow window = renderer->layerXyzFootprint(l);
        size_t tiles = 0;
        if (!window.empty()) {
            const int columns = (window.x + window.width - 1) / kTilePx - window.x / kTilePx + 1;
            const int rows = (window.y + window.height - 1) / kTilePx - window.y / kTilePx + 1;
            tiles = static_cast<size_t>(columns) * rows;
        }
        EXPECT_LE(renderer->film().layerBytes(l), tiles * tileBytes) << renderer->layerNames()[l];
        bytes += renderer->film().layerBytes(l);
        footprintTiles += tiles;
    }
    const size_t frameTiles = static_cast<size_t>((kWidthPx + kTilePx - 1) / kTilePx) * ((kHeightPx + kTilePx - 1) / kTilePx);
    EXPECT_LE(bytes, footprintTiles * tileBytes);
    EXPECT_LT(footprintTiles, layers.size() * frameTiles / 2);  // this scene's ghosts cover much less than a frame each
    // The fixed layers stay double.
    EXPECT_FALSE(renderer->film().layerSinglePrecision(kLayerGhost));
}

// top:N keeps the N ghosts of largest planned power (PathTally::plannedPowerFraction), share:F the
// fewest strongest that hold F of it; the kept layers are the same beams as with every layer, and
// ghost_other is the sum of the others.
TEST(GhostLayers, TopAndShareKeepTheStrongestAndTheRestIsGhostOther) {
    const Scene scene = doubleGaussScene();
    const LensSystem lens = buildSceneLens(scene);
    const auto every = beamsRenderer(scene, lens, {}, 2);
    // The planned powers by label (one light), strongest first (ties by name).
    std::vector<std::pair<double, std::string>> ranked;
    for (const PathTally& t : every->tallies())
        if (t.kind == PathTally::Kind::Ghost && every->film().layerCount() > 0 &&
            std::find(every->layerNames().begin(), every->layerNames().end(), t.path.label()) != every->layerNames().end())
            ranked.push_back({t.plannedPowerFraction, t.path.label()});
    ASSERT_EQ(ranked.size(), perGhostLayers(*every).size());
    std::sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) { return a.first != b.first ? a.first > b.first : a.second < b.second; });
    double total = 0.0;
    for (const auto& r : ranked) total += r.first;
    ASSERT_GT(total, 0.0);
    std::map<std::string, std::vector<float>> everyLayer;
    for (int l : perGhostLayers(*every)) everyLayer[every->layerNames()[l]] = every->layerXyz(l);

    auto check = [&](const LayerSelection& selection, size_t expectedKept) {
        SCOPED_TRACE(selection.text());
        const auto some = beamsRenderer(scene, lens, selection, 2);
        EXPECT_EQ(some->layerXyz(kLayerGhost), every->layerXyz(kLayerGhost));  // the same beams
        std::vector<std::string> kept;
        std::vector<float> other;
        for (int l : perGhostLayers(*some)) {
            const std::string& name = some->layerNames()[l];
            if (name == kOtherGhostsLayer) other = some->layerXyz(l);
            else kept.push_back(name);
        }
        ASSERT_EQ(kept.size(), expectedKept);
        for (size_t k = 0; k < expectedKept; ++k) {
            EXPECT_NE(std::find(kept.begin(), kept.end(), ranked[k].second), kept.end()) << ranked[k].second;
            const auto it = std::find(some->layerNames().begin(), some->layerNames().end(), ranked[k].second);
            EXPECT_EQ(some->layerXyz(static_cast<int>(it - some->layerNames().begin())), everyLayer[ranked[k].second]);
        }
        ASSERT_EQ(other.empty(), expectedKept == ranked.size());
        if (other.empty()) return;
        // ghost_other: the left-out ghosts' beams accumulated in one float layer, against their own
        // layers summed in double: per value within a float rounding per pass and layer.
        std::vector<double> rest(other.size(), 0.0), magnitude(other.size(), 0.0);
        for (size_t k = expectedKept; k < ranked.size(); ++k) {
            const std::vector<float>& layer = everyLayer[ranked[k].second];
            for (size_t i = 0; i < layer.size(); ++i) rest[i] += layer[i], magnitude[i] += std::abs(layer[i]);
        }
        const double unit = std::ldexp(1.0, -24);
        for (size_t i = 0; i < other.size(); ++i)
            ASSERT_LE(std::abs(other[i] - rest[i]), 4 * unit * magnitude[i] * static_cast<double>(ranked.size()))
                << "value " << i;
    };
    check(LayerSelection::parse("top:4"), 4);
    check(LayerSelection::parse("top:1000"), ranked.size());
    // share:F: the fewest strongest whose planned powers reach F of the total.
    for (double share : {0.5, 0.9}) {
        size_t kept = 0;
        double held = 0.0;
        while (held < share * total) held += ranked[kept++].first;
        EXPECT_LT(kept, ranked.size());
        LayerSelection selection;
        selection.rule = LayerSelection::Rule::Share;
        selection.share = share;
        check(selection, kept);
    }
}

}  // namespace
}  // namespace flare
