// Which nodes a frame draws, refines and uploads (ALGORITHM.md §8.3; docs/REALTIME.md, "The level
// of detail"): culling by the view frustum and the nodes' normal cones, the level of detail with its
// hysteresis, and the facing classes of the nodes drawn. No Vulkan: the engine (engine.h) calls it
// once or more a frame (lockstep rounds), and tests run it without a device.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "pnsplat/engine/camera.h"
#include "pnsplat/refine/node_tree.h"

namespace pnsplat::engine {

// Frame stamps are a frame's index + 1; this one is none.
inline constexpr std::uint64_t kNever = 0;

// Facing classes: a normal's class is the face of the cube its direction crosses (+x, +y, +z, -x,
// -y, -z: the axis direction nearest it) and the cell of that face, the face cut into
// kFacingCells × kFacingCells by the normal's two other components over the largest. A chunk holds
// its splats class after class, so that a frame can leave out the classes of a node none of whose
// splats faces the eye before the passes: beside the silhouette a node's normals spread over half a
// sphere and more. With whole faces (6 classes) about a third of the splats of the nodes drawn
// faced away (the passes skip them one by one); with 2 × 2 cells (24 classes) the splats drawn fell
// by 11 to 19 % at bench settle's framing and grazing cameras (bunny, lion, nefertiti; the same
// picture), at the same pass times (docs/REALTIME.md, "Choices").
inline constexpr std::uint32_t kFacingCells = 2;
inline constexpr std::uint32_t kFacingClasses = 6 * kFacingCells * kFacingCells;
using FacingMask = std::uint64_t; // bit c: class c
static_assert(kFacingClasses <= 64);
using ClassStarts = std::array<std::uint32_t, kFacingClasses + 1>; // offsets in the chunk
std::uint32_t facingClass(glm::vec3 n);

// A frame's view of the scene, computed once a frame (frameView) and read by the selection, the
// measure of the splats drawn and the passes.
struct FrameView {
    Camera camera;
    glm::mat4 view{1.0f};
    glm::vec3 forward{0.0f}, right{0.0f}, upward{0.0f}; // the camera's axes in world space
    Frustum frustum{};                                  // its range: the passes' depth range
    float focal = 0.0f;                                 // pixels per unit at depth 1
    float radiusScale = 1.0f;                           // RenderSettings::radiusScale
};
// `bounds` encloses every splat of the scene (its depth range is the passes').
FrameView frameView(const Camera& camera, std::uint32_t width, std::uint32_t height, float radiusScale,
                    const Sphere& bounds);

// What the selection keeps of a node slot between frames.
struct NodeSelection {
    ClassStarts classes{};                // where each facing class starts in its chunk
    std::vector<std::uint8_t> pointClass; // while resident: each point's facing class (facingClass)
    bool resident = false;                // its chunk is in the cache
    bool descended = false;               // drawn through its children the last time it was visited
    std::uint64_t lastVisited = kNever;   // frame + 1 of the last selection that passed through it
};

struct SelectionSettings {
    float threshold = 3.0f; // the threshold in force, pixels (EngineSettings::threshold)
    float asked = 3.0f;     // the one asked for: the silhouette test scales with threshold / asked
    float hysteresis = 0.8f;
    bool adaptive = true; // leaves may be refined
    bool cullNodes = true;
};

// A node wanted refined or uploaded, and its order: coarsest level first, then largest on screen
// (its 99th percentile splat at its nearest depth), then id.
struct WantedNode {
    NodeId node;
    std::uint32_t level;
    float size;
};
struct Selection {
    std::vector<NodeId> draw;
    std::vector<FacingMask> facing; // per node drawn: the facing classes drawn (bit c: class c)
    std::vector<WantedNode> refine, upload;
    // Nodes drawn through their children only by the hysteresis (their splats pass the test at the
    // threshold in force, not at its hysteresis multiple): a camera that never moved would draw them
    // themselves.
    std::size_t heldByHysteresis = 0;
};

// Walks the tree from its roots for the frame `stamp` (index + 1). A node is drawn through its
// children while its splats are too coarse for the threshold, once all of its visible children
// are resident (until then it is drawn itself and they are wanted for upload); a leaf too coarse
// is wanted refined. `stateOf` gives each node slot's NodeSelection, which the walk updates
// (`descended`, `lastVisited`).
Selection selectNodes(const NodeTree& tree, const FrameView& view, const SelectionSettings& settings,
                      std::uint64_t stamp, const std::function<NodeSelection&(NodeId)>& stateOf);

// The splats of `drawn` in view and facing the eye (as the passes draw them), measured as the level
// of detail measures them (Node::shape.splatRadius): their median, 99th-percentile (by
// quantileIndex, as splatDiameterQuantile takes it) and largest diameters on screen and the share of
// them wider than `threshold` pixels (zeros when none).
struct SplatSizes {
    float medianPx = 0.0f, p99Px = 0.0f, maxPx = 0.0f;
    double overThreshold = 0.0;
};
SplatSizes measureSplats(const NodeTree& tree, std::span<const NodeId> drawn, const FrameView& view,
                         float threshold);

} // namespace pnsplat::engine
