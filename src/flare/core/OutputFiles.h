// Output files written all or nothing (docs/robustness.md, "Outputs").
//
// Every output is written first to a temporary file; only when all of a command's outputs are
// complete are they moved into place together (commit()). If anything fails before, or the set is
// dropped uncommitted, the temporaries are removed and nothing at the output paths has changed.
//
// What an output path names decides how it is written:
// - a regular file, or nothing yet: the temporary is made beside the target (same folder, so that
//   the final rename is atomic) and renamed over it; a file replaced keeps its permission bits;
// - a symbolic link: followed (through a chain of links) to the path it names, which is written
//   as above: the link stays a link and its target gets the content, as with every Unix tool;
// - a character device (/dev/null, a terminal) or a FIFO or pipe (/dev/stdout in a pipeline, a
//   shell's >(...)): written through, never replaced: the finished temporary, kept in the
//   temporary folder, is copied into it when the set is committed;
// - a folder, a socket or a block device: refused.
// add() checks a path before any work is done, so that a long render cannot fail at its end for
// want of a folder: it creates and renames a probe file in the target's folder.
#pragma once

#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace flare {

class OutputFiles {
public:
    OutputFiles() = default;
    ~OutputFiles();  // removes the temporaries of an uncommitted set
    OutputFiles(const OutputFiles&) = delete;
    OutputFiles& operator=(const OutputFiles&) = delete;

    // Checks that `path` can be written and adds it to the set. Throws InputError(path, 0, why)
    // (InputError(what, 0, ...) for an empty path: `what` names it, e.g. the option "--png") for a
    // missing or unwritable folder, a folder, socket or block device at the path, a path that
    // cannot be resolved, or a path whose target the set already writes.
    void add(const std::string& path, const std::string& what = "output");

    // Whether `path` (added) is written through (a character device or a FIFO) rather than replaced.
    bool writesThrough(const std::string& path) const;

    // The file to write `path`'s content into: a temporary created (empty) on the first call.
    // `path` must have been added. Throws std::runtime_error if it cannot be created.
    const std::string& file(const std::string& path);

    // Writes `content` into file(path).
    void write(const std::string& path, std::string_view content);

    // Moves every written output into place: devices and FIFOs first (their content copied through),
    // then the renames. Throws std::runtime_error naming the output that failed; outputs not yet
    // moved are then removed (the renames come last, after every file is complete, and fail only
    // if the folder changed since add()).
    void commit();

private:
    struct Output {
        std::string path, target;  // as given; the file replaced (symbolic links followed)
        bool through = false;
        bool keepMode = false;
        unsigned mode = 0;  // of the replaced file
        std::string temporary;
        bool moved = false;
    };
    Output& find(const std::string& path);
    const Output& find(const std::string& path) const;

    std::vector<Output> outputs_;
    bool committed_ = false;
};

// One output file, all or nothing: `write` fills the given file (a temporary), which then
// replaces (or is written through) `path` as OutputFiles does. Throws as add() and commit() do,
// and whatever `write` throws (the temporary is removed).
void writeOutputFile(const std::string& path, const std::function<void(const std::string& file)>& write);
void writeOutputFile(const std::string& path, std::string_view content);

}  // namespace flare
