// A pinhole camera and the view and projection it gives. Angles in radians; right-handed view
// space looking down -z; Vulkan clip space (y down, depth 0 at near to 1 at far).
#pragma once

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

namespace pnsplat::engine {

struct Camera {
    glm::vec3 eye{0.0f, 0.0f, 3.0f};
    glm::vec3 target{0.0f};
    glm::vec3 up{0.0f, 1.0f, 0.0f};
    float fovY = 0.7f; // vertical field of view

    // False when eye and target coincide, up is parallel to the view direction, a value is not
    // finite, or fovY is outside (0, π).
    bool valid() const;
    glm::mat4 view() const;
};

// A bounding sphere (of a model or a node).
struct Sphere {
    glm::vec3 centre{0.0f};
    float radius = 0.0f;
};

// A camera that frames `bounds` whole in an image of the given aspect (width / height), looking
// along -z from +z, then turned by `orbit` about the up axis (y) through the centre.
Camera frameSphere(const Sphere& bounds, float aspect, float fovY, float orbit);

// Near and far distances that enclose `bounds` seen from `camera` (near stays positive when the
// eye is inside the sphere).
struct DepthRange {
    float near, far;
};
DepthRange depthRange(const Camera& camera, const Sphere& bounds);

glm::mat4 projection(float fovY, float aspect, DepthRange range);

// View-space frustum test of a bounding sphere (centre already in view space).
struct Frustum {
    float tanX, tanY; // half-angle tangents: x / -z and y / -z at the edges
    DepthRange range;
    bool intersects(glm::vec3 viewCentre, float radius) const;
};

} // namespace pnsplat::engine
