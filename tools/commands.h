// Subcommands of the `pnsplat` program. Each add*Command registers its options on `app` and a
// callback; a callback reports failure by throwing CommandError, which main() prints as one line
// ("pnsplat: <message>") before exiting with status 1.
#pragma once

#include <initializer_list>
#include <stdexcept>
#include <string>

// GCC 12 at -O1 (the sanitizer builds) reports a "potential null pointer dereference" inside
// CLI11's own string splitting (CLI::detail::split, inlined std::string moves), depending on what
// else the including file inlines: a false positive in library code, silenced for it alone.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <CLI/CLI.hpp>
#pragma GCC diagnostic pop

#include "pnsplat/refine/output_file.h"
#include "pnsplat/refine/result.h"

namespace pnsplat::tools {

struct CommandError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// Unwraps a Result or throws its error as a CommandError.
template <typename T>
T unwrap(Result<T>&& result) {
    if (!result) throw CommandError(result.error().message);
    if constexpr (!std::is_void_v<T>) return std::move(result).value();
}

// Refuses (CommandError) to write `output` over one of `inputs`, the same file by device and inode
// (links, other spellings and hard links included: sameFile), unless `force`. Empty names are none.
inline void refuseToOverwriteInput(const std::string& output, std::initializer_list<std::string> inputs,
                                   bool force) {
    if (force || output.empty()) return;
    for (const std::string& input : inputs)
        if (!input.empty() && sameFile(input, output))
            throw CommandError(output + ": is the input " + input + "; not overwriting it without --force");
}

// `--force` on `cmd`, into `force` (refuseToOverwriteInput).
inline void addForceFlag(CLI::App& cmd, bool& force) {
    cmd.add_flag("--force", force,
                 "write the output even where it is an input file (which is read whole first)");
}

void addRefineCommand(CLI::App& app);
void addEvalCommand(CLI::App& app);
void addBenchCommand(CLI::App& app);
void addRenderCommand(CLI::App& app);
void addDiffCommand(CLI::App& app);

} // namespace pnsplat::tools
