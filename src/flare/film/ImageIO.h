// Image output: multi-layer OpenEXR (32-bit float, or half precision for selected layers) for the result (and reading it back for tests and
// image comparison), and a tone-mapped 8-bit sRGB PNG for a quick look. Both writers are
// all-or-nothing: they write `path + ".partial"` and rename it over `path` only when complete, so
// a failed or interrupted render never leaves a truncated image under the final name.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>

#include "flare/core/OutputFiles.h"

namespace flare {

// One RGB image: interleaved linear Rec.709 RGB (sRGB primaries, D65 white), row-major, first row
// at the top. Name "" is the main image; other names become EXR layers ("ghosts" → ghosts.R, ...).
struct ImageLayer {
    std::string name;
    int width = 0, height = 0;
    std::vector<float> rgb;
};

// A layer of linear Rec.709 RGB from interleaved CIE XYZ (what the preview and the film hold).
ImageLayer rgbLayerFromXyz(const std::string& name, const std::vector<float>& xyz, int width, int height);

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

// The EXR's lossless compression. ZIP suits smooth images (the preview's, with many mostly empty
// per-ghost layers: 86 MB against PIZ's 138 MB for the default scene); PIZ (a wavelet transform
// and Huffman coding) suits grainy ones, where it is both smaller and faster (the default
// render's layers: 57 MB in 0.5 s against ZIP's 72 MB in 1.0 s on two cores).
enum class ExrCompression : std::uint8_t { Zip, Piz };

struct ExrWriteOptions {
    std::map<std::string, ExrStorage> storage;  // by layer name; layers not named are Float
    ExrCompression compression = ExrCompression::Zip;
};

// Writes the layers (all of one size) as a losslessly compressed EXR, 32-bit float unless options say
// otherwise, with the standard `chromaticities` attribute (Rec.709 primaries, D65 white) and each
// metadata pair as a string attribute. Throws std::logic_error for malformed input (mismatched
// sizes, duplicate layer names, a metadata key that is a standard attribute, any NaN or infinity,
// a value beyond half's range in a Half layer: programming errors) and std::runtime_error naming
// `path` when the file cannot be written (InputError from OutputFiles::add when its folder is not
// writable); nothing is left behind. A symbolic link is followed, a device or FIFO written
// through (OutputFiles).
void writeExr(const std::string& path, const std::vector<ImageLayer>& layers,
              const std::vector<std::pair<std::string, std::string>>& metadata,
              const ExrWriteOptions& options = {});
// The same into `outputs`' temporary for `path` (added to them), moved into place by their commit().
void writeExr(OutputFiles& outputs, const std::string& path, const std::vector<ImageLayer>& layers,
              const std::vector<std::pair<std::string, std::string>>& metadata,
              const ExrWriteOptions& options = {});

// Every layer of an EXR that has R, G and B channels, the main one (if any) first, then the others
// by name. Half or float channels are read as float. A missing, unreadable or corrupt file throws
// InputError(path, 0, problem).
std::vector<ImageLayer> readExr(const std::string& path);

// The layer `name` of an EXR ("" = the main image). A missing layer (a typo, or a file written
// without --layers) throws InputError(path, 0, problem) listing the layers the file does have.
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

// An exposure for the PNG preview that shows the ghosts. See ImageIO.cpp for the choice.
double autoExposure(const ImageLayer& image);

}  // namespace flare
