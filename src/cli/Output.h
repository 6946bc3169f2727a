// What the commands print: JSON on stdout. (Output files go through flare::OutputFiles: checked
// before any work, written all or nothing; src/flare/core/OutputFiles.h.)
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace flare::cli {

// `j` as text, indented by two spaces. Bytes that are not UTF-8 (a lens, light or grid name read
// from a file can hold any) are replaced by U+FFFD instead of failing the command.
std::string jsonText(const nlohmann::json& j);

}  // namespace flare::cli
