// The sparse real models of ../shared/data that the benchmarks run by default (../shared/data's
// README lists their sources), read from the project's root as CI and a developer's clone have
// them; a user's clone may lack them, and the benchmarks then skip them, saying so.
#pragma once

#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/core.h>

namespace pnsplat::tools {

// Issue 26 measures the first kSettleModelCount (bench settle); bench refine takes all of them
// (the fandisk too: a CAD part whose creases the refinement keeps).
inline constexpr const char* kSparseModels[] = {
    "bunny-3500-random",  "igea-600-uniform",       "lion-3500-random",    "nefertiti-3500-random",
    "banana-1500-random", "rockerarm-2000-uniform", "fandisk-1500-uniform"};
inline constexpr std::size_t kSettleModelCount = 6;

// "../shared/data/NAME.ply" for each of `models` that exists; each absent one is named on standard
// error as skipped by `command`.
inline std::vector<std::string> sharedModelFiles(std::span<const char* const> models,
                                                 std::string_view command) {
    std::vector<std::string> files;
    for (const char* model : models) {
        std::string file = fmt::format("../shared/data/{}.ply", model);
        if (std::filesystem::exists(file))
            files.push_back(std::move(file));
        else
            fmt::print(stderr, "pnsplat: {}: {} not found (run from the project's root); skipped\n", command,
                       file);
    }
    return files;
}

} // namespace pnsplat::tools
