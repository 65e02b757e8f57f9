// The real-time engine (engine.h).
#include "pnsplat/engine/engine.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <chrono>
#include <cmath>
#include <cstring>
#include <deque>
#include <optional>
#include <string>

#include <fmt/format.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "chunk_cache.h"
#include "gpu_types.h"
#include "pnsplat/engine/selection.h"
#include "pnsplat/refine/node_workers.h"

namespace pnsplat::engine {

namespace {

using Clock = std::chrono::steady_clock;
double millisecondsSince(Clock::time_point t) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

// Reports of finished frames kept until reports() takes them.
constexpr std::size_t kKeptReports = 256;
// The threshold in force stays at most this many times the one asked for (adaptThreshold). Past a
// point a coarser level costs as much as it saves (the pixels a frame's footprints cover stay, and
// fewer, larger splats each walk more of them) while its picture gets worse: bench view of the
// bunny at 640x480 on lavapipe, orbit and zoom, against the settled pictures: at 8 times (24 px)
// 29.5 / 47.7 ms median frames and 38.2 / 31.5 dB median PSNR, at 3 times 32.4 / 53.8 ms and
// 39.8 / 36.3 dB. 4 since the silhouettes coarsen with the square root of the rise (selection.cpp):
// the bunny's and the lion's zooms 41.9 and 41.7 ms, 39.3 and 37.4 dB, against 43.0 and 46.7 ms,
// 40.4 and 39.3 dB at 3 (docs/REALTIME.md). (With the 99th-percentile rule before, 16 px was the
// point.)
constexpr float kMaxThresholdRise = 4.0f;
// A camera unchanged for this long (and at least kRestFrames frames) is at rest: the frame-time
// target lets go, and the threshold in force is the one asked for, so that refinement goes on to
// it and the picture becomes the settled one; it applies again once the camera moves (from the
// moving frames' mean frame time: adaptThreshold). QSplat
// (2000) shrank its splats after half a second at rest.
constexpr double kRestSeconds = 0.5;
constexpr std::size_t kRestFrames = 2;
// At rest, a frame first waits up to this long for the refinement jobs outstanding: the picture
// changes only as the tree does, and the processors the frames would take go to the workers, which
// run at a lower priority than drawing (kWorkerNice). The bunny held still after a turn of a bench
// view path (640x480, 2-core host): without the wait, at nice 10, the picture was 50 dB from the
// settled one after 2.0 s and not settled 7 s later (docs/REALTIME.md, "At rest"). Engine::frame
// blocks that long at most, so a camera that moves again is drawn that much later.
constexpr auto kRestWait = std::chrono::milliseconds(100);

// The splats of a node's points (normals, radii drawn: Node::shape.splatRadius, optional colours), 32 bytes
// each (gpu::Splat): a chunk's contents, for its upload and its check, and the classes' starts. By facing
// class, then in order of radius (then of index): the compute path gives each splat one invocation, and
// invocations run in lockstep in groups (8 lanes of a SIMD batch on lavapipe, a subgroup on a GPU), each
// group as long as its largest footprint; splats of like radii side by side waste fewer lanes (the bunny
// close-up at 640x480 on lavapipe: visibility 25.5 -> 21.6 ms). The compute path's sums are integers and its
// depth a minimum, so its picture does not depend on the order (the graphics path's float blending does, in
// the last bits).
ClassStarts packSplats(const PointSet& points, std::span<const float> radius, gpu::Splat* splats,
                       std::vector<std::uint8_t>* pointClass = nullptr) {
    // Radii are positive: their bits order as the floats do.
    struct Key {
        std::uint32_t facing, radius, index;
        auto operator<=>(const Key&) const = default;
    };
    std::vector<Key> order(points.size());
    ClassStarts starts{};
    for (std::size_t i = 0; i < points.size(); ++i) {
        const std::uint32_t facing = facingClass(points.normal[i]);
        order[i] = {facing, std::bit_cast<std::uint32_t>(radius[i]), static_cast<std::uint32_t>(i)};
        ++starts[facing + 1];
    }
    for (std::uint32_t c = 0; c < kFacingClasses; ++c) starts[c + 1] += starts[c];
    if (pointClass != nullptr) {
        pointClass->resize(points.size());
        for (std::size_t i = 0; i < points.size(); ++i)
            (*pointClass)[i] = static_cast<std::uint8_t>(order[i].facing);
    }
    std::sort(order.begin(), order.end());
    for (std::size_t k = 0; k < points.size(); ++k) {
        const std::size_t i = order[k].index;
        std::uint32_t colour = kDefaultColour;
        if (points.hasColour()) {
            const glm::u8vec3 c = points.colour[i];
            colour = std::uint32_t{c.x} | std::uint32_t{c.y} << 8 | std::uint32_t{c.z} << 16;
        }
        splats[k] = gpu::Splat{points.position[i], radius[i], points.normal[i], colour};
    }
    return starts;
}

} // namespace

struct Engine::Impl {
    Context& context;
    EngineSettings settings;
    NodeTree tree;
    // Declared in the order they must be destroyed last to first: the frames (waiting for the GPU)
    // go first, then the workers (joined), then what the GPU read.
    std::unique_ptr<SplatRenderer> renderer;
    std::unique_ptr<ChunkCache> cache;
    std::unique_ptr<NodeWorkers> workers;
    std::unique_ptr<FrameRing> frames;

