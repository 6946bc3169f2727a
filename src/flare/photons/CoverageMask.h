// Where on a surface dust or grease sits: a grey-level image laid over the surface that scales
// the contamination's coverage point by point (local coverage = coverage × mask value), so that a
// fingerprint is a smudge with ridges, not a uniform film, and dust gathers towards the rim.
//
// The image is data, not a picture: a pixel's value is its stored code value over the largest
// one (0..255 or 0..65535; no gamma decoding), an RGB pixel's value is the Rec.709 luminance
// 0.2126 R + 0.7152 G + 0.0722 B of those values, and alpha composites over black (transparent:
// clean). An EXR mask gives its values directly (its Y channel, or the luminance of R, G, B, or its
// only channel); they must lie in [0, 1].
//
// Placement, in the surface's x, y (mm): the image is a widthMm × heightMm rectangle centred at
// centreMm, its columns running along +x and its rows from +y (top row) to −y. That is the image as
// the photographer sees it through the lens (from the sensor side, x to the right, y up). Outside
// the rectangle the mask is 0. Values are piecewise constant over pixels (nearest pixel): every
// lookup is one of the stored values, so an all-black mask is exactly no contamination.
#pragma once

#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include <glm/vec2.hpp>

namespace flare {

class CoverageMask {
public:
    // Reads a PNG (8- or 16-bit, grey or RGB, with or without alpha, or palette) or an OpenEXR
    // image. Any problem (missing or unreadable file, neither PNG nor EXR, an EXR value outside
    // [0, 1] or not finite, a channel layout it cannot use) throws InputError(path, 0, problem).
    static CoverageMask load(const std::string& path);

    // From values (row-major, first row at the top, each in [0, 1]); throws std::invalid_argument
    // for a wrong count, an empty image or a value outside [0, 1].
    static CoverageMask fromValues(int widthPx, int heightPx, std::vector<float> values);

    // Places the image on the surface (see above). widthMm and heightMm must be > 0.
    void place(double widthMm, double heightMm, const glm::dvec2& centreMm);

    int widthPx() const { return widthPx_; }
    int heightPx() const { return heightPx_; }
    double widthMm() const { return widthMm_; }
    double heightMm() const { return heightMm_; }
    glm::dvec2 centreMm() const { return centreMm_; }
    const std::string& sourceFile() const { return sourceFile_; }  // "" for fromValues()
    bool allZero() const { return maxValue_ <= 0.0f; }
    double meanValue() const { return meanValue_; }  // over the pixels

    // The mask value at (xMm, yMm) on the surface: its pixel's value, 0 outside the rectangle
    // (also for NaN). Never throws.
    double valueAt(double xMm, double yMm) const {
        const double u = (xMm - centreMm_.x) / widthMm_ + 0.5;
        const double v = 0.5 - (yMm - centreMm_.y) / heightMm_;
        if (!(u >= 0.0 && u < 1.0 && v >= 0.0 && v < 1.0)) return 0.0;
        const int column = std::min(static_cast<int>(u * widthPx_), widthPx_ - 1);
        const int row = std::min(static_cast<int>(v * heightPx_), heightPx_ - 1);
        return values_[static_cast<std::size_t>(row) * widthPx_ + column];
    }

private:
    int widthPx_ = 0, heightPx_ = 0;
    std::vector<float> values_;
    float maxValue_ = 0.0f;
    double meanValue_ = 0.0;
    double widthMm_ = 1.0, heightMm_ = 1.0;
    glm::dvec2 centreMm_{0.0};
    std::string sourceFile_;
};

}  // namespace flare
