// Bodies of the libFuzzer targets (tests/fuzz/fuzz_*.cpp), kept apart from the entry points so
// that the default test suite can replay every input kept under tests/data/fuzz/ through exactly
// the code the fuzzer ran (tests/unit/fuzz/test_fuzz_regressions.cpp).
//
// Each body feeds one input to an engine reader and swallows the error the reader documents for
// bad input (InputError; std::runtime_error for Film::load). Anything else escapes: an exception
// of another type is a bug in the reader's input validation, and libFuzzer reports it as a crash,
// as it does for the memory errors and undefined behaviour that ASan and UBSan catch.
#pragma once

#include <string>
#include <string_view>

namespace flare::fuzz {

// parseLensText, parsePbrtLensText and parseZemaxText on the same text; a lens that parses is built and a few
// rays are traced through it (sequentially and with the photon tracer).
void lensInput(std::string_view data);
// parseZemaxText alone (its own seeds: .zmx files in both encodings, which the .lens seeds of
// lensInput do not resemble); a lens that parses is built and traced as in lensInput.
void zmxInput(std::string_view data);
// AgfCatalog::parse on the decoded bytes (UTF-16 or 8-bit, as AgfCatalog::load reads a file); every
// glass of a catalogue that parses has its index evaluated across the visible, and the first few
// that cover it (what the .zmx reader accepts) are put into a singlet that is built and traced.
void agfInput(std::string_view data);
// parseSceneText; a scene that names a shipped lens is then built (zoom, focus, f-number,
// sensor size checks).
void sceneInput(std::string_view data);
// readExr on the bytes written to a temporary file.
void exrInput(std::string_view data);
// Renderer::loadCheckpoint on the bytes (a small fixed render of the double Gauss), and
// Film::load of a film of that render's settings when the bytes are a bare film.
void checkpointInput(std::string_view data);
// VolumeGrid::load (the loader of `flare volume info` and of scenes' volumes) on the bytes written
// to a temporary .vdb file; a grid that loads has its bounds, statistics, active boxes and a few
// densities read.
void vdbInput(std::string_view data);

// How many inputs the exr, checkpoint and vdb bodies' loaders have accepted in this process. The
// replay test's evidence that the bytes reach the loaders through the memory file these bodies
// write them to: were it to fail, every input would be refused as bad input and nothing else would
// show it.
long acceptedInputCount();

// Writes seed inputs that cannot be copied from the source tree: small EXRs (float and half,
// scanline and tiled, several compressions, layers, offset and negative data windows), a checkpoint and a bare film of the render
// checkpointInput uses, small .vdb files (float grids as flare writes them, compressed and
// not, and the grids load() rejects), .zmx files (the shipped lenses and a few library lenses as
// writeZemax writes them, in UTF-8 and UTF-16, and hand-written files using what the writer never
// writes) and small .agf files (a few glasses of each shipped catalogue, whose files are
// 400-640 kB, and one glass of every formula). Returns the number of files written under dir/exr,
// dir/checkpoint, dir/vdb, dir/zmx and dir/agf.
int writeGeneratedSeeds(const std::string& dir);

}  // namespace flare::fuzz
