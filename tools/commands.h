// Subcommands of the `pnsplat` program. Each add*Command registers its options on `app` and a
// callback; a callback reports failure by throwing CommandError, which main() prints as one line
// ("pnsplat: <message>") before exiting with status 1.
#pragma once

#include <stdexcept>
#include <string>

#include <CLI/CLI.hpp>

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

void addRefineCommand(CLI::App& app);
void addEvalCommand(CLI::App& app);
void addBenchCommand(CLI::App& app);
void addRenderCommand(CLI::App& app);
void addDiffCommand(CLI::App& app);

} // namespace pnsplat::tools
