#include "pnsplat/engine/camera.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <vector>

#include <fmt/format.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/vec2.hpp>
#include <glm/vec4.hpp>

#include "pnsplat/refine/quantile.h"
#include "pnsplat/refine/text.h"

namespace pnsplat::engine {

namespace {

bool finite(glm::vec3 v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

template <typename Index>
Sphere boundingSphereOf(std::span<const glm::vec3> positions, std::size_t count, Index index) {
    if (count == 0) return {};
    glm::vec3 lo(positions[index(0)]), hi(lo);
    for (std::size_t k = 1; k < count; ++k) {
        lo = glm::min(lo, positions[index(k)]);
        hi = glm::max(hi, positions[index(k)]);
    }
    Sphere sphere{(lo + hi) * 0.5f, 0.0f};
    for (std::size_t k = 0; k < count; ++k)
        sphere.radius = std::max(sphere.radius, glm::length(positions[index(k)] - sphere.centre));
    return sphere;
}

glm::vec3 axisDirection(int axis, float sign) {
    glm::vec3 d(0.0f);
    d[axis] = sign;
    return d;
}

// The axis a unit axis direction lies along.
int axisOf(glm::vec3 direction) {
    return std::abs(direction.x) > 0.5f ? 0 : (std::abs(direction.y) > 0.5f ? 1 : 2);
}

// Share of the model's bounding rectangle across `up` (an axis direction) covered by the bounding
// rectangle of its base (kBaseHeight above the lowest point along up); 0 when the mean of the
// points does not lie over the base.
float baseShare(std::span<const glm::vec3> positions, glm::vec3 lo, glm::vec3 hi, glm::vec3 mean, int axis,
                float sign) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    const float height = hi[axis] - lo[axis];
    const float lowest = sign > 0.0f ? lo[axis] : hi[axis];
    glm::vec2 baseLo(std::numeric_limits<float>::infinity()), baseHi(-baseLo);
    for (const glm::vec3& p : positions) {
        if (std::abs(p[axis] - lowest) > kBaseHeight * height) continue;
        baseLo = glm::min(baseLo, glm::vec2(p[u], p[v]));
        baseHi = glm::max(baseHi, glm::vec2(p[u], p[v]));
    }
    const float area = (hi[u] - lo[u]) * (hi[v] - lo[v]);
    if (!(baseHi.x >= baseLo.x) || !(area > 0.0f)) return 0.0f;
    if (mean[u] < baseLo.x || mean[u] > baseHi.x || mean[v] < baseLo.y || mean[v] > baseHi.y) return 0.0f;
    return (baseHi.x - baseLo.x) * (baseHi.y - baseLo.y) / area;
}

} // namespace

bool Camera::valid() const {
    if (!finite(eye) || !finite(target) || !finite(up) || !(fovY > 0.0f && fovY < 3.1415f)) return false;
    const glm::vec3 forward = target - eye;
    const float length = glm::length(forward);
    if (!(length > 0.0f) || !(glm::length(up) > 0.0f)) return false;
    return glm::length(glm::cross(forward / length, glm::normalize(up))) > 1e-6f;
}

glm::mat4 Camera::view() const {
    return glm::lookAtRH(eye, target, up);
}

std::string cameraText(const Camera& c, glm::dvec3 origin) {
    if (origin == glm::dvec3(0.0))
        return fmt::format("{},{},{},{},{},{},{},{},{}", c.eye.x, c.eye.y, c.eye.z, c.target.x, c.target.y,
                           c.target.z, c.up.x, c.up.y, c.up.z);
    const double size = 1e-3 * glm::distance(glm::dvec3(c.eye), glm::dvec3(c.target));
    return fmt::format("{},{},{},{},{}", placeText(origin + glm::dvec3(c.eye), size, ','),
                       placeText(origin + glm::dvec3(c.target), size, ','), c.up.x, c.up.y, c.up.z);
}

Sphere boundingSphere(std::span<const glm::vec3> positions) {
    return boundingSphereOf(positions, positions.size(), [](std::size_t k) { return k; });
}

Sphere boundingSphere(std::span<const glm::vec3> positions, std::span<const std::uint32_t> indices) {
    return boundingSphereOf(positions, indices.size(), [&](std::size_t k) { return indices[k]; });
}

Viewpoint chooseViewpoint(std::span<const glm::vec3> positions, std::span<const glm::vec3> normals,
                          std::optional<glm::vec3> up) {
    assert(normals.empty() || normals.size() == positions.size());
    Viewpoint view;
    if (positions.empty()) return view;
    glm::vec3 lo(positions[0]), hi(lo);
    glm::dvec3 sum(0.0);
    for (const glm::vec3& p : positions) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
        sum += glm::dvec3(p);
    }
    const glm::vec3 extent = hi - lo;
    const glm::vec3 mean(sum / double(positions.size()));

