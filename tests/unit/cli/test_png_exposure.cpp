// The PNG's exposure (issue 28, item 9): `--exposure STOPS` multiplies the linear image by 2^STOPS
// before the tone curve, pixel for pixel what displayEncode gives for the EXR's main image; without
// it the exposure is chosen from the ghosts and said in stops.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <png.h>

#include "TestUtil.h"
#include "flare/film/ImageIO.h"

namespace flare {
namespace {

namespace fs = std::filesystem;

// The PNG's 8-bit RGB pixels (libpng's simplified API).
std::vector<std::uint8_t> readPng(const fs::path& path, int& width, int& height) {
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&png, path.c_str())) return {};
    png.format = PNG_FORMAT_RGB;
    std::vector<std::uint8_t> pixels(PNG_IMAGE_SIZE(png));
    if (!png_image_finish_read(&png, nullptr, pixels.data(), 0, nullptr)) return {};
    width = static_cast<int>(png.width);
    height = static_cast<int>(png.height);
    return pixels;
}

// Pixels of the PNG that differ from displayEncode(main image, exposure), and the mean 8-bit value.
int mismatches(const ImageLayer& image, const std::vector<std::uint8_t>& pixels, double exposure) {
    int wrong = 0;
    for (size_t i = 0; i < image.rgb.size(); i += 3) {
        const glm::dvec3 v = displayEncode({image.rgb[i], image.rgb[i + 1], image.rgb[i + 2]}, exposure);
        for (int c = 0; c < 3; ++c)
            if (pixels[i + c] != static_cast<std::uint8_t>(std::lround(255.0 * v[c]))) ++wrong;
    }
    return wrong;
}

double mean(const std::vector<std::uint8_t>& pixels) {
    double sum = 0.0;
    for (std::uint8_t p : pixels) sum += p;
    return sum / static_cast<double>(pixels.size());
}

TEST(PngExposure, ExposureInStopsScalesTheLinearImageBeforeTheToneCurve) {
    const fs::path dir = test::freshDir("png_exposure", "stops");
    const std::string scene = test::writeTinyScene(dir);
    const fs::path exr = dir / "p.exr";
    double previousMean = -1.0;
    for (double stops : {-2.0, 3.0, 9.5}) {
        const fs::path png = dir / ("p" + std::to_string(static_cast<int>(stops * 10)) + ".png");
        const test::CliRun r = test::runCli("preview " + scene + " -o " + exr.string() + " --png " + png.string() +
                                            " --exposure " + std::to_string(stops) + " --quiet");
        ASSERT_EQ(r.exitCode, 0) << r.out;
        int width = 0, height = 0;
        const std::vector<std::uint8_t> pixels = readPng(png, width, height);
        ASSERT_EQ(width, 96);
        ASSERT_EQ(height, 64);
        const ImageLayer image = readExrLayer(exr.string(), "");
        EXPECT_EQ(mismatches(image, pixels, std::exp2(stops)), 0) << stops << " stops";
        // Brighter with every stop (the same preview each time: same seed and passes).
        EXPECT_GT(mean(pixels), previousMean) << stops << " stops";
        previousMean = mean(pixels);
    }
}

TEST(PngExposure, TheAutomaticExposureIsSaidInStopsAndTheRenderTakesTheOptionToo) {
    const fs::path dir = test::freshDir("png_exposure", "auto");
    const std::string scene = test::writeTinyScene(dir);
    const test::CliRun automatic = test::runCli("preview " + scene + " -o " + (dir / "a.exr").string() + " --png " +
                                                (dir / "a.png").string());
    ASSERT_EQ(automatic.exitCode, 0) << automatic.out;
    EXPECT_NE(automatic.out.find("PNG exposure "), std::string::npos) << automatic.out;
    EXPECT_NE(automatic.out.find("stops (automatic"), std::string::npos) << automatic.out;

    const fs::path png = dir / "r.png", exr = dir / "r.exr";
    const test::CliRun render = test::runCli("render " + scene + " -o " + exr.string() + " --png " + png.string() +
                                             " --photons 100000 --exposure 4 --quiet");
    ASSERT_EQ(render.exitCode, 0) << render.out;
    int width = 0, height = 0;
    const std::vector<std::uint8_t> pixels = readPng(png, width, height);
    ASSERT_FALSE(pixels.empty());
    EXPECT_EQ(mismatches(readExrLayer(exr.string(), ""), pixels, 16.0), 0);

    EXPECT_EQ(test::runCli("preview " + scene + " -o " + (dir / "b.exr").string() + " --png " +
                           (dir / "b.png").string() + " --exposure 100")
                  .exitCode,
              2);
    EXPECT_FALSE(fs::exists(dir / "b.exr"));
}

}  // namespace
}  // namespace flare
