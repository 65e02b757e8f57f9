// Subcommands of the `pnsplat` program. Each add*Command registers its options on `app` and a
// callback; a callback reports failure by throwing CommandError, which main() prints as one line
// ("pnsplat: <message>") before exiting with the error's status.
#pragma once

#include <exception>
#include <initializer_list>
#include <memory>
#include <span>
#include <string>
#include <utility>

// GCC 12 at -O1 (the sanitizer builds) reports a "potential null pointer dereference" inside
// CLI11's own string splitting (CLI::detail::split, inlined std::string moves), depending on what
// else the including file inlines: a false positive in library code, silenced for it alone.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#pragma GCC diagnostic pop

#include "command_error.h"
#include "pnsplat/refine/io/output_file.h"
#include "pnsplat/refine/result.h"

namespace pnsplat::tools {

// Checks of a count of at least 1 and of a number of at least 0, for options: CLI11's own
// (PositiveNumber, NonNegativeNumber) print their range up to the largest double, 309 digits.
inline const CLI::Validator kPositiveCount(
    [](std::string& value) -> std::string {
        std::size_t used = 0;
        try {
            if (!value.empty() && value.front() != '-' && std::stoull(value, &used) >= 1 &&
                used == value.size())
                return {};
        } catch (const std::exception&) {
        }
        return "must be a whole number of at least 1 (got " + value + ")";
    },
    "COUNT>=1");
inline const CLI::Validator kNonNegative(
    [](std::string& value) -> std::string {
        std::size_t used = 0;
        try {
            if (const double x = std::stod(value, &used); used == value.size() && x >= 0.0) return {};
        } catch (const std::exception&) {
        }
        return "must be a number of at least 0 (got " + value + ")";
    },
    "NUMBER>=0");

// CLI::Range for floating-point options, refusing NaN too (CLI11's lets it through: every
// comparison with NaN is false, and `--orbit nan` reached the camera as one).
inline CLI::Validator finiteRange(double lo, double hi) {
    return CLI::Validator(
        [lo, hi](std::string& value) -> std::string {
            std::size_t used = 0;
            try {
                if (const double x = std::stod(value, &used); used == value.size() && x >= lo && x <= hi)
                    return {};
            } catch (const std::exception&) {
            }
            return fmt::format("must be a number from {:g} to {:g} (got {})", lo, hi, value);
        },
        fmt::format("NUMBER in [{:g}, {:g}]", lo, hi));
}

// Adds the subcommand `name` to `parent`: its options fill the returned Args (which the subcommand
// owns), and `run` runs with them once the command line is parsed. Returns the subcommand, for the
// caller to register the options on, and the Args.
template <typename Args>
std::pair<CLI::App*, Args*> addSubcommand(CLI::App& parent, std::string name, std::string description,
                                          void (*run)(const Args&)) {
    auto args = std::make_shared<Args>();
    CLI::App* cmd = parent.add_subcommand(std::move(name), std::move(description));
    cmd->callback([args, run] { run(*args); });
    return {cmd, args.get()};
}

// Refuses (CommandError) to write `output` over one of `inputs`, the same file by device and inode
// (links, other spellings and hard links included: sameFile), unless `force`. Empty names are none.
inline void refuseToOverwriteInput(const std::string& output, std::span<const std::string> inputs,
                                   bool force) {
    if (force || output.empty()) return;
    for (const std::string& input : inputs)
        if (!input.empty() && sameFile(input, output))
            throw CommandError(output + ": is the input " + input + "; not overwriting it without --force");
}

inline void refuseToOverwriteInput(const std::string& output, std::initializer_list<std::string> inputs,
                                   bool force) {
    refuseToOverwriteInput(output, std::span(inputs.begin(), inputs.size()), force);
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
void addViewCommand(CLI::App& app);
// `bench view`, under `bench`.
void addBenchViewCommand(CLI::App& bench);
void addBenchSettleCommand(CLI::App& bench);

} // namespace pnsplat::tools
