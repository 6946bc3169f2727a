// OutputFiles: outputs checked before any work and written all or nothing; what is at an output
// path (a file, a link, a device or FIFO, a folder) decides how it is written, and nothing else
// there changes.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/core/Error.h"
#include "flare/core/OutputFiles.h"

namespace flare {
namespace {

namespace fs = std::filesystem;

class OutputFilesTest : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = test::processTempDir("output_files") / ::testing::UnitTest::GetInstance()->current_test_info()->name();
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    std::string path(const std::string& name) const { return (dir_ / name).string(); }

    static std::string read(const std::string& file) {
        std::ifstream in(file, std::ios::binary);
        std::ostringstream s;
        s << in.rdbuf();
        return s.str();
    }

    std::vector<std::string> entries() const {
        std::vector<std::string> names;
        for (const auto& e : fs::directory_iterator(dir_)) names.push_back(e.path().filename().string());
        std::sort(names.begin(), names.end());
        return names;
    }

    void expectRefused(OutputFiles& outputs, const std::string& file, const std::string& part) const {
        try {
            outputs.add(file, "-o");
            ADD_FAILURE() << "no InputError for " << file;
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
        }
    }

    fs::path dir_;
};

TEST_F(OutputFilesTest, NothingChangesUntilCommitAndAllAtOnceThen) {
    std::ofstream(path("a.txt")) << "old";
    {
        OutputFiles outputs;
        outputs.add(path("a.txt"));
        outputs.add(path("b.txt"));
        EXPECT_EQ(entries(), std::vector<std::string>{"a.txt"});  // the probes leave nothing
        outputs.write(path("a.txt"), "new a");
        outputs.write(path("b.txt"), "new b");
        EXPECT_EQ(read(path("a.txt")), "old");
        // Dropped uncommitted (a failure later in the command): the temporaries go.
    }
    EXPECT_EQ(entries(), std::vector<std::string>{"a.txt"});
    EXPECT_EQ(read(path("a.txt")), "old");

    OutputFiles outputs;
    outputs.add(path("a.txt"));
    outputs.add(path("b.txt"));
    outputs.write(path("a.txt"), "new a");
    outputs.write(path("b.txt"), "new b");
    outputs.commit();
    EXPECT_EQ(entries(), (std::vector<std::string>{"a.txt", "b.txt"}));
    EXPECT_EQ(read(path("a.txt")), "new a");
    EXPECT_EQ(read(path("b.txt")), "new b");
}

TEST_F(OutputFilesTest, AReplacedFileKeepsItsPermissions) {
    std::ofstream(path("a.txt")) << "old";
    ::chmod(path("a.txt").c_str(), 0640);
    writeOutputFile(path("a.txt"), "new");
    struct stat st {};
    ASSERT_EQ(::stat(path("a.txt").c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 07777, 0640u);
    EXPECT_EQ(read(path("a.txt")), "new");
}

TEST_F(OutputFilesTest, AFailedWriteLeavesNothing) {
    std::ofstream(path("a.txt")) << "old";
    EXPECT_THROW(writeOutputFile(path("a.txt"),
                                 [](const std::string& file) {
                                     std::ofstream(file) << "half";
                                     throw std::runtime_error("the writer failed");
                                 }),
                 std::runtime_error);
    EXPECT_EQ(entries(), std::vector<std::string>{"a.txt"});
    EXPECT_EQ(read(path("a.txt")), "old");
}

TEST_F(OutputFilesTest, PathsThatCannotBeWrittenAreRefusedUpFront) {
    OutputFiles outputs;
    try {
        outputs.add("", "--png");
        ADD_FAILURE() << "no InputError";
    } catch (const InputError& e) {
        EXPECT_EQ(std::string(e.what()), "--png: the file name is empty");
    }
    fs::create_directories(path("folder"));
    expectRefused(outputs, path("folder"), "it is a folder");
    expectRefused(outputs, path("folder/"), "it is a folder");
    expectRefused(outputs, path("no-such-folder/x.exr"), "No such file or directory");
    std::ofstream(path("file")) << "x";
    expectRefused(outputs, path("file/x.exr"), "Not a directory");
    expectRefused(outputs, "/proc/flare-output-test.exr", "cannot create a file in the folder '/proc'");
    expectRefused(outputs, path(std::string(300, 'n')), "File name too long");
    // A socket.
    const int s = ::socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    const std::string socketPath = path("socket");
    if (socketPath.size() < sizeof address.sun_path) {
        std::copy(socketPath.begin(), socketPath.end(), address.sun_path);
        ASSERT_EQ(::bind(s, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
        expectRefused(outputs, socketPath, "it is a socket");
    }
    ::close(s);
    // One file twice, also through a link.
    outputs.add(path("a.exr"));
    fs::create_symlink("a.exr", path("link.exr"));
    expectRefused(outputs, path("a.exr"), "the same file as the output");
    expectRefused(outputs, path("link.exr"), "the same file as the output");
    // A loop of links.
    fs::create_symlink("loop2", path("loop1"));
    fs::create_symlink("loop1", path("loop2"));
    expectRefused(outputs, path("loop1"), "symbolic links");
}

}  // namespace
}  // namespace flare
