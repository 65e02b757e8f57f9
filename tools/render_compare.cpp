#include "render_compare.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec4.hpp>

#include "command_error.h"
#include "pnsplat/viewer/overlay.h"

namespace pnsplat::tools {

namespace {

constexpr int kCaptionLines = 1;

std::uint8_t toByte(float v) {
    return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
}

engine::RgbaImage filled(std::uint32_t width, std::uint32_t height, glm::vec3 colour) {
    engine::RgbaImage image(width, height);
    for (std::size_t i = 0; i < image.pixels.size(); i += 4) {
        image.pixels[i] = toByte(colour.x);
        image.pixels[i + 1] = toByte(colour.y);
        image.pixels[i + 2] = toByte(colour.z);
        image.pixels[i + 3] = 255;
    }
    return image;
}

// One frame of `points` through the engine (adaptive: refined for the camera until settled).
engine::RgbaImage renderFrame(engine::Context& context, PointSet points,
                              const engine::EngineSettings& settings, const engine::Camera& camera,
                              engine::FrameReport* report, std::size_t* splats) {
    auto created = engine::Engine::create(context, std::move(points), settings);
    if (!created) throw CommandError(created.error().message);
    engine::Engine& engine = **created;
    engine::FrameOptions options;
    options.lockstep = true;
    options.readBack = true;
    options.measureSplats = settings.adaptive;
    const engine::FrameReport drawn = unwrap(engine.frame(camera, options));
    engine::RgbaImage image = unwrap(engine.image(drawn.frame));
    engine.finish();
    if (report) *report = drawn;
    if (splats) *splats = engine.tree().pointCount();
    return image;
}

// Copies `panel` into `picture` with its top left corner at (x, 0).
void place(engine::RgbaImage& picture, const engine::RgbaImage& panel, std::uint32_t x) {
    for (std::uint32_t y = 0; y < panel.height; ++y)
        std::memcpy(&picture.pixels[(std::size_t{y} * picture.width + x) * 4],
                    &panel.pixels[std::size_t{y} * panel.width * 4], std::size_t{panel.width} * 4);
}

// The `width` leftmost columns of `image`.
engine::RgbaImage leftPart(const engine::RgbaImage& image, std::uint32_t width) {
    engine::RgbaImage part(width, image.height);
    for (std::uint32_t y = 0; y < image.height; ++y)
        std::memcpy(&part.pixels[std::size_t{y} * width * 4], &image.pixels[std::size_t{y} * image.width * 4],
                    std::size_t{width} * 4);
    return part;
}

int captionScale(std::uint32_t width) {
    return width >= 480 ? 2 : 1;
}

} // namespace

int captionHeight(std::uint32_t width) {
    // viewer::drawPanel: 12 units a line and 4 units of margin about them, less 2.
    return (12 * kCaptionLines + 2 * 4 - 2) * captionScale(width);
}

engine::RgbaImage drawDots(const PointSet& points, const engine::Camera& camera, std::uint32_t width,
                           std::uint32_t height, glm::vec3 background, float radiusPx) {
    engine::RgbaImage image = filled(width, height, background);
    if (points.empty()) return image;
    const glm::mat4 clip =
        engine::projection(camera.fovY, float(width) / float(height),
                           engine::depthRange(camera, engine::boundingSphere(points.position))) *
        camera.view();
    std::vector<float> depth(std::size_t{width} * height, std::numeric_limits<float>::infinity());
    const int reach = static_cast<int>(std::ceil(radiusPx));
    for (std::size_t i = 0; i < points.size(); ++i) {
        const glm::vec3 toEye = camera.eye - points.position[i];
        const float distance = glm::length(toEye);
        const float facing = glm::dot(points.normal[i], toEye) / distance;
        if (!(facing > 0.0f)) continue; // facing away: the splats' back is not drawn either
        const glm::vec4 c = clip * glm::vec4(points.position[i], 1.0f);
        if (!(c.w > 0.0f)) continue;
        const float px = (c.x / c.w * 0.5f + 0.5f) * float(width);
        const float py = (c.y / c.w * 0.5f + 0.5f) * float(height);
        // The headlight's diffuse term, as the splats' shading (splat_common.glsl, shade), without
        // the sRGB encoding: dots read as a cloud, not as a surface.
        glm::vec3 albedo = glm::vec3(0xC8) / 255.0f;
        if (points.hasColour()) albedo = glm::vec3(points.colour[i]) / 255.0f;
        const glm::vec3 colour = albedo * (0.35f + 0.65f * facing);
        const int x0 = static_cast<int>(std::floor(px)), y0 = static_cast<int>(std::floor(py));
        for (int y = y0 - reach; y <= y0 + reach; ++y)
            for (int x = x0 - reach; x <= x0 + reach; ++x) {
                if (x < 0 || y < 0 || x >= int(width) || y >= int(height)) continue;
                const float dx = float(x) + 0.5f - px, dy = float(y) + 0.5f - py;
                if (dx * dx + dy * dy > radiusPx * radiusPx) continue;
                float& z = depth[std::size_t(y) * width + std::size_t(x)];
                if (distance >= z) continue;
                z = distance;
                std::uint8_t* p = &image.pixels[(std::size_t(y) * width + std::size_t(x)) * 4];
                p[0] = toByte(colour.x);
                p[1] = toByte(colour.y);
                p[2] = toByte(colour.z);
            }
    }
    return image;
}

Comparison renderComparison(engine::Context& context, CompareJob job) {
    const std::uint32_t width = job.engine.width, height = job.engine.height;
    Comparison out;
    // Panel 1: the input as dots of a fixed size (2 px in radius in a 540-pixel-high panel).
    const float dotRadius = std::max(1.0f, float(height) / 270.0f);
    out.panels[0] = drawDots(job.input, job.camera, width, height, job.background, dotRadius);

    engine::EngineSettings splatSettings = engineSettings(job.engine, context, false);
    splatSettings.render.background = job.background;
    engine::EngineSettings refinedSettings = engineSettings(job.engine, context, true);
    refinedSettings.render.background = job.background;
    out.path = splatSettings.render.path;
    // Panel 2: the input as splats; panel 3: refined for this camera (render --adaptive).
    out.panels[1] = renderFrame(context, job.input, splatSettings, job.camera, nullptr, nullptr);
    out.panels[2] = renderFrame(context, std::move(job.input), refinedSettings, job.camera, &out.refinedFrame,
                                &out.treePoints);
    if (job.reference) {
        out.reference =
            renderFrame(context, std::move(*job.reference), splatSettings, job.camera, nullptr, nullptr);
        out.splats = unwrap(engine::compareImages(out.panels[1], out.reference));
        out.refined = unwrap(engine::compareImages(out.panels[2], out.reference));
    }

    return out;
}

engine::RgbaImage sideBySide(std::span<const engine::RgbaImage> panels,
                             std::span<const std::string> captions) {
    assert(!panels.empty() && captions.size() == panels.size());
    const std::uint32_t width = panels[0].width, height = panels[0].height;
    const bool any = std::ranges::any_of(captions, [](const std::string& c) { return !c.empty(); });
    const int strip = any ? captionHeight(width) : 0;
    const auto count = static_cast<std::uint32_t>(panels.size());
    engine::RgbaImage picture =
        filled(count * width, height + std::uint32_t(strip), glm::vec3(viewer::kPanelBackground) / 255.0f);
    for (std::uint32_t k = 0; k < count; ++k) {
        assert(panels[k].width == width && panels[k].height == height);
        place(picture, panels[k], k * width);
        if (captions[k].empty()) continue;
        // The caption's panel, cut off at the panel's right edge.
        const viewer::TextLine line{captions[k], viewer::kTextColour};
        engine::RgbaImage label = viewer::drawPanel({&line, 1}, captionScale(width));
        if (label.width > width) label = leftPart(label, width);
        viewer::paste(picture, {std::move(label), int(k * width), int(height)});
    }
    return picture;
}

} // namespace pnsplat::tools