    // Per node slot of the tree.
    struct NodeState : NodeSelection {
        Chunk chunk;
        bool jobInFlight = false;        // a refinement of it is with the workers
        std::uint64_t uploaded = kNever; // frame + 1 of its upload
    };
    std::vector<NodeState> state;

    Sphere modelBounds;
    bool hasColour = false;          // else every splat is kDefaultColour
    double workersBusySeconds = 0.0; // NodeWorkers::busySeconds at the last frame's report
    double workersJobSeconds = 0.0;  // NodeWorkers::jobSeconds at the last frame's report
    float rootMaxRadius = 0.0f;
    // The threshold in force, and the frame time it is adapted to (EngineSettings::targetFrameMs):
    // an exponential mean of the time from one frame's start to the next's.
    float threshold = 0.0f;
    float movingThreshold = 0.0f; // the threshold in force while the camera moves, kept at rest
    double meanFrameMs = 0.0;
    // The last frame's camera, and since when (and for how many frames) it has not moved.
    Camera lastCamera;
    Clock::time_point stillSince{};
    std::size_t stillFrames = 0;
    Clock::time_point lastFrameStart{};
    bool haveLastFrame = false;
    bool lastResting = false; // the last frame was at rest
    std::vector<NodeId> drawnNodes;
    std::vector<FacingMask> drawnFacing; // Selection::facing of drawnNodes
    std::deque<FrameReport> submitted;   // frames in flight, oldest first
    std::deque<FrameReport> finished;    // the latest kKeptReports at most
    // Test check: the ranges each frame in flight draws, to see that no write overlaps them.
    std::array<std::vector<DrawRange>, kFramesInFlight> slotDraws;
    std::array<std::uint64_t, kFramesInFlight> slotFrame{};
    std::size_t overwrites = 0;

    Impl(Context& c, const EngineSettings& s, NodeTree t) : context(c), settings(s), tree(std::move(t)) {}

    NodeState& stateOf(NodeId id) {
        if (state.size() <= id) state.resize(tree.slotCount());
        return state[id];
    }
    // The oldest frame (as frame + 1) that may still read the cache: pinned from there on.
    std::uint64_t oldestInUse() { return frames->completed() + 1; }

