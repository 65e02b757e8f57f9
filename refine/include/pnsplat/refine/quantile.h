// The index rule of the splat-size quantiles: the engine's level of detail (drawnRadiusOf), the
// camera's splat sizes (splatDiameterQuantile) and the sizes a frame reports (SplatSizes) take the
// same element, so that their figures agree. Pure; any thread.
#pragma once

#include <algorithm>
#include <cstddef>

namespace pnsplat {

// The index of the `quantile` quantile of `count` values in increasing order: min(count - 1,
// ⌊quantile · count⌋); `count` > 0.
inline std::size_t quantileIndex(std::size_t count, float quantile) {
    return std::min(count - 1, static_cast<std::size_t>(quantile * static_cast<float>(count)));
}

} // namespace pnsplat
