// Camera paths for `pnsplat bench view` (and scripted views): the framing orbit, a zoom towards the
// model and back, or keyframes from a text file.
//
// File format (docs/REALTIME.md): one keyframe per line,
//     FRAME  ex ey ez  tx ty tz  [ux uy uz  [FOV]]
// FRAME a frame index (increasing), e/t/u the eye, target and up (default up 0 1 0), FOV the
// vertical field of view in degrees (default 40). Frames between keyframes interpolate eye, target
// and up linearly (and the field of view); blank lines and text after '#' are ignored.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "pnsplat/engine/camera.h"

namespace pnsplat::tools {

class CameraPath {
  public:
    // A whole turn about the model's vertical (y) axis in `frames` frames, framing `bounds`.
    static CameraPath orbit(const engine::Sphere& bounds, float aspect, float fovY, std::size_t frames);
    // From the framing distance towards the centre to 0.4 of it and back, in `frames` frames.
    static CameraPath zoom(const engine::Sphere& bounds, float aspect, float fovY, std::size_t frames);
    // Keyframes from a file, in the coordinates of the model's file (less `origin`, PlyData::origin,
    // where the model is held less it); a malformed file is a CommandError naming the file and the line.
    static CameraPath load(const std::string& path, glm::dvec3 origin = glm::dvec3(0.0));

    // The number of frames the path defines (the last keyframe's index + 1 for a file).
    std::size_t frames() const { return frames_; }
    // The camera of frame k (clamped to the path's last frame).
    engine::Camera at(std::size_t k) const;

  private:
    struct Key {
        std::size_t frame;
        engine::Camera camera;
    };
    std::vector<Key> keys_;
    std::size_t frames_ = 0;
};

} // namespace pnsplat::tools
