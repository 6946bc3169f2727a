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
#include <string_view>
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
#include <OpenEXR/ImfInputPart.h>
#include <OpenEXR/ImfMultiPartInputFile.h>
#include <OpenEXR/ImfMultiPartOutputFile.h>
#include <OpenEXR/ImfOutputPart.h>
#include <OpenEXR/ImfPartType.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStdIO.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfThreading.h>
#include <OpenEXR/openexr.h>
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

namespace {

// A layer's channels in a header, of its storage's type.
void addLayerChannels(const ImageLayer& layer, ExrStorage storage, Imf::Header& header) {
    for (int c = 0; c < 3; ++c)
        header.channels().insert(channelName(layer.name, c), Imf::Channel(storage == ExrStorage::Half ? Imf::HALF : Imf::FLOAT));
}

// A layer's slices in a frame buffer, converted to its storage; the conversions are kept in
// `halves` and `rounded` until the pixels are written. OpenEXR addresses pixels by absolute (x, y)
// in the data window, which for a layer at (x, y) of the frame starts there.
void addLayerSlices(const ImageLayer& layer, ExrStorage storage, Imf::FrameBuffer& frameBuffer,
                    std::vector<std::vector<half>>& halves, std::vector<std::vector<float>>& rounded) {
    const size_t rowValues = 3 * static_cast<size_t>(layer.width);
    const ptrdiff_t originValues = -(static_cast<ptrdiff_t>(layer.y) * static_cast<ptrdiff_t>(rowValues) +
                                     3 * static_cast<ptrdiff_t>(layer.x));
    if (storage == ExrStorage::Half) {
        std::vector<half>& h = halves.emplace_back(layer.rgb.size());
        for (size_t i = 0; i < layer.rgb.size(); ++i) h[i] = half(layer.rgb[i]);
        for (int c = 0; c < 3; ++c) {
            char* base = reinterpret_cast<char*>(h.data() + c) + originValues * static_cast<ptrdiff_t>(sizeof(half));
            frameBuffer.insert(channelName(layer.name, c),
                               Imf::Slice(Imf::HALF, base, 3 * sizeof(half), rowValues * sizeof(half)));
        }
        return;
    }
    const float* data = layer.rgb.data();
    if (storage == ExrStorage::FloatHalfPrecision) {
        std::vector<float>& r = rounded.emplace_back(layer.rgb.size());
        for (size_t i = 0; i < layer.rgb.size(); ++i) r[i] = toHalfPrecision(layer.rgb[i]);
        data = r.data();
    }
    for (int c = 0; c < 3; ++c) {
        char* base = const_cast<char*>(reinterpret_cast<const char*>(data + c)) +
                     originValues * static_cast<ptrdiff_t>(sizeof(float));
        frameBuffer.insert(channelName(layer.name, c),
                           Imf::Slice(Imf::FLOAT, base, 3 * sizeof(float), rowValues * sizeof(float)));
    }
}

Imath::Box2i windowBox(const ImageLayer& layer) {
    return Imath::Box2i(Imath::V2i(layer.x, layer.y), Imath::V2i(layer.x + layer.width - 1, layer.y + layer.height - 1));
}

}  // namespace

