// Writing output files all-or-nothing: the content goes to a temporary file beside the target,
// which is renamed over it only when complete, so a failure never leaves a half-written file.
#pragma once

#include <string>

namespace flare::cli {

// Throws std::runtime_error (with the path and the reason) if the file cannot be written.
void writeFileAtomically(const std::string& path, const std::string& content);

// Checks, before any work, that an output file can be written where it is asked for: its folder
// exists and is writable, and the path is not a folder. Else InputError(path, 0, why), which the
// CLI reports with exit code 2 (a long render must not fail at its end for want of a folder).
void checkWritable(const std::string& path);

}  // namespace flare::cli
