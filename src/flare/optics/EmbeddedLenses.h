// The lenses shipped in lenses/, compiled into the library so that they can be named without a
// path (the CLI resolves "double-gauss-50mm" to the embedded copy when no such file exists).
#pragma once

#include <span>

namespace flare {

struct EmbeddedLens {
    const char* name;  // file name without extension
    const char* text;
};

std::span<const EmbeddedLens> embeddedLenses();

}  // namespace flare