void writeExr(OutputFiles& outputs, const std::string& path, const std::vector<ImageLayer>& layers,
              const std::vector<std::pair<std::string, std::string>>& metadata, const ExrWriteOptions& options) {
    if (layers.empty()) throw std::invalid_argument("writeExr: no image layers for " + path);
    const int width = layers[0].width, height = layers[0].height;
    std::set<std::string> names;
    for (const ImageLayer& layer : layers) {
        checkLayer(layer);
        const bool whole = layer.x == 0 && layer.y == 0 && layer.width == width && layer.height == height;
        if (options.ownParts.count(layer.name)) {
            if (&layer == &layers[0]) throw std::invalid_argument("writeExr: the first layer is the frame, not a part of its own");
            if (layer.x < 0 || layer.y < 0 || layer.x + layer.width > width || layer.y + layer.height > height)
                throw std::invalid_argument("writeExr: layer \"" + layer.name + "\"'s window lies outside the frame");
        } else if (!whole) {
            throw std::invalid_argument("writeExr: layer \"" + layer.name + "\" is not the whole frame of \"" +
                                        layers[0].name + "\" and not a part of its own");
        }
        if (!names.insert(layer.name).second)
            throw std::invalid_argument("writeExr: duplicate layer \"" + layer.name + "\"");
    }
    for (const auto& [name, storage] : options.storage)
        if (!names.count(name)) throw std::invalid_argument("writeExr: storage given for no layer \"" + name + "\"");
    for (const ImageLayer& layer : layers) {
        const auto it = options.storage.find(layer.name);
        if (it == options.storage.end() || it->second != ExrStorage::Half) continue;
        for (size_t i = 0; i < layer.rgb.size(); ++i)
            if (std::abs(layer.rgb[i]) > kHalfMax)
                throw std::logic_error("writeExr: layer \"" + layer.name + "\" has " + std::to_string(layer.rgb[i]) +
                                       ", beyond half's range, at pixel " + std::to_string(i / 3));
    }
    for (const std::string& name : options.ownParts)
        if (!names.count(name)) throw std::invalid_argument("writeExr: a part given for no layer \"" + name + "\"");

    // The first part: the whole-frame layers, the chromaticities and the metadata.
    Imf::Header first(width, height);
    switch (options.compression) {
        case ExrCompression::None: first.compression() = Imf::NO_COMPRESSION; break;
        case ExrCompression::Zip: first.compression() = Imf::ZIP_COMPRESSION; break;
        case ExrCompression::Piz: first.compression() = Imf::PIZ_COMPRESSION; break;
    }
    const std::array<double, 8> xy = options.chromaticities.value_or(
        std::array<double, 8>{kRec709RedXy[0], kRec709RedXy[1], kRec709GreenXy[0], kRec709GreenXy[1], kRec709BlueXy[0],
                              kRec709BlueXy[1], kD65WhiteXy[0], kD65WhiteXy[1]});
    auto v2 = [&](int i) { return Imath::V2f(static_cast<float>(xy[2 * i]), static_cast<float>(xy[2 * i + 1])); };
    Imf::addChromaticities(first, Imf::Chromaticities(v2(0), v2(1), v2(2), v2(3)));
    // The attributes every part carries (the display window and chromaticities must agree between
    // parts), before the first part's own.
    const Imf::Header shared = first;
    for (const auto& [key, value] : metadata) {
        if (key.empty() || first.find(key) != first.end())
            throw std::invalid_argument("writeExr: metadata key \"" + key + "\" is empty or a standard attribute");
        first.insert(key, Imf::StringAttribute(value));
    }
    auto storageOf = [&](const std::string& name) {
        const auto it = options.storage.find(name);
        return it == options.storage.end() ? ExrStorage::Float : it->second;
    };
    // The parts: the first holds every whole-frame layer, then one per layer in ownParts.
    std::vector<Imf::Header> headers{first};
    std::vector<std::vector<const ImageLayer*>> partLayers(1);
    for (const ImageLayer& layer : layers) {
        if (!options.ownParts.count(layer.name)) {
            addLayerChannels(layer, storageOf(layer.name), headers[0]);
            partLayers[0].push_back(&layer);
            continue;
        }
        Imf::Header& header = headers.emplace_back(shared);
        header.dataWindow() = windowBox(layer);
        header.setName(layer.name);
        header.setType(Imf::SCANLINEIMAGE);
        addLayerChannels(layer, storageOf(layer.name), header);
        partLayers.push_back({&layer});
    }
    // A part's pixels, converted to their storage when the part is written (one part's conversions
    // in memory at a time: hundreds of per-ghost parts would otherwise hold a second copy).
    auto writePart = [&](auto& out, size_t p) {
        Imf::FrameBuffer frameBuffer;
        std::vector<std::vector<half>> halves;
        std::vector<std::vector<float>> rounded;
        halves.reserve(partLayers[p].size());
        rounded.reserve(partLayers[p].size());
        for (const ImageLayer* layer : partLayers[p]) addLayerSlices(*layer, storageOf(layer->name), frameBuffer, halves, rounded);
        out.setFrameBuffer(frameBuffer);
        out.writePixels(partLayers[p].front()->height);
    };

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
            if (headers.size() == 1) {
                Imf::OutputFile file(exrStream, headers[0]);
                writePart(file, 0);
            } else {
                headers[0].setName("rgba");  // Nuke's name for the main layer's part
                headers[0].setType(Imf::SCANLINEIMAGE);
                Imf::MultiPartOutputFile file(exrStream, headers.data(), static_cast<int>(headers.size()));
                for (size_t p = 0; p < headers.size(); ++p) {
                    Imf::OutputPart part(file, static_cast<int>(p));
                    writePart(part, p);
                }
            }
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

namespace {

// The RGB layers of one part: names with all three of R, G, B (std::map orders the main layer ""
// first).
std::vector<std::string> rgbLayerNames(const Imf::Header& header) {
    std::map<std::string, int> found;
    const Imf::ChannelList& channels = header.channels();
    for (auto it = channels.begin(); it != channels.end(); ++it) {
        const std::string name = it.name();
        const size_t dot = name.rfind('.');
        const std::string layer = dot == std::string::npos ? "" : name.substr(0, dot);
        const std::string suffix = dot == std::string::npos ? name : name.substr(dot + 1);
        for (int c = 0; c < 3; ++c)
            if (suffix == kChannelSuffixes[c]) found[layer] |= 1 << c;
    }
    std::vector<std::string> names;
    for (const auto& [name, mask] : found)
        if (mask == 7) names.push_back(name);
    return names;
}

// Reads the named RGB layers of part `p`, over its data window placed relative to `frameOrigin`
// (the display window's corner).
std::vector<ImageLayer> readPart(Imf::MultiPartInputFile& file, int p, const std::vector<std::string>& names,
                                 const Imath::V2i& frameOrigin) {
    Imf::InputPart part(file, p);
    const Imath::Box2i window = part.header().dataWindow();
    const long long width = static_cast<long long>(window.max.x) - window.min.x + 1;
    const long long height = static_cast<long long>(window.max.y) - window.min.y + 1;
    if (width <= 0 || height <= 0 || width * height > kMaxExrFramePixels)
        throw std::runtime_error("a part's data window of " + std::to_string(width) + " × " + std::to_string(height) +
                                 " pixels (at most " + std::to_string(kMaxExrFramePixels) + ")");
    std::vector<ImageLayer> layers;
    Imf::FrameBuffer frameBuffer;
    const size_t xStride = 3 * sizeof(float), yStride = xStride * static_cast<size_t>(width);
    layers.reserve(names.size());
    for (const std::string& name : names) {
        ImageLayer& layer = layers.emplace_back();
        layer.name = name;
        layer.width = static_cast<int>(width);
        layer.height = static_cast<int>(height);
        // The window's place in the frame, in 64 bits: a hostile header's corners can lie 2^32 apart.
        const long long x = static_cast<long long>(window.min.x) - frameOrigin.x;
        const long long y = static_cast<long long>(window.min.y) - frameOrigin.y;
        if (x < std::numeric_limits<int>::min() || x > std::numeric_limits<int>::max() ||
            y < std::numeric_limits<int>::min() || y > std::numeric_limits<int>::max())
            throw std::runtime_error("a part's data window lies too far from its frame");
        layer.x = static_cast<int>(x);
        layer.y = static_cast<int>(y);
        layer.rgb.assign(3 * static_cast<size_t>(width) * static_cast<size_t>(height), 0.0f);
        // OpenEXR addresses pixels by absolute (x, y) in the data window; Slice::Make takes the
        // window's first pixel and offsets it in signed 64-bit arithmetic (offsetting the pointer
        // here with size_t strides wrapped a negative window origin around the address space:
        // tests/data/fuzz/exr/negative-data-window-origin.exr).
        char* first = reinterpret_cast<char*>(layer.rgb.data());
        for (int c = 0; c < 3; ++c)
            frameBuffer.insert(channelName(name, c),
                               Imf::Slice::Make(Imf::FLOAT, first + c * sizeof(float), window, xStride, yStride));
    }
    part.setFrameBuffer(frameBuffer);
    part.readPixels(window.min.y, window.max.y);
    return layers;
}

// Parses every header of `path` with OpenEXR's C core and throws its first complaint. The C++
// reader (Imf) trusts a header's declared sizes as it goes: a channel list read past its declared
// size puts the next attribute's size in the wrong bytes, and Imf allocates whatever that says
// (1.6 GB for an 87-byte file found by the exr fuzz target). The core reads each attribute by its
// declared size, checks the sizes against the file's length and the channels, windows, tiles and
// chunk counts before it allocates; a file it refuses never reaches Imf. (It does not check every
// declared size against its type: checkAttributeSizes does.)
void checkHeaders(const std::string& path) {
    static thread_local std::string firstComplaint;
    firstComplaint.clear();
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = [](exr_const_context_t, exr_result_t, const char* message) {
        if (firstComplaint.empty() && message != nullptr) firstComplaint = message;
    };
    exr_context_t context = nullptr;
    const exr_result_t result = exr_start_read(&context, path.c_str(), &init);
    exr_finish(&context);
    if (result != EXR_ERR_SUCCESS)
        throw std::runtime_error(firstComplaint.empty() ? exr_get_default_error_message(result) : firstComplaint);
}

// The size OpenEXR's C++ reader reads for an attribute of a fixed-size type, whatever the header
// declares (0: a type whose size the declaration gives).
size_t fixedAttributeSize(std::string_view type) {
    static const std::map<std::string_view, size_t> sizes = {
        {"box2i", 16}, {"box2f", 16}, {"chromaticities", 32}, {"compression", 1}, {"deepImageState", 1},
        {"double", 8}, {"envmap", 1}, {"float", 4}, {"int", 4}, {"keycode", 28}, {"lineOrder", 1},
        {"m33f", 36}, {"m33d", 72}, {"m44f", 64}, {"m44d", 128}, {"rational", 8}, {"tiledesc", 9},
        {"timecode", 8}, {"v2i", 8}, {"v2f", 8}, {"v2d", 16}, {"v3i", 12}, {"v3f", 12}, {"v3d", 24}};
    const auto it = sizes.find(type);
    return it == sizes.end() ? 0 : it->second;
}

// Walks every header of `path` and throws where OpenEXR's C++ reader would read an attribute by
// something other than its declared size. That reader reads a fixed-size type by its type, a
// channel list by its contents, a preview by its width and height and a string vector by its
// strings' own lengths; where those disagree with the declared size it reads the following
// attributes from the wrong bytes, sizes included, and allocates what it finds (1.9 GB for a
// 440-byte file from the exr fuzz target). OpenEXR's C core reads by the declared size and
// accepts some of these, so both checks are needed. A header cut short is left to them.
void checkAttributeSizes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::string bytes;
    const auto have = [&](size_t n) {  // reads on until `bytes` holds n bytes or the file ends
        while (bytes.size() < n && in) {
            char chunk[1 << 16];
            in.read(chunk, sizeof chunk);
            bytes.append(chunk, static_cast<size_t>(in.gcount()));
        }
        return bytes.size() >= n;
    };
    const auto text = [&](size_t& at, std::string& out) {  // a NUL-terminated name
        for (size_t end = at;; ++end) {
            if (!have(end + 1)) return false;
            if (bytes[end] == '\0') {
                out.assign(bytes, at, end - at);
                at = end + 1;
                return true;
            }
        }
    };
    const auto int32At = [&](size_t at) {
        std::int32_t v = 0;
        std::memcpy(&v, bytes.data() + at, 4);
        return v;
    };
    if (!have(8)) return;
    const bool multipart = (static_cast<std::uint32_t>(int32At(4)) & 0x1000u) != 0;
    size_t at = 8;
    for (;;) {
        if (!have(at + 1)) return;
        if (bytes[at] == '\0') {  // the end of a header; a multi-part file's list ends with an empty one
            if (!multipart || !have(at + 2) || bytes[at + 1] == '\0') return;
            ++at;
            continue;
        }
        std::string name, type;
        if (!text(at, name) || !text(at, type) || !have(at + 4)) return;
        const std::int32_t declared = int32At(at);
        at += 4;
        if (declared < 0) return;  // the core refuses it
        const size_t size = static_cast<size_t>(declared);
        const auto refuse = [&](const std::string& problem) {
            throw std::runtime_error("the header attribute \"" + name + "\" (" + type + ") declares " +
                                     std::to_string(size) + " bytes, but " + problem);
        };
        if (const size_t fixed = fixedAttributeSize(type); fixed != 0 && fixed != size)
            refuse("a " + type + " is " + std::to_string(fixed));
        if (type == "chlist" || type == "preview" || type == "stringvector") {
            if (!have(at + size)) return;
            size_t read = 0;
            if (type == "chlist") {  // names, each followed by 16 bytes, up to an empty name
                while (read < size && bytes[at + read] != '\0') {
                    const size_t end = bytes.find('\0', at + read);
                    if (end == std::string::npos || end >= at + size) refuse("its channel names run past it");
                    read = end - at + 1 + 16;
                }
                ++read;
            } else if (type == "preview") {  // width, height, then 4 bytes a pixel
                if (size < 8) refuse("a preview's width and height are 8");
                // In double: the two 32-bit sides' product exceeds 64 bits.
                const double needed = 8.0 + 4.0 * static_cast<std::uint32_t>(int32At(at)) *
                                                  static_cast<double>(static_cast<std::uint32_t>(int32At(at + 4)));
                if (needed != static_cast<double>(size)) refuse("its width and height need 8 + 4 × width × height");
                read = size;
            } else {  // strings, each after its 4-byte length
                while (read + 4 <= size) {
                    const std::int32_t length = int32At(at + read);
                    if (length < 0 || static_cast<size_t>(length) > size - read - 4) refuse("a string in it runs past it");
                    read += 4 + static_cast<size_t>(length);
                }
            }
            if (read != size) refuse("its contents are " + std::to_string(read));
        }
        at += size;
    }
}

// Opens `path` and calls read(file, frame size, frame origin).
template <class Read>
auto withExr(const std::string& path, Read read) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) throw InputError(path, 0, "no such image file");
    try {
        checkHeaders(path);
        checkAttributeSizes(path);
        Imf::MultiPartInputFile file(path.c_str());
        const Imath::Box2i display = file.header(0).displayWindow();
        const long long width = static_cast<long long>(display.max.x) - display.min.x + 1;
        const long long height = static_cast<long long>(display.max.y) - display.min.y + 1;
        if (width <= 0 || height <= 0 || width * height > kMaxExrFramePixels)
            throw std::runtime_error("a frame (display window) of " + std::to_string(width) + " × " +
                                     std::to_string(height) + " pixels (at most " + std::to_string(kMaxExrFramePixels) + ")");
        return read(file, static_cast<int>(width), static_cast<int>(height), display.min);
    } catch (const InputError&) {
        throw;
    } catch (const std::exception& e) {
        throw InputError(path, 0, std::string("cannot read OpenEXR image: ") + e.what());
    }
}

}  // namespace