    // 1. The view axis: z, or a much thinner one; across a given up, the thinner, z first.
    int viewAxis = 2;
    if (up) {
        const int upAxis = axisOf(*up);
        viewAxis = -1;
        for (const int axis : {2, 1, 0})
            if (axis != upAxis && (viewAxis < 0 || extent[axis] < extent[viewAxis])) viewAxis = axis;
    } else if (std::min(extent.x, extent.y) < kThinnerThanZ * extent.z) {
        viewAxis = extent.y <= extent.x ? 1 : 0;
    }

    // 2. Up: given, or the broadest base across the view axis.
    if (up) {
        view.up = *up;
    } else {
        view.up = axisDirection(viewAxis == 1 ? 2 : 1, 1.0f);
        float best = kMinBaseShare;
        for (const int axis : {1, 2, 0}) {
            if (axis == viewAxis) continue;
            for (const float sign : {1.0f, -1.0f}) {
                const float share = baseShare(positions, lo, hi, mean, axis, sign);
                if (share >= best) {
                    if (share > best || !view.upFromBase) view.up = axisDirection(axis, sign);
                    best = share;
                    view.upFromBase = true;
                }
            }
        }
    }

    // 3. The side of the view axis: away from a flat face that fills the + side.
    view.front = axisDirection(viewAxis, 1.0f);
    std::size_t headOn[2] = {0, 0}; // facing + and - within 10 degrees
    std::size_t facing[2] = {0, 0}; // facing + and - at all: what an eye on that side sees
    for (const glm::vec3& n : normals) {
        headOn[0] += n[viewAxis] >= kHeadOnCosine;
        headOn[1] += n[viewAxis] <= -kHeadOnCosine;
        facing[0] += n[viewAxis] > 0.0f;
        facing[1] += n[viewAxis] < 0.0f;
    }
    const double share = double(kFlatFaceShare) * double(positions.size());
    const bool flatFace = double(headOn[0]) >= share && headOn[0] > 2 * headOn[1];
    if (double(facing[1]) >= share && (flatFace || double(facing[0]) < share)) {
        view.front = -view.front;
        view.frontFlipped = true;
    }
    return view;
}

Camera frameSphere(const Sphere& bounds, float aspect, float fovY, float orbit, const Viewpoint& view,
                   float elevation) {
    assert(std::abs(glm::dot(view.up, view.front)) < 1e-6f && std::abs(elevation) < 1.5707963f);
    // The sphere fits when its distance exceeds radius / sin(half angle) of the narrower field.
    const float halfY = fovY * 0.5f;
    const float halfX = std::atan(std::tan(halfY) * aspect);
    const float half = std::min(halfX, halfY);
    const float radius = bounds.radius > 0.0f ? bounds.radius : 1.0f;
    const float distance = radius / std::sin(half) * 1.05f;
    // The front turned by `orbit` about up (right-handed), then raised towards up.
    const glm::vec3 side = glm::cross(view.up, view.front);
    const glm::vec3 turned = std::cos(orbit) * view.front + std::sin(orbit) * side;
    const glm::vec3 direction = std::cos(elevation) * turned + std::sin(elevation) * view.up;
    Camera camera;
    camera.fovY = fovY;
    camera.target = bounds.centre;
    camera.eye = bounds.centre + distance * direction;
    camera.up = view.up;
    return camera;
}

