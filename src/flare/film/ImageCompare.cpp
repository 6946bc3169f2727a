#include "flare/film/ImageCompare.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "flare/core/Error.h"
#include "flare/core/Spectrum.h"

namespace flare {

namespace {

std::string sizeText(const ImageLayer& image) {
    return std::to_string(image.width) + " x " + std::to_string(image.height);
}

void checkShape(const ImageLayer& image) {
    if (image.width < 0 || image.height < 0 ||
        image.rgb.size() != 3 * static_cast<size_t>(image.width) * static_cast<size_t>(image.height))
        throw std::logic_error("compareImages: rgb holds " + std::to_string(image.rgb.size()) +
                               " values for a " + sizeText(image) + " image");
}

// A NaN or infinity would make every sum NaN and the report meaningless; the engine never writes
// one (writeExr refuses them), so it can only come from a foreign or damaged file: a user-input
// error, reported at the first offending pixel so it can be found.
void checkFinite(const ImageLayer& image, const std::string& label) {
    const auto bad = std::find_if(image.rgb.begin(), image.rgb.end(), [](float v) { return !std::isfinite(v); });
    if (bad == image.rgb.end()) return;
    const size_t index = static_cast<size_t>(bad - image.rgb.begin());
    const size_t pixel = index / 3;
    const size_t x = pixel % static_cast<size_t>(image.width), y = pixel / static_cast<size_t>(image.width);
    throw InputError(label, 0,
                     "pixel (" + std::to_string(x) + ", " + std::to_string(y) + ") channel " + "RGB"[index % 3] +
                         " of layer " + (image.name.empty() ? std::string("(main)") : image.name) + " is " +
                         (std::isnan(*bad) ? "NaN" : "infinite") + "; cannot compare");
}

// numerator / denominator, or empty when the denominator is exactly zero (the reference gives no
// scale). Any non-zero denominator is a sum of finite floats' products, so the ratio is finite.
std::optional<double> ratio(double numerator, double denominator) {
    if (denominator == 0.0) return std::nullopt;
    return numerator / denominator;
}

}  // namespace

ImageComparison compareImages(const ImageLayer& a, const ImageLayer& b, const std::string& aLabel,
                              const std::string& bLabel) {
    checkShape(a);
    checkShape(b);
    if (a.width != b.width || a.height != b.height)
        throw InputError(aLabel, 0,
                         "image is " + sizeText(a) + " pixels but the reference " + bLabel + " is " + sizeText(b) +
                             "; cannot compare images of different sizes");
    checkFinite(a, aLabel);
    checkFinite(b, bLabel);

    // Sums in double: a float squared (≤ 1.2e77) times any pixel count stays far below the double
    // range, and the products of floats are exact in double, so only the additions round.
    std::array<double, 3> diffSquared{}, refSquared{};
    double sumYA = 0.0, sumYB = 0.0, maxAbsDiff = 0.0;
    for (size_t i = 0; i < a.rgb.size(); i += 3) {
        const glm::dvec3 pa(a.rgb[i], a.rgb[i + 1], a.rgb[i + 2]);
        const glm::dvec3 pb(b.rgb[i], b.rgb[i + 1], b.rgb[i + 2]);
        for (int c = 0; c < 3; ++c) {
            const double d = pa[c] - pb[c];  // exact: the difference of two floats fits a double
            diffSquared[c] += d * d;
            refSquared[c] += pb[c] * pb[c];
            maxAbsDiff = std::max(maxAbsDiff, std::abs(d));
        }
        sumYA += linearSrgbToXyz(pa).y;
        sumYB += linearSrgbToXyz(pb).y;
    }

    ImageComparison result;
    result.width = a.width;
    result.height = a.height;
    result.pixels = static_cast<long long>(a.width) * a.height;
    const double diffTotal = diffSquared[0] + diffSquared[1] + diffSquared[2];
    const double refTotal = refSquared[0] + refSquared[1] + refSquared[2];
    // relMse = (Σd²/3N)/(Σb²/3N): the 3N cancels, so compute it as the plain ratio (no rounding from
    // the division by 3N) and relL2 as its square root, which keeps relMse = relL2² to the last bit
    // up to the sqrt's own rounding.
    result.relMse = ratio(diffTotal, refTotal);
    if (result.relMse) result.relL2 = std::sqrt(*result.relMse);
    for (int c = 0; c < 3; ++c)
        if (const auto r = ratio(diffSquared[c], refSquared[c])) result.relL2Rgb[c] = std::sqrt(*r);
    result.powerRatio = ratio(sumYA, sumYB);
    result.sumYA = sumYA;
    result.sumYB = sumYB;
    result.maxAbsDiff = maxAbsDiff;
    return result;
}

nlohmann::json imageComparisonJson(const ImageComparison& c) {
    const auto orNull = [](const std::optional<double>& value) {
        return value ? nlohmann::json(*value) : nlohmann::json(nullptr);
    };
    nlohmann::json rgb = nlohmann::json::array();
    for (const auto& value : c.relL2Rgb) rgb.push_back(orNull(value));
    return {
        {"width", c.width},
        {"height", c.height},
        {"pixels", c.pixels},
        {"rel_l2", orNull(c.relL2)},
        {"rel_mse", orNull(c.relMse)},
        {"power_ratio", orNull(c.powerRatio)},
        {"max_abs_diff", c.maxAbsDiff},
        {"rel_l2_rgb", rgb},
        {"sum_y_a", c.sumYA},
        {"sum_y_b", c.sumYB},
    };
}

}  // namespace flare
