#include "CompareCommand.h"
#include "Output.h"

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "flare/film/ImageCompare.h"
#include "flare/film/ImageIO.h"

namespace flare::cli {

namespace {

struct CompareCommandOptions {
    std::string a, b;
    std::string layer;  // "" = the main RGB image
    bool json = false;
};

nlohmann::json comparisonJson(const CompareCommandOptions& o, const ImageComparison& c) {
    nlohmann::json j = imageComparisonJson(c);
    j["a"] = o.a;
    j["b"] = o.b;
    j["layer"] = o.layer;
    return j;
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
    line("layer", o.layer.empty() ? "(main)" : o.layer);
    line("size", std::to_string(c.width) + " x " + std::to_string(c.height) + " (" + std::to_string(c.pixels) +
                     " pixels)");
    line("rel_l2", formatMetric(c.relL2, kZeroReference));
    line("rel_mse", formatMetric(c.relMse, kZeroReference));
    line("power_ratio", formatMetric(c.powerRatio, "the reference's total luminance is zero"));
    line("max_abs_diff", formatMetric(c.maxAbsDiff, ""));
    const char* channelKeys[3] = {"rel_l2 R", "rel_l2 G", "rel_l2 B"};
    for (int k = 0; k < 3; ++k) line(channelKeys[k], formatMetric(c.relL2Rgb[k], kZeroChannel));
}

// A layer, or the sum of layers named "a+b+c" (e.g. the flare without the direct image:
// ghost+higher+scatter, what a render's target error measures).
ImageLayer readLayerSum(const std::string& path, const std::string& layers) {
    ImageLayer sum;
    size_t begin = 0;
    do {
        const size_t end = std::min(layers.find('+', begin), layers.size());
        const ImageLayer part = readExrLayer(path, layers.substr(begin, end - begin));
        if (begin == 0) {
            sum = part;
        } else {
            for (size_t i = 0; i < sum.rgb.size(); ++i) sum.rgb[i] += part.rgb[i];
            sum.name += "+" + part.name;
        }
        begin = end + 1;
    } while (begin <= layers.size());
    return sum;
}

void run(const CompareCommandOptions& o) {
    const ImageLayer a = readLayerSum(o.a, o.layer);
    const ImageLayer b = readLayerSum(o.b, o.layer);
    const ImageComparison comparison = compareImages(a, b, o.a, o.b);
    if (o.json) std::cout << jsonText(comparisonJson(o, comparison)) << "\n";
    else printComparison(o, comparison);
}

}  // namespace

void addCompareCommand(CLI::App& app) {
    auto o = std::make_shared<CompareCommandOptions>();
    CLI::App* compare = app.add_subcommand("compare", "error metrics of image A against a reference image B (EXR)");
    compare->add_option("A", o->a, "EXR image to assess")->required();
    compare->add_option("B", o->b, "reference EXR image, same size")->required();
    compare->add_option("--layer", o->layer, "layer to compare in both files (default: the main RGB image); layers joined by + are summed, "
                    "e.g. ghost+higher+scatter (the flare without the direct image)");
    compare->add_flag("--json", o->json, "print one JSON object");
    compare->callback([o] { run(*o); });
}

}  // namespace flare::cli