    // The frame's view: the scene's splats lie within modelBounds grown by the largest drawn radius.
    FrameView viewOf(const Camera& camera) const {
        const float margin = 2.0f * rootMaxRadius * settings.render.radiusScale;
        return frameView(camera, settings.render.width, settings.render.height, settings.render.radiusScale,
                         {modelBounds.centre, modelBounds.radius * 1.05f + margin});
    }
    Selection select(const FrameView& view, bool resting);
    void integrate(FrameReport& report);
    std::size_t dispatch(const std::vector<WantedNode>& wanted, bool lockstep);
    std::size_t upload(const std::vector<WantedNode>& wanted, bool lockstep, FrameReport& report,
                       VkCommandBuffer& uploads);
    void releaseUnused();
    bool resting(const Camera& camera, Clock::time_point start);
    void adaptThreshold(Clock::time_point start, bool lockstep, bool resting);
    void collectFinished();
};

Result<std::unique_ptr<Engine>> Engine::create(Context& context, PointSet points,
                                               const EngineSettings& settings) {
    if (!(settings.threshold > 0.0f) || !std::isfinite(settings.threshold))
        return Error{fmt::format("the splat size threshold must be a positive number of pixels (got {})",
                                 settings.threshold)};
    if (!(settings.hysteresis > 0.0f && settings.hysteresis <= 1.0f))
        return Error{fmt::format("the hysteresis must lie in (0, 1] (got {})", settings.hysteresis)};
    if (settings.workers < 1) return Error{"at least one refinement worker is needed"};
    if (!(settings.cpuCacheFactor >= 1.0f)) return Error{"the CPU cache factor must be at least 1"};
    if (!(settings.targetFrameMs >= 0.0f) || !std::isfinite(settings.targetFrameMs))
        return Error{fmt::format("the target frame time must be a number of milliseconds (got {})",
                                 settings.targetFrameMs)};
    if (points.empty() && settings.adaptive) return Error{"there are no points to refine"};
    const std::size_t inputPoints = points.size();
    const std::size_t splatBytes = sizeof(gpu::Splat);
    // The passes read the cache as texels, two a splat (splat_common.glsl).
    const std::size_t deviceSplats = context.properties().limits.maxTexelBufferElements / 2;
    std::size_t capacity = settings.cacheBytes / splatBytes;
    if (!settings.adaptive) capacity = std::max<std::size_t>(inputPoints, 1); // no ring: the input only
    const auto mib = [](double bytes) { return bytes / double(1 << 20); };
    if (inputPoints > deviceSplats)
        return Error{fmt::format("{} splats exceed the device's texel buffer limit of {} splats ({:.0f} MiB)",
                                 inputPoints, deviceSplats, mib(double(deviceSplats * splatBytes)))};
    if (capacity < inputPoints)
        return Error{
            fmt::format("a cache of {:.1f} MiB cannot hold the input's {} points ({:.1f} MiB, 32 bytes "
                        "each), which stay resident; give it at least {:.0f} MiB",
                        mib(double(settings.cacheBytes)), inputPoints, mib(double(inputPoints * splatBytes)),
                        std::ceil(mib(double(inputPoints * splatBytes)) * 2.0))};
    if (capacity > deviceSplats)
        return Error{
            fmt::format("a cache of {:.0f} MiB exceeds the device's texel buffer limit of {:.0f} MiB",
                        mib(double(settings.cacheBytes)), mib(double(deviceSplats * splatBytes)))};

    const bool hasColour = points.hasColour();
    NodeSettings nodes = settings.nodes;
    // The tree keeps the whole levels for good: at most half of the points it may keep.
    nodes.wholeLevelPoints =
        std::min(settings.wholeLevelPoints,
                 static_cast<std::size_t>(0.5 * double(settings.cpuCacheFactor) * double(capacity)));
    nodes.refine.threads = settings.workers;
    auto tree = NodeTree::create(std::move(points), nodes, settings.adaptive);
    if (!tree) return tree.error();
    auto renderer = SplatRenderer::create(context, settings.render);
    if (!renderer) return renderer.error();
    auto impl = std::make_unique<Impl>(context, settings, std::move(tree).value());
    impl->threshold = impl->movingThreshold = settings.threshold;
    impl->hasColour = hasColour;
    impl->renderer = std::move(renderer).value();
    try {
        impl->cache = std::make_unique<ChunkCache>(context, static_cast<std::uint32_t>(capacity),
                                                   settings.forceStaging);
        impl->frames = std::make_unique<FrameRing>(context);
        if (settings.adaptive)
            impl->workers =
                std::make_unique<NodeWorkers>(settings.workers, settings.nodes, settings.workerNice);
        // The input's chunks, at the front of the cache for good; uploaded with the first frame's
        // transfers (or directly).
        glm::vec3 lo(std::numeric_limits<float>::max()), hi(std::numeric_limits<float>::lowest());
        impl->frames->begin();
        VkCommandBuffer uploads = VK_NULL_HANDLE;
        std::vector<gpu::Splat> splats;
        for (const NodeId root : impl->tree.roots()) {
            const Node& node = impl->tree.node(root);
            lo = glm::min(lo, node.lo);
            hi = glm::max(hi, node.hi);
            impl->rootMaxRadius = std::max(impl->rootMaxRadius, node.maxRadius);
            const auto chunk = impl->cache->allocatePermanent(static_cast<std::uint32_t>(node.points.size()));
            assert(chunk);
            splats.resize(node.points.size());
            Impl::NodeState& s = impl->stateOf(root);
            s.classes = packSplats(node.points, node.shape.splatRadius, splats.data(), &s.pointClass);
            impl->cache->write(*chunk, splats, *impl->frames, uploads);
            s.chunk = *chunk;
            s.resident = true;
        }
        if (uploads != VK_NULL_HANDLE) {
            impl->frames->submit(uploads, true);
        } else {
            // Nothing to submit: an empty submission signals the frame's fence.
            impl->frames->submit(impl->frames->commandBuffer(), true);
        }
        impl->modelBounds = impl->tree.roots().empty()
                                ? Sphere{glm::vec3(0.0f), 1.0f}
                                : Sphere{(lo + hi) * 0.5f, glm::length(hi - lo) * 0.5f};
        const Sphere& b = impl->modelBounds;
        if (!std::isfinite(b.radius) || !std::isfinite(b.centre.x) || !std::isfinite(b.centre.y) ||
            !std::isfinite(b.centre.z))
            return Error{"the points spread farther than can be measured (their bounding sphere overflows "
                         "3.4e38); scale the model down"};
    } catch (const VulkanError& e) {
        return Error{std::string("Vulkan: ") + e.what()};
    }
    return std::unique_ptr<Engine>(new Engine(std::move(impl)));
}

Engine::Engine(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Engine::~Engine() = default;

// At rest the level of detail decides without hysteresis, as a camera that never moved would: the
// nodes a turn left refined whose splats pass the test at the threshold (not at its hysteresis
// multiple: Selection::heldByHysteresis) are drawn themselves again, so that
// the picture becomes the lockstep settled one (after the bunny's and the lion's turns it stayed
// 1 to 2 dB short of 50 dB from it); the camera does not move, so no level flips.
Selection Engine::Impl::select(const FrameView& view, bool resting) {
    const SelectionSettings selection{threshold, settings.threshold, resting ? 1.0f : settings.hysteresis,
                                      settings.adaptive, settings.render.cullNodes};
    return selectNodes(tree, view, selection, frames->index() + 1,
                       [this](NodeId id) -> NodeSelection& { return stateOf(id); });
}

void Engine::Impl::integrate(FrameReport& report) {
    if (!workers) return;
    for (NodeJobResult& result : workers->takeResults()) {
        const NodeId id = result.node;
        if (tree.isLive(id)) stateOf(id).jobInFlight = false;
        const std::size_t before = tree.isLive(id) ? tree.node(id).points.size() : 0;
        if (!tree.attach(std::move(result))) continue;
        ++report.nodesRefined;
        std::size_t after = 0;
        for (const NodeId c : tree.node(id).childIds()) {
            stateOf(c) = NodeState{};
            after += tree.node(c).points.size();
        }
        report.pointsGenerated += after - before;
    }
}

// Submits jobs for the wanted nodes, or for the coarser leaves they wait for (balance rule). Returns
// the number submitted. Outside lockstep at most 6 jobs a worker (+ 2) are outstanding: jobs are
// handed out once a frame, and a node's job (a few milliseconds) must not leave its worker idle for
// the rest of a frame; with 2 a worker the bunny's orbit generated 181,000 points/s while nodes were
// queued, with 6 232,000 (docs/REALTIME.md).
std::size_t Engine::Impl::dispatch(const std::vector<WantedNode>& wanted, bool lockstep) {
    const std::size_t capacity =
        lockstep ? std::numeric_limits<std::size_t>::max() : 6 * workers->threads() + 2;
    std::vector<NodeJob> jobs;
    std::vector<NodeId> blockers, pending;
    const auto full = [&] { return workers->outstanding() + jobs.size() >= capacity; };
    for (const WantedNode& w : wanted) {
        if (full()) break;
        pending.assign(1, w.node);
        // Depth-first through the blockers: each node is ready or names the coarser leaves it waits
        // for, which lie at lower levels, so this ends.
        while (!pending.empty() && !full()) {
            const NodeId id = pending.back();
            pending.pop_back();
            NodeState& s = stateOf(id);
            if (s.jobInFlight) continue;
            blockers.clear();
            if (tree.ready(id, blockers)) {
                jobs.push_back(tree.makeJob(id));
                s.jobInFlight = true;
            } else {
                pending.insert(pending.end(), blockers.begin(), blockers.end());
            }
        }
    }
    const std::size_t count = jobs.size();
    workers->submit(std::move(jobs));
    return count;
}

// Uploads the wanted nodes' chunks (within the frame's budget unless in lockstep). Returns the
// number uploaded.
std::size_t Engine::Impl::upload(const std::vector<WantedNode>& wanted, bool lockstep, FrameReport& report,
                                 VkCommandBuffer& uploads) {
    const std::uint64_t pinnedFrom = oldestInUse();
    const std::uint64_t stamp = frames->index() + 1;
    const auto pinned = [&](std::uint32_t owner) {
        const NodeState& s = state[owner];
        return s.lastVisited >= pinnedFrom || s.uploaded == stamp;
    };
    std::vector<std::uint32_t> evicted;
    std::vector<gpu::Splat> splats;
    std::size_t count = 0;
    for (const WantedNode& w : wanted) {
        NodeState& s = stateOf(w.node);
        if (s.resident) continue;
        const Node& node = tree.node(w.node);
        const std::size_t bytes = node.points.size() * sizeof(gpu::Splat);
        if (!lockstep && report.bytesUploaded > 0 &&
            report.bytesUploaded + bytes > settings.uploadBytesPerFrame)
            break;
        evicted.clear();
        const auto chunk =
            cache->allocate(static_cast<std::uint32_t>(node.points.size()), w.node, pinned, evicted);
        if (!chunk) continue; // the cache is full of what is drawn: this node waits
        for (const std::uint32_t owner : evicted) {
            state[owner].resident = false;
            state[owner].pointClass = {};
        }
        report.evictions += evicted.size();
        // Test check: nothing a frame in flight draws is overwritten.
        for (std::uint32_t k = 0; k < kFramesInFlight; ++k) {
            if (slotFrame[k] + 1 < pinnedFrom || slotFrame[k] == 0) continue;
            for (const DrawRange& d : slotDraws[k])
                if (d.first < chunk->first + chunk->count && chunk->first < d.first + d.count) ++overwrites;
        }
        splats.resize(node.points.size());
        s.classes = packSplats(node.points, node.shape.splatRadius, splats.data(), &s.pointClass);
        cache->write(*chunk, splats, *frames, uploads);
        s.chunk = *chunk;
        s.resident = true;
        s.uploaded = stamp;
        ++count;
        ++report.nodesUploaded;
        report.bytesUploaded += bytes;
    }
    return count;
}

// The threshold in force (EngineSettings::targetFrameMs): a frame time above 90 % of the target
// raises it by sqrt(mean / (0.8 target)), 8 % to 25 % (the splats drawn fall with the threshold's
// square, so this aims at 80 % of the target), one below 70 % lowers it by 4 % towards the
// threshold asked for. The rises are larger so that an overload passes within a few frames (a
// fixed 8 % held the bunny zoom's first frames over the target for 15 frames); between the two
// bounds it stays put, so a steady view does not flip between levels. It rises to
// kMaxThresholdRise times the threshold asked for at most: a frame of few large splats costs its
// pixels (each splat's footprint walked by one invocation), which refining divides among smaller
// ones, so past that, coarser is slower.
// Whether `camera` is at rest: the same as the last frames' for kRestSeconds and kRestFrames.
bool Engine::Impl::resting(const Camera& camera, Clock::time_point start) {
    if (stillFrames == 0 || !(camera == lastCamera)) {
        lastCamera = camera;
        stillSince = start;
        stillFrames = 1;
        return false;
    }
    ++stillFrames;
    return stillFrames > kRestFrames &&
           std::chrono::duration<double>(start - stillSince).count() >= kRestSeconds;
}

void Engine::Impl::adaptThreshold(Clock::time_point start, bool lockstep, bool resting) {
    // The mean is the moving frames': a frame at rest draws at the threshold asked for and waits for
    // the workers (kRestWait), so an interval that begins or ends at rest does not count (with it,
    // the first frames after a rest rose toward the cap).
    if (haveLastFrame && !resting && !lastResting) {
        const double ms = std::chrono::duration<double, std::milli>(start - lastFrameStart).count();
        meanFrameMs = meanFrameMs > 0.0 ? 0.7 * meanFrameMs + 0.3 * ms : ms;
    }
    lastFrameStart = start;
    haveLastFrame = true;
    lastResting = resting;
    if (lockstep || settings.targetFrameMs <= 0.0f) {
        threshold = movingThreshold = settings.threshold;
        return;
    }
    if (resting) {
        threshold = settings.threshold;
        return;
    }
    // Moving (again): from the threshold in force while it last moved, not from the rest's.
    threshold = std::max(movingThreshold, settings.threshold);
    const double target = settings.targetFrameMs;
    if (meanFrameMs > 0.9 * target) {
        const auto rise = static_cast<float>(std::clamp(std::sqrt(meanFrameMs / (0.8 * target)), 1.08, 1.25));
        threshold = std::min(threshold * rise, kMaxThresholdRise * settings.threshold);
    } else if (meanFrameMs < 0.7 * target)
        threshold = std::max(settings.threshold, threshold / 1.04f);
    movingThreshold = threshold;
}

// Keeps the tree's points within cpuCacheFactor × the cache's capacity: releases the children of
// nodes whose children are leaves, no selection in use passed through and no job is refining,
// least recently visited first.
void Engine::Impl::releaseUnused() {
    const auto budget = static_cast<std::size_t>(settings.cpuCacheFactor * float(cache->capacity()));
    if (tree.pointCount() <= budget) return;
    const std::uint64_t pinnedFrom = oldestInUse();
    struct Candidate {
        std::uint64_t lastVisited;
        NodeId node;
    };
    std::vector<Candidate> candidates;
    for (NodeId id = 0; id < tree.slotCount(); ++id) {
        // The whole levels stay: a job would make other children than the whole level's.
        if (!tree.isLive(id) || tree.node(id).isLeaf() || tree.node(id).level < tree.wholeLevels()) continue;
        std::uint64_t last = kNever;
        bool releasable = true;
        for (const NodeId c : tree.node(id).childIds()) {
            const NodeState& s = stateOf(c);
            if (!tree.node(c).isLeaf() || s.jobInFlight || s.lastVisited >= pinnedFrom ||
                s.uploaded >= pinnedFrom) {
                releasable = false;
                break;
            }
            last = std::max(last, s.lastVisited);
        }
        if (releasable) candidates.push_back({last, id});
    }
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
        return a.lastVisited != b.lastVisited ? a.lastVisited < b.lastVisited : a.node < b.node;
    });
    for (const Candidate& c : candidates) {
        if (tree.pointCount() <= budget) break;
        for (const NodeId child : tree.node(c.node).childIds()) {
            NodeState& s = stateOf(child);
            if (s.resident) cache->release(s.chunk);
            s = NodeState{};
        }
        tree.release(c.node);
        stateOf(c.node).descended = false;
    }
}