DepthRange depthRange(const Camera& camera, const Sphere& bounds) {
    const float distance = glm::length(bounds.centre - camera.eye);
    const float radius = std::max(bounds.radius, 1e-6f);
    const float far = distance + radius * 1.01f;
    // Inside or near the sphere: a small fixed fraction of its size keeps depth precision.
    const float near = std::max(distance - radius * 1.01f, far * 1e-4f);
    return {near, far};
}

glm::mat4 projection(float fovY, float aspect, DepthRange range) {
    glm::mat4 p = glm::perspectiveRH_ZO(fovY, aspect, range.near, range.far);
    p[1][1] = -p[1][1]; // Vulkan: y down
    return p;
}

bool Frustum::intersects(glm::vec3 c, float radius) const {
    const float depth = -c.z;
    if (depth + radius < range.near || depth - radius > range.far) return false;
    // Distance to each side plane through the eye, e.g. x = tanX · depth, normal (1, 0, tanX) / norm.
    const float nx = 1.0f / std::sqrt(1.0f + tanX * tanX);
    const float ny = 1.0f / std::sqrt(1.0f + tanY * tanY);
    if ((c.x - tanX * depth) * nx > radius || (-c.x - tanX * depth) * nx > radius) return false;
    if ((c.y - tanY * depth) * ny > radius || (-c.y - tanY * depth) * ny > radius) return false;
    return true;
}

float splatDiameterQuantile(std::span<const glm::vec3> positions, std::span<const glm::vec3> normals,
                            std::span<const float> radii, const Camera& camera, std::uint32_t width,
                            std::uint32_t height, float quantile) {
    const glm::mat4 view = camera.view();
    const float tanY = std::tan(camera.fovY * 0.5f), tanX = tanY * float(width) / float(height);
    const float focal = float(height) / (2.0f * tanY);
    std::vector<float> sizes;
    for (std::size_t i = 0; i < positions.size(); ++i) {
        const glm::vec3 p = glm::vec3(view * glm::vec4(positions[i], 1.0f));
        const float depth = -p.z;
        if (!(depth > 1e-6f) || std::abs(p.x) > tanX * depth || std::abs(p.y) > tanY * depth) continue;
        if (glm::dot(normals[i], positions[i] - camera.eye) >= 0.0f) continue;
        sizes.push_back(2.0f * radii[i] * focal / depth);
    }
    if (sizes.empty()) return 0.0f;
    const auto at = sizes.begin() + static_cast<std::ptrdiff_t>(quantileIndex(sizes.size(), quantile));
    std::nth_element(sizes.begin(), at, sizes.end());
    return *at;
}

std::vector<std::uint32_t> splatsOutOfPicture(std::span<const glm::vec3> positions,
                                              std::span<const glm::vec3> normals,
                                              std::span<const float> radii, const Camera& camera,
                                              std::uint32_t width, std::uint32_t height, float radiusScale) {
    const glm::mat4 view = camera.view();
    const float tanY = std::tan(camera.fovY * 0.5f);
    // No far plane, and a near plane at the eye: depthRange encloses every splat kept.
    const Frustum frustum{
        tanY * float(width) / float(height), tanY, {0.0f, std::numeric_limits<float>::infinity()}};
    std::vector<std::uint32_t> out;
    for (std::size_t i = 0; i < positions.size(); ++i) {
        const glm::vec3 toSplat = positions[i] - camera.eye;
        const float distance = glm::length(toSplat);
        // The passes test the same dot product in view space: a relative margin far above the
        // rounding of either (1e-4 of the distance, the normal being unit).
        const bool away = glm::dot(normals[i], toSplat) > 1e-4f * distance;
        const glm::vec3 centre = glm::vec3(view * glm::vec4(positions[i], 1.0f));
        const float reach = radii[i] * radiusScale * 1.01f + 1e-5f * distance;
        if (away || !frustum.intersects(centre, reach)) out.push_back(static_cast<std::uint32_t>(i));
    }
    return out;
}

} // namespace pnsplat::engine
