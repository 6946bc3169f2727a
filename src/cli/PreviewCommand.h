// `flare preview`: the deterministic ghost preview of a scene, written as a layered EXR and PNG.
#pragma once

#include <CLI/CLI.hpp>

namespace flare::cli {

void addPreviewCommand(CLI::App& app);

}  // namespace flare::cli