void Engine::Impl::collectFinished() {
    const std::uint64_t done = frames->completed();
    while (!submitted.empty() && submitted.front().frame < done) {
        FrameReport report = submitted.front();
        submitted.pop_front();
        report.gpu = renderer->passTimes(report.frame);
        report.coveredPixels = renderer->coveredPixels(report.frame).value_or(0);
        // A caller that never asks for them keeps only the latest.
        if (finished.size() == kKeptReports) finished.pop_front();
        finished.push_back(report);
    }
}

Result<FrameReport> Engine::frame(const Camera& camera, const FrameOptions& options) {
    if (!camera.valid())
        return Error{
            "camera: eye and target must differ (by a distance single precision can measure), up must "
            "not be parallel to the view direction, and the field of view must lie in (0, 180) degrees"};
    Impl& m = *impl_;
    const Clock::time_point start = Clock::now();
    const bool resting = m.resting(camera, start);
    m.adaptThreshold(start, options.lockstep, resting);
    try {
        // The frame that used this slot last must be done: its report first, then the slot.
        const Clock::time_point slotWait = Clock::now();
        m.frames->wait(m.frames->index() + 1 >= kFramesInFlight ? m.frames->index() + 1 - kFramesInFlight
                                                                : 0);
        const double gpuWaitMs = millisecondsSince(slotWait);
        m.collectFinished();
        const Clock::time_point restWait = Clock::now();
        if (resting && !options.lockstep && m.workers && m.workers->outstanding() > 0)
            m.workers->waitIdleFor(kRestWait);
        const double restWaitMs = millisecondsSince(restWait);
        FrameReport report;
        report.gpuWaitMs = gpuWaitMs;
        report.refineWaitMs = restWaitMs;
        report.frame = m.frames->begin();
        VkCommandBuffer uploads = VK_NULL_HANDLE;
        const FrameView view = m.viewOf(camera);
        Selection selection;
        for (std::size_t round = 0;; ++round) {
            const Clock::time_point integrating = Clock::now();
            m.integrate(report);
            report.refineMs += millisecondsSince(integrating);
            const Clock::time_point selecting = Clock::now();
            selection = m.select(view, resting);
            report.selectionMs += millisecondsSince(selecting);
            const Clock::time_point dispatching = Clock::now();
            const std::size_t dispatched =
                m.workers && !selection.refine.empty() ? m.dispatch(selection.refine, options.lockstep) : 0;
            report.refineMs += millisecondsSince(dispatching);
            const Clock::time_point uploading = Clock::now();
            const std::size_t uploaded = m.upload(selection.upload, options.lockstep, report, uploads);
            report.uploadMs += millisecondsSince(uploading);
            // Nothing more wanted at the threshold asked for (a threshold in force raised by the
            // frame-time target is wanted no more only once the camera rests); not in lockstep, settled
            // once no node is held by the hysteresis either, which lets go at rest.
            const bool done = selection.refine.empty() && selection.upload.empty() &&
                              (!m.workers || m.workers->outstanding() == 0) &&
                              m.threshold == m.settings.threshold;
            report.heldByHysteresis = selection.heldByHysteresis;
            report.settled = done && (options.lockstep || selection.heldByHysteresis == 0);
            if (!options.lockstep || done) break;
            if (m.workers && m.workers->outstanding() > 0) {
                const Clock::time_point waiting = Clock::now();
                m.workers->waitIdle();
                report.refineWaitMs += millisecondsSince(waiting);
            } else if (dispatched == 0 && uploaded == 0) {
                break; // nothing can move (a full cache): draw what there is, not settled
            }
        }
        m.drawnNodes = std::move(selection.draw);
        m.drawnFacing = std::move(selection.facing);
        const Clock::time_point releasing = Clock::now();
        m.releaseUnused();
        report.refineMs += millisecondsSince(releasing);

        std::vector<DrawRange> ranges;
        ranges.reserve(m.drawnNodes.size());
        for (std::size_t k = 0; k < m.drawnNodes.size(); ++k) {
            const Impl::NodeState& s = m.state[m.drawnNodes[k]];
            for (std::uint32_t c = 0; c < kFacingClasses; ++c) {
                if (!(m.drawnFacing[k] >> c & 1u)) continue;
                const std::uint32_t count = s.classes[c + 1] - s.classes[c];
                ranges.push_back({s.chunk.first + s.classes[c], count});
                report.splatsDrawn += count;
            }
        }
        // Draw runs in cache order (adjacent chunks and classes merge into one draw:
        // SplatRenderer::submit; empty classes are skipped there).
        std::sort(ranges.begin(), ranges.end(),
                  [](const DrawRange& a, const DrawRange& b) { return a.first < b.first; });
        report.nodesVisible = m.drawnNodes.size();
        if (uploads != VK_NULL_HANDLE) m.frames->submit(uploads, false);
        FrameOutput output = options.output;
        output.readBack = options.readBack;
        m.slotDraws[m.frames->slot()] = ranges;
        m.slotFrame[m.frames->slot()] = report.frame;
        // A model without colours is drawn in kDefaultColour throughout.
        const auto oneColour = m.hasColour ? std::nullopt : std::optional{kDefaultColour};
        m.renderer->submit(*m.frames, m.cache->texels(), oneColour, ranges, camera, view.frustum.range,
                           output);

        // Measured once the passes are submitted, so that lavapipe's threads draw meanwhile.
        if (options.measureSplats) {
            const SplatSizes sizes = measureSplats(m.tree, m.drawnNodes, view, m.settings.threshold);
            report.splatsMeasured = true;
            report.medianSplatPx = sizes.medianPx;
            report.p99SplatPx = sizes.p99Px;
            report.maxSplatPx = sizes.maxPx;
            report.overThreshold = sizes.overThreshold;
        }
        report.cacheBytesUsed = std::size_t{m.cache->used()} * sizeof(gpu::Splat);
        report.thresholdPx = m.threshold;
        report.camera = camera;
        report.resting = resting;
        report.queueLength = m.workers ? m.workers->outstanding() : 0;
        if (m.workers) {
            const double busy = m.workers->busySeconds();
            report.refineBusyMs = (busy - m.workersBusySeconds) * 1e3;
            m.workersBusySeconds = busy;
            const double jobs = m.workers->jobSeconds();
            report.refineCpuMs = (jobs - m.workersJobSeconds) * 1e3;
            m.workersJobSeconds = jobs;
        }
        report.treeNodes = m.tree.nodeCount();
        report.treePoints = m.tree.pointCount();
        report.cpuMs = millisecondsSince(start);
        m.submitted.push_back(report);
        return report;
    } catch (const VulkanError& e) {
        return Error{std::string("Vulkan: ") + e.what()};
    }
}

