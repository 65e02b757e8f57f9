// Seeded random numbers for tests, the same on every standard library (std::*_distribution is not).
#pragma once

#include <cmath>
#include <random>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace pnsplat::test {

// Uniform in [0, 1) from the top 53 bits.
inline double uniform01(std::mt19937_64& rng) {
    return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

inline float uniform(std::mt19937_64& rng, double lo, double hi) {
    return static_cast<float>(lo + (hi - lo) * uniform01(rng));
}

// A uniformly distributed unit vector (rejection from the cube).
inline glm::vec3 randomUnit(std::mt19937_64& rng) {
    for (;;) {
        const glm::dvec3 v(2.0 * uniform01(rng) - 1.0, 2.0 * uniform01(rng) - 1.0,
                           2.0 * uniform01(rng) - 1.0);
        const double l2 = glm::dot(v, v);
        if (l2 > 1e-4 && l2 <= 1.0) return glm::vec3(v / std::sqrt(l2));
    }
}

} // namespace pnsplat::test
