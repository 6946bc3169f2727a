#include "flare/core/OutputFiles.h"

#include <cerrno>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <stdexcept>
#include <system_error>

#include <fcntl.h>
#include <limits.h>
#include <sys/stat.h>
#include <unistd.h>

#include "flare/core/Error.h"

namespace flare {

namespace fs = std::filesystem;

namespace {

constexpr int kMaxSymlinks = 40;  // as the kernel's ELOOP limit

std::string errnoText() { return std::strerror(errno); }

// A name no file has yet: `stem` followed by random letters and digits, created empty (O_EXCL, so
// never a file or link someone else put there). Returns "" with errno set if it cannot be created.
std::string createUnique(const fs::path& folder, const std::string& stem) {
    static thread_local std::mt19937_64 random{std::random_device{}()};
    static const char kLetters[] = "abcdefghijklmnopqrstuvwxyz0123456789";
    for (int attempt = 0; attempt < 100; ++attempt) {
        std::string name = stem;
        for (int i = 0; i < 8; ++i) name += kLetters[random() % (sizeof kLetters - 1)];
        const fs::path file = folder / name;
        const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0) {
            ::close(fd);
            return file.string();
        }
        if (errno != EEXIST) return "";
    }
    errno = EEXIST;
    return "";
}

// The temporary's stem beside a target: hidden, named after it.
std::string stemBeside(const fs::path& target) {
    std::string stem(1, '.');
    stem += target.filename().string();
    stem += ".flare-";
    return stem;
}

// The path a write through `path` replaces: symbolic links followed (relative ones from their own
// folder) until a path that is no link, or does not exist (a new file, or a dangling link's target).
fs::path resolveLinks(const std::string& path, const std::string& what) {
    fs::path p = path;
    for (int i = 0; i <= kMaxSymlinks; ++i) {
        struct stat st {};
        if (::lstat(p.c_str(), &st) != 0) {
            if (errno == ENOENT) return p;
            throw InputError(path, 0, "cannot write the " + what + " file: " + errnoText());
        }
        if (!S_ISLNK(st.st_mode)) return p;
        char buffer[PATH_MAX];
        const ssize_t n = ::readlink(p.c_str(), buffer, sizeof buffer);
        if (n < 0) throw InputError(path, 0, "cannot write the " + what + " file: " + errnoText());
        const fs::path link(std::string(buffer, static_cast<std::size_t>(n)));
        p = link.is_absolute() ? link : p.parent_path() / link;
    }
    throw InputError(path, 0, "cannot write the " + what + " file: too many levels of symbolic links");
}

// Copies `from` into the open descriptor `fd` (a device or FIFO); false with errno on failure.
bool copyInto(const std::string& from, int fd) {
    const int in = ::open(from.c_str(), O_RDONLY | O_CLOEXEC);
    if (in < 0) return false;
    const auto finish = [in](bool ok) {
        const int saved = errno;
        ::close(in);
        errno = saved;
        return ok;
    };
    char buffer[1 << 16];
    for (;;) {
        const ssize_t n = ::read(in, buffer, sizeof buffer);
        if (n == 0) return finish(true);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) return finish(false);
        for (ssize_t done = 0; done < n;) {
            const ssize_t w = ::write(fd, buffer + done, static_cast<std::size_t>(n - done));
            if (w < 0 && errno == EINTR) continue;
            if (w < 0) return finish(false);
            done += w;
        }
    }
}

// Ignores SIGPIPE while it lives: a reader that goes away is a write error (EPIPE) to report, not
// a signal that ends the program.
struct IgnoreSigpipe {
    struct sigaction previous {};
    IgnoreSigpipe() {
        struct sigaction ignore {};
        ignore.sa_handler = SIG_IGN;
        sigemptyset(&ignore.sa_mask);
        ::sigaction(SIGPIPE, &ignore, &previous);
    }
    ~IgnoreSigpipe() { ::sigaction(SIGPIPE, &previous, nullptr); }
};

}  // namespace

OutputFiles::~OutputFiles() {
    for (const Output& o : outputs_)
        if (!o.temporary.empty() && !o.moved) ::unlink(o.temporary.c_str());
}

