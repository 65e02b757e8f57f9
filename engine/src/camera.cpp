#include "pnsplat/engine/camera.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

namespace pnsplat::engine {

namespace {
bool finite(glm::vec3 v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
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

Camera frameSphere(const Sphere& bounds, float aspect, float fovY, float orbit) {
    // The sphere fits when its distance exceeds radius / sin(half angle) of the narrower field.
    const float halfY = fovY * 0.5f;
    const float halfX = std::atan(std::tan(halfY) * aspect);
    const float half = std::min(halfX, halfY);
    const float radius = bounds.radius > 0.0f ? bounds.radius : 1.0f;
    const float distance = radius / std::sin(half) * 1.05f;
    Camera camera;
    camera.fovY = fovY;
    camera.target = bounds.centre;
    camera.eye = bounds.centre + distance * glm::vec3(std::sin(orbit), 0.0f, std::cos(orbit));
    camera.up = {0.0f, 1.0f, 0.0f};
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

} // namespace pnsplat::engine
