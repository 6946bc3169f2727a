// User-input errors. A malformed lens, scene, volume or image file raises InputError carrying
// the file, the 1-based line (0 when the problem is not tied to a line) and the problem; the CLI
// prints it as "file:line: problem" and exits with code 2. Programming errors are assertions.
#pragma once

#include <stdexcept>
#include <string>

namespace flare {

class InputError : public std::runtime_error {
public:
    InputError(std::string file, int line, std::string problem);

    const std::string& file() const { return file_; }
    int line() const { return line_; }
    const std::string& problem() const { return problem_; }

private:
    std::string file_;
    int line_;
    std::string problem_;
};

// Exit code the CLI uses for InputError.
inline constexpr int kExitInputError = 2;

}  // namespace flare