void OutputFiles::add(const std::string& path, const std::string& what) {
    if (committed_) throw std::logic_error("OutputFiles::add after commit");
    if (path.empty()) throw InputError(what, 0, "the file name is empty");
    const auto refuse = [&](const std::string& why) { throw InputError(path, 0, "cannot write the " + what + " file: " + why); };
    Output o;
    o.path = path;
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0) {
        if (S_ISDIR(st.st_mode)) refuse("it is a folder");
        if (S_ISCHR(st.st_mode) || S_ISFIFO(st.st_mode)) {
            o.through = true;
        } else if (!S_ISREG(st.st_mode)) {
            refuse(std::string(S_ISBLK(st.st_mode) ? "it is a block device" : "it is a socket") +
                   "; flare writes regular files, character devices and pipes");
        }
    } else if (errno != ENOENT) {
        refuse(errnoText());  // e.g. a name too long, a file used as a folder, no permission
    }

    if (o.through) {
        if (::access(path.c_str(), W_OK) != 0) refuse(errnoText());
        // The content waits in the temporary folder until the set is committed.
        std::error_code ec;
        const fs::path temp = fs::temp_directory_path(ec);
        const std::string probe = ec ? std::string() : createUnique(temp, "flare-output-");
        if (probe.empty()) refuse("cannot create a temporary file in " + temp.string() + ": " + errnoText());
        ::unlink(probe.c_str());
        o.target = path;
    } else {
        const fs::path target = resolveLinks(path, what);
        if (target.filename().empty()) refuse("it names a folder");
        o.target = target.string();
        struct stat existing {};
        if (::stat(target.c_str(), &existing) == 0) {
            if (!S_ISREG(existing.st_mode)) refuse("its link leads to something that is not a regular file");
            o.keepMode = true;
            o.mode = existing.st_mode & 07777;
        }
        const fs::path folder = target.parent_path().empty() ? fs::path(".") : target.parent_path();
        struct stat dir {};
        if (::stat(folder.c_str(), &dir) != 0) refuse("the folder '" + folder.string() + "': " + errnoText());
        if (!S_ISDIR(dir.st_mode)) refuse("'" + folder.string() + "' is not a folder");
        // The probe: a file created and renamed where the output will be.
        const std::string probe = createUnique(folder, stemBeside(target));
        if (probe.empty()) refuse("cannot create a file in the folder '" + folder.string() + "': " + errnoText());
        const std::string renamed = createUnique(folder, stemBeside(target));
        const bool renames = !renamed.empty() && ::rename(probe.c_str(), renamed.c_str()) == 0;
        const std::string why = errnoText();
        ::unlink(probe.c_str());
        if (!renamed.empty()) ::unlink(renamed.c_str());
        if (!renames) refuse("cannot rename a file in the folder '" + folder.string() + "': " + why);
        // In a sticky folder (/tmp) only a file's owner, the folder's owner or root may replace it.
        if (o.keepMode && (dir.st_mode & S_ISVTX) && ::geteuid() != 0 && existing.st_uid != ::geteuid() &&
            dir.st_uid != ::geteuid())
            refuse("the file belongs to another user in a folder where only its owner may replace it");
    }

    // Two outputs writing one file would leave only one of them (character devices, /dev/null
    // above all, can take any number).
    for (const Output& other : outputs_) {
        std::error_code ec1, ec2;
        const bool same = o.through ? other.through && fs::equivalent(other.target, o.target, ec1)
                                    : !other.through && fs::weakly_canonical(other.target, ec1) ==
                                                            fs::weakly_canonical(o.target, ec2) && !ec1 && !ec2;
        if (same && !(o.through && S_ISCHR(st.st_mode))) refuse("it is the same file as the output " + other.path);
    }
    outputs_.push_back(std::move(o));
}

OutputFiles::Output& OutputFiles::find(const std::string& path) {
    for (Output& o : outputs_)
        if (o.path == path) return o;
    throw std::logic_error("OutputFiles: " + path + " was not added");
}

const OutputFiles::Output& OutputFiles::find(const std::string& path) const {
    return const_cast<OutputFiles*>(this)->find(path);
}

bool OutputFiles::writesThrough(const std::string& path) const { return find(path).through; }

const std::string& OutputFiles::file(const std::string& path) {
    Output& o = find(path);
    if (o.temporary.empty()) {
        std::error_code ec;
        const fs::path target(o.target);
        o.temporary = o.through ? createUnique(fs::temp_directory_path(ec), "flare-output-")
                                : createUnique(target.parent_path().empty() ? fs::path(".") : target.parent_path(),
                                               stemBeside(target));
        if (o.temporary.empty()) throw std::runtime_error("cannot write " + path + ": cannot create a temporary file: " + errnoText());
    }
    return o.temporary;
}

void OutputFiles::write(const std::string& path, std::string_view content) {
    const std::string& temporary = file(path);
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.close();
    if (!out) throw std::runtime_error("cannot write " + path + ": " + errnoText());
}

void OutputFiles::commit() {
    if (committed_) throw std::logic_error("OutputFiles::commit called twice");
    committed_ = true;
    {
        const IgnoreSigpipe ignore;
        for (Output& o : outputs_) {
            if (!o.through || o.temporary.empty()) continue;
            // No O_CREAT: should the node have gone, nothing is created in its place.
            const int fd = ::open(o.path.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC);
            const bool ok = fd >= 0 && copyInto(o.temporary, fd);
            const std::string why = errnoText();
            if (fd >= 0 && ::close(fd) != 0 && ok) throw std::runtime_error("cannot write " + o.path + ": " + errnoText());
            if (!ok) throw std::runtime_error("cannot write " + o.path + ": " + why);
            ::unlink(o.temporary.c_str());
            o.moved = true;
        }
    }
    for (Output& o : outputs_) {
        if (o.through || o.temporary.empty()) continue;
        if (o.keepMode) ::chmod(o.temporary.c_str(), o.mode);
        if (::rename(o.temporary.c_str(), o.target.c_str()) != 0)
            throw std::runtime_error("cannot write " + o.path + ": renaming the finished file failed: " + errnoText());
        o.moved = true;
    }
}

void writeOutputFile(const std::string& path, const std::function<void(const std::string& file)>& write) {
    OutputFiles outputs;
    outputs.add(path);
    write(outputs.file(path));
    outputs.commit();
}

void writeOutputFile(const std::string& path, std::string_view content) {
    OutputFiles outputs;
    outputs.add(path);
    outputs.write(path, content);
    outputs.commit();
}

}  // namespace flare
