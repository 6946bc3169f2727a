#include "CompareCommand.h"

#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "flare/core/Error.h"
#include "flare/film/ImageCompare.h"
#include "flare/film/ImageIO.h"

namespace flare::cli {

namespace {

struct CompareCommandOptions {
    std::string a, b;
    std::string layer;  // "" = the main RGB image
    bool json = false;
};

std::string layerDisplayName(const std::string& name) { return name.empty() ? "(main)" : name; }

// The requested layer of `path`. A missing layer is the user's error (a typo, or a file written
// without --layers), so the message lists what the file does have.
ImageLayer readLayer(const std::string& path, const std::string& name) {
    std::vector<ImageLayer> layers = readExr(path);
    for (ImageLayer& layer : layers)
        if (layer.name == name) return std::move(layer);
    std::string available;
    for (const ImageLayer& layer : layers) available += (available.empty() ? "" : ", ") + layerDisplayName(layer.name);
    const std::string wanted = name.empty() ? std::string("no main RGB layer (R, G, B)") : "no layer \"" + name + "\"";
    throw InputError(path, 0, wanted + "; layers in the file: " + available);
}

nlohmann::json orNull(const std::optional<double>& value) {
    return value ? nlohmann::json(*value) : nlohmann::json(nullptr);
}

nlohmann::json comparisonJson(const CompareCommandOptions& o, const ImageComparison& c) {
    nlohmann::json rgb = nlohmann::json::array();
    for (const auto& value : c.relL2Rgb) rgb.push_back(orNull(value));
    return {
        {"a", o.a},
        {"b", o.b},
        {"layer", o.layer},
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

// Never prints NaN: an undefined metric (zero reference) says so and why.
std::string formatMetric(const std::optional<double>& value, const char* whyUndefined) {
    if (!value) return std::string("undefined (") + whyUndefined + ")";
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.6g", *value);
    return buffer;
}

void printComparison(const CompareCommandOptions& o, const ImageComparison& c) {
    constexpr const char* kZeroReference = "the reference is all zero";
    constexpr const char* kZeroChannel = "the reference channel is all zero";
    const auto line = [](const char* key, const std::string& value) { std::printf("%-14s%s\n", key, value.c_str()); };
    line("a", o.a);
    line("b", o.b + " (reference)");
    line("layer", layerDisplayName(o.layer));
    line("size", std::to_string(c.width) + " x " + std::to_string(c.height) + " (" + std::to_string(c.pixels) +
                     " pixels)");
    line("rel_l2", formatMetric(c.relL2, kZeroReference));
    line("rel_mse", formatMetric(c.relMse, kZeroReference));
    line("power_ratio", formatMetric(c.powerRatio, "the reference's total luminance is zero"));
    line("max_abs_diff", formatMetric(c.maxAbsDiff, ""));
    const char* channelKeys[3] = {"rel_l2 R", "rel_l2 G", "rel_l2 B"};
    for (int k = 0; k < 3; ++k) line(channelKeys[k], formatMetric(c.relL2Rgb[k], kZeroChannel));
}

void run(const CompareCommandOptions& o) {
    const ImageLayer a = readLayer(o.a, o.layer);
    const ImageLayer b = readLayer(o.b, o.layer);
    const ImageComparison comparison = compareImages(a, b, o.a, o.b);
    if (o.json) std::cout << comparisonJson(o, comparison).dump(2) << "\n";
    else printComparison(o, comparison);
}

}  // namespace

void addCompareCommand(CLI::App& app) {
    auto o = std::make_shared<CompareCommandOptions>();
    CLI::App* compare = app.add_subcommand("compare", "error metrics of image A against a reference image B (EXR)");
    compare->add_option("A", o->a, "EXR image to assess")->required();
    compare->add_option("B", o->b, "reference EXR image, same size")->required();
    compare->add_option("--layer", o->layer, "layer to compare in both files (default: the main RGB image)");
    compare->add_flag("--json", o->json, "print one JSON object");
    compare->callback([o] { run(*o); });
}

}  // namespace flare::cli
