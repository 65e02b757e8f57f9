// A nanoflann k-d tree over a span of positions, the library's one adaptor for nanoflann: for the
// estimations of inputs that come without radii or normals (normal_estimation.cpp,
// radius_estimation.cpp), the outlier search (outliers.cpp), the refinement's check for points too close to
// tell apart (validateForRefinement) and the nearest points of `pnsplat eval` (quality.cpp). Private to
// refine/src. Build once, then query from any thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include <glm/vec3.hpp>
#include <nanoflann.hpp>

namespace pnsplat {

// The positions as nanoflann reads them, with coordinates and distances in T.
template <typename T>
struct KdCloudIn {
    std::span<const glm::vec3> points;
    std::size_t kdtree_get_point_count() const { return points.size(); }
    T kdtree_get_pt(std::size_t i, std::size_t dim) const { return points[i][static_cast<int>(dim)]; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const {
        return false;
    }
};

template <typename T>
using KdTreeIn = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<T, KdCloudIn<T>>,
                                                     KdCloudIn<T>, 3, std::uint32_t>;
using KdCloud = KdCloudIn<float>;
using KdTree = KdTreeIn<float>;
// Distances in double precision: they stay apart where single precision's squares underflow
// (validateForRefinement).
using KdCloudDouble = KdCloudIn<double>;
using KdTreeDouble = KdTreeIn<double>;

} // namespace pnsplat
