// Writing output files all-or-nothing: the content goes to a temporary file beside the target,
// which is renamed over it only when complete, so a failure never leaves a half-written file.
#pragma once

#include <string>

namespace flare::cli {

// Throws std::runtime_error (with the path and the reason) if the file cannot be written.
void writeFileAtomically(const std::string& path, const std::string& content);

}  // namespace flare::cli
