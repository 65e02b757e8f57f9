// Where tests find the real models of ../shared/data, and a skip when they are absent.
#pragma once

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

} // namespace pnsplat::test

// Skips the current test, saying why, when a file of ../shared/data is missing (a user's clone).
#define PNSPLAT_REQUIRE_DATA(file)                                                                           \
    do {                                                                                                     \
        if (!std::filesystem::exists(::pnsplat::test::dataDir() / (file)))                                   \
            GTEST_SKIP() << "needs ../shared/data/" << (file) << " beside the project; not found";           \
    } while (0)
