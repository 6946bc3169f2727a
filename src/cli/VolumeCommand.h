// `flare volume make` and `flare volume info`: procedural OpenVDB density grids for glass bulk
// scattering, and a summary of a .vdb grid (docs/volumes.md).
#pragma once

#include <CLI/CLI.hpp>

namespace flare::cli {

void addVolumeCommands(CLI::App& app);

}  // namespace flare::cli
