#include "flare/photons/CoverageMask.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <system_error>

#include <Imath/ImathBox.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <png.h>

#include "flare/core/Error.h"

namespace flare {

namespace {

// Rec.709 luminance weights (sum 1, so a grey RGB pixel keeps its value).
constexpr double kLumaR = 0.2126, kLumaG = 0.7152, kLumaB = 0.0722;
// Larger images would only slow the load: a mask is a coverage map, not a photograph.
constexpr long kMaxPixels = 1L << 26;

std::vector<float> readPng(const std::string& path, int& width, int& height) {
    // libpng's simplified API reports errors in image.message instead of longjmp-ing through us.
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&image, path.c_str()))
        throw InputError(path, 0, std::string("cannot read the PNG file: ") + image.message);
    if (static_cast<long>(image.width) * image.height > kMaxPixels) {
        png_image_free(&image);
        throw InputError(path, 0, "the image is too large for a mask (" + std::to_string(image.width) + " x " +
                                      std::to_string(image.height) + " pixels)");
    }
    // Read in the file's own bit depth, so that libpng converts no code values: 8-bit files as
    // 8-bit RGB, 16-bit ones as 16-bit ("linear") RGB. Alpha is composited over the zeroed buffer.
    const bool sixteenBit = (image.format & PNG_FORMAT_FLAG_LINEAR) != 0;
    image.format = sixteenBit ? PNG_FORMAT_LINEAR_RGB : PNG_FORMAT_RGB;
    std::vector<std::uint8_t> buffer(PNG_IMAGE_SIZE(image), 0);
    if (!png_image_finish_read(&image, nullptr, buffer.data(), 0, nullptr)) {
        const std::string message = image.message;
        png_image_free(&image);
        throw InputError(path, 0, "cannot read the PNG file: " + message);
    }
    width = static_cast<int>(image.width);
    height = static_cast<int>(image.height);
    const std::size_t pixels = static_cast<std::size_t>(width) * height;
    std::vector<float> values(pixels);
    for (std::size_t i = 0; i < pixels; ++i) {
        double rgb[3];
        for (int c = 0; c < 3; ++c)
            rgb[c] = sixteenBit ? reinterpret_cast<const std::uint16_t*>(buffer.data())[3 * i + c] / 65535.0
                                : buffer[3 * i + c] / 255.0;
        values[i] = static_cast<float>(std::clamp(kLumaR * rgb[0] + kLumaG * rgb[1] + kLumaB * rgb[2], 0.0, 1.0));
    }
    return values;
}

std::vector<float> readExrMask(const std::string& path, int& width, int& height) {
    try {
        Imf::InputFile file(path.c_str());
        const Imath::Box2i window = file.header().dataWindow();
        width = window.max.x - window.min.x + 1;
        height = window.max.y - window.min.y + 1;
        if (static_cast<long>(width) * height > kMaxPixels)
            throw InputError(path, 0, "the image is too large for a mask");
        const Imf::ChannelList& channels = file.header().channels();
        std::vector<std::string> names;
        for (auto it = channels.begin(); it != channels.end(); ++it) names.emplace_back(it.name());
        std::vector<std::pair<std::string, double>> used;  // channel, weight
        if (channels.findChannel("Y")) used = {{"Y", 1.0}};
        else if (channels.findChannel("R") && channels.findChannel("G") && channels.findChannel("B"))
            used = {{"R", kLumaR}, {"G", kLumaG}, {"B", kLumaB}};
        else if (names.size() == 1) used = {{names[0], 1.0}};
        else {
            std::string list;
            for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
            throw InputError(path, 0, "an EXR mask needs a Y channel, R, G and B, or a single channel (it has " +
                                          (list.empty() ? std::string("none") : list) + ")");
        }
        const std::size_t pixels = static_cast<std::size_t>(width) * height;
        std::vector<std::vector<float>> planes(used.size(), std::vector<float>(pixels, 0.0f));
        Imf::FrameBuffer frameBuffer;
        for (std::size_t c = 0; c < used.size(); ++c) {
            // OpenEXR addresses pixels by absolute (x, y) in the data window.
            char* origin = reinterpret_cast<char*>(planes[c].data()) -
                           (static_cast<std::ptrdiff_t>(window.min.y) * width + window.min.x) * sizeof(float);
            frameBuffer.insert(used[c].first, Imf::Slice(Imf::FLOAT, origin, sizeof(float), sizeof(float) * width));
        }
        file.setFrameBuffer(frameBuffer);
        file.readPixels(window.min.y, window.max.y);
        std::vector<float> values(pixels);
        for (std::size_t i = 0; i < pixels; ++i) {
            double v = 0.0;
            for (std::size_t c = 0; c < used.size(); ++c) v += used[c].second * planes[c][i];
            if (!(v >= -1e-6 && v <= 1.0 + 1e-6))  // luminance weights sum to 1 up to rounding
                throw InputError(path, 0, "mask value " + std::to_string(v) + " at pixel (" + std::to_string(i % width) +
                                              ", " + std::to_string(i / width) + ") is outside [0, 1]");
            values[i] = static_cast<float>(std::clamp(v, 0.0, 1.0));
        }
        return values;
    } catch (const InputError&) {
        throw;
    } catch (const std::exception& e) {
        throw InputError(path, 0, std::string("cannot read the OpenEXR file: ") + e.what());
    }
}

}  // namespace

