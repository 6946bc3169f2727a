#include "flare/film/ImageIO.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>
#include <utility>

#include <Imath/ImathBox.h>
#include <Imath/half.h>
#include <Imath/ImathVec.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStdIO.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfThreading.h>
#include <png.h>

#include "flare/core/Error.h"
#include "flare/core/OutputFiles.h"
#include "flare/core/Spectrum.h"

namespace flare {

namespace {

const char* const kChannelSuffixes[3] = {"R", "G", "B"};

std::string channelName(const std::string& layer, int c) {
    return layer.empty() ? kChannelSuffixes[c] : layer + "." + kChannelSuffixes[c];
}

void checkLayer(const ImageLayer& layer) {
    if (layer.width <= 0 || layer.height <= 0)
        throw std::invalid_argument("image layer \"" + layer.name + "\" has no pixels");
    if (layer.rgb.size() != 3 * static_cast<size_t>(layer.width) * layer.height)
        throw std::invalid_argument("image layer \"" + layer.name + "\" holds " +
                                    std::to_string(layer.rgb.size()) + " values for " +
                                    std::to_string(layer.width) + "×" +
                                    std::to_string(layer.height) + " RGB pixels");
    for (size_t i = 0; i < layer.rgb.size(); ++i)
        if (!std::isfinite(layer.rgb[i]))
            throw std::logic_error("image layer \"" + layer.name + "\" has a non-finite value at pixel " +
                                   std::to_string(i / 3) + " (" + std::to_string(layer.rgb[i]) + ")");
}

double luminance(const glm::dvec3& rgb) { return linearSrgbToXyz(rgb).y; }

double srgbOetf(double v) {  // IEC 61966-2-1
    return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

}  // namespace

namespace {

constexpr float kHalfMax = 65504.0f;
constexpr float kHalfMinNormal = 6.103515625e-05f;  // 2⁻¹⁴

// A float rounded to nearest at 11 significant bits (10 explicit mantissa bits), keeping its
// exponent: half's precision with float's range.
float toHalfPrecision(float v) {
    std::uint32_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    constexpr int kDropped = 23 - 10;
    const std::uint32_t rounded = (bits + (std::uint32_t{1} << (kDropped - 1))) & ~((std::uint32_t{1} << kDropped) - 1);
    float out = 0.0f;
    std::memcpy(&out, &rounded, sizeof out);
    return std::isfinite(out) ? out : v;  // rounding up past the largest float keeps the float
}

}  // namespace

bool fitsHalf(const ImageLayer& layer) {
    float largest = 0.0f;
    for (float v : layer.rgb) largest = std::max(largest, std::abs(v));
    if (!(largest <= kHalfMax)) return false;
    for (float v : layer.rgb)
        if (std::abs(v) > 1e-3f * largest && std::abs(v) < kHalfMinNormal) return false;
    return true;
}

void writeExr(OutputFiles& outputs, const std::string& path, const std::vector<ImageLayer>& layers,
              const std::vector<std::pair<std::string, std::string>>& metadata, const ExrWriteOptions& options) {
    if (layers.empty()) throw std::invalid_argument("writeExr: no image layers for " + path);
    std::set<std::string> names;
    for (const ImageLayer& layer : layers) {
        checkLayer(layer);
        if (layer.width != layers[0].width || layer.height != layers[0].height)
            throw std::invalid_argument("writeExr: layer \"" + layer.name + "\" is not the size of \"" +
                                        layers[0].name + "\"");
        if (!names.insert(layer.name).second)
            throw std::invalid_argument("writeExr: duplicate layer \"" + layer.name + "\"");
    }
    const int width = layers[0].width, height = layers[0].height;

    Imf::Header header(width, height);
    header.compression() = options.compression == ExrCompression::Piz ? Imf::PIZ_COMPRESSION : Imf::ZIP_COMPRESSION;
    Imf::addChromaticities(
        header, Imf::Chromaticities(Imath::V2f(kRec709RedXy[0], kRec709RedXy[1]),
                                    Imath::V2f(kRec709GreenXy[0], kRec709GreenXy[1]),
                                    Imath::V2f(kRec709BlueXy[0], kRec709BlueXy[1]),
                                    Imath::V2f(kD65WhiteXy[0], kD65WhiteXy[1])));
    for (const auto& [key, value] : metadata) {
        if (key.empty() || header.find(key) != header.end())
            throw std::invalid_argument("writeExr: metadata key \"" + key +
                                        "\" is empty or a standard attribute");
        header.insert(key, Imf::StringAttribute(value));
    }
    for (const auto& [name, storage] : options.storage)
        if (!names.count(name)) throw std::invalid_argument("writeExr: storage given for no layer \"" + name + "\"");
    Imf::FrameBuffer frameBuffer;
    std::vector<std::vector<half>> halves;  // converted layers, alive until the pixels are written
    std::vector<std::vector<float>> rounded;
    halves.reserve(layers.size());
    rounded.reserve(layers.size());
    for (const ImageLayer& layer : layers) {
        const auto it = options.storage.find(layer.name);
        const ExrStorage storage = it == options.storage.end() ? ExrStorage::Float : it->second;
        const size_t rowFloats = 3 * static_cast<size_t>(width);
        if (storage == ExrStorage::Half) {
            std::vector<half>& h = halves.emplace_back(layer.rgb.size());
            for (size_t i = 0; i < layer.rgb.size(); ++i) {
                if (std::abs(layer.rgb[i]) > kHalfMax)
                    throw std::logic_error("writeExr: layer \"" + layer.name + "\" has " + std::to_string(layer.rgb[i]) +
                                           ", beyond half's range, at pixel " + std::to_string(i / 3));
                h[i] = half(layer.rgb[i]);
            }
            for (int c = 0; c < 3; ++c) {
                const std::string name = channelName(layer.name, c);
                header.channels().insert(name, Imf::Channel(Imf::HALF));
                frameBuffer.insert(name, Imf::Slice(Imf::HALF, reinterpret_cast<char*>(h.data() + c), 3 * sizeof(half),
                                                    rowFloats * sizeof(half)));
            }
            continue;
        }
        const float* data = layer.rgb.data();
        if (storage == ExrStorage::FloatHalfPrecision) {
            std::vector<float>& r = rounded.emplace_back(layer.rgb.size());
            for (size_t i = 0; i < layer.rgb.size(); ++i) r[i] = toHalfPrecision(layer.rgb[i]);
            data = r.data();
        }
        for (int c = 0; c < 3; ++c) {
            const std::string name = channelName(layer.name, c);
            header.channels().insert(name, Imf::Channel(Imf::FLOAT));
            char* base = const_cast<char*>(reinterpret_cast<const char*>(data + c));
            frameBuffer.insert(name, Imf::Slice(Imf::FLOAT, base, 3 * sizeof(float), rowFloats * sizeof(float)));
        }
    }

    // Compression dominates writing many layers (the per-ghost ones); OpenEXR compresses blocks
    // of scanlines in parallel once given threads, with the same bytes as one thread.
    if (Imf::globalThreadCount() == 0)
        Imf::setGlobalThreadCount(static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
    const std::string& temporary = outputs.file(path);
    try {
        // Our own stream, so that errors while closing (OpenEXR writes the line offset table in
        // its destructor and swallows failures there) are still seen.
        std::ofstream stream(temporary, std::ios::binary | std::ios::trunc);
        if (!stream) throw std::runtime_error(std::strerror(errno));
        {
            Imf::StdOFStream exrStream(stream, temporary.c_str());
            Imf::OutputFile file(exrStream, header);
            file.setFrameBuffer(frameBuffer);
            file.writePixels(height);
        }
        stream.close();
        if (!stream) throw std::runtime_error("error while finishing the file");
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot write " + path + ": " + e.what());
    }
}

void writeExr(const std::string& path, const std::vector<ImageLayer>& layers,
              const std::vector<std::pair<std::string, std::string>>& metadata, const ExrWriteOptions& options) {
    OutputFiles outputs;
    outputs.add(path);
    writeExr(outputs, path, layers, metadata, options);
    outputs.commit();
}

std::vector<ImageLayer> readExr(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) throw InputError(path, 0, "no such image file");
    try {
        Imf::InputFile file(path.c_str());
        const Imath::Box2i window = file.header().dataWindow();
        // In 64 bits: a window from -2^31 to 2^31 - 1 is 2^32 pixels wide.
        const std::int64_t width64 = std::int64_t{window.max.x} - window.min.x + 1;
        const std::int64_t height64 = std::int64_t{window.max.y} - window.min.y + 1;
        if (width64 > std::numeric_limits<int>::max() || height64 > std::numeric_limits<int>::max())
            throw std::runtime_error("data window " + std::to_string(width64) + " x " + std::to_string(height64) +
                                     " pixels is too large");
        const int width = static_cast<int>(width64), height = static_cast<int>(height64);

        // Layers with all three of R, G, B; std::map orders the main layer ("") first.
        std::map<std::string, int> found;
        const Imf::ChannelList& channels = file.header().channels();
        for (auto it = channels.begin(); it != channels.end(); ++it) {
            const std::string name = it.name();
            const size_t dot = name.rfind('.');
            const std::string layer = dot == std::string::npos ? "" : name.substr(0, dot);
            const std::string suffix = dot == std::string::npos ? name : name.substr(dot + 1);
            for (int c = 0; c < 3; ++c)
                if (suffix == kChannelSuffixes[c]) found[layer] |= 1 << c;
        }
        std::vector<ImageLayer> layers;
        for (const auto& [name, mask] : found)
            if (mask == 7) layers.push_back({name, width, height, {}});
        if (layers.empty()) throw std::runtime_error("no layer with R, G and B channels");

        Imf::FrameBuffer frameBuffer;
        const size_t xStride = 3 * sizeof(float), yStride = xStride * static_cast<size_t>(width);
        for (ImageLayer& layer : layers) {
            layer.rgb.assign(3 * static_cast<size_t>(width) * height, 0.0f);
            // OpenEXR addresses pixels by absolute (x, y) in the data window; Slice::Make takes the
            // window's first pixel and offsets it in signed 64-bit arithmetic. Offsetting the
            // pointer here with the size_t strides turned a negative window origin (an overscan
            // image, or a fuzzed header) into an unsigned offset that wrapped around the address
            // space (undefined behaviour: tests/data/fuzz/exr/negative-data-window-origin.exr).
            char* first = reinterpret_cast<char*>(layer.rgb.data());
            for (int c = 0; c < 3; ++c)
                frameBuffer.insert(channelName(layer.name, c),
                                   Imf::Slice::Make(Imf::FLOAT, first + c * sizeof(float), window, xStride, yStride));
        }
        file.setFrameBuffer(frameBuffer);
        file.readPixels(window.min.y, window.max.y);
        return layers;
    } catch (const std::exception& e) {
        throw InputError(path, 0, std::string("cannot read OpenEXR image: ") + e.what());
    }
}

ImageLayer readExrLayer(const std::string& path, const std::string& name) {
    std::vector<ImageLayer> layers = readExr(path);
    for (ImageLayer& layer : layers)
        if (layer.name == name) return std::move(layer);
    std::string available;
    for (const ImageLayer& layer : layers)
        available += (available.empty() ? "" : ", ") + (layer.name.empty() ? std::string("(main)") : layer.name);
    const std::string wanted = name.empty() ? std::string("no main RGB layer (R, G, B)") : "no layer \"" + name + "\"";
    throw InputError(path, 0, wanted + "; layers in the file: " + available);
}

glm::dvec3 displayEncode(const glm::dvec3& linearRgb, double exposure) {
    const glm::dvec3 exposed = linearRgb * exposure;
    const double y = luminance(exposed);
    if (!(y > 0.0)) return glm::dvec3(0.0);
    const double mapped = y / (1.0 + y);
    glm::dvec3 rgb = exposed * (mapped / y);
    // Desaturate toward grey of the same luminance (Y is linear in RGB) just enough to fit:
    // rgb = mapped + s·(rgb − mapped) with the largest s ≤ 1 that keeps every channel in [0, 1].
    const double hi = std::max({rgb.r, rgb.g, rgb.b}), lo = std::min({rgb.r, rgb.g, rgb.b});
    double s = 1.0;
    if (hi > 1.0) s = std::min(s, (1.0 - mapped) / (hi - mapped));
    if (lo < 0.0) s = std::min(s, mapped / (mapped - lo));
    rgb = glm::dvec3(mapped) + s * (rgb - glm::dvec3(mapped));
    return {srgbOetf(std::clamp(rgb.r, 0.0, 1.0)), srgbOetf(std::clamp(rgb.g, 0.0, 1.0)),
            srgbOetf(std::clamp(rgb.b, 0.0, 1.0))};
}

void writePng(OutputFiles& outputs, const std::string& path, const ImageLayer& image, double exposure) {
    checkLayer(image);
    if (!std::isfinite(exposure) || exposure < 0.0)
        throw std::invalid_argument("writePng: exposure must be finite and non-negative");
    std::vector<std::uint8_t> pixels(image.rgb.size());
    for (size_t i = 0; i < image.rgb.size(); i += 3) {
        const glm::dvec3 v = displayEncode({image.rgb[i], image.rgb[i + 1], image.rgb[i + 2]}, exposure);
        for (int c = 0; c < 3; ++c)
            pixels[i + c] = static_cast<std::uint8_t>(std::lround(255.0 * v[c]));
    }
    // libpng's simplified API reports errors in image.message instead of longjmp-ing through us.
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    png.width = static_cast<png_uint_32>(image.width);
    png.height = static_cast<png_uint_32>(image.height);
    png.format = PNG_FORMAT_RGB;
    if (!png_image_write_to_file(&png, outputs.file(path).c_str(), 0, pixels.data(), 0, nullptr)) {
        const std::string message = png.message;
        png_image_free(&png);
        throw std::runtime_error("cannot write " + path + ": " + message);
    }
    png_image_free(&png);
}

void writePng(const std::string& path, const ImageLayer& image, double exposure) {
    OutputFiles outputs;
    outputs.add(path);
    writePng(outputs, path, image, exposure);
    outputs.commit();
}

// Flare images are mostly black with a core 10⁴–10⁶ times brighter than the ghosts, so neither the
// maximum nor the mean gives a useful exposure: the first leaves the ghosts invisible and the
// second is dominated by the core. Pixels below 1e-6 of the maximum are treated as empty (they
// would pull any percentile to zero). The 99th percentile of the remaining luminances is mapped to
// 4, which the x/(1 + x) curve shows at 0.8: the brightest 1% of the lit pixels (the core and its
// immediate surroundings) roll off in the shoulder while the ghosts stay on the near-linear toe.
double autoExposure(const ImageLayer& image) {
    checkLayer(image);
    std::vector<double> lit;
    double brightest = 0.0;
    for (size_t i = 0; i < image.rgb.size(); i += 3) {
        const double y = luminance({image.rgb[i], image.rgb[i + 1], image.rgb[i + 2]});
        lit.push_back(y);
        brightest = std::max(brightest, y);
    }
    if (!(brightest > 0.0)) return 1.0;  // a black image: any exposure shows it
    std::erase_if(lit, [&](double y) { return !(y > 1e-6 * brightest); });
    const size_t index = static_cast<size_t>(0.99 * static_cast<double>(lit.size() - 1));
    std::nth_element(lit.begin(), lit.begin() + static_cast<ptrdiff_t>(index), lit.end());
    const double displayTarget = 0.8;
    return displayTarget / (1.0 - displayTarget) / lit[index];
}

ImageLayer rgbLayerFromXyz(const std::string& name, const std::vector<float>& xyz, int width, int height) {
    ImageLayer layer{name, width, height, std::vector<float>(xyz.size())};
    for (size_t i = 0; i < xyz.size(); i += 3) {
        const glm::dvec3 rgb = xyzToLinearSrgb({xyz[i], xyz[i + 1], xyz[i + 2]});
        for (int c = 0; c < 3; ++c) layer.rgb[i + c] = static_cast<float>(rgb[c]);
    }
    return layer;
}

}  // namespace flare
