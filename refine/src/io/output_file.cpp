// The one writer of pnsplat's outputs (output_file.h): unnamed temporary files linked in when
// complete, links followed, streams and devices written through.
#include "pnsplat/refine/io/output_file.h"

#include <array>
#include <atomic>
#include <cassert>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <mutex>
#include <string>
#include <system_error>
#include <utility>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/vfs.h>
#include <unistd.h>

#include <fmt/core.h>

namespace pnsplat {

namespace fs = std::filesystem;

namespace {

constexpr long kProcSuperMagic = 0x9fa0; // statfs's f_type of /proc (linux/magic.h)
constexpr int kMaxLinkHops = 40;         // as the kernel's ELOOP limit

Error fail(std::string_view name, std::string_view problem) {
    return Error{fmt::format("{}: {}", name, problem)};
}

std::string reason(int error) {
    return std::generic_category().message(error);
}

// --- Named temporaries (the fallback): removed when SIGINT, SIGTERM or SIGHUP ends the program.

struct PendingRemoval {
    std::atomic<int> state{0}; // 0 free, 1 being filled, 2 to remove on a signal
    std::array<char, 4096> path{};
};
std::array<PendingRemoval, 8> pendingRemovals;

extern "C" void removePendingAndDie(int signal) {
    for (PendingRemoval& p : pendingRemovals)
        if (p.state.load() == 2) ::unlink(p.path.data());
    ::raise(signal); // SA_RESETHAND restored the default action: it ends the program on return
}

// Installs the handler for the signals whose action is still the default (once).
void installRemovalHandlers() {
    static std::once_flag once;
    std::call_once(once, [] {
        for (const int signal : {SIGINT, SIGTERM, SIGHUP}) {
            struct sigaction old {};
            if (::sigaction(signal, nullptr, &old) != 0 || (old.sa_flags & SA_SIGINFO) != 0 ||
                old.sa_handler != SIG_DFL)
                continue;
            struct sigaction action {};
            action.sa_handler = removePendingAndDie;
            sigemptyset(&action.sa_mask);
            action.sa_flags = SA_RESETHAND;
            ::sigaction(signal, &action, nullptr);
        }
    });
}

// A slot for `path`, or -1 when all are taken or the path is too long (then a signal leaves it).
int registerRemoval(const fs::path& path) {
    installRemovalHandlers();
    const std::string& text = path.native();
    if (text.size() >= PendingRemoval{}.path.size()) return -1;
    for (std::size_t slot = 0; slot < pendingRemovals.size(); ++slot) {
        int expected = 0;
        PendingRemoval& p = pendingRemovals[slot];
        if (!p.state.compare_exchange_strong(expected, 1)) continue;
        std::memcpy(p.path.data(), text.c_str(), text.size() + 1);
        p.state.store(2);
        return static_cast<int>(slot);
    }
    return -1;
}

void unregisterRemoval(int slot) {
    if (slot >= 0) pendingRemovals[static_cast<std::size_t>(slot)].state.store(0);
}

// --- Where the path leads.

enum class TargetKind { Missing, Regular, Stream };
struct Target {
    TargetKind kind;
    fs::path path;
    mode_t mode = 0; // of an existing regular file
};

bool inProc(const fs::path& link) {
    struct statfs fs {};
    const fs::path folder = link.has_parent_path() ? link.parent_path() : fs::path(".");
    return ::statfs(folder.c_str(), &fs) == 0 && static_cast<long>(fs.f_type) == kProcSuperMagic;
}

// Follows symbolic links from `path` to what must be written.
Result<Target> resolve(const fs::path& path, std::string_view name) {
    fs::path p = path;
    for (int hop = 0; hop <= kMaxLinkHops; ++hop) {
        struct stat s {};
        if (::lstat(p.c_str(), &s) != 0) {
            if (errno == ENOENT) return Target{TargetKind::Missing, p};
            return fail(name, fmt::format("cannot write: {}", reason(errno)));
        }
        if (S_ISLNK(s.st_mode)) {
            if (inProc(p)) return Target{TargetKind::Stream, p}; // a descriptor: /proc/self/fd/N
            std::error_code ec;
            const fs::path next = fs::read_symlink(p, ec);
            if (ec) return fail(name, fmt::format("cannot follow the link {}: {}", p.string(), ec.message()));
            p = next.is_absolute() ? next : p.parent_path() / next;
            continue;
        }
        if (S_ISREG(s.st_mode)) return Target{TargetKind::Regular, p, s.st_mode & 0777};
        if (S_ISCHR(s.st_mode) || S_ISFIFO(s.st_mode)) return Target{TargetKind::Stream, p};
        if (S_ISDIR(s.st_mode)) return fail(name, "is a directory");
        return fail(name, S_ISBLK(s.st_mode) ? "is a block device; not writing to it"
                                             : "is not a file, a device or a pipe; not writing to it");
    }
    return fail(name, "cannot write: too many levels of symbolic links");
}

// A descriptor for a stream target: standard output and /proc/self/fd/N are duplicated (keeping
// their offset and append mode), anything else opened for writing.
int openStream(const fs::path& path) {
    if (path == "-") return ::fcntl(STDOUT_FILENO, F_DUPFD_CLOEXEC, 0);
    if (path.parent_path() == "/proc/self/fd" || path.parent_path() == "/dev/fd") {
        const std::string number = path.filename().string();
        if (!number.empty() && number.find_first_not_of("0123456789") == std::string::npos)
            return ::fcntl(std::stoi(number), F_DUPFD_CLOEXEC, 0);
    }
    return ::open(path.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC);
}

std::atomic<unsigned> temporaryCounter{0};

// ".NAME.pnsplat-PID-N" beside `target`.
fs::path temporaryBeside(const fs::path& target) {
    return target.parent_path() / fmt::format(".{}.pnsplat-{}-{}", target.filename().string(), ::getpid(),
                                              temporaryCounter.fetch_add(1));
}

bool procFdAvailable() {
    struct stat s {};
    return ::stat("/proc/self/fd", &s) == 0 && S_ISDIR(s.st_mode);
}

} // namespace

std::string outputName(const fs::path& path) {
    return path == "-" ? std::string("standard output") : path.string();
}

Result<OutputFile> OutputFile::open(const fs::path& path, OutputContent content, bool namedTemporary) {
    OutputFile out;
    out.name_ = outputName(path);
    Result<Target> target =
        path == "-" ? Result<Target>(Target{TargetKind::Stream, path}) : resolve(path, out.name_);
    if (!target) return target.error();

    if (target->kind == TargetKind::Stream) {
        out.fd_ = openStream(target->path);
        if (out.fd_ < 0) return fail(out.name_, fmt::format("cannot write: {}", reason(errno)));
        if (content == OutputContent::Binary && ::isatty(out.fd_))
            return fail(out.name_,
                        "is a terminal; not writing binary data to it (redirect it to a file or a pipe)");
        return out;
    }

    out.target_ = target->path;
    out.replace_ = target->kind == TargetKind::Regular;
    const fs::path folder = out.target_.has_parent_path() ? out.target_.parent_path() : fs::path(".");
    bool unnamed = !namedTemporary && procFdAvailable();
    if (unnamed) {
        out.fd_ = ::open(folder.c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
        // Kernels without O_TMPFILE take it for O_DIRECTORY (EISDIR); file systems without it say
        // EOPNOTSUPP.
        unnamed = out.fd_ >= 0 || (errno != EOPNOTSUPP && errno != EISDIR);
    }
    if (unnamed) {
        out.kind_ = Kind::Unnamed;
    } else {
        out.kind_ = Kind::Named;
        do {
            out.temporary_ = temporaryBeside(out.target_);
            out.fd_ = ::open(out.temporary_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        } while (out.fd_ < 0 && errno == EEXIST);
        if (out.fd_ >= 0) out.pendingSlot_ = registerRemoval(out.temporary_);
    }
    if (out.fd_ < 0) {
        const int error = errno;
        return fail(out.name_, error == ENOENT ? "cannot write: its folder does not exist"
                                               : fmt::format("cannot write: {}", reason(error)));
    }
    if (out.replace_ && ::fchmod(out.fd_, target->mode) != 0)
        return fail(out.name_, fmt::format("cannot write: {}", reason(errno)));
    return out;
}

OutputFile::OutputFile(OutputFile&& other) noexcept
    : name_(std::move(other.name_)), kind_(std::exchange(other.kind_, Kind::Stream)),
      fd_(std::exchange(other.fd_, -1)), target_(std::move(other.target_)),
      temporary_(std::move(other.temporary_)), replace_(other.replace_), committed_(other.committed_),
      pendingSlot_(std::exchange(other.pendingSlot_, -1)) {}

OutputFile::~OutputFile() {
    discard();
}

void OutputFile::discard() noexcept {
    if (fd_ >= 0) ::close(std::exchange(fd_, -1));
    if (kind_ == Kind::Named && !committed_ && !temporary_.empty()) ::unlink(temporary_.c_str());
    unregisterRemoval(std::exchange(pendingSlot_, -1));
}

Result<void> OutputFile::write(std::string_view bytes) {
    assert(fd_ >= 0 && !committed_);
    while (!bytes.empty()) {
        const ssize_t written = ::write(fd_, bytes.data(), bytes.size());
        if (written < 0) {
            if (errno == EINTR) continue;
            return fail(name_, fmt::format("cannot write: {}", reason(errno)));
        }
        bytes.remove_prefix(static_cast<std::size_t>(written));
    }
    return {};
}

Result<void> OutputFile::commit() {
    assert(fd_ >= 0 && !committed_);
    const auto failed = [&](std::string_view doing, int error) {
        return fail(name_, fmt::format("{}: {}", doing, reason(error)));
    };
    if (kind_ == Kind::Stream) {
        committed_ = true;
        if (::close(std::exchange(fd_, -1)) != 0 && errno != EINTR) return failed("cannot write", errno);
        return {};
    }
    if (::fsync(fd_) != 0) return failed("cannot write", errno);
    if (kind_ == Kind::Named) {
        if (::close(std::exchange(fd_, -1)) != 0 && errno != EINTR) return failed("cannot write", errno);
        if (::rename(temporary_.c_str(), target_.c_str()) != 0) return failed("cannot replace it", errno);
        committed_ = true;
        unregisterRemoval(std::exchange(pendingSlot_, -1));
        return {};
    }
    // Unnamed: a new file is linked at its path at once; a file to replace is linked beside it
    // under a temporary name, then renamed over it.
    const std::string descriptor = fmt::format("/proc/self/fd/{}", fd_);
    if (!replace_) {
        if (::linkat(AT_FDCWD, descriptor.c_str(), AT_FDCWD, target_.c_str(), AT_SYMLINK_FOLLOW) == 0) {
            committed_ = true;
            return {};
        }
        if (errno != EEXIST) return failed("cannot create it", errno); // else made meanwhile: replace it
    }
    fs::path temporary;
    int linked = 0;
    do {
        temporary = temporaryBeside(target_);
        linked = ::linkat(AT_FDCWD, descriptor.c_str(), AT_FDCWD, temporary.c_str(), AT_SYMLINK_FOLLOW);
    } while (linked != 0 && errno == EEXIST);
    if (linked != 0) return failed("cannot replace it", errno);
    if (::rename(temporary.c_str(), target_.c_str()) != 0) {
        const int error = errno;
        ::unlink(temporary.c_str());
        return failed("cannot replace it", error);
    }
    committed_ = true;
    return {};
}

Result<void> writeFile(const fs::path& path, std::string_view bytes) {
    Result<OutputFile> out = OutputFile::open(path, OutputContent::Text);
    if (!out) return out.error();
    if (Result<void> written = out->write(bytes); !written) return written;
    return out->commit();
}

namespace {

bool statOf(const fs::path& path, struct stat& s) {
    return path != "-" && ::stat(path.c_str(), &s) == 0;
}

} // namespace

bool sameFile(const fs::path& a, const fs::path& b) {
    struct stat sa {
    }, sb{};
    return statOf(a, sa) && statOf(b, sb) && sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

bool isStandardOutput(const fs::path& path) {
    if (path == "-") return true;
    struct stat s {
    }, out{};
    return statOf(path, s) && ::fstat(STDOUT_FILENO, &out) == 0 && s.st_dev == out.st_dev &&
           s.st_ino == out.st_ino;
}

} // namespace pnsplat
