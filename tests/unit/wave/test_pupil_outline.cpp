// The pupil as the light sees it, traced, against the paraxial optics: on axis at f/8 (where
// pupil aberrations are small) its area is the entrance pupil's and the image moves by the focal
// length per radian; off axis the vignetting only takes area away.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include <glm/matrix.hpp>

#include "flare/optics/Paraxial.h"
#include "flare/scene/Scene.h"
#include "flare/wave/ApertureTransform.h"
#include "flare/wave/PupilOutline.h"

namespace flare {
namespace {

LensSystem doubleGaussAt(double fNumber) {
    const Scene scene = parseSceneText(R"({"lens": "double-gauss-50mm", "f_number": )" + std::to_string(fNumber) +
                                           R"(, "lights": [{"type": "directional", "field_deg": [0, 0]}]})",
                                       "pupil.json", ".");
    return buildSceneLens(scene);
}

TEST(PupilOutline, OnAxisItIsTheEntrancePupilAndTheImageMovesByTheFocalLength) {
    const LensSystem lens = doubleGaussAt(8.0);
    const ParaxialData paraxial = analyseParaxial(lens, 587.56);
    PupilOutlineOptions options;  // 1536 px across the 36 mm sensor
    const PupilOutline outline = tracePupilOutline(lens, {0.0, 0.0, 1.0}, options);
    ASSERT_TRUE(outline.found);
    const ApertureTransform aperture(outline.outlineMm);
    // The iris is a hexagon of the nominal circle's area (Iris.h): the entrance pupil's area.
    const double pupilArea = std::numbers::pi * std::pow(0.5 * paraxial.entrancePupilDiameterMm, 2);
    EXPECT_NEAR(aperture.areaMm2() / pupilArea, 1.0, 0.01);
    EXPECT_EQ(aperture.spikeEdges().size(), 6u);
    // The image of the axial beam sits at the frame's centre and moves by f per radian (mirrored:
    // the camera orientation), to the paraxial accuracy of a 10⁻⁵ rad tilt.
    EXPECT_NEAR(outline.imagePx.x, 768.0, 0.05);
    EXPECT_NEAR(outline.imagePx.y, 512.0, 0.05);
    const double pxPerRad = paraxial.eflMm / (36.0 / 1536.0);
    EXPECT_NEAR(std::abs(glm::determinant(outline.pxPerRad)) / (pxPerRad * pxPerRad), 1.0, 2e-3);
    EXPECT_NEAR(std::abs(outline.pxPerRad[0][0]) / pxPerRad, 1.0, 1e-3);
    EXPECT_NEAR(std::abs(outline.pxPerRad[0][1]) / pxPerRad, 0.0, 1e-3);
}

TEST(PupilOutline, OffAxisVignettingOnlyTakesAreaAway) {
    const LensSystem lens = doubleGaussAt(2.1);  // nearly wide open: the front and rear elements vignette
    PupilOutlineOptions options;
    const PupilOutline axial = tracePupilOutline(lens, {0.0, 0.0, 1.0}, options);
    const double field = 15.0 * std::numbers::pi / 180.0;
    const PupilOutline oblique = tracePupilOutline(lens, {std::sin(field), 0.0, std::cos(field)}, options);
    ASSERT_TRUE(axial.found && oblique.found);
    const double axialArea = ApertureTransform(axial.outlineMm).areaMm2();
    const double obliqueArea = ApertureTransform(oblique.outlineMm).areaMm2();
    // Seen obliquely a round pupil would shrink by cos θ; vignetting cuts further.
    EXPECT_LT(obliqueArea, std::cos(field) * axialArea);
    EXPECT_GT(obliqueArea, 0.2 * axialArea);
}

}  // namespace
}  // namespace flare
