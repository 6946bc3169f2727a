// Where the CLI's outputs go (issue 33): a FIFO or a character device at an output path is written
// through and stays what it is, a symbolic link is followed to its target, an output that cannot
// be written stops the command with exit code 2 before any work and nothing is written, and names
// that are not UTF-8 do not break --json.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "TestUtil.h"

namespace flare {
namespace {

namespace fs = std::filesystem;
using test::CliRun;

std::string readAll(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

// Entries of `dir` other than `keep`: what a command left behind.
std::vector<std::string> leftovers(const fs::path& dir, const std::vector<std::string>& keep) {
    std::vector<std::string> found;
    for (const auto& e : fs::directory_iterator(dir))
        if (std::find(keep.begin(), keep.end(), e.path().filename().string()) == keep.end())
            found.push_back(e.path().filename().string());
    return found;
}

constexpr char kExrMagic[] = {0x76, 0x2f, 0x31, 0x01};

TEST(CliOutputs, FifoStaysAFifoAndReceivesTheImage) {
    const fs::path dir = test::freshDir("cli_outputs", "fifo");
    const fs::path fifo = dir / "image.exr";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
    // A reader on the FIFO for as long as the command runs (opened first, without blocking, so
    // that the command's open for writing finds it).
    const int fd = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
    ASSERT_GE(fd, 0);
    std::string received;
    std::atomic<bool> done{false};
    std::thread reader([&] {
        char buffer[1 << 16];
        for (;;) {
            pollfd p{fd, POLLIN, 0};
            ::poll(&p, 1, 20);
            const ssize_t n = ::read(fd, buffer, sizeof buffer);
            if (n > 0) {
                received.append(buffer, static_cast<std::size_t>(n));
            } else {
                if (done.load()) break;  // the command has ended and the FIFO is drained
                std::this_thread::sleep_for(std::chrono::milliseconds(5));  // no writer yet, or EAGAIN
            }
        }
    });
    const CliRun r = test::runCli("preview " + test::writeTinyScene(dir) + " -o " + fifo.string() + " --quiet");
    done.store(true);
    reader.join();
    ::close(fd);
    ASSERT_EQ(r.exitCode, 0) << r.out;
    struct stat st {};
    ASSERT_EQ(::lstat(fifo.c_str(), &st), 0);
    EXPECT_TRUE(S_ISFIFO(st.st_mode)) << "the FIFO was replaced";
    ASSERT_GT(received.size(), 1000u);
    EXPECT_EQ(received.substr(0, 4), std::string(kExrMagic, 4));
    EXPECT_EQ(leftovers(dir, {"image.exr", "tiny.json"}), std::vector<std::string>{});
}

// As root, `-o /dev/null` replaced the device with an EXR. Tested on a node of /dev/null's kind
// made in a scratch folder (mknod needs root: skipped otherwise), never on /dev/null itself.
TEST(CliOutputs, CharacterDeviceStaysTheDevice) {
    const fs::path dir = test::freshDir("cli_outputs", "device");
    const fs::path node = dir / "null";
    if (::mknod(node.c_str(), S_IFCHR | 0666, makedev(1, 3)) != 0) GTEST_SKIP() << "mknod needs root";
    for (const std::string& command : {"preview " + test::writeTinyScene(dir) + " --quiet -o " + node.string(),
                                       "lens draw double-gauss-50mm -o " + node.string()}) {
        const CliRun r = test::runCli(command);
        EXPECT_EQ(r.exitCode, 0) << r.out;
        struct stat st {};
        ASSERT_EQ(::lstat(node.c_str(), &st), 0);
        EXPECT_TRUE(S_ISCHR(st.st_mode)) << "the device was replaced by " << command;
        EXPECT_EQ(st.st_rdev, makedev(1, 3));
    }
    EXPECT_EQ(leftovers(dir, {"null", "tiny.json"}), std::vector<std::string>{});
}

TEST(CliOutputs, SymbolicLinkIsFollowedToItsTarget) {
    const fs::path dir = test::freshDir("cli_outputs", "link");
    fs::create_directories(dir / "real");
    std::ofstream(dir / "real" / "drawing.svg") << "old";
    fs::create_symlink("real/drawing.svg", dir / "link.svg");
    fs::create_symlink("link.svg", dir / "chain.svg");
    fs::create_symlink("real/new.svg", dir / "dangling.svg");
    for (const char* name : {"link.svg", "chain.svg", "dangling.svg"}) {
        const CliRun r = test::runCli("lens draw double-gauss-50mm -o " + (dir / name).string());
        ASSERT_EQ(r.exitCode, 0) << name << ": " << r.out;
        EXPECT_TRUE(fs::is_symlink(dir / name)) << name << " is no longer a link";
    }
    EXPECT_EQ(fs::read_symlink(dir / "link.svg"), "real/drawing.svg");
    EXPECT_EQ(fs::read_symlink(dir / "dangling.svg"), "real/new.svg");
    EXPECT_EQ(readAll(dir / "real" / "drawing.svg").substr(0, 4), "<svg");
    EXPECT_EQ(readAll(dir / "real" / "new.svg").substr(0, 4), "<svg");
    EXPECT_EQ(leftovers(dir / "real", {"drawing.svg", "new.svg"}), std::vector<std::string>{});
}

// An output that cannot be written (nothing can be created in /proc, even by root) stops the
// command before any work, with exit code 2 naming it; the other outputs are not written either.
TEST(CliOutputs, UnwritableOutputFailsBeforeAnyWorkAndNothingIsWritten) {
    const fs::path dir = test::freshDir("cli_outputs", "unwritable");
    const std::string scene = test::writeTinyScene(dir), ok = (dir / "ok.exr").string();
    const std::string report = (dir / "ok.json").string();
    const std::string commands[] = {
        "preview " + scene + " -o " + ok + " --png /proc/flare-test.png",
        "render " + scene + " -o " + ok + " --photons 20000 --quiet --report /proc/flare-test.json",
        "render " + scene + " -o " + ok + " --photons 20000 --quiet --report " + report + " --png /proc/flare-test.png",
        "render " + scene + " -o /proc/flare-test.exr --photons 20000 --quiet",
    };
    for (const std::string& command : commands) {
        const auto start = std::chrono::steady_clock::now();
        const CliRun r = test::runCli(command);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        EXPECT_EQ(r.exitCode, 2) << command << "\n" << r.out;
        EXPECT_NE(r.out.find("/proc/flare-test."), std::string::npos) << r.out;
        EXPECT_LT(seconds, 5.0) << command;
        EXPECT_EQ(leftovers(dir, {"tiny.json"}), std::vector<std::string>{}) << command;
    }
    // Before any work: with a scene that does not exist, the output is still what is reported.
    const CliRun first = test::runCli("preview " + (dir / "no-such-scene.json").string() + " -o " + ok +
                                      " --png /proc/flare-test.png");
    EXPECT_EQ(first.exitCode, 2);
    EXPECT_NE(first.out.find("/proc/flare-test.png"), std::string::npos) << first.out;
    // An empty output name is an input error too, named by its option.
    const CliRun empty = test::runCli("render " + scene + " -o '' --photons 20000 --quiet");
    EXPECT_EQ(empty.exitCode, 2);
    EXPECT_NE(empty.out.find("-o: the file name is empty"), std::string::npos) << empty.out;
    EXPECT_EQ(test::runCli("preview " + scene + " -o " + ok + " --png ''").exitCode, 2);
    // Two outputs to one file, and a folder as the output.
    EXPECT_EQ(test::runCli("preview " + scene + " -o " + ok + " --png " + ok).exitCode, 2);
    EXPECT_EQ(test::runCli("lens draw double-gauss-50mm -o " + dir.string()).exitCode, 2);
    EXPECT_EQ(leftovers(dir, {"tiny.json"}), std::vector<std::string>{});
}

// A lens whose name holds bytes that are not UTF-8: --json replaces them (U+FFFD) instead of
// failing with exit code 1 (nlohmann::json's type_error.316).
TEST(CliOutputs, NameThatIsNotUtf8DoesNotBreakJson) {
    const fs::path dir = test::freshDir("cli_outputs", "utf8");
    const std::string shipped = readAll(test::sourcePath("lenses/double-gauss-50mm.lens"));
    const std::size_t at = shipped.find("\nname ");
    ASSERT_NE(at, std::string::npos);
    const std::size_t end = shipped.find('\n', at + 1);
    const std::string lens = (dir / "bad-name.lens").string();
    std::ofstream(lens, std::ios::binary) << shipped.substr(0, at) << "\nname Gauss \xff\xfe\xc3 50" << shipped.substr(end);
    for (const std::string& command : {"lens info " + lens + " --json", "ghosts " + lens + " --json"}) {
        const CliRun r = test::runCli(command);
        ASSERT_EQ(r.exitCode, 0) << command << "\n" << r.out;
        const nlohmann::json j = nlohmann::json::parse(r.out);
        const std::string name = j.contains("name") ? j["name"].get<std::string>() : j["lens"].get<std::string>();
        EXPECT_EQ(name, "Gauss \xef\xbf\xbd\xef\xbf\xbd\xef\xbf\xbd 50") << command;
    }
}

}  // namespace
}  // namespace flare