Result<void> Engine::setRenderSettings(const RenderSettings& render) {
    Impl& m = *impl_;
    if (m.renderer->adjust(render)) { // the frame's uniforms only: no wait, same passes
        m.settings.render = render;
        return {};
    }
    try {
        m.frames->waitAll();
        m.collectFinished(); // their pass times, before the old passes go
    } catch (const VulkanError& e) {
        return Error{std::string("Vulkan: ") + e.what()};
    }
    auto renderer = SplatRenderer::create(m.context, render);
    if (!renderer) return renderer.error();
    m.renderer = std::move(renderer).value();
    m.settings.render = render;
    return {};
}

Result<void> Engine::setThreshold(float px) {
    if (!(px > 0.0f) || !std::isfinite(px))
        return Error{
            fmt::format("the splat size threshold must be a positive number of pixels (got {})", px)};
    Impl& m = *impl_;
    m.threshold = std::min(m.threshold * (px / m.settings.threshold), kMaxThresholdRise * px);
    m.movingThreshold = std::min(m.movingThreshold * (px / m.settings.threshold), kMaxThresholdRise * px);
    m.settings.threshold = px;
    return {};
}

std::vector<FrameReport> Engine::reports() {
    impl_->collectFinished();
    std::vector<FrameReport> reports(impl_->finished.begin(), impl_->finished.end());
    impl_->finished.clear();
    return reports;
}

