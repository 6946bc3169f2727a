// Image comparison: the metrics on analytic cases (identical images, a reference scaled by 2, a
// hand-computed perturbation), the relMSE = relL2² identity, undefined metrics for a zero
// reference, the errors for mismatched sizes and non-finite pixels, and `flare compare` run as a
// subprocess (text and JSON output, --layer, exit code 2 for a missing layer, file or size match).
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "flare/core/Error.h"
#include "flare/film/ImageCompare.h"
#include "TestUtil.h"
#include "flare/film/ImageIO.h"

namespace flare {
namespace {

namespace fs = std::filesystem;

// The luminance weights of linear Rec.709 as printed in the standard (4 decimals). The engine
// uses the matrix derived from the primaries, which agrees with these to 5e-5 per weight.
constexpr double kYr = 0.2126, kYg = 0.7152, kYb = 0.0722;
constexpr double kWeightRounding = 5e-5;

// Tolerance for a ratio of two luminance sums computed with the printed weights: each sum is off by
// at most kWeightRounding times the sum of the channel values it weighs.
double ratioTolerance(double numerator, double numeratorChannelSum, double denominator, double denominatorChannelSum) {
    return numerator / denominator *
           (kWeightRounding * numeratorChannelSum / numerator + kWeightRounding * denominatorChannelSum / denominator);
}

ImageLayer image(int width, int height, std::vector<float> rgb, const std::string& name = "") {
    return ImageLayer{name, width, height, std::move(rgb)};
}

// A deterministic image with positive and negative values of varied size.
ImageLayer pattern(int width, int height, float scale = 1.0f) {
    std::vector<float> rgb;
    for (int i = 0; i < 3 * width * height; ++i)
        rgb.push_back(scale * (static_cast<float>((i * 37) % 101) * 0.25f - 3.0f));
    return image(width, height, rgb);
}

TEST(ImageCompare, IdenticalImagesHaveZeroErrorAndUnitPowerRatio) {
    const ImageLayer a = pattern(7, 5);
    const ImageComparison c = compareImages(a, a);
    EXPECT_EQ(c.width, 7);
    EXPECT_EQ(c.height, 5);
    EXPECT_EQ(c.pixels, 35);
    ASSERT_TRUE(c.relL2 && c.relMse && c.powerRatio);
    EXPECT_EQ(*c.relL2, 0.0);
    EXPECT_EQ(*c.relMse, 0.0);
    EXPECT_EQ(*c.powerRatio, 1.0);
    EXPECT_EQ(c.maxAbsDiff, 0.0);
    for (const auto& channel : c.relL2Rgb) {
        ASSERT_TRUE(channel);
        EXPECT_EQ(*channel, 0.0);
    }
}

// B = 2A: A − B = −A, so ‖A − B‖/‖B‖ = ‖A‖/(2‖A‖) = 1/2 and ΣY(A)/ΣY(B) = 1/2. Scaling by a power
// of two is exact in floating point, so these hold to the last bit.
TEST(ImageCompare, ReferenceTwiceTheImageGivesOneHalfExactly) {
    const ImageLayer a = pattern(6, 4);
    const ImageLayer b = pattern(6, 4, 2.0f);
    const ImageComparison c = compareImages(a, b);
    ASSERT_TRUE(c.relL2 && c.relMse && c.powerRatio);
    EXPECT_EQ(*c.relL2, 0.5);
    EXPECT_EQ(*c.relMse, 0.25);
    EXPECT_EQ(*c.powerRatio, 0.5);
    for (const auto& channel : c.relL2Rgb) EXPECT_EQ(channel.value(), 0.5);
    float maxAbs = 0.0f;
    for (float v : a.rgb) maxAbs = std::max(maxAbs, std::abs(v));
    EXPECT_EQ(c.maxAbsDiff, maxAbs);
}

// B = [(1, 2, 2), (0, 0, 4)]; A changes R of pixel 0 by +1 and B of pixel 1 by −2.
// Σ(A − B)² = 1 + 4 = 5, ΣB² = 1 + 4 + 4 + 16 = 25: relMSE = 5/25 = 1/5, relL2 = √(1/5).
// Per channel: R 1/1, G 0/4, B 4/20. Max |A − B| = 2.
// ΣY(B) = 0.2126·1 + 0.7152·2 + 0.0722·6, ΣY(A) = 0.2126·2 + 0.7152·2 + 0.0722·4.
TEST(ImageCompare, SmallPerturbationMatchesHandComputedValues) {
    const ImageLayer b = image(2, 1, {1, 2, 2, 0, 0, 4});
    const ImageLayer a = image(2, 1, {2, 2, 2, 0, 0, 2});
    const ImageComparison c = compareImages(a, b);
    ASSERT_TRUE(c.relL2 && c.relMse && c.powerRatio);
    EXPECT_DOUBLE_EQ(*c.relMse, 0.2);
    EXPECT_DOUBLE_EQ(*c.relL2, std::sqrt(0.2));
    EXPECT_DOUBLE_EQ(c.relL2Rgb[0].value(), 1.0);
    EXPECT_DOUBLE_EQ(c.relL2Rgb[1].value(), 0.0);
    EXPECT_DOUBLE_EQ(c.relL2Rgb[2].value(), std::sqrt(0.2));
    EXPECT_EQ(c.maxAbsDiff, 2.0);
    const double yB = kYr * 1 + kYg * 2 + kYb * 6, yA = kYr * 2 + kYg * 2 + kYb * 4;
    EXPECT_NEAR(c.sumYB, yB, 9 * kWeightRounding);
    EXPECT_NEAR(c.sumYA, yA, 8 * kWeightRounding);
    EXPECT_NEAR(*c.powerRatio, yA / yB, ratioTolerance(yA, 8, yB, 9));
}

// The power ratio weighs channels by luminance: pure red against pure green of equal value.
TEST(ImageCompare, PowerRatioUsesRec709Luminance) {
    const ImageLayer red = image(1, 1, {1, 0, 0}), green = image(1, 1, {0, 1, 0}), blue = image(1, 1, {0, 0, 1});
    EXPECT_NEAR(compareImages(red, green).powerRatio.value(), kYr / kYg, ratioTolerance(kYr, 1, kYg, 1));
    EXPECT_NEAR(compareImages(blue, green).powerRatio.value(), kYb / kYg, ratioTolerance(kYb, 1, kYg, 1));
    EXPECT_NEAR(compareImages(red, green).sumYA, kYr, kWeightRounding);
}

TEST(ImageCompare, RelativeMseIsTheSquareOfRelativeL2) {
    ImageLayer a = pattern(9, 7), b = pattern(9, 7);
    for (size_t i = 0; i < a.rgb.size(); i += 4) a.rgb[i] += 0.1f * static_cast<float>(i % 13);
    const ImageComparison c = compareImages(a, b);
    ASSERT_TRUE(c.relL2 && c.relMse);
    EXPECT_GT(*c.relL2, 0.0);
    EXPECT_DOUBLE_EQ(*c.relMse, *c.relL2 * *c.relL2);
    // Relative metrics do not depend on the images' common scale (×4 is exact).
    ImageLayer a4 = a, b4 = b;
    for (float& v : a4.rgb) v *= 4.0f;
    for (float& v : b4.rgb) v *= 4.0f;
    const ImageComparison c4 = compareImages(a4, b4);
    EXPECT_EQ(*c4.relL2, *c.relL2);
    EXPECT_EQ(*c4.powerRatio, *c.powerRatio);
    EXPECT_EQ(c4.maxAbsDiff, 4.0 * c.maxAbsDiff);
}

TEST(ImageCompare, ZeroReferenceLeavesRelativeMetricsUndefined) {
    const ImageLayer zero = image(2, 2, std::vector<float>(12, 0.0f));
    const ImageLayer a = pattern(2, 2);
    const ImageComparison c = compareImages(a, zero);
    EXPECT_FALSE(c.relL2);
    EXPECT_FALSE(c.relMse);
    EXPECT_FALSE(c.powerRatio);
    for (const auto& channel : c.relL2Rgb) EXPECT_FALSE(channel);
    EXPECT_EQ(c.sumYB, 0.0);
    EXPECT_GT(c.maxAbsDiff, 0.0);
    EXPECT_FALSE(compareImages(zero, zero).relL2);  // 0/0 is undefined too, not 0
    EXPECT_EQ(compareImages(zero, zero).maxAbsDiff, 0.0);

    // Only the zero channel is undefined.
    const ImageComparison greenOnly = compareImages(image(1, 1, {1, 2, 3}), image(1, 1, {0, 1, 0}));
    EXPECT_FALSE(greenOnly.relL2Rgb[0]);
    EXPECT_DOUBLE_EQ(greenOnly.relL2Rgb[1].value(), 1.0);
    EXPECT_FALSE(greenOnly.relL2Rgb[2]);
    EXPECT_TRUE(greenOnly.relL2);

    // A reference whose luminance cancels to zero: L2 metrics defined, power ratio not.
    const ImageComparison cancelling = compareImages(image(2, 1, {1, 0, 0, 1, 0, 0}), image(2, 1, {1, 0, 0, -1, 0, 0}));
    EXPECT_TRUE(cancelling.relL2);
    EXPECT_FALSE(cancelling.powerRatio);
}

TEST(ImageCompare, DifferentSizesThrowInputErrorNamingBothFilesAndSizes) {
    try {
        compareImages(pattern(4, 3), pattern(3, 4), "render.exr", "reference.exr");
        FAIL() << "expected InputError";
    } catch (const InputError& e) {
        const std::string message = e.what();
        EXPECT_EQ(e.file(), "render.exr");
        EXPECT_NE(message.find("reference.exr"), std::string::npos) << message;
        EXPECT_NE(message.find("4 x 3"), std::string::npos) << message;
        EXPECT_NE(message.find("3 x 4"), std::string::npos) << message;
    }
}

TEST(ImageCompare, NonFinitePixelThrowsInputErrorNamingTheImageAndPixel) {
    ImageLayer b = pattern(4, 3);
    b.rgb[3 * (2 * 4 + 1) + 1] = std::numeric_limits<float>::quiet_NaN();  // pixel (1, 2), G
    try {
        compareImages(pattern(4, 3), b, "render.exr", "reference.exr");
        FAIL() << "expected InputError";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), "reference.exr");
        EXPECT_NE(std::string(e.what()).find("pixel (1, 2) channel G"), std::string::npos) << e.what();
    }
    ImageLayer a = pattern(4, 3);
    a.rgb[0] = std::numeric_limits<float>::infinity();
    EXPECT_THROW(compareImages(a, pattern(4, 3)), InputError);
}

