#include "LensOptions.h"

#include "flare/optics/LensFile.h"

namespace flare::cli {

void addLensOptions(CLI::App* command, LensOptions& options, const std::string& positionalHelp) {
    command->add_option("LENS", options.file, positionalHelp)->required();
    command->add_option("--zoom", options.zoom, "zoom position name, or a focal length in mm");
    command->add_option("--focus", options.focusMm,
                        "object distance in mm from the first vertex (default: the file's, usually infinity)")
        ->check(CLI::PositiveNumber);
    command->add_option("--f-number", options.fNumber, "stop the iris down to this f-number")
        ->check(CLI::PositiveNumber);
}

LensSystem buildLens(const LensOptions& options) {
    return LensSystem::build(loadLens(options.file), options.state());
}

}  // namespace flare::cli