ExrImage readExrImage(const std::string& path) {
    return withExr(path, [&](Imf::MultiPartInputFile& file, int width, int height, const Imath::V2i& origin) {
        ExrImage image{width, height, {}, {}};
        std::set<std::string> seen;
        for (int p = 0; p < file.parts(); ++p) {
            if (file.header(p).hasType() && !Imf::isImage(file.header(p).type())) continue;  // deep parts
            const std::vector<std::string> names = rgbLayerNames(file.header(p));
            for (const std::string& name : names)
                if (!seen.insert(name).second)
                    throw std::runtime_error("the layer \"" + name + "\" is in two parts");
            if (names.empty()) continue;
            if (p > 0) image.ownParts.insert(names.begin(), names.end());
            for (ImageLayer& layer : readPart(file, p, names, origin)) image.layers.push_back(std::move(layer));
        }
        if (image.layers.empty()) throw std::runtime_error("no layer with R, G and B channels");
        // The main layer first, then the others by name, wherever their parts are.
        std::stable_sort(image.layers.begin(), image.layers.end(),
                         [](const ImageLayer& a, const ImageLayer& b) { return a.name < b.name; });
        return image;
    });
}

std::vector<ImageLayer> readExr(const std::string& path) {
    ExrImage image = readExrImage(path);
    std::vector<ImageLayer> layers;
    layers.reserve(image.layers.size());
    for (ImageLayer& layer : image.layers) {
        const bool whole = layer.x == 0 && layer.y == 0 && layer.width == image.width && layer.height == image.height;
        layers.push_back(whole ? std::move(layer) : expandToFrame(layer, image.width, image.height));
        std::vector<float>().swap(layer.rgb);
    }
    return layers;
}