CoverageMask CoverageMask::load(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) throw InputError(path, 0, "no such file");
    if (!std::filesystem::is_regular_file(path, ec)) throw InputError(path, 0, "not a regular file");
    unsigned char magic[8] = {};
    {
        std::ifstream in(path, std::ios::binary);
        if (!in) throw InputError(path, 0, "cannot open the file");
        in.read(reinterpret_cast<char*>(magic), sizeof magic);
    }
    static constexpr unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    static constexpr unsigned char kExr[4] = {0x76, 0x2f, 0x31, 0x01};
    int width = 0, height = 0;
    std::vector<float> values;
    if (std::equal(kPng, kPng + 8, magic)) values = readPng(path, width, height);
    else if (std::equal(kExr, kExr + 4, magic)) values = readExrMask(path, width, height);
    else throw InputError(path, 0, "neither a PNG nor an OpenEXR image");
    if (width <= 0 || height <= 0) throw InputError(path, 0, "the image has no pixels");
    CoverageMask mask = fromValues(width, height, std::move(values));
    mask.sourceFile_ = path;
    return mask;
}

CoverageMask CoverageMask::fromValues(int widthPx, int heightPx, std::vector<float> values) {
    if (widthPx <= 0 || heightPx <= 0) throw std::invalid_argument("CoverageMask: the image has no pixels");
    if (values.size() != static_cast<std::size_t>(widthPx) * heightPx)
        throw std::invalid_argument("CoverageMask: " + std::to_string(values.size()) + " values for " +
                                    std::to_string(widthPx) + " x " + std::to_string(heightPx) + " pixels");
    double sum = 0.0;
    float maximum = 0.0f;
    for (float v : values) {
        if (!(v >= 0.0f && v <= 1.0f)) throw std::invalid_argument("CoverageMask: a value outside [0, 1]");
        sum += v;
        maximum = std::max(maximum, v);
    }
    CoverageMask mask;
    mask.widthPx_ = widthPx;
    mask.heightPx_ = heightPx;
    mask.values_ = std::move(values);
    mask.maxValue_ = maximum;
    mask.meanValue_ = sum / static_cast<double>(mask.values_.size());
    return mask;
}

void CoverageMask::place(double widthMm, double heightMm, const glm::dvec2& centreMm) {
    if (!(widthMm > 0.0 && heightMm > 0.0) || !std::isfinite(widthMm) || !std::isfinite(heightMm) ||
        !std::isfinite(centreMm.x) || !std::isfinite(centreMm.y))
        throw std::invalid_argument("CoverageMask::place: the size must be > 0 and finite, the centre finite");
    widthMm_ = widthMm;
    heightMm_ = heightMm;
    centreMm_ = centreMm;
}

}  // namespace flare
