// How a subcommand of the `pnsplat` program fails (commands.h): a CommandError carries the one line
// main() prints and the exit status. Apart from commands.h so that files that register no options
// need not compile CLI11 (a few seconds a file).
#pragma once

#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

#include "pnsplat/refine/result.h"

namespace pnsplat::tools {

// Exit statuses (README, "Exit status"; the footer of --help): 0 success.
inline constexpr int kExitDiffers = 1; // `diff`: the images differ past --max-rmse
inline constexpr int kExitUsage = 2;   // the command line asks for something impossible
inline constexpr int kExitFailure = 3; // a bad or missing file, a device error, no memory

class CommandError : public std::runtime_error {
  public:
    explicit CommandError(const std::string& message, int status = kExitFailure)
        : std::runtime_error(message), status_(status) {}
    int status() const { return status_; }

  private:
    int status_;
};

// Unwraps a Result or throws its error as a CommandError.
template <typename T>
T unwrap(Result<T>&& result) {
    if (!result) throw CommandError(result.error().message);
    if constexpr (!std::is_void_v<T>) return std::move(result).value();
}

} // namespace pnsplat::tools
