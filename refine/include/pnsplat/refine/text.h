// Numbers in the text of specs given on command lines ("sphere:R", "torus:R,r", "X,Y,Z,R").
// Pure functions; any thread.
#pragma once

#include <charconv>
#include <cmath>
#include <optional>
#include <string_view>
#include <system_error>

namespace pnsplat {

// Parses a whole string as a finite float (no leading '+', no trailing characters).
inline std::optional<float> parseFloat(std::string_view text) {
    float value = 0.0f;
    const char* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, value);
    if (ec != std::errc() || ptr != end || !std::isfinite(value)) return std::nullopt;
    return value;
}

} // namespace pnsplat
