// `flare ghosts`: the per-ghost table (paraxial ghost focus, power, footprint) for one light.
#pragma once

#include <CLI/CLI.hpp>

namespace flare::cli {

void addGhostCommands(CLI::App& app);

}  // namespace flare::cli
