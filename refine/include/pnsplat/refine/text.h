// Numbers in the text of specs given on command lines ("sphere:R", "torus:R,r", "X,Y,Z,R"), and
// values in JSON text. Pure functions; any thread.
#pragma once

#include <charconv>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>

#include <glm/ext/vector_double3.hpp>

namespace pnsplat {

// Parses a whole string as a finite float or double (no leading '+', no trailing characters).
template <typename T>
std::optional<T> parseFinite(std::string_view text) {
    T value = 0;
    const char* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, value);
    if (ec != std::errc() || ptr != end || !std::isfinite(value)) return std::nullopt;
    return value;
}
inline std::optional<float> parseFloat(std::string_view text) {
    return parseFinite<float>(text);
}
// Coordinates of a file held less an origin (PlyData::origin) are given in double.
inline std::optional<double> parseDouble(std::string_view text) {
    return parseFinite<double>(text);
}

// A place in a file's coordinates (PlyData::origin + position) as text: x, y and z between
// `separator`s, each to about a thousandth of `size` (4 significant digits near 0, more far from it),
// without an exponent up to 16 whole digits (a whole number, rounded to those digits, where the size
// is 10,000 or more).
std::string placeText(glm::dvec3 place, double size, char separator);

// A JSON number: the shortest text that reads back as `v`; null when not finite (JSON has no
// infinity or NaN).
std::string jsonNumber(double v);

// A JSON string literal of `s` (quotes, backslashes and control characters escaped; other bytes,
// UTF-8 included, as they are).
std::string jsonString(std::string_view s);

} // namespace pnsplat
