#include "Output.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <string>

namespace flare::cli {

std::string jsonText(const nlohmann::json& j) {
    return j.dump(2, ' ', /*ensure_ascii=*/false, nlohmann::json::error_handler_t::replace);
}

void addExposureOption(CLI::App* command, std::optional<double>& stops) {
    command
        ->add_option("--exposure", stops,
                     "the PNG's exposure in stops: the linear image times 2^STOPS before the tone curve (default: "
                     "chosen from the ghosts, and printed)")
        ->check(CLI::Range(-64.0, 64.0));
}

void addCompressionOption(CLI::App* command, ExrCompression& compression) {
    const std::map<std::string, ExrCompression> names = {
        {"piz", ExrCompression::Piz}, {"zip", ExrCompression::Zip}, {"none", ExrCompression::None}};
    command
        ->add_option("--compression", compression,
                     "the EXR's lossless compression: piz (default; grainy images), zip (smooth ones) or none "
                     "(fastest to write, largest)")
        ->transform(CLI::CheckedTransformer(names, CLI::ignore_case));
}

double pngExposure(const std::optional<double>& stops, const ImageLayer& ghostLayer, const char* command, bool quiet) {
    if (stops) return std::exp2(*stops);
    const double exposure = 0.25 * autoExposure(ghostLayer);
    if (!quiet)
        std::fprintf(stderr, "%s: PNG exposure %+.2f stops (automatic; --exposure %.2f keeps it)\n", command,
                     std::log2(exposure), std::log2(exposure));
    return exposure;
}

}  // namespace flare::cli