ImageLayer readExrLayer(const std::string& path, const std::string& name) {
    return withExr(path, [&](Imf::MultiPartInputFile& file, int width, int height, const Imath::V2i& origin) {
        std::vector<std::string> available;
        for (int p = 0; p < file.parts(); ++p) {
            if (file.header(p).hasType() && !Imf::isImage(file.header(p).type())) continue;
            for (const std::string& layer : rgbLayerNames(file.header(p))) {
                if (layer == name) {
                    const ImageLayer found = std::move(readPart(file, p, {name}, origin).front());
                    return expandToFrame(found, width, height);
                }
                available.push_back(layer);
            }
        }
        std::sort(available.begin(), available.end());
        std::string list;
        for (const std::string& layer : available)
            list += (list.empty() ? "" : ", ") + (layer.empty() ? std::string("(main)") : layer);
        const std::string wanted = name.empty() ? std::string("no main RGB layer (R, G, B)") : "no layer \"" + name + "\"";
        throw InputError(path, 0, wanted + "; layers in the file: " + list);
    });
}

ImageLayer expandToFrame(const ImageLayer& layer, int frameWidth, int frameHeight) {
    ImageLayer whole{layer.name, frameWidth, frameHeight,
                     std::vector<float>(3 * static_cast<size_t>(frameWidth) * static_cast<size_t>(frameHeight), 0.0f)};
    const int x0 = std::max(layer.x, 0), x1 = std::min(layer.x + layer.width, frameWidth);
    const int y0 = std::max(layer.y, 0), y1 = std::min(layer.y + layer.height, frameHeight);
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x)
            for (int c = 0; c < 3; ++c)
                whole.rgb[(static_cast<size_t>(y) * frameWidth + x) * 3 + c] =
                    layer.rgb[(static_cast<size_t>(y - layer.y) * layer.width + (x - layer.x)) * 3 + c];
    return whole;
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

