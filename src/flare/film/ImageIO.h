// Image output: multi-layer OpenEXR (32-bit float, or half precision for selected layers; layers
// over a window of the frame as parts of their own) for the result (and reading it back for tests and
// image comparison), and a tone-mapped 8-bit sRGB PNG for a quick look. Both writers are
// all-or-nothing: they write `path + ".partial"` and rename it over `path` only when complete, so
// a failed or interrupted render never leaves a truncated image under the final name.
#pragma once

#include <cstdint>
#include <array>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>

#include "flare/core/OutputFiles.h"

namespace flare {

// One RGB image: interleaved linear Rec.709 RGB (sRGB primaries, D65 white), row-major, first row
// at the top. Name "" is the main image; other names become EXR layers ("ghosts" → ghosts.R, ...).
// A layer may hold only a window of its frame (a ghost's footprint: the bounding box of the pixels
// it reaches): its width × height pixels start at column x, row y of the frame, and every pixel
// outside the window is zero. A whole-frame layer has x = y = 0 and the frame's size.
struct ImageLayer {
    std::string name;
    int width = 0, height = 0;  // of the window
    std::vector<float> rgb;
    int x = 0, y = 0;  // the window's top-left pixel in the frame
};

// A layer of linear Rec.709 RGB from interleaved CIE XYZ (what the preview and the film hold), at
// (x, y) in its frame.
ImageLayer rgbLayerFromXyz(const std::string& name, const std::vector<float>& xyz, int width, int height, int x = 0,
                           int y = 0);
// The same converted in place (no second copy).
ImageLayer rgbLayerFromXyz(const std::string& name, std::vector<float>&& xyz, int width, int height, int x = 0,
                           int y = 0);

// The layer over the whole frame of frameWidth × frameHeight pixels (zeros outside its window; the
// parts of the window outside the frame dropped), at (0, 0).
ImageLayer expandToFrame(const ImageLayer& layer, int frameWidth, int frameHeight);

// How a layer's channels are stored in an EXR.
enum class ExrStorage : std::uint8_t {
    Float,  // 32-bit float, exact
    // 16-bit half float, which compositing uses: 11 significant bits, magnitudes up to 65504 and
    // full precision from 6.1e-5 (see fitsHalf). A value beyond ±65504 is an error.
    Half,
    // 32-bit float rounded to half's 11 significant bits: half's precision with float's range,
    // for layers whose values lie below half's range (physical units put a weak ghost at 1e-9 of
    // its light). The zeroed low bits make ZIP compress it about as well as half.
    FloatHalfPrecision,
};

// Whether half floats keep a layer: no value beyond ±65504, and every value above 1e-3 of the
// layer's largest magnitude at least half's smallest normal (6.1e-5), where half's relative
// precision (2⁻¹¹) holds.
bool fitsHalf(const ImageLayer& layer);

// The EXR's lossless compression. ZIP suits smooth images (the preview's: with full-frame per-ghost
// layers, 86 MB against PIZ's 138 MB for the default scene); PIZ (a wavelet transform and Huffman
// coding) suits grainy ones, where it is both smaller and faster (the default render's layers,
// full-frame then: 57 MB in 0.5 s against ZIP's 72 MB in 1.0 s on two cores). None suits one
// float image whose low bits are noise, as the preview's main image without layers: ZIP keeps 91 %
// of its bytes (17.3 of 18.9 MB, 1536 × 1024) and takes 30 times as long as storing them.
enum class ExrCompression : std::uint8_t { None, Zip, Piz };

struct ExrWriteOptions {
    std::map<std::string, ExrStorage> storage;  // by layer name; layers not named are Float
    ExrCompression compression = ExrCompression::Zip;
    // Layers written each as a part of its own (by name), with its window as the part's data
    // window: a multi-part file (OpenEXR 2+), whose first part holds the other layers.
    std::set<std::string> ownParts;
    // The `chromaticities` attribute: CIE xy of red, green, blue and white, in that order. Unset:
    // linear Rec.709 (every engine image); `flare composite` gives its plate's (the layers are then
    // in that space).
    std::optional<std::array<double, 8>> chromaticities;
};

// Writes the layers as a losslessly compressed EXR, 32-bit float unless options say otherwise,
// with the standard `chromaticities` attribute (Rec.709 primaries, D65 white) and each metadata
// pair as a string attribute. The first layer is the frame (whole, at (0, 0)); the layers not in
// options.ownParts must be whole frames too, and are written together as the first part (the only
// one without ownParts: a single-part file, as a reader that knows no parts expects). Each layer in
// ownParts is a part of its own named after the layer, its data window the layer's window, its
// display window the frame, channels `name.R`, `name.G`, `name.B` as in the first part (so readers
// that merge the parts by channel name, like Nuke's, keep them apart). Throws std::logic_error for
// malformed input (a window outside the frame or a windowed layer in the first part, duplicate
// layer names, a metadata key that is a standard attribute, any NaN or infinity, a value beyond
// half's range in a Half layer: programming errors) and std::runtime_error naming `path` when the
// file cannot be written (InputError from OutputFiles::add when its folder is not writable);
// nothing is left behind. A symbolic link is followed, a device or FIFO written through
// (OutputFiles).
void writeExr(const std::string& path, const std::vector<ImageLayer>& layers,
              const std::vector<std::pair<std::string, std::string>>& metadata,
              const ExrWriteOptions& options = {});
// The same into `outputs`' temporary for `path` (added to them), moved into place by their commit().
void writeExr(OutputFiles& outputs, const std::string& path, const std::vector<ImageLayer>& layers,
              const std::vector<std::pair<std::string, std::string>>& metadata,
              const ExrWriteOptions& options = {});

// An EXR as stored: its frame (the first part's display window) and every layer that has R, G and B
// channels, in any part, each over its own window (its part's data window, placed relative to the
// display window's corner): the first part's main layer (if any) first, then the others by name.
// Half or float channels are read as float. A missing, unreadable or corrupt file, a layer in two
// parts, or a frame beyond kMaxExrFramePixels throws InputError(path, 0, problem).
struct ExrImage {
    int width = 0, height = 0;  // the frame
    std::vector<ImageLayer> layers;
    std::set<std::string> ownParts;  // the layers read from parts after the first (writeExr's ownParts)
};
constexpr long long kMaxExrFramePixels = 1LL << 28;  // 16384²: the largest scene resolution
ExrImage readExrImage(const std::string& path);

// Every layer of readExrImage over the whole frame (expandToFrame): a frame's memory per layer.
std::vector<ImageLayer> readExr(const std::string& path);

// The layer `name` of an EXR ("" = the main image) over the whole frame; only its part is read. A
// missing layer (a typo, or a file written without --layers) throws InputError(path, 0, problem)
// listing the layers the file does have.
ImageLayer readExrLayer(const std::string& path, const std::string& name);

// Display encoding for the PNG preview of a linear Rec.709 value: multiply by `exposure`, apply
// the Reinhard curve x/(1 + x) to the luminance while keeping the chromaticity (so bright cores
// roll off smoothly instead of clipping to a hue-shifted plateau), pull colours that still leave
// [0, 1]³ toward the grey of the same luminance (spectral ghosts are often out of gamut), then the
// sRGB OETF. Returns non-linear sRGB in [0, 1]³.
glm::dvec3 displayEncode(const glm::dvec3& linearRgb, double exposure);

// 8-bit sRGB PNG of displayEncode(pixel, exposure); all-or-nothing like writeExr, same errors.
void writePng(const std::string& path, const ImageLayer& image, double exposure);
void writePng(OutputFiles& outputs, const std::string& path, const ImageLayer& image, double exposure);
// 8-bit PNG of display-referred values as they are (an OpenColorIO view's output), each clamped to
// [0, 1] (a non-finite value is written as 0); no tone curve, no encoding.
void writeDisplayPng(OutputFiles& outputs, const std::string& path, const ImageLayer& displayRgb);

// An exposure for the PNG preview that shows the ghosts. See ImageIO.cpp for the choice.
double autoExposure(const ImageLayer& image);

}  // namespace flare
