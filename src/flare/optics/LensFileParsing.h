// Internal to the lens readers, not a public API (callers use LensFile.h): what the native `.lens`
// reader (LensFile.cpp) and pbrt's `.dat` reader (PbrtLensFile.cpp) share. The text split into
// numbered lines, tokens read as numbers, fractions, key=value pairs and glasses with errors that
// name the file and line, and the checks every reader makes once its rows are read.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "flare/optics/LensPrescription.h"

namespace flare::lensfile {

std::string_view trim(std::string_view s);

// One source line with its number, comment removed.
struct Line {
    int number;
    std::string_view text;
};

// The non-empty lines of `text` (numbered from 1), each without its '#' comment and surrounding
// white space.
std::vector<Line> splitLines(std::string_view text);

// Reads the tokens of one file; every problem raises InputError naming the file and the line.
class Parser {
public:
    Parser(std::string file) : file_(std::move(file)) {}

    [[noreturn]] void error(int line, const std::string& problem) const;

    // A number, or ±inf / ±infinity in any case.
    double number(int line, std::string_view token, const std::string& what) const;
    double finiteNumber(int line, std::string_view token, const std::string& what) const;
    double fraction(int line, std::string_view token, const std::string& what) const;
    double positive(int line, std::string_view token, const std::string& what) const;
    // Splits "key=value" (the key in lower case); errors if there is no '='.
    std::pair<std::string, std::string_view> keyValue(int line, std::string_view token) const;
    // The material column: air, n=<constant index>, nd/Vd, or a catalogue glass made for the visible.
    Medium material(int line, std::string_view token) const;

private:
    std::string file_;
};

// The row's semi-aperture lies within its surface (a sphere's |radius|, a conic's extent).
void checkAperture(const Parser& parser, const PrescriptionRow& row);

// Only the stop row's semi-aperture may name an `aperture` line (an element's clear aperture is
// glass and does not change with zoom; the iris does), and every `aperture` line is used.
void checkApertures(const Parser& parser, const LensPrescription& p);

// Checks that apply to every format once all rows are read (validatePrescription in LensFile.h).
void validate(const Parser& parser, const LensPrescription& p, int lastLine);

}  // namespace flare::lensfile
