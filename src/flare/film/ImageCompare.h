// Error metrics of an image A against a reference B of the same size: how far a render (a preview,
// a photon render at some budget, a build after a change) is from a reference image, in the
// numbers that convergence plots and regression checks use.
#pragma once

#include <array>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "flare/film/ImageIO.h"

namespace flare {

// All sums run over every pixel and the three channels of linear Rec.709 RGB, in double precision.
// A relative metric whose denominator is exactly zero is undefined and left empty (std::nullopt)
// rather than set to NaN or infinity: an all-zero reference has no scale to be relative to.
struct ImageComparison {
    int width = 0, height = 0;
    long long pixels = 0;  // width × height

    // Relative L2 error ‖A − B‖₂ / ‖B‖₂ over all pixels and channels. Empty when B is all zero.
    std::optional<double> relL2;
    // The same per channel (R, G, B): ‖A_c − B_c‖₂ / ‖B_c‖₂, empty when channel c of B is all zero.
    std::array<std::optional<double>, 3> relL2Rgb;

    // Relative MSE = mean((A − B)²) / mean(B²), both means over all pixels and channels, so that
    // relMse = relL2² exactly. This is the *global* normalisation, chosen over the per-pixel
    // mean((A − B)² / (B² + ε)) common in denoising papers: the per-pixel form needs an ε, and for
    // a flare image (a few bright ghosts on a black field) its value is dominated by whichever
    // near-black pixels ε lets through, i.e. by ε itself. Here the bright structures the user sees
    // carry the weight, and there is no free parameter. Empty when B is all zero.
    std::optional<double> relMse;

    // Ratio of total power ΣY(A) / ΣY(B), Y the CIE luminance of linear Rec.709 RGB
    // (Y = 0.2126 R + 0.7152 G + 0.0722 B, to the printed digits; the engine's exact matrix from
    // linearSrgbToXyz is used). 1 means the same total light whatever its distribution; it tells an
    // energy error (wrong Fresnel weight, lost photons) from a noise or blur error. Empty when
    // ΣY(B) is exactly zero.
    std::optional<double> powerRatio;
    double sumYA = 0.0, sumYB = 0.0;  // ΣY over the pixels of A and of B

    // max |A − B| over all pixels and channels (absolute, in the images' units); 0 for identical images.
    double maxAbsDiff = 0.0;
};

// Compares A against the reference B. `aLabel` and `bLabel` (usually the file names) only name the
// images in errors. Images of different sizes, or with a NaN or infinite value, throw
// InputError naming the image(s) and the sizes or the pixel. An `rgb` whose length is not
// 3·width·height is a programming error (std::logic_error).
ImageComparison compareImages(const ImageLayer& a, const ImageLayer& b, const std::string& aLabel = "A",
                              const std::string& bLabel = "B");

// The metrics as `flare compare --json` prints them (without the file names): width, height,
// pixels, rel_l2, rel_mse, power_ratio, max_abs_diff, rel_l2_rgb, sum_y_a, sum_y_b; an undefined
// metric is null.
nlohmann::json imageComparisonJson(const ImageComparison& c);

}  // namespace flare
