#include "Output.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <unistd.h>

#include "flare/core/Error.h"

namespace flare::cli {

void writeFileAtomically(const std::string& path, const std::string& content) {
    const std::string temporary = path + ".partial";
    {
        std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
        if (!out) throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
        out.write(content.data(), static_cast<std::streamsize>(content.size()));
        out.flush();
        if (!out) {
            std::remove(temporary.c_str());
            throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
        }
    }
    if (std::rename(temporary.c_str(), path.c_str()) != 0) {
        const std::string reason = std::strerror(errno);
        std::remove(temporary.c_str());
        throw std::runtime_error("cannot write " + path + ": " + reason);
    }
}

void checkWritable(const std::string& path) {
    namespace fs = std::filesystem;
    std::error_code ec;
    if (fs::is_directory(path, ec)) throw InputError(path, 0, "cannot write the output: it is a folder");
    fs::path folder = fs::path(path).parent_path();
    if (folder.empty()) folder = ".";
    if (!fs::exists(folder, ec))
        throw InputError(path, 0, "cannot write the output: the folder '" + folder.string() + "' does not exist");
    if (!fs::is_directory(folder, ec))
        throw InputError(path, 0, "cannot write the output: '" + folder.string() + "' is not a folder");
    if (::access(folder.c_str(), W_OK) != 0)
        throw InputError(path, 0, "cannot write the output: the folder '" + folder.string() + "' is not writable");
}

}  // namespace flare::cli
