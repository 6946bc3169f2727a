// `flare composite`: the flare of a plate's bright sources through a lens, added over the plate
// (docs/composite.md).
#pragma once

#include <CLI/CLI.hpp>

namespace flare::cli {

void addCompositeCommand(CLI::App& app);

}  // namespace flare::cli
