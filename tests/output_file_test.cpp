// The one writer of every output (output_file.h): a file appears complete or not at all, links are
// followed, devices and pipes are written through and never replaced, and a named temporary (the
// fallback where O_TMPFILE is missing) goes away on failure and on SIGINT, SIGTERM and SIGHUP.
#include "pnsplat/refine/io/output_file.h"

#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <string>
#include <thread>

#include <fcntl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "temp_dir.h"

namespace pnsplat {
namespace {

namespace fs = std::filesystem;

class OutputFileTest : public ::testing::Test {
  protected:
    fs::path file(const std::string& name) const { return dir_ / name; }
    std::set<std::string> entries() const { return dir_.entries(); }

    test::TempDir dir_;
};

// The whole file or stream, read to its end ("" when it cannot be opened).
std::string readText(const fs::path& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    std::string text;
    char buffer[4096];
    for (ssize_t n; fd >= 0 && (n = ::read(fd, buffer, sizeof buffer)) > 0;)
        text.append(buffer, static_cast<std::size_t>(n));
    if (fd >= 0) ::close(fd);
    return text;
}

void writeText(const fs::path& path, const std::string& text) {
    std::ofstream(path, std::ios::binary) << text;
}

// Writes `text` to `path` through an OutputFile and commits it; the error message when it fails.
std::string writeThrough(const fs::path& path, const std::string& text,
                         OutputContent content = OutputContent::Text, bool named = false) {
    Result<OutputFile> out = OutputFile::open(path, content, named);
    if (!out) return out.error().message;
    if (Result<void> w = out->write(text); !w) return w.error().message;
    if (Result<void> c = out->commit(); !c) return c.error().message;
    return "";
}

mode_t modeOf(const fs::path& path) {
    struct stat s {};
    EXPECT_EQ(::lstat(path.c_str(), &s), 0) << path;
    return s.st_mode;
}

// Written data is invisible until commit (no name in the folder at all), then complete; a file
// never committed leaves nothing. The same with the named temporary of the fallback, which is
// visible (under a hidden name) while it is written.
TEST_F(OutputFileTest, AFileAppearsOnlyWhenCommitted) {
    for (const bool named : {false, true}) {
        SCOPED_TRACE(named ? "named temporary" : "unnamed temporary");
        const fs::path path = file("out.json");
        {
            Result<OutputFile> out = OutputFile::open(path, OutputContent::Text, named);
            ASSERT_TRUE(out.ok()) << out.error().message;
            ASSERT_TRUE(out->write("{\"a\": 1}\n").ok());
            if (named) {
                ASSERT_EQ(entries().size(), 1u);
                EXPECT_EQ(entries().begin()->rfind(".out.json.pnsplat-", 0), 0u) << *entries().begin();
            } else {
                EXPECT_TRUE(entries().empty());
            }
            ASSERT_TRUE(out->commit().ok());
        }
        EXPECT_EQ(entries(), std::set<std::string>{"out.json"});
        EXPECT_EQ(readText(path), "{\"a\": 1}\n");
        const mode_t mask = ::umask(0);
        ::umask(mask);
        EXPECT_EQ(modeOf(path) & 0777, 0666 & ~mask);
        {
            Result<OutputFile> out = OutputFile::open(file("never.json"), OutputContent::Text, named);
            ASSERT_TRUE(out.ok());
            ASSERT_TRUE(out->write("partial").ok());
        } // destroyed without commit
        EXPECT_EQ(entries(), std::set<std::string>{"out.json"});
        fs::remove(path);
    }
}

// Replacing keeps the permission bits and leaves no other file.
TEST_F(OutputFileTest, ReplacesARegularFileKeepingItsMode) {
    for (const bool named : {false, true}) {
        const fs::path path = file("old.txt");
        writeText(path, "old and longer contents");
        fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
        EXPECT_EQ(writeThrough(path, "new", OutputContent::Text, named), "");
        EXPECT_EQ(readText(path), "new");
        EXPECT_EQ(modeOf(path) & 0777, 0640u);
        EXPECT_EQ(entries(), std::set<std::string>{"old.txt"});
        fs::remove(path);
    }
}

// Links (a chain of a relative and an absolute one, and a dangling one) lead to the file written;
// the links stay links. Before, the first link was replaced by a regular file.
TEST_F(OutputFileTest, WritesThroughSymbolicLinks) {
    fs::create_directory(file("sub"));
    writeText(file("sub") / "target.ply", "old");
    fs::create_symlink(file("sub") / "target.ply", file("absolute"));
    fs::create_symlink("absolute", file("relative"));
    EXPECT_EQ(writeThrough(file("relative"), "new"), "");
    EXPECT_EQ(readText(file("sub") / "target.ply"), "new");
    EXPECT_TRUE(S_ISLNK(modeOf(file("relative"))));
    EXPECT_TRUE(S_ISLNK(modeOf(file("absolute"))));
    EXPECT_EQ(entries(), (std::set<std::string>{"absolute", "relative", "sub"}));

    fs::create_symlink("sub/created.ply", file("dangling"));
    EXPECT_EQ(writeThrough(file("dangling"), "made"), "");
    EXPECT_EQ(readText(file("sub") / "created.ply"), "made");
    EXPECT_TRUE(S_ISLNK(modeOf(file("dangling"))));

    fs::create_symlink("loop-b", file("loop-a"));
    fs::create_symlink("loop-a", file("loop-b"));
    EXPECT_NE(writeThrough(file("loop-a"), "x").find("too many levels of symbolic links"), std::string::npos);
}

// /dev/null is written through and stays the device; a FIFO gets the bytes and stays a FIFO.
TEST_F(OutputFileTest, WritesThroughDevicesAndPipes) {
    EXPECT_EQ(writeThrough("/dev/null", std::string(1 << 20, 'x'), OutputContent::Binary), "");
    struct stat null {};
    ASSERT_EQ(::lstat("/dev/null", &null), 0);
    EXPECT_TRUE(S_ISCHR(null.st_mode));
    EXPECT_EQ(null.st_rdev, makedev(1, 3));

    const fs::path fifo = file("pipe");
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    std::string received;
    std::thread reader([&] { received = readText(fifo); });
    EXPECT_EQ(writeThrough(fifo, "through the pipe"), "");
    reader.join();
    EXPECT_EQ(received, "through the pipe");
    EXPECT_TRUE(S_ISFIFO(modeOf(fifo)));

    // A full device: the error names it and the device stays.
    const std::string full = writeThrough("/dev/full", "x");
    EXPECT_NE(full.find("/dev/full: cannot write: No space left on device"), std::string::npos) << full;
}

// A device node made with mknod (root only): written through, not replaced by a file; a block
// device is refused.
TEST_F(OutputFileTest, DeviceNodesAreNotReplaced) {
    if (::geteuid() != 0) GTEST_SKIP() << "mknod needs root";
    const fs::path node = file("null-node"), block = file("block-node");
    if (::mknod(node.c_str(), S_IFCHR | 0666, makedev(1, 3)) != 0)
        GTEST_SKIP() << "mknod refused (" << std::strerror(errno) << "): no CAP_MKNOD here";
    EXPECT_EQ(writeThrough(node, "discarded"), "");
    EXPECT_TRUE(S_ISCHR(modeOf(node)));
    ASSERT_EQ(::mknod(block.c_str(), S_IFBLK | 0600, makedev(7, 200)), 0);
    EXPECT_NE(writeThrough(block, "x").find("is a block device"), std::string::npos);
    EXPECT_TRUE(S_ISBLK(modeOf(block)));
}

TEST_F(OutputFileTest, DirectoriesSocketsAndMissingFoldersAreRefused) {
    fs::create_directory(file("folder"));
    EXPECT_NE(writeThrough(file("folder"), "x").find("folder: is a directory"), std::string::npos);
    EXPECT_NE(writeThrough(file("missing") / "out.txt", "x").find("its folder does not exist"),
              std::string::npos);

    const int sock = ::socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    const std::string socketPath = file("socket").string();
    ASSERT_LT(socketPath.size(), sizeof address.sun_path);
    std::copy(socketPath.begin(), socketPath.end(), address.sun_path);
    ASSERT_EQ(::bind(sock, reinterpret_cast<const sockaddr*>(&address), sizeof address), 0);
    EXPECT_NE(writeThrough(file("socket"), "x").find("not writing to it"), std::string::npos);
    ::close(sock);
    EXPECT_EQ(entries(), (std::set<std::string>{"folder", "socket"}));
}

// Binary data is not written to a terminal; text is.
TEST_F(OutputFileTest, BinaryDataIsNotWrittenToATerminal) {
    const int master = ::posix_openpt(O_RDWR | O_NOCTTY);
    if (master < 0 || ::grantpt(master) != 0 || ::unlockpt(master) != 0) GTEST_SKIP() << "no pseudo-terminal";
    const fs::path terminal = ::ptsname(master);
    EXPECT_NE(writeThrough(terminal, "\x89PNG", OutputContent::Binary).find("is a terminal"),
              std::string::npos);
    EXPECT_EQ(writeThrough(terminal, "{}\n", OutputContent::Text), "");
    ::close(master);
}

TEST_F(OutputFileTest, SameFileComparesDeviceAndInode) {
    writeText(file("a.ply"), "a");
    writeText(file("b.ply"), "a");
    fs::create_hard_link(file("a.ply"), file("hard.ply"));
    fs::create_symlink("a.ply", file("soft.ply"));
    EXPECT_TRUE(sameFile(file("a.ply"), dir_ / "." / "a.ply"));
    EXPECT_TRUE(sameFile(file("a.ply"), file("hard.ply")));
    EXPECT_TRUE(sameFile(file("soft.ply"), file("a.ply")));
    EXPECT_FALSE(sameFile(file("a.ply"), file("b.ply")));
    EXPECT_FALSE(sameFile(file("a.ply"), file("missing.ply")));
    EXPECT_FALSE(sameFile("-", "-"));
    EXPECT_TRUE(isStandardOutput("-"));
}

// The named temporary of the fallback, in a child killed by a signal while it writes: the handler
// removes it. (The unnamed one has no name to remove: SIGKILL leaves nothing either.)
TEST_F(OutputFileTest, SignalsRemoveTheNamedTemporary) {
    for (const int signal : {SIGINT, SIGTERM, SIGHUP, SIGKILL}) {
        for (const bool named : {true, false}) {
            if (named && signal == SIGKILL) continue; // nothing can remove it then (documented)
            struct sigaction inherited {};
            ::sigaction(signal, nullptr, &inherited);
            if (inherited.sa_handler == SIG_IGN) {
                std::cout << "    " << strsignal(signal) << " is ignored here (nohup?): not tested\n";
                continue;
            }
            SCOPED_TRACE(std::string(strsignal(signal)) + (named ? ", named" : ", unnamed"));
            int ready[2];
            ASSERT_EQ(::pipe(ready), 0);
            const pid_t child = ::fork();
            ASSERT_GE(child, 0);
            if (child == 0) {
                Result<OutputFile> out = OutputFile::open(file("out.ply"), OutputContent::Binary, named);
                if (!out || !out->write(std::string(1 << 16, 'x'))) ::_exit(2);
                const char byte = 1;
                if (::write(ready[1], &byte, 1) != 1) ::_exit(3);
                for (;;) ::pause();
            }
            ::close(ready[1]);
            char byte = 0;
            ASSERT_EQ(::read(ready[0], &byte, 1), 1) << "the child did not start writing";
            ::close(ready[0]);
            ASSERT_EQ(entries().size(), named ? 1u : 0u);
            ::kill(child, signal);
            int status = 0;
            ASSERT_EQ(::waitpid(child, &status, 0), child);
            EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == signal) << status;
            EXPECT_TRUE(entries().empty()) << *entries().begin();
        }
    }
}

} // namespace
} // namespace pnsplat