void Engine::finish() {
    impl_->frames->waitAll();
}

Result<RgbaImage> Engine::image(std::uint64_t frame) {
    Impl& m = *impl_;
    if (frame > m.frames->index() || frame + kFramesInFlight <= m.frames->index())
        return Error{fmt::format("frame {} is no longer (or not yet) held", frame)};
    try {
        m.frames->wait(frame);
        return m.renderer->image(frame);
    } catch (const VulkanError& e) {
        return Error{std::string("Vulkan: ") + e.what()};
    }
}

Sphere Engine::bounds() const {
    return impl_->modelBounds;
}
const EngineSettings& Engine::settings() const {
    return impl_->settings;
}
const NodeTree& Engine::tree() const {
    return impl_->tree;
}
double Engine::refinementMs(const FrameReport& report) const {
    return report.refineWaitMs + 1000.0 * impl_->tree.creationSeconds();
}
std::span<const NodeId> Engine::drawn() const {
    return impl_->drawnNodes;
}
std::uint32_t Engine::deepestDrawnLevel() const {
    std::uint32_t deepest = 0;
    for (const NodeId id : impl_->drawnNodes) deepest = std::max(deepest, tree().node(id).level);
    return deepest;
}
std::size_t Engine::overwritesInFlight() const {
    return impl_->overwrites;
}

