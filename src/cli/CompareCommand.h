// `flare compare A.exr B.exr`: error metrics of image A against the reference B (relative L2 and
// MSE, total power ratio, maximum difference), as aligned text or one JSON object.
#pragma once

#include <CLI/CLI.hpp>

namespace flare::cli {

void addCompareCommand(CLI::App& app);

}  // namespace flare::cli
