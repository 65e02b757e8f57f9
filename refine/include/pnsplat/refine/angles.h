// Degrees and radians. Angles inside the project are radians; degrees appear only where people
// read or type them (command-line options, reports, test figures), converted here. π itself is
// std::numbers::pi (std::numbers::pi_v<float> in single precision).
// Pure functions; any thread.
#pragma once

#include <cmath>
#include <concepts>
#include <numbers>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace pnsplat {

template <std::floating_point T>
constexpr T radians(T angleInDegrees) {
    return angleInDegrees * (std::numbers::pi_v<T> / T{180});
}

template <std::floating_point T>
constexpr T degrees(T angleInRadians) {
    return angleInRadians * (T{180} / std::numbers::pi_v<T>);
}

// The angle between two directions (of any nonzero length), in degrees, computed in double
// precision as atan2(|a × b|, a · b): accurate for small angles too, where acos is not. For
// reports and tests; the refinement's own angles are fastAtan2's (fast_math.h).
inline double angleInDegrees(glm::vec3 a, glm::vec3 b) {
    const glm::dvec3 da(a), db(b);
    return degrees(std::atan2(glm::length(glm::cross(da, db)), glm::dot(da, db)));
}

} // namespace pnsplat
