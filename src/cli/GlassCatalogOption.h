// `--glass-catalog FILE.agf` on every command that reads lenses: a private Zemax glass catalogue
// whose glasses the lens files may use (useGlassCatalog, flare/optics/AgfCatalog.h).
#pragma once

#include <CLI/CLI.hpp>

namespace flare::cli {

// Adds the option to the commands that read lenses (lens info, check, export and draw, ghosts,
// preview, render), once they are all defined. Each file given is read before the command runs:
// a missing or malformed one stops it with exit code 2 before any work.
void addGlassCatalogOptions(CLI::App& app);

}  // namespace flare::cli
