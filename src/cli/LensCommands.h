// `flare lens info` and `flare lens draw`.
#pragma once

#include <CLI/CLI.hpp>

namespace flare::cli {

void addLensCommands(CLI::App& app);

}  // namespace flare::cli
