// Data set specs (DatasetSpec.h): the shipped examples parse; image k's scene is a function of
// the seed and k; what it draws lies in the spec's ranges, and lights are placed inside or outside
// the paraxial frame as drawn.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/optics/Paraxial.h"
#include "flare/scene/DatasetSpec.h"
#include "flare/scene/Scene.h"

namespace flare {
namespace {

TEST(DatasetSpec, TheExamplesParse) {
    for (const char* name : {"docs/examples/datasets/preview.json", "docs/examples/datasets/final.json"}) {
        const DatasetSpec spec = loadDatasetSpec(test::sourcePath(name));
        EXPECT_GT(spec.images, 0) << name;
        EXPECT_FALSE(spec.lenses.empty()) << name;
    }
}

TEST(DatasetSpec, ImagesAreDrawnFromTheSeedAndPlacedAsDrawn) {
    const DatasetSpec spec = parseDatasetSpec(R"({ "images": 40, "seed": 5,
        "lenses": ["double-gauss-50mm", "wide-angle-28mm"], "f_number": [4, 8],
        "lights": { "count": [1, 3], "kinds": ["directional", "point"], "outside_frame": 0.5,
                    "power": [0.5, 2], "distance_mm": [1000, 5000] },
        "resolution": [300, 200] })",
                                              "spec.json");
    EXPECT_EQ(datasetImage(spec, 7).scene, datasetImage(spec, 7).scene);
    EXPECT_NE(datasetImage(spec, 7).scene, datasetImage(spec, 8).scene);
    int inside = 0, outside = 0;
    for (int k = 0; k < spec.images; ++k) {
        const DatasetImage image = datasetImage(spec, k);
        // The drawn scene is a valid scene, at the drawn f-number (no lens here is slower than f/4).
        const Scene scene = parseSceneText(image.scene.dump(), "image.json", "");
        const LensSystem lens = buildSceneLens(scene);
        const double fNumber = image.scene["f_number"].get<double>();
        EXPECT_GE(fNumber, 4.0);
        EXPECT_LE(fNumber, 8.0);
        EXPECT_NEAR(analyseParaxial(lens, 587.56).fNumber, fNumber, 1e-3 * fNumber) << k;
        const double efl = analyseParaxial(lens, 587.56).eflMm;
        const double halfX = 0.5 * lens.sensor().widthMm / efl, halfY = halfX * 200.0 / 300.0;
        ASSERT_EQ(scene.lights.size(), image.drawn["lights"].size());
        EXPECT_GE(scene.lights.size(), 1u);
        EXPECT_LE(scene.lights.size(), 3u);
        for (size_t i = 0; i < scene.lights.size(); ++i) {
            const LightSpec& light = scene.lights[i];
            // Where the light appears: its rays' direction, as tangents of the field angles.
            const glm::dvec3 d = light.travelDirection();
            const double x = -d.x / d.z, y = -d.y / d.z;
            const bool inFrame = std::abs(x) <= halfX * (1 + 1e-9) && std::abs(y) <= halfY * (1 + 1e-9);
            EXPECT_EQ(inFrame, image.drawn["lights"][i]["in_frame"].get<bool>()) << k << " " << i;
            EXPECT_LE(std::abs(x), 2.0 * halfX * (1 + 1e-9));
            EXPECT_LE(std::abs(y), 2.0 * halfY * (1 + 1e-9));
            (inFrame ? inside : outside)++;
            if (light.type == LightSpec::Type::Point) {
                const double distance = std::sqrt(light.positionMm.x * light.positionMm.x +
                                                  light.positionMm.y * light.positionMm.y +
                                                  light.positionMm.z * light.positionMm.z);
                EXPECT_GE(distance, 1000.0 * (1 - 1e-12));
                EXPECT_LE(distance, 5000.0 * (1 + 1e-12));
            }
            EXPECT_GE(light.power, 0.5);
            EXPECT_LE(light.power, 2.0);
        }
    }
    // Half the lights outside, as drawn: with ~80 lights, a binomial count within 4σ of half.
    const double n = inside + outside;
    EXPECT_LT(std::abs(inside - 0.5 * n), 4.0 * std::sqrt(0.25 * n)) << inside << " inside of " << n;
}

}  // namespace
}  // namespace flare
