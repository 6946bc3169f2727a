// Text files written by other programs: Zemax writes its .zmx and .agf files either as UTF-16
// little-endian with a byte-order mark or as 8-bit text (ASCII or UTF-8, with or without a BOM).
// Readers decode the bytes once and parse UTF-8 lines.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace flare {

// The bytes as UTF-8: UTF-16 LE or BE with a BOM is transcoded (an unpaired surrogate becomes
// U+FFFD), a UTF-8 BOM is dropped, anything else is returned as it is. Line ends are left alone.
// UTF-16 with an odd number of bytes (a file cut short, or not UTF-16 after all) raises
// InputError(file, 0, ...).
std::string decodeText(std::string_view bytes, const std::string& file = "");

// The reverse for writers: UTF-8 text as UTF-16 little-endian with a byte-order mark, as Zemax
// writes its own files (a malformed UTF-8 sequence becomes U+FFFD).
std::string encodeUtf16Le(std::string_view utf8);

// Reads a whole file as bytes; raises InputError(path, 0, ...) naming `what` when it cannot be read.
std::string readFileBytes(const std::string& path, const std::string& what);

// What the line-based readers (.lens, .zmx, .agf) share: a line's whitespace-separated tokens
// (views into it), and ASCII case folding for keywords and glass names.
std::vector<std::string_view> splitWhitespace(std::string_view line);
std::string asciiUpper(std::string_view s);
std::string asciiLower(std::string_view s);

// For the writers: the shortest decimal text that reads back as the same double (std::to_chars),
// so that a number written and read again is the number it was.
std::string shortestNumberText(double value);

}  // namespace flare
