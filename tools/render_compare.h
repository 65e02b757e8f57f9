// `pnsplat render --compare`: one camera, three panels side by side in one picture — the input as
// points, the input as splats, and the refinement for that camera (the real-time engine in
// lockstep, as `render --adaptive`) — and, against a dense render of the same surface from the same
// camera, how close the two splat panels come (PSNR, SSIM).
#pragma once

#include <optional>
#include <span>
#include <string>

#include <glm/vec3.hpp>

#include "engine_setup.h"
#include "pnsplat/engine/camera.h"
#include "pnsplat/engine/context.h"
#include "pnsplat/engine/engine.h"
#include "pnsplat/engine/image.h"
#include "pnsplat/refine/point_set.h"

namespace pnsplat::tools {

// Points of the dense version of the default model that serve as its reference (shapes.h,
// sampleDefaultModel): about 1.3 px apart where the model fills a 540-pixel-high panel.
inline constexpr std::size_t kDefaultReferencePoints = 300000;

struct CompareJob {
    PointSet input;                    // normals and radii (completeInput); a valid refinement input
    std::optional<PointSet> reference; // a dense version of the same surface (normals, radii), or none
    engine::Camera camera;             // valid; used for every panel and the reference
    EngineArgs engine; // width and height: of each panel; the rest: the refined panel's engine
    glm::vec3 background{1.0f};
};

struct Comparison {
    engine::RgbaImage panels[3];                            // each width × height: points, splats, refined
    engine::RgbaImage reference;                            // width × height, or empty without a reference
    std::optional<engine::ImageDifference> splats, refined; // each against the reference
    engine::FrameReport refinedFrame;                       // the refined panel's frame (measured)
    std::size_t treePoints = 0; // points in the engine's node tree at the end (every level)
    engine::RenderPath path = engine::RenderPath::Compute;
};

// Renders the three panels and the reference with `context` (render thread). Throws CommandError
// on an engine or Vulkan failure.
Comparison renderComparison(engine::Context& context, CompareJob job);

// The panels (of one size) side by side, left to right, over a strip of captions, one line under
// each (as many captions as panels, each cut off at its panel's edge; the strip is left out when
// all are empty): a picture panels · width × (height + captionHeight(width)).
engine::RgbaImage sideBySide(std::span<const engine::RgbaImage> panels,
                             std::span<const std::string> captions);
// The caption strip's height in pixels under panels `width` wide: 18, or 36 from 480 pixels wide.
int captionHeight(std::uint32_t width);

// `points` as dots of `radiusPx` pixels (fixed on screen), coloured by their colour (the engine's
// default grey without) and shaded by the headlight; points facing away are left out, nearer dots
// cover farther ones. On the CPU; a picture width × height of `background`.
engine::RgbaImage drawDots(const PointSet& points, const engine::Camera& camera, std::uint32_t width,
                           std::uint32_t height, glm::vec3 background, float radiusPx);

} // namespace pnsplat::tools
