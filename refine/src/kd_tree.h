// A nanoflann k-d tree over a span of positions, for the estimations of inputs that come without
// radii or normals (SPEC 9). Private to refine/src. Build once, then query from any thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include <glm/vec3.hpp>
#include <nanoflann.hpp>

namespace pnsplat {

struct KdCloud {
    std::span<const glm::vec3> points;
    std::size_t kdtree_get_point_count() const { return points.size(); }
    float kdtree_get_pt(std::size_t i, std::size_t dim) const { return points[i][static_cast<int>(dim)]; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const {
        return false;
    }
};

using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, KdCloud>, KdCloud, 3,
                                                   std::uint32_t>;

} // namespace pnsplat
