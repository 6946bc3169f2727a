// The starburst's report on the terminal, shared by `flare preview` and `flare render`.
#pragma once

#include "flare/wave/Starburst.h"

namespace flare::cli {

// One line per light on stderr: what its PSF was built from and where its energy went.
void printStarburst(const StarburstImage& image);

}  // namespace flare::cli