namespace {

void writePngPixels(OutputFiles& outputs, const std::string& path, const ImageLayer& image,
                    const std::vector<std::uint8_t>& pixels) {
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

}  // namespace

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
    writePngPixels(outputs, path, image, pixels);
}

void writeDisplayPng(OutputFiles& outputs, const std::string& path, const ImageLayer& displayRgb) {
    checkLayer(displayRgb);
    std::vector<std::uint8_t> pixels(displayRgb.rgb.size());
    for (size_t i = 0; i < pixels.size(); ++i) {
        const float v = displayRgb.rgb[i];
        pixels[i] = static_cast<std::uint8_t>(std::lround(255.0 * (std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 0.0f)));
    }
    writePngPixels(outputs, path, displayRgb, pixels);
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

ImageLayer rgbLayerFromXyz(const std::string& name, const std::vector<float>& xyz, int width, int height, int x, int y) {
    ImageLayer layer{name, width, height, std::vector<float>(xyz.size()), x, y};
    for (size_t i = 0; i < xyz.size(); i += 3) {
        const glm::dvec3 rgb = xyzToLinearSrgb({xyz[i], xyz[i + 1], xyz[i + 2]});
        for (int c = 0; c < 3; ++c) layer.rgb[i + c] = static_cast<float>(rgb[c]);
    }
    return layer;
}

ImageLayer rgbLayerFromXyz(const std::string& name, std::vector<float>&& xyz, int width, int height, int x, int y) {
    ImageLayer layer{name, width, height, std::move(xyz), x, y};
    for (size_t i = 0; i < layer.rgb.size(); i += 3) {
        const glm::dvec3 rgb = xyzToLinearSrgb({layer.rgb[i], layer.rgb[i + 1], layer.rgb[i + 2]});
        for (int c = 0; c < 3; ++c) layer.rgb[i + c] = static_cast<float>(rgb[c]);
    }
    return layer;
}

}  // namespace flare
