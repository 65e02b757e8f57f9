#include "pnsplat/viewer/camera_control.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>

namespace pnsplat::viewer {

CameraControl::CameraControl(const engine::Camera& camera, const engine::Sphere& model) {
    reset(camera, model);
}

void CameraControl::reset(const engine::Camera& camera) {
    assert(camera.valid());
    camera_ = camera;
    camera_.up = glm::normalize(camera.up);
}

void CameraControl::reset(const engine::Camera& camera, const engine::Sphere& model) {
    model_ = model;
    if (!(model_.radius > 0.0f) || !std::isfinite(model_.radius)) model_.radius = 1.0f;
    reset(camera);
}

glm::vec3 CameraControl::forward() const {
    return glm::normalize(camera_.target - camera_.eye);
}

glm::vec3 CameraControl::turn(glm::vec3 offset, float yaw, float pitch) const {
    const glm::vec3 up = camera_.up;
    const float length = glm::length(offset);
    glm::vec3 d = glm::angleAxis(yaw, up) * (offset / length);
    // The angle from the up axis, kept within [margin, π - margin].
    const float polar = std::acos(std::clamp(glm::dot(d, up), -1.0f, 1.0f));
    const float turned = std::clamp(polar - pitch, kPoleMargin, 3.14159265f - kPoleMargin);
    glm::vec3 side = glm::cross(up, d);
    if (glm::length(side) < 1e-6f)
        side = glm::cross(up, glm::abs(up.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0));
    side = glm::normalize(side);
    // Rotating about `side` by a positive angle moves d from up towards its horizontal part.
    d = glm::angleAxis(turned - polar, side) * d;
    return d * length;
}

void CameraControl::orbit(glm::vec2 delta, glm::vec2 size) {
    const float k = kTurnPerHeight / size.y;
    const glm::vec3 offset = camera_.eye - camera_.target;
    // Down (dy > 0) raises the eye: the angle from the up axis shrinks.
    camera_.eye = camera_.target + turn(offset, -delta.x * k, delta.y * k);
}

void CameraControl::look(glm::vec2 delta, glm::vec2 size) {
    const float k = kTurnPerHeight / size.y;
    const glm::vec3 offset = camera_.target - camera_.eye;
    // Down (dy > 0) looks down: the angle from the up axis grows.
    camera_.target = camera_.eye + turn(offset, -delta.x * k, -delta.y * k);
}

void CameraControl::pan(glm::vec2 delta, glm::vec2 size) {
    const glm::vec3 f = forward();
    const glm::vec3 right = glm::normalize(glm::cross(f, camera_.up));
    const glm::vec3 screenUp = glm::cross(right, f);
    const float distance = glm::length(camera_.target - camera_.eye);
    const float perPixel = 2.0f * distance * std::tan(camera_.fovY * 0.5f) / size.y;
    const glm::vec3 move = (-delta.x * right + delta.y * screenUp) * perPixel;
    camera_.eye += move;
    camera_.target += move;
}

void CameraControl::zoom(float steps, glm::vec2 cursor, glm::vec2 size) {
    const glm::vec3 f = forward();
    const glm::vec3 right = glm::normalize(glm::cross(f, camera_.up));
    const glm::vec3 screenUp = glm::cross(right, f);
    const float distance = glm::length(camera_.target - camera_.eye);
    const float tanY = std::tan(camera_.fovY * 0.5f);
    const glm::vec2 ndc = cursor / size * 2.0f - 1.0f;
    const glm::vec3 point =
        camera_.eye + distance * (f + ndc.x * tanY * (size.x / size.y) * right - ndc.y * tanY * screenUp);
    float scale = std::pow(1.0f - kZoomStep, steps);
    scale = std::clamp(scale, 1e-4f * model_.radius / distance, 1e4f * model_.radius / distance);
    camera_.eye = point + (camera_.eye - point) * scale;
    camera_.target = point + (camera_.target - point) * scale;
}

void CameraControl::fly(glm::vec3 direction, float seconds) {
    const glm::vec3 f = forward();
    const glm::vec3 right = glm::normalize(glm::cross(f, camera_.up));
    const float speed = 2.0f * model_.radius / kFlySeconds;
    const glm::vec3 move =
        (direction.x * right + direction.y * camera_.up + direction.z * f) * speed * seconds;
    camera_.eye += move;
    camera_.target += move;
}

void CameraControl::frame(glm::vec2 size) {
    const glm::vec3 f = forward();
    engine::Viewpoint view;
    view.front = -f;
    view.up = glm::normalize(camera_.up - glm::dot(camera_.up, view.front) * view.front);
    const glm::vec3 up = camera_.up;
    camera_ = engine::frameSphere(model_, size.x / size.y, camera_.fovY, 0.0f, view);
    camera_.up = up;
}

} // namespace pnsplat::viewer