Result<std::size_t> Engine::verifyCache() {
    Impl& m = *impl_;
    try {
        m.frames->waitAll();
        const Buffer& buffer = m.cache->buffer();
        const VkDeviceSize bytes = buffer.size;
        Buffer readback =
            createBuffer(m.context, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUse::Readback);
        m.context.submitAndWait([&](VkCommandBuffer cmd) {
            const VkBufferCopy region{0, 0, bytes};
            vkCmdCopyBuffer(cmd, buffer.buffer.get(), readback.buffer.get(), 1, &region);
            VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
            barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
            barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
            vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1,
                                 &barrier, 0, nullptr, 0, nullptr);
        });
        const auto* gpu = static_cast<const gpu::Splat*>(readback.mapped);
        std::vector<gpu::Splat> expected;
        std::vector<std::uint8_t> classes;
        std::size_t compared = 0;
        for (NodeId id = 0; id < m.tree.slotCount(); ++id) {
            if (!m.tree.isLive(id) || id >= m.state.size() || !m.state[id].resident) continue;
            const Node& node = m.tree.node(id);
            const Chunk chunk = m.state[id].chunk;
            if (chunk.count != node.points.size())
                return Error{fmt::format("node {}: chunk of {} splats for {} points", id, chunk.count,
                                         node.points.size())};
            expected.resize(chunk.count);
            packSplats(node.points, node.shape.splatRadius, expected.data(), &classes);
            if (std::memcmp(expected.data(), gpu + chunk.first, chunk.count * sizeof(gpu::Splat)) != 0)
                return Error{fmt::format("node {} (level {}): its chunk at splat {} differs from its points",
                                         id, node.level, chunk.first)};
            if (classes != m.state[id].pointClass)
                return Error{fmt::format("node {} (level {}): the facing classes kept for the selection "
                                         "differ from its points'",
                                         id, node.level)};
            ++compared;
        }
        return compared;
    } catch (const VulkanError& e) {
        return Error{std::string("Vulkan: ") + e.what()};
    }
}

} // namespace pnsplat::engine
