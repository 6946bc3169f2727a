// The lens and its state as every command takes them: a positional lens (file or shipped name)
// with --zoom, --focus and --f-number.
#pragma once

#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "flare/optics/LensSystem.h"

namespace flare::cli {

struct LensOptions {
    std::string file;
    std::string zoom;
    std::optional<double> focusMm;
    std::optional<double> fNumber;

    LensState state() const { return LensState{zoom, focusMm, fNumber}; }
};

void addLensOptions(CLI::App* command, LensOptions& options, const std::string& positionalHelp);

// Loads options.file (a path or a shipped lens name) and builds it at the requested state.
LensSystem buildLens(const LensOptions& options);

}  // namespace flare::cli
