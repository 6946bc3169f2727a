// `flare render`: the physically based final render (photon tracing, guided or naive).
#pragma once

#include <CLI/CLI.hpp>

namespace flare::cli {

void addRenderCommand(CLI::App& app);

}  // namespace flare::cli
