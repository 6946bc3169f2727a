#include "flare/core/Error.h"

namespace flare {

namespace {
std::string formatLocation(const std::string& file, int line, const std::string& problem) {
    std::string where = file.empty() ? std::string("<input>") : file;
    if (line > 0) where += ":" + std::to_string(line);
    return where + ": " + problem;
}
}  // namespace

InputError::InputError(std::string file, int line, std::string problem)
    : std::runtime_error(formatLocation(file, line, problem)),
      file_(std::move(file)),
      line_(line),
      problem_(std::move(problem)) {}

}  // namespace flare
