// Where tests find the real models of ../shared/data and the program, a skip when a model is
// absent, and the engine's whole levels of the tests that test something else.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

namespace pnsplat::test {

inline std::filesystem::path dataDir() {
    return PNSPLAT_DATA_DIR;
}

inline std::filesystem::path programPath() {
    return PNSPLAT_PROGRAM;
}

// The whole levels (EngineSettings::wholeLevelPoints, --whole-levels) of the engine's tests that
// are not about them: a level or two of the small models, so the path from whole levels to jobs is
// still taken. The default's 250,000 points cost about 5 s per engine made under TSan, about a
// tenth of the CI run in all.
inline constexpr std::size_t kFewWholeLevelPoints = 20'000;
inline const std::string kFewWholeLevels = " --whole-levels " + std::to_string(kFewWholeLevelPoints);

} // namespace pnsplat::test

// Skips the current test, saying why, when a file of ../shared/data is missing (a user's clone).
#define PNSPLAT_REQUIRE_DATA(file)                                                                           \
    do {                                                                                                     \
        if (!std::filesystem::exists(::pnsplat::test::dataDir() / (file)))                                   \
            GTEST_SKIP() << "needs ../shared/data/" << (file) << " beside the project; not found";           \
    } while (0)
