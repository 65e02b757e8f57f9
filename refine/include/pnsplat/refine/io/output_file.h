// The one writer of every file pnsplat makes (PLY, PNG, JSON reports, heat and hole maps): an
// output appears complete or not at all, and writing never replaces what is not a regular file.
//
// What the path names decides how it is written:
//  - "-": standard output, written as it is produced (a file named "-" is "./-").
//  - nothing yet, or a regular file: a new file in the same folder, unnamed until it is complete
//    (Linux O_TMPFILE), then linked in at the path (linkat through /proc/self/fd) or, to replace a
//    file, linked under a temporary name beside it and renamed over it. A failure, an exception, a
//    signal, SIGKILL included, leave nothing behind (but for the microseconds between that link and
//    the rename). A replaced file's permission bits carry over; a new file's are 0666 less the
//    umask. Data is synced before the file appears.
//    Where the folder's file system has no O_TMPFILE (some network, FUSE and older overlay file
//    systems) or /proc is not mounted: a named temporary file ".NAME.pnsplat-PID-N" beside it, then
//    renamed; it is removed on failure, and on SIGINT, SIGTERM and SIGHUP by a handler installed
//    for them where they had the default action. SIGKILL leaves it behind.
//  - a symbolic link (or a chain of them, relative or absolute): followed to the file it names,
//    written as above; the link stays a link. A dangling link gets its target created.
//  - a character device or a FIFO (/dev/null, a terminal, a named pipe) or a descriptor of /proc
//    (/dev/stdout, /dev/fd/N, process substitution): written through as the data is produced, never
//    replaced; /dev/null discards. A failure may leave part of the data there.
//  - a directory, a block device, a socket: refused.
// Binary content is not written to a terminal (refused, as gzip does).
//
// Errors are one line naming the path ("standard output" for "-") and the problem. Any thread may
// use its own OutputFile.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include "pnsplat/refine/result.h"

namespace pnsplat {

enum class OutputContent { Binary, Text };

class OutputFile {
  public:
    // `namedTemporary` forces the fallback's named temporary file even where O_TMPFILE works (tests).
    static Result<OutputFile> open(const std::filesystem::path& path, OutputContent content,
                                   bool namedTemporary = false);
    OutputFile(OutputFile&& other) noexcept;
    OutputFile& operator=(OutputFile&&) = delete;
    OutputFile(const OutputFile&) = delete;
    OutputFile& operator=(const OutputFile&) = delete;
    // Discards what was written unless commit() succeeded.
    ~OutputFile();

    // Appends `bytes` (retrying interrupted and partial writes).
    Result<void> write(std::string_view bytes);
    // Makes the file appear at its path, complete; a stream is closed. Call once, after the writes.
    Result<void> commit();

    // "standard output" or the path as given, for messages.
    const std::string& name() const { return name_; }

  private:
    enum class Kind { Stream, Unnamed, Named };
    OutputFile() = default;
    void discard() noexcept;

    std::string name_;
    Kind kind_ = Kind::Stream;
    int fd_ = -1;
    std::filesystem::path target_;    // the regular file made or replaced (links followed)
    std::filesystem::path temporary_; // Kind::Named: the temporary file's path
    bool replace_ = false;            // target_ exists and is replaced
    bool committed_ = false;
    int pendingSlot_ = -1; // Kind::Named: its entry among the files a signal removes
};

// How messages name an output: "standard output" for "-", else the path.
std::string outputName(const std::filesystem::path& path);

// The whole of `bytes` through an OutputFile (Text).
Result<void> writeFile(const std::filesystem::path& path, std::string_view bytes);

// True when `a` and `b` name the same existing file (device and inode, links followed); "-" names
// no file. For the tools' refusal to overwrite an input.
bool sameFile(const std::filesystem::path& a, const std::filesystem::path& b);
// True when output to `path` reaches standard output: "-", or the file standard output is open on
// (device and inode), where the tools must not print anything else.
bool isStandardOutput(const std::filesystem::path& path);

} // namespace pnsplat
