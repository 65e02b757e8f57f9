// The real-time engine (paper section 7; docs/ARCHITECTURE.md, "Real-time refinement"): one frame
// loop for `pnsplat render`, `pnsplat bench` and the viewer.
//
// Each frame: finished refinements join the node tree (node_tree.h); the nodes are selected for
// the camera (frustum culling; level of detail by projected splat size, with hysteresis);
// visible nodes whose splats are larger than the threshold are queued for refinement, coarsest
// level first, then largest on screen (breadth-first), on the worker threads (node_workers.h).
// chunks of nodes to draw go into the ring-buffer cache (chunk_cache.h); the three passes draw the
// selected chunks (splat_renderer.h). The render thread never waits for a refinement: a node is
// drawn once its children are all uploaded, its parent until then. With `lockstep` a frame instead
// refines and uploads until nothing more is wanted for its camera (settled), which makes frames
// reproducible. Frames are pipelined (frames.h): frame() waits only for the frame that used the
// same resources kFramesInFlight frames before.
//
// Without `adaptive` the engine draws the input as it is (the nodes of the input, no refinement):
// `pnsplat render` without --adaptive.
//
// Thread use: create, frame and everything else on one thread (the render thread).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "pnsplat/engine/camera.h"
#include "pnsplat/engine/context.h"
#include "pnsplat/engine/image.h"
#include "pnsplat/engine/splat_renderer.h"
#include "pnsplat/refine/node_tree.h"
#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/result.h"

namespace pnsplat::engine {

// The colour of splats of a model without colour (sRGB).
inline constexpr std::uint32_t kDefaultColour = 0xC8C8C8u;

// The default of EngineSettings::wholeLevelPoints: the sparse inputs of ../shared/data (3,500
// points) start from their fourth level, the uniform 600-point igea from its fifth
// (docs/REALTIME.md, "Whole levels first").
inline constexpr std::size_t kWholeLevelPoints = 250'000;

// The default of EngineSettings::workerNice: the refinement workers yield the processors to the
// render thread and the driver's threads (lavapipe draws on the same cores), and take what the
// frame leaves. On the 2-core host, against nice 0, the zooms' p95 frame fell by a sixth to a third
// and the pictures along the paths held or improved (docs/REALTIME.md, "Worker priority").
inline constexpr int kWorkerNice = 10;

struct EngineSettings {
    RenderSettings render;
    bool adaptive = true;
    // The splat diameter wanted on screen, in pixels (> 0): a node whose median splat drawn is wider is
    // refined, and so is one whose splats at the silhouette stand out of the surface (selection.cpp;
    // docs/REALTIME.md, "The level of detail"). At 3 px the points drawn lie about a pixel apart.
    float threshold = 3.0f;
    // A node drawn refined (its children) goes back to being drawn itself once its own splats are
    // below threshold × hysteresis, in (0, 1]: a moving camera does not flip between two levels. At
    // rest the level of detail decides without it, as a camera that never moved would.
    float hysteresis = 0.8f;
    // A frame time to keep to, in milliseconds (0: none). Where frames take longer, the threshold in
    // force rises (coarser nodes, fewer splats) until they fit, and falls back towards `threshold`
    // while they have room: a device too slow for the threshold keeps its frame rate, and a fast
    // one draws at the threshold. The threshold in force is in each FrameReport. Not in lockstep,
    // and not while the camera rests (FrameReport::resting): then the frames draw at `threshold`
    // until the picture is the settled one, and the target applies again, from the threshold in
    // force before, once the camera moves.
    float targetFrameMs = 0.0f;
    // The GPU cache, in bytes (32 bytes a splat); must hold the input's points.
    std::size_t cacheBytes = std::size_t{96} << 20;
    // Points the node tree keeps on the CPU, as a multiple of the cache's capacity: the nodes drawn,
    // their ancestors and recently drawn nodes (the least recently drawn are released first).
    float cpuCacheFactor = 2.0f;
    // Refinement worker threads (>= 1), and the nice value added to theirs (Linux: 0 shares the
    // processors equally with the render thread and the driver's threads); docs/REALTIME.md has the
    // measurements behind the defaults.
    unsigned workers = 2;
    int workerNice = kWorkerNice;
    // Most bytes uploaded to the cache per frame (not in lockstep), so that a burst of refined
    // nodes does not stall one frame.
    std::size_t uploadBytesPerFrame = std::size_t{16} << 20;
    // Whole levels first (NodeSettings::wholeLevelPoints, which this sets, at most half of the
    // points the tree keeps: cpuCacheFactor times the cache's capacity), refined on `workers`
    // threads before the first frame; the tree keeps them (they are not released).
    std::size_t wholeLevelPoints = kWholeLevelPoints;
    NodeSettings nodes;
    bool forceStaging = false; // write the cache through staging even where it is host-visible (tests)
};

struct FrameOptions {
    bool lockstep = false; // refine and upload until settled before drawing (see above)
    bool readBack = false; // keep the image: image() after the frame has finished
    bool measureSplats =
        false; // FrameReport::medianSplatPx, maxSplatPx and overThreshold (a pass over the splats drawn)
    FrameOutput output; // where else the image goes (a swapchain); readBack is taken from above
};

// What one frame did. The CPU parts are known when frame() returns; the GPU pass times when the
// frame has finished (reports()).
struct FrameReport {
    std::uint64_t frame = 0;
    Camera camera;                            // the camera drawn
    double cpuMs = 0.0;                       // frame() from entry to submission
    double selectionMs = 0.0, uploadMs = 0.0; // of that: choosing nodes; writing chunks
    double refineWaitMs = 0.0;                // of that, in lockstep or at rest: waiting for the workers
    double gpuWaitMs = 0.0;                   // of that: waiting for the frame kFramesInFlight back
    double refineMs = 0.0;                    // of that: results into the tree, jobs out, releases
    PassTimes gpu;
    std::size_t splatsDrawn = 0, nodesVisible = 0;
    // With readBack, once finished (reports()): the pixels a splat covers (not the background).
    std::size_t coveredPixels = 0;
    std::size_t nodesRefined = 0, pointsGenerated = 0; // refinements that joined the tree this frame
    std::size_t nodesUploaded = 0, bytesUploaded = 0, evictions = 0;
    std::size_t cacheBytesUsed = 0, queueLength = 0; // after the frame; jobs waiting or running
    // Time since the last frame's report during which a refinement job was waiting or running (the
    // queue was not empty; NodeWorkers::busySeconds): points generated over it is the refinement's
    // rate while it has work.
    double refineBusyMs = 0.0;
    // Processor time of the refinement jobs that finished since the last frame's report, summed
    // over the workers (NodeWorkers::jobSeconds): points generated over it is the refinement's rate
    // per core, which waiting for a processor does not lower.
    double refineCpuMs = 0.0;
    std::size_t treeNodes = 0, treePoints = 0; // on the CPU
    // Nothing was wanted for this camera at the threshold asked for: no refinement, no upload, and the
    // threshold in force is the one asked for (the frame-time target has not raised it, or let go);
    // and, but in lockstep, no node is drawn through its children by the hysteresis alone
    // (heldByHysteresis), which lets go at rest: the picture is the one a fresh engine draws in
    // lockstep.
    bool settled = false;
    // Nodes drawn through their children by the hysteresis alone (Selection::heldByHysteresis): a
    // camera that stopped after a move draws them so until it is at rest.
    std::size_t heldByHysteresis = 0;
    // The camera has not moved for half a second: the frame-time target let go (thresholdPx is the
    // threshold asked for) until it moves again, and refinement goes on to the settled picture.
    bool resting = false;
    float thresholdPx = 0.0f; // the threshold in force (EngineSettings::targetFrameMs)
    // With measureSplats (splatsMeasured): the median and the largest projected splat diameter
    // drawn, as the level of detail measures it (Node::shape.splatRadius; pixels), and the share of
    // the splats drawn (in view, facing the eye) above the threshold (about half of a node's splats
    // may be: its median is what the level of detail holds to).
    bool splatsMeasured = false;
    float medianSplatPx = 0.0f;
    float p99SplatPx = 0.0f; // the 99th percentile (SplatSizes::p99Px)
    float maxSplatPx = 0.0f;
    double overThreshold = 0.0;
};

class Engine {
  public:
    // `points` need normals and radii (completeInput); with settings.adaptive they must pass
    // validateForRefinement. Errors: settings out of range, a cache too small for the input or too
    // large for the device, a Vulkan error.
    static Result<std::unique_ptr<Engine>> create(Context& context, PointSet points,
                                                  const EngineSettings& settings);
    ~Engine();
    Engine(const Engine&) = delete;
    Engine& operator=(const Engine&) = delete;

