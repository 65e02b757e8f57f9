// The viewer's camera controls (docs/VIEWER.md, "Controls"): orbit about the target, look around
// from the eye (fly mode), pan, zoom to the cursor, fly with the keys, frame the model, reset.
// Distances follow the view (a pan moves the point under the cursor with it) or the model's size
// (flying crosses the model's bounding sphere in kFlySeconds), so any model handles alike.
//
// Screen positions and motions are in window coordinates (origin top left, y down) of a view
// `size` wide and high; only their ratios to the size matter. The camera's `up` is the world's up,
// which orbiting turns about; the view never looks along it. Thread use: one thread.
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "pnsplat/engine/camera.h"

namespace pnsplat::viewer {

// A drag over the view's full height turns the view by this angle (radians).
inline constexpr float kTurnPerHeight = 3.14159265f;
// One wheel step brings the eye and the target this share closer to the point under the cursor.
inline constexpr float kZoomStep = 0.15f;
// Flying (W, A, S, D, E, C) crosses the model's bounding sphere (its diameter) in this many seconds.
inline constexpr float kFlySeconds = 4.0f;
// The view keeps at least this angle (radians) between its direction and the up axis.
inline constexpr float kPoleMargin = 0.02f;

class CameraControl {
  public:
    // Starts at `camera` (valid) for a model enclosed by `model` (radius > 0).
    CameraControl(const engine::Camera& camera, const engine::Sphere& model);

    const engine::Camera& camera() const { return camera_; }
    const engine::Sphere& model() const { return model_; }

    // Turns the eye about the target by a drag of `delta`: right turns the model right (the eye goes
    // left), down tilts its top towards the eye; the distance to the target stays.
    void orbit(glm::vec2 delta, glm::vec2 size);
    // Fly mode's drag: turns the view about the eye (right looks right, down looks down).
    void look(glm::vec2 delta, glm::vec2 size);
    // Moves eye and target across the view so that the point at the target's depth under the cursor
    // follows a drag of `delta`.
    void pan(glm::vec2 delta, glm::vec2 size);
    // `steps` wheel steps (> 0 closer): eye and target scaled towards the point at the target's
    // depth under `cursor` by (1 - kZoomStep)^steps, so that point stays under the cursor. The
    // distance to the target stays within [1e-4, 1e4] model radii.
    void zoom(float steps, glm::vec2 cursor, glm::vec2 size);
    // Flies for `seconds`: `direction` is (right, up, forward) in [-1, 1] each (up: the world's).
    void fly(glm::vec3 direction, float seconds);
    // The whole model in view along the current direction (the distance engine::frameSphere
    // chooses for the aspect `size.x / size.y`), aimed at its centre.
    void frame(glm::vec2 size);
    // Back to `camera`; a new model when given.
    void reset(const engine::Camera& camera);
    void reset(const engine::Camera& camera, const engine::Sphere& model);

  private:
    glm::vec3 forward() const;
    // Turns `offset` about the up axis by `yaw` and towards it by `pitch`, keeping kPoleMargin.
    glm::vec3 turn(glm::vec3 offset, float yaw, float pitch) const;

    engine::Camera camera_;
    engine::Sphere model_;
};

} // namespace pnsplat::viewer
