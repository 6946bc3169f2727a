#include "LayersOption.h"

#include <stdexcept>

namespace flare::cli {

void addLayersOption(CLI::App* command, LayersOption& option, const std::string& what) {
    command->add_option("--layers", option.text,
                        what + "; with a value, keep the strongest ghosts' layers and sum the rest into ghost_other: "
                               "top:N (the N strongest) or share:F (the strongest until they hold F of the ghosts' "
                               "power, 0 < F <= 1); each ghost's layer covers its footprint (an EXR part with its own "
                               "data window)")
        ->expected(0, 1)
        ->default_str("all")
        ->type_name("[all|top:N|share:F]");
}

void resolveLayersOption(CLI::App* command, LayersOption& option, std::string& scene) {
    option.given = command->count("--layers") > 0;
    if (!option.given) return;
    try {
        option.selection = LayerSelection::parse(option.text);
    } catch (const std::invalid_argument& e) {
        if (!scene.empty() || option.text.empty()) throw CLI::ValidationError("--layers", e.what());
        scene = option.text;
        option.text = "all";
        option.selection = {};
    }
}

}  // namespace flare::cli