    // One frame for `camera` (which must be valid(): else an error, nothing drawn). At rest
    // (FrameReport::resting), not in lockstep, it first waits up to 100 ms for the refinement jobs
    // outstanding, so that the workers have the processors (refineWaitMs).
    Result<FrameReport> frame(const Camera& camera, const FrameOptions& options = {});
    // New render settings (image size, path, splat look) for the frames that follow. A new size or
    // path waits for the frames in flight, then makes the passes anew; the rest (background, splat
    // look, heat map: SplatRenderer::adjust) applies from the next frame without waiting. On error
    // the old settings stay.
    Result<void> setRenderSettings(const RenderSettings& render);
    // The threshold asked for (EngineSettings::threshold: pixels, > 0) from the next frame on: nodes
    // are refined, or drawn coarser, to it as frames go (no wait, nothing refined is dropped). A
    // threshold in force raised by the frame-time target keeps its ratio to the one asked. On
    // error (not a positive number) nothing changes.
    Result<void> setThreshold(float px);
    // Reports of the frames that have finished since the last call (GPU times filled), in order; the
    // latest 256 at most.
    std::vector<FrameReport> reports();
    // Waits for every frame submitted; then reports() returns all of them (the latest 256).
    void finish();
    // The image of `frame`, which was drawn with readBack: waits for it. Only until its frame slot
    // is used again (kFramesInFlight frames later).
    Result<RgbaImage> image(std::uint64_t frame);

    // The sphere enclosing the input (cameras are framed on it).
    Sphere bounds() const;
    const EngineSettings& settings() const;
    const NodeTree& tree() const;
    // The refinement's time up to `report`, a frame in lockstep (render --adaptive, bench settle):
    // the tree's creation (its whole levels refined, split and measured) and the workers waited for.
    double refinementMs(const FrameReport& report) const;
    // The nodes drawn by the last frame, and the deepest level among them (0 when none).
    std::span<const NodeId> drawn() const;
    std::uint32_t deepestDrawnLevel() const;
    // Test access. Waits for the GPU, reads the cache buffer back and compares every resident
    // node's chunk with the splats of its points on the CPU: the number of nodes compared, or an
    // error naming the first node that differs.
    Result<std::size_t> verifyCache();
    // Test access: splat ranges drawn by frames in flight that a chunk write has overlapped (must
    // stay 0: the cache evicts no chunk a frame in flight reads).
    std::size_t overwritesInFlight() const;

  private:
    struct Impl;
    explicit Engine(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

} // namespace pnsplat::engine
