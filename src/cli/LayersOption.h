// `--layers [all|top:N|share:F]`, the per-ghost layers of `flare preview` and `flare render`: a
// bare `--layers` keeps every ghost's layer, `top:N` the N strongest and `share:F` the strongest
// until they hold F of the ghosts' power, the rest summed in one layer (flare/film/LayerSelection.h).
#pragma once

#include <string>

#include <CLI/CLI.hpp>

#include "flare/film/LayerSelection.h"

namespace flare::cli {

struct LayersOption {
    std::string text;  // as given; "all" for a bare --layers
    bool given = false;
    LayerSelection selection;
};

// Adds the option to `command`; `what` says what the layers are.
void addLayersOption(CLI::App* command, LayersOption& option, const std::string& what);

// In the command's callback: whether --layers was given and its selection. A value that is no
// selection while `scene` is empty was the scene of a bare `--layers SCENE` (as the flag was
// written before it took a value): it becomes the scene and every layer is kept. Any other value
// that is no selection throws CLI::ValidationError (exit 2) saying what --layers accepts.
void resolveLayersOption(CLI::App* command, LayersOption& option, std::string& scene);

}  // namespace flare::cli
