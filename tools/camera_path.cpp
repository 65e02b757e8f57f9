#include "camera_path.h"

#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>

#include <fmt/core.h>
#include <glm/geometric.hpp>

#include "command_error.h"

namespace pnsplat::tools {

CameraPath CameraPath::orbit(const engine::Sphere& bounds, float aspect, float fovY, std::size_t frames) {
    CameraPath path;
    path.frames_ = frames;
    for (std::size_t k = 0; k < frames; ++k) {
        const float angle = 2.0f * std::numbers::pi_v<float> * float(k) / float(frames);
        path.keys_.push_back({k, engine::frameSphere(bounds, aspect, fovY, angle)});
    }
    return path;
}

CameraPath CameraPath::zoom(const engine::Sphere& bounds, float aspect, float fovY, std::size_t frames) {
    CameraPath path;
    path.frames_ = frames;
    const engine::Camera framing = engine::frameSphere(bounds, aspect, fovY, 0.6f);
    for (std::size_t k = 0; k < frames; ++k) {
        const float t = frames > 1 ? float(k) / float(frames - 1) : 0.0f;
        const float closeness = 0.6f * std::sin(std::numbers::pi_v<float> * t); // 0 → 0.6 → 0
        engine::Camera camera = framing;
        camera.eye = framing.target + (framing.eye - framing.target) * (1.0f - closeness);
        path.keys_.push_back({k, camera});
    }
    return path;
}

CameraPath CameraPath::load(const std::string& file, glm::dvec3 origin) {
    std::ifstream in(file);
    if (!in) throw CommandError(file + ": cannot open the camera path");
    CameraPath path;
    std::string line;
    for (std::size_t number = 1; std::getline(in, line); ++number) {
        if (const std::size_t hash = line.find('#'); hash != std::string::npos) line.erase(hash);
        std::istringstream fields(line);
        std::vector<double> values;
        std::string word;
        while (fields >> word) {
            char* end = nullptr;
            const double v = std::strtod(word.c_str(), &end);
            if (end == word.c_str() || *end != '\0' || !std::isfinite(v))
                throw CommandError(fmt::format("{}:{}: '{}' is not a number", file, number, word));
            values.push_back(v);
        }
        if (values.empty()) continue;
        if (values.size() != 7 && values.size() != 10 && values.size() != 11)
            throw CommandError(fmt::format("{}:{}: expected FRAME ex ey ez tx ty tz [ux uy uz [FOV]], got {} "
                                           "number(s)",
                                           file, number, values.size()));
        if (values[0] < 0 || values[0] != std::floor(values[0]) || values[0] > 1e7 ||
            (!path.keys_.empty() && values[0] <= double(path.keys_.back().frame)))
            throw CommandError(fmt::format(
                "{}:{}: the frame index must be a whole number above the previous one", file, number));
        engine::Camera camera;
        camera.eye = glm::vec3(glm::dvec3(values[1], values[2], values[3]) - origin);
        camera.target = glm::vec3(glm::dvec3(values[4], values[5], values[6]) - origin);
        if (values.size() >= 10) camera.up = {float(values[7]), float(values[8]), float(values[9])};
        camera.fovY = float((values.size() == 11 ? values[10] : 40.0) * std::numbers::pi / 180.0);
        if (!camera.valid())
            throw CommandError(fmt::format("{}:{}: not a camera (eye and target must differ, up must not be "
                                           "parallel to the view, the field of view in (0, 180) degrees)",
                                           file, number));
        path.keys_.push_back({std::size_t(values[0]), camera});
    }
    if (path.keys_.empty()) throw CommandError(file + ": the camera path has no keyframe");
    path.frames_ = path.keys_.back().frame + 1;
    return path;
}

engine::Camera CameraPath::at(std::size_t k) const {
    if (k <= keys_.front().frame) return keys_.front().camera;
    if (k >= keys_.back().frame) return keys_.back().camera;
    std::size_t next = 1;
    while (keys_[next].frame <= k) ++next; // a keyframe's own frame: t = 0, its camera exactly
    const Key& a = keys_[next - 1];
    const Key& b = keys_[next];
    const float t = float(k - a.frame) / float(b.frame - a.frame);
    // a + (b - a) t, which is a exactly where the keyframes agree (glm::mix's a (1 - t) + b t is
    // not: a camera held between two equal keyframes moved by rounding and never came to rest).
    const auto between = [t](const auto& from, const auto& to) { return from + (to - from) * t; };
    engine::Camera camera;
    camera.eye = between(a.camera.eye, b.camera.eye);
    camera.target = between(a.camera.target, b.camera.target);
    camera.up = between(a.camera.up, b.camera.up);
    camera.fovY = between(a.camera.fovY, b.camera.fovY);
    // Interpolation can pass through an invalid camera (eye on target, up along the view): keep the
    // nearer keyframe's then.
    return camera.valid() ? camera : (t < 0.5f ? a.camera : b.camera);
}

} // namespace pnsplat::tools