TEST(ImageCompare, MalformedLayerIsAProgrammingError) {
    EXPECT_THROW(compareImages(image(2, 2, std::vector<float>(11, 0.0f)), pattern(2, 2)), std::logic_error);
}

// ---- the command line ----------------------------------------------------------------------

using test::CliRun;
using test::runCli;

// A fresh directory per test, removed afterwards.
class CompareCliTest : public ::testing::Test {
protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = fs::temp_directory_path() / ("flare_compare_" + std::to_string(::getpid()) + "_" + info->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    std::string write(const std::string& file, const std::vector<ImageLayer>& layers) const {
        const std::string path = (dir_ / file).string();
        writeExr(path, layers, {});
        return path;
    }

    fs::path dir_;
};

TEST_F(CompareCliTest, JsonHasTheDocumentedKeysAndValues) {
    const std::string a = write("a.exr", {pattern(6, 4)});
    const std::string b = write("b.exr", {pattern(6, 4, 2.0f)});
    const CliRun r = runCli("compare " + a + " " + b + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["a"], a);
    EXPECT_EQ(j["b"], b);
    EXPECT_EQ(j["layer"], "");
    EXPECT_EQ(j["width"], 6);
    EXPECT_EQ(j["height"], 4);
    EXPECT_EQ(j["rel_l2"].get<double>(), 0.5);
    EXPECT_EQ(j["rel_mse"].get<double>(), 0.25);
    EXPECT_EQ(j["power_ratio"].get<double>(), 0.5);
    EXPECT_TRUE(j["max_abs_diff"].is_number());
    EXPECT_EQ(j["rel_l2_rgb"].size(), 3u);
}

TEST_F(CompareCliTest, TextPrintsOneAlignedMetricPerLine) {
    const std::string a = write("a.exr", {pattern(3, 2)});
    const CliRun r = runCli("compare " + a + " " + a);
    ASSERT_EQ(r.exitCode, 0) << r.out;
    for (const char* line : {"rel_l2        0\n", "rel_mse       0\n", "power_ratio   1\n", "max_abs_diff  0\n",
                             "size          3 x 2 (6 pixels)\n"})
        EXPECT_NE(r.out.find(line), std::string::npos) << line << " in\n" << r.out;
}

TEST_F(CompareCliTest, ZeroReferenceIsNullInJsonAndUndefinedInText) {
    const std::string a = write("a.exr", {pattern(3, 2)});
    const std::string zero = write("zero.exr", {image(3, 2, std::vector<float>(18, 0.0f))});
    const CliRun json = runCli("compare " + a + " " + zero + " --json");
    ASSERT_EQ(json.exitCode, 0) << json.out;
    const nlohmann::json j = nlohmann::json::parse(json.out);
    EXPECT_TRUE(j["rel_l2"].is_null());
    EXPECT_TRUE(j["rel_mse"].is_null());
    EXPECT_TRUE(j["power_ratio"].is_null());
    EXPECT_GT(j["max_abs_diff"].get<double>(), 0.0);
    const CliRun text = runCli("compare " + a + " " + zero);
    ASSERT_EQ(text.exitCode, 0) << text.out;
    EXPECT_NE(text.out.find("rel_l2        undefined"), std::string::npos) << text.out;
    EXPECT_NE(text.out.find("power_ratio   undefined"), std::string::npos) << text.out;
    for (const char* bad : {" nan", " -nan", " inf", " -inf"}) EXPECT_EQ(text.out.find(bad), std::string::npos) << text.out;
}

TEST_F(CompareCliTest, LayerOptionPicksTheNamedLayer) {
    // Main images identical, ghost layers differ by a factor 2.
    const std::string a = write("a.exr", {pattern(4, 4), image(4, 4, pattern(4, 4).rgb, "ghost")});
    const std::string b = write("b.exr", {pattern(4, 4), image(4, 4, pattern(4, 4, 2.0f).rgb, "ghost")});
    const nlohmann::json main = nlohmann::json::parse(runCli("compare " + a + " " + b + " --json").out);
    EXPECT_EQ(main["rel_l2"].get<double>(), 0.0);
    const CliRun r = runCli("compare " + a + " " + b + " --layer ghost --json");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    const nlohmann::json ghost = nlohmann::json::parse(r.out);
    EXPECT_EQ(ghost["layer"], "ghost");
    EXPECT_EQ(ghost["rel_l2"].get<double>(), 0.5);
}

TEST_F(CompareCliTest, MissingLayerExitsWithCodeTwoListingTheLayers) {
    const std::string a = write("a.exr", {pattern(2, 2), image(2, 2, pattern(2, 2).rgb, "direct")});
    const std::string b = write("b.exr", {pattern(2, 2), image(2, 2, pattern(2, 2).rgb, "ghost")});
    const CliRun r = runCli("compare " + a + " " + b + " --layer ghost");
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.out.find(a + ": no layer \"ghost\""), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("(main), direct"), std::string::npos) << r.out;
    // Only a named layer, no main image.
    const std::string noMain = write("nomain.exr", {image(2, 2, pattern(2, 2).rgb, "ghost")});
    const CliRun main = runCli("compare " + noMain + " " + b);
    EXPECT_EQ(main.exitCode, 2);
    EXPECT_NE(main.out.find(noMain + ": no main RGB layer"), std::string::npos) << main.out;
}

TEST_F(CompareCliTest, MissingFileAndSizeMismatchExitWithCodeTwo) {
    const std::string a = write("a.exr", {pattern(4, 3)});
    const std::string missing = (dir_ / "missing.exr").string();
    const CliRun noFile = runCli("compare " + a + " " + missing);
    EXPECT_EQ(noFile.exitCode, 2);
    EXPECT_NE(noFile.out.find(missing), std::string::npos) << noFile.out;
    EXPECT_EQ(runCli("compare " + missing + " " + a).exitCode, 2);

    const std::string other = write("other.exr", {pattern(3, 4)});
    const CliRun size = runCli("compare " + a + " " + other);
    EXPECT_EQ(size.exitCode, 2);
    EXPECT_NE(size.out.find(a), std::string::npos) << size.out;
    EXPECT_NE(size.out.find(other), std::string::npos) << size.out;

    EXPECT_EQ(runCli("compare " + a).exitCode, 2);  // the reference is required
}

}  // namespace
}  // namespace flare
