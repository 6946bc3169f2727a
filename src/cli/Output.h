// What the commands print: JSON on stdout. (Output files go through flare::OutputFiles: checked
// before any work, written all or nothing; src/flare/core/OutputFiles.h.)
#pragma once

#include <optional>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "flare/film/ImageIO.h"

namespace flare::cli {

// `j` as text, indented by two spaces. Bytes that are not UTF-8 (a lens, light or grid name read
// from a file can hold any) are replaced by U+FFFD instead of failing the command.
std::string jsonText(const nlohmann::json& j);

// `--exposure STOPS` of the commands that write a PNG (--png): the linear image is multiplied by
// 2^STOPS before the tone curve (displayEncode, ImageIO.h; docs/rendering.md, "The PNG").
void addExposureOption(CLI::App* command, std::optional<double>& stops);
// `--compression piz|zip|none`: the EXR's lossless compression (ExrCompression, ImageIO.h). PIZ
// by default; none writes a 1080p composite in a quarter of PIZ's time at twice its size.
void addCompressionOption(CLI::App* command, ExrCompression& compression);
// The PNG's exposure multiplier: 2^stops when given, else chosen from the ghost layer (two stops
// under autoExposure, so that overlapping ghosts keep their colour while the light's own image
// clips, as in a photograph of a flare) and, unless quiet, said on stderr in stops so that it can
// be fixed for a sequence of frames.
double pngExposure(const std::optional<double>& stops, const ImageLayer& ghostLayer, const char* command, bool quiet);

}  // namespace flare::cli
