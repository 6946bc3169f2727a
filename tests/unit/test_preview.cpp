// The deterministic preview against the sparse-trace estimates of the same ghosts, and its
// symmetry on axis.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/EmbeddedLenses.h"
#include "flare/LensFile.h"
#include "flare/Preview.h"

namespace flare {
namespace {

PreviewLight monochromatic(const glm::dvec3& direction) {
    PreviewLight light;
    light.direction = direction;
    light.spectrum = {SpectralSample{550.0, {0.0, 1.0, 0.0}}};
    return light;
}

// The double Gauss with a circular iris.
LensSystem circularDoubleGauss() {
    std::string text;
    for (const EmbeddedLens& l : embeddedLenses())
        if (std::string(l.name) == "double-gauss-50mm") text = l.text;
    const size_t at = text.find("iris ");
    text.replace(at, text.find('\n', at) - at, "iris blades=0");
    return LensSystem::build(parseLensText(text, "circular.lens"));
}

TEST(Preview, GhostPowerAgreesWithTheSparseTrace) {
    const LensSystem lens = test::loadLens("lenses/double-gauss-50mm.lens");
    GhostAnalysisOptions analysis;
    analysis.fineCells = 128;  // the reference: finer than the default report
    const glm::dvec3 direction = directionFromFieldDeg(10.0, 5.0);
    const GhostReport report = analyseGhosts(lens, direction, analysis);
    const PreviewLight light = monochromatic(direction);
    PreviewOptions options;
    options.perGhostLayers = true;
    const PreviewImage image = renderPreview(lens, light, report, options);
    size_t k = 0;
    int compared = 0;
    for (const GhostEstimate& g : report.ghosts) {
        if (g.pruned) continue;
        const double preview = layerPowerFraction(image, image.perGhost[k++], report, 1.0);
        // Both integrate the same smooth throughput over the same live pupil region; they differ
        // by how they resolve the region's edge. Ghosts whose footprint runs off the sensor edge are
        // included: both count only what lands on it.
        EXPECT_NEAR(preview / g.powerFraction, 1.0, 0.01) << g.path.label();
        ++compared;
    }
    EXPECT_GT(compared, 30);
    EXPECT_NEAR(layerPowerFraction(image, image.direct, report, 1.0) / report.direct.powerFraction, 1.0, 0.01);
}

TEST(Preview, OnAxisGhostsAreRotationallySymmetricWithACircularIris) {
    const LensSystem lens = circularDoubleGauss();
    const GhostReport report = analyseGhosts(lens, {0.0, 0.0, 1.0}, GhostAnalysisOptions{});
    PreviewOptions options;
    options.widthPx = 768;
    options.heightPx = 512;
    options.perGhostLayers = true;
    const PreviewImage image = renderPreview(lens, monochromatic({0.0, 0.0, 1.0}), report, options);
    const double cx = 0.5 * image.widthPx, cy = 0.5 * image.heightPx;
    size_t k = 0;
    int tested = 0;
    for (const GhostEstimate& g : report.ghosts) {
        if (g.pruned) continue;
        const XyzLayer& layer = image.perGhost[k++];
        // Only ghosts that lie wholly on the sensor can be symmetric in the picture.
        if (std::max(std::abs(g.footprintMinMm.y), std::abs(g.footprintMaxMm.y)) > 0.45 * lens.sensor().heightMm) continue;
        double m0 = 0, mx = 0, my = 0, mxx = 0, myy = 0, mxy = 0;
        for (int y = 0; y < image.heightPx; ++y)
            for (int x = 0; x < image.widthPx; ++x) {
                const double w = layer.xyz[(static_cast<size_t>(y) * image.widthPx + x) * 3 + 1];
                const double dx = x + 0.5 - cx, dy = y + 0.5 - cy;
                m0 += w, mx += w * dx, my += w * dy, mxx += w * dx * dx, myy += w * dy * dy, mxy += w * dx * dy;
            }
        ASSERT_GT(m0, 0.0) << g.path.label();
        const double spread = std::sqrt((mxx + myy) / m0);
        // A symmetric ghost has its centroid on the axis and equal second moments in x and y. The
        // square pupil grid and the pixel grid break the symmetry only at the scale of a grid cell's
        // image relative to the ghost (≲ 1 %) — far below what an asymmetry bug would give.
        EXPECT_LT(std::hypot(mx / m0, my / m0), 0.01 * spread + 0.5) << g.path.label();
        EXPECT_NEAR(mxx / myy, 1.0, 0.02) << g.path.label();
        EXPECT_LT(std::abs(mxy / m0), 0.01 * spread * spread + 0.25) << g.path.label();
        ++tested;
    }
    EXPECT_GE(tested, 8);  // on axis, 9 of the kept ghosts lie wholly on the 36 × 24 mm sensor
}

TEST(Preview, DeterministicAcrossRuns) {
    const LensSystem lens = test::loadLens("lenses/double-gauss-50mm.lens");
    const glm::dvec3 direction = directionFromFieldDeg(8.0, 3.0);
    const GhostReport report = analyseGhosts(lens, direction, GhostAnalysisOptions{});
    PreviewOptions options;
    options.widthPx = 384;
    options.heightPx = 256;
    const PreviewImage a = renderPreview(lens, monochromatic(direction), report, options);
    const PreviewImage b = renderPreview(lens, monochromatic(direction), report, options);
    EXPECT_EQ(a.ghosts.xyz, b.ghosts.xyz);
    EXPECT_EQ(a.direct.xyz, b.direct.xyz);
    for (float v : a.ghosts.xyz) ASSERT_TRUE(std::isfinite(v));
}

}  // namespace
}  // namespace flare
