// The nodes a frame draws, refines and uploads (selection.h).
#include "pnsplat/engine/selection.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec4.hpp>

#include "pnsplat/refine/quantile.h"
#include "pnsplat/refine/simd_clone.h"

namespace pnsplat::engine {

namespace {

constexpr float kHalfPi = 1.57079632679f;
constexpr float kPi = 3.14159265359f;
// The level of detail (docs/REALTIME.md, "The level of detail"). A node is drawn through its
// children while more than kOverShare of its splats drawn are wider than the threshold: its median
// splat. Splats are measured with Node::shape.splatRadius, about the local spacing (the
// refinement's radii are about twice it: docs/REALTIME.md, "Splats of the local spacing"), and drawn
// with it. The 99th percentile (a share of 0.008, before) let the sparsest patches of a node decide for all
// of it: the refinement's radii spread (the 99th percentile is about 1.9 times the median), so at 2 px the
// median splat drawn was 0.8 px and a covered pixel held 28 splats (the bunny at 640x480), while away from
// the silhouettes a picture changes little from one level to the next.
constexpr double kOverShare = 0.5;
// At the silhouettes it does: there a coarser level covers more pixels than the next (a splat's
// disk stands out of a curved surface by about r · bend / 2, node_tree.h, neighbourShapeOf, which the next
// level's smaller splats shrink), and a pixel of surface against background costs far more than a
// shade. A splat seen within acos(kRimCosine) of edge-on (its normal's cosine to the ray below
// kRimCosine) is at the silhouette; a node is also drawn through its children while more than
// kRimShare of those (at least kRimPoints) stand out by more than kRimBulgePx pixels and are wider
// than kRimMinPx. The contour of a view moves out by about that on average: with hard edges, at
// 0.25 px the far Igea of EngineTest (320x240) covered 49 pixels the offline picture does not (PSNR
// 36.9 dB), at 0.1 px 39.7 dB, at 0.05 px 42.6 dB with 1.5 times the splats. The outer silhouette
// is smoothed now (RenderSettings::smoothEdges: a contour moved by a fraction of a pixel changes its
// pixels by about that fraction), and 0.2 px keeps every case of `bench settle` at 40.3 dB or more
// from the offline refinement a level deeper, with at most 5.84 splats drawn a covered pixel, where
// 0.1 px drew up to 10.21 (the lion's grazing camera) and 0.3 px opened a one-pixel hole on the lion
// (docs/REALTIME.md, "Smooth silhouettes").
//
// The silhouette test refines a node at most one level past the median rule at the threshold
// asked: only while its median splat is wider than that threshold over kRimDeepest, the ratio of a
// level's spacing to the next's (√3: a level holds three times the points). Where `bend` stays
// large at every level (a crease or a fold seen edge-on: the refinement interpolates its normals
// over a spacing, so the angle across the 6 nearest does not shrink), the bulge r · bend / 2 only shrinks
// with r, and the test went on two levels past the median rule or more: the nefertiti's headdress at render's
// framing made 16.41 points a covered pixel, now 9.52, with 42.60 dB from the offline refinement a level
// deeper, against 42.67 (docs/REALTIME.md, "Where the points made go").
constexpr float kRimCosine = 0.3f;
constexpr float kRimDeepest = 1.7320508f;
constexpr float kRimBulgePx = 0.2f;
constexpr float kRimMinPx = 1.0f;
constexpr double kRimShare = 0.1;
constexpr std::size_t kRimPoints = 4;

// What the camera sees of a node, from its box and its normal cone (a cone around coneAxis of
// half-angle coneAngle holds its normals; the directions from the eye to a sphere of radius R
// around the box's centre lie within asin(R / d) of the direction to the centre, d away).
struct NodeView {
    bool visible = true;                   // in the frustum, and not seen only from behind
    bool allFront = false;                 // every splat faces the eye (n · (p - eye) < 0)
    bool noRim = false;                    // every splat faces the eye within acos(kRimCosine) of its normal
    bool inView = false;                   // the whole box in the frustum, beyond the near plane
    float nearest = 0.0f, farthest = 0.0f; // depths of the box's corners
};

// What Walk::exceeds measures splat by splat: the view, and the bounds over depth (each a size
// over its limit, times depth).
struct SplatTest {
    glm::vec3 eye, forward, right, upward;
    float near, tanX, tanY;
    float k;       // the diameter over the limit
    float coarseK; // the diameter over the limit over rimDeepest
    float bulge;   // the bulge r · bend / 2 over its limit
    float rimK;    // the diameter over kRimMinPx
    // The squared cosine below which a splat is at the silhouette; 0 where the node has no rim.
    float rimCosine2;
};

// The splats of a node counted for Walk::exceeds: those drawn (in view, facing the eye), those
// wider than the limit and than the limit over rimDeepest, and those at the silhouette, with the
// ones standing out. Without branches, so that the loop runs on SIMD lanes (eight with AVX2, the
// same bits: no fused multiply-adds, the same order of operations in every lane): a splat out of
// view or facing away counts nowhere. The squares avoid a square root (whose errno path is a
// branch): facing > 0 where seen.
struct SplatCounts {
    std::uint32_t drawn = 0, over = 0, coarse = 0, rim = 0, rimOver = 0;
};

PNSPLAT_AVX2_CLONE SplatCounts countSplats(const SplatTest& t, const glm::vec3* position,
                                           const glm::vec3* normal, const float* radius, const float* bend,
                                           std::size_t n) {
    SplatCounts c;
    for (std::size_t i = 0; i < n; ++i) {
        const glm::vec3 d = position[i] - t.eye;
        const float depth = glm::dot(d, t.forward);
        const float facing = -glm::dot(normal[i], d); // |d| times the cosine to the ray
        const bool seen = (depth > t.near) & (facing > 0.0f) &
                          (std::abs(glm::dot(d, t.right)) <= t.tanX * depth) &
                          (std::abs(glm::dot(d, t.upward)) <= t.tanY * depth);
        const float r = radius[i];
        c.drawn += seen;
        c.over += seen & (r * t.k > depth);
        c.coarse += seen & (r * t.coarseK > depth);
        const bool edgeOn = seen & (facing * facing < t.rimCosine2 * glm::dot(d, d));
        c.rim += edgeOn;
        c.rimOver += edgeOn & (r * bend[i] * t.bulge > depth) & (r * t.rimK > depth);
    }
    return c;
}

// The facing classes of the points [0, n) that hold a splat facing the eye, their classes given:
// without branches, for SIMD lanes. Walk::draw asks a block of kFacingBlock points at a time, and
// stops once every class the node holds is found.
PNSPLAT_AVX2_CLONE FacingMask classesFacing(glm::vec3 eye, const glm::vec3* position, const glm::vec3* normal,
                                            const std::uint8_t* pointClass, std::size_t n) {
    FacingMask facing = 0;
    for (std::size_t i = 0; i < n; ++i)
        facing |= FacingMask{glm::dot(normal[i], position[i] - eye) < 0.0f} << pointClass[i];
    return facing;
}
constexpr std::size_t kFacingBlock = 64;

// One walk of the tree (selectNodes).
class Walk {
  public:
    Walk(const NodeTree& tree, const FrameView& view, const SelectionSettings& settings, std::uint64_t stamp,
         const std::function<NodeSelection&(NodeId)>& stateOf)
        : tree_(tree), v_(view), settings_(settings), stamp_(stamp), stateOf_(stateOf) {}

    void visit(NodeId id);
    Selection& result() { return out_; }

  private:
    NodeView see(const Node& node) const;
    float bound(const NodeView& v, float radius) const;
    bool exceeds(const Node& node, const NodeView& v, float factor) const;
    void draw(NodeId id, const Node& node, const NodeView& v);

    const NodeTree& tree_;
    const FrameView& v_;
    const SelectionSettings& settings_;
    std::uint64_t stamp_;
    const std::function<NodeSelection&(NodeId)>& stateOf_;
    Selection out_;
};

NodeView Walk::see(const Node& node) const {
    const Camera& camera = v_.camera;
    const DepthRange range = v_.frustum.range;
    NodeView v;
    v.nearest = std::numeric_limits<float>::max();
    v.farthest = std::numeric_limits<float>::lowest();
    v.inView = true;
    for (int corner = 0; corner < 8; ++corner) {
        const glm::vec3 d = glm::vec3{corner & 1 ? node.hi.x : node.lo.x, corner & 2 ? node.hi.y : node.lo.y,
                                      corner & 4 ? node.hi.z : node.lo.z} -
                            camera.eye;
        const float depth = glm::dot(d, v_.forward);
        v.nearest = std::min(v.nearest, depth);
        v.farthest = std::max(v.farthest, depth);
        v.inView = v.inView && depth > range.near &&
                   std::abs(glm::dot(d, v_.right)) <= v_.frustum.tanX * depth &&
                   std::abs(glm::dot(d, v_.upward)) <= v_.frustum.tanY * depth;
    }
    if (!settings_.cullNodes) return v;
    const glm::vec3 centre = (node.lo + node.hi) * 0.5f;
    const float box = glm::length(node.hi - node.lo) * 0.5f;
    const float radius = box + node.maxRadius * v_.radiusScale;
    v.visible = v_.frustum.intersects(glm::vec3(v_.view * glm::vec4(centre, 1.0f)), radius);
    const glm::vec3 toCentre = centre - camera.eye;
    const float distance = glm::length(toCentre);
    if (!v.visible || node.coneAngle >= kHalfPi || !(distance > radius)) return v;
    const float between = std::acos(std::clamp(glm::dot(toCentre / distance, node.coneAxis), -1.0f, 1.0f));
    // Seen only from behind: every n · (p - eye) positive (splat_common.glsl skips those).
    v.visible = between + std::asin(radius / distance) + node.coneAngle >= kHalfPi;
    const float least = between - std::asin(box / distance) - node.coneAngle; // of n to p - eye
    const float rimAngle = kPi - std::acos(kRimCosine); // the angle of n to p - eye beyond which no rim
    v.allFront = least > kHalfPi;
    v.noRim = least > rimAngle;
    return v;
}

// The diameter on screen of a node's splat of radius r, at most: r at the depth of the nearest
// corner of its box (depth is linear, so its minimum over the box is at a corner).
float Walk::bound(const NodeView& v, float radius) const {
    return 2.0f * radius * v_.radiusScale * v_.focal / std::max(v.nearest, v_.frustum.range.near);
}

// Whether the node's splats drawn (in view, facing the eye) are too coarse for the threshold in
// force times `factor` (the hysteresis, or 1): more than kOverShare of them wider than it (its
// median splat), or, while more than kOverShare are wider than the threshold asked (times
// `factor`) over kRimDeepest, more than kRimShare of those at the silhouette standing out by more
// than kRimBulgePx times `factor` and the square root of the frame-time target's rise (threshold /
// asked). The silhouettes coarsen more slowly than the median because they decide most of a
// picture's difference from the settled one: the bunny's and the lion's zooms in bench view at
// 640x480, the threshold in force at most 3 times the one asked, gave 38.0 and 35.3 dB median with
// the rise itself, 40.4 and 39.3 with its square root, for 3 and 9 ms more a frame; with the square
// root and at most 4 times (engine.cpp, kMaxThresholdRise), 39.3 and 37.4 dB for 2 and 4 ms more
// (docs/REALTIME.md, "Frame-time target"). The bound of one level past the median is the asked
// threshold's, not the one in force: bound to the raised median, the lion's zoom fell to 37.4 dB
// median, and to 37.98 with the bound coarsened by the square root of the rise; 39.5 to 41.0 so. The
// box settles most nodes at once: none of its splats reaches kRimMinPx or the limit; or, for a node all in
// view and facing the eye, its median radii at the nearest and the farthest corner (Node::medianRadius) and,
// for the silhouette, its normal cone or its largest radius and bend (Node::maxBend). The others are measured
// splat by splat (no division: r · k > depth), which is exact where a box seen at a grazing angle or reaching
// out of the view would refine a node for its nearest corner alone.
bool Walk::exceeds(const Node& node, const NodeView& v, float factor) const {
    const float limit = settings_.threshold * factor;
    if (bound(v, node.maxRadius) <= std::min(limit, kRimMinPx)) return false;
    const float scale = v_.radiusScale, focal = v_.focal, rise = settings_.threshold / settings_.asked;
    const float k = 2.0f * scale * focal / limit; // the diameter over the limit, times depth
    // The bulge r · bend / 2 over its limit, times depth.
    const float bulge = scale * focal * 0.5f / (kRimBulgePx * std::sqrt(rise) * factor);
    const float rimK = 2.0f * scale * focal / kRimMinPx;
    // The rim test's bound: one level past where the median rule settles at the threshold asked.
    const float rimDeepest = kRimDeepest * rise;
    const bool rimPossible =
        !v.noRim && node.maxRadius * node.maxBend * bulge > v.nearest && node.maxRadius * rimK > v.nearest;
    if (v.inView && v.allFront) { // every splat drawn: the median radii settle the first test
        if (node.medianRadius[0] * k > v.farthest) return true; // more than half wider
        // At most half wider (than the limit, or than the rim test's bound below).
        if (node.medianRadius[1] * k * (rimPossible ? rimDeepest : 1.0f) <= v.nearest) return false;
    }
    const Frustum& frustum = v_.frustum;
    const SplatTest test{
        v_.camera.eye,      v_.forward,   v_.right,     v_.upward,
        frustum.range.near, frustum.tanX, frustum.tanY, k,
        k * rimDeepest,     bulge,        rimK,         rimPossible ? kRimCosine * kRimCosine : 0.0f};
    const SplatCounts c =
        countSplats(test, node.points.position.data(), node.points.normal.data(),
                    node.shape.splatRadius.data(), node.shape.bend.data(), node.points.size());
    return double(c.over) > kOverShare * double(c.drawn) ||
           (c.rim >= kRimPoints && double(c.rimOver) > kRimShare * double(c.rim) &&
            double(c.coarse) > kOverShare * double(c.drawn));
}

// The facing classes of a node that hold a splat facing the eye (the passes skip a splat seen from
// behind: the test of frontFacing in splat_common.glsl); the others draw nothing and are left out
// before the passes, and so is a node with none. The normal cone settles the nodes that face the
// eye whole; the others, beside the silhouette, are tested point by point until every class of the
// node is found facing the eye.
void Walk::draw(NodeId id, const Node& node, const NodeView& v) {
    const NodeSelection& s = stateOf_(id);
    FacingMask present = 0, facing = 0;
    for (std::uint32_t c = 0; c < kFacingClasses; ++c)
        present |= FacingMask{s.classes[c + 1] > s.classes[c]} << c;
    if (!settings_.cullNodes || v.allFront) facing = present; // (a test switch: everything drawn)
    const PointSet& points = node.points;
    const std::size_t n = points.size();
    assert(s.pointClass.size() == n); // a drawn node is resident: its points' classes are kept
    for (std::size_t begin = 0; begin < n && facing != present; begin += kFacingBlock)
        facing |= classesFacing(v_.camera.eye, points.position.data() + begin, points.normal.data() + begin,
                                s.pointClass.data() + begin, std::min(kFacingBlock, n - begin));
    if (facing == 0 && present != 0) return;
    out_.draw.push_back(id);
    out_.facing.push_back(facing);
}

void Walk::visit(NodeId id) {
    const Node& node = tree_.node(id);
    const NodeView v = see(node);
    if (!v.visible) return;
    NodeSelection& s = stateOf_(id);
    // Hysteresis holds only for a node seen without a break (in the last frame or earlier in
    // this one): one that left the view (or whose subtree was released meanwhile) decides
    // afresh, so what a frame draws does not depend on how long ago a node was last seen.
    const bool descended = s.descended && s.lastVisited + 1 >= stamp_;
    s.lastVisited = stamp_;
    // Order of refinement and upload: the node's 99th percentile splat at its nearest depth.
    const float size = bound(v, node.drawnRadius);
    const bool coarse = !node.isLeaf() && exceeds(node, v, 1.0f);
    const bool held = !coarse && descended && !node.isLeaf() && settings_.hysteresis < 1.0f &&
                      exceeds(node, v, settings_.hysteresis);
    out_.heldByHysteresis += held;
    if (coarse || held) {
        bool ready = true;
        for (const NodeId c : node.childIds()) {
            if (stateOf_(c).resident || !see(tree_.node(c)).visible) continue;
            out_.upload.push_back({c, tree_.node(c).level, size});
            ready = false;
        }
        stateOf_(id).descended = true; // wanted, even while its children are uploaded
        if (ready) {
            for (const NodeId c : node.childIds()) visit(c);
            return;
        }
        draw(id, node, v);
        return;
    }
    if (node.isLeaf() && settings_.adaptive && node.level < tree_.settings().maxLevel &&
        exceeds(node, v, 1.0f))
        out_.refine.push_back({id, node.level, size});
    stateOf_(id).descended = false;
    draw(id, node, v);
}

} // namespace

std::uint32_t facingClass(glm::vec3 n) {
    const glm::vec3 a = glm::abs(n);
    const int axis = a.x >= a.y && a.x >= a.z ? 0 : a.y >= a.z ? 1 : 2;
    const std::uint32_t face = n[axis] < 0.0f ? std::uint32_t(axis) + 3u : std::uint32_t(axis);
    // The face's cell: the other two components over the largest, in [-1, 1].
    const float scale = 0.5f * float(kFacingCells) / a[axis];
    const auto cell = [&](int k) {
        return std::min(std::uint32_t(std::max((n[k] + a[axis]) * scale, 0.0f)), kFacingCells - 1);
    };
    return (face * kFacingCells + cell((axis + 1) % 3)) * kFacingCells + cell((axis + 2) % 3);
}

FrameView frameView(const Camera& camera, std::uint32_t width, std::uint32_t height, float radiusScale,
                    const Sphere& bounds) {
    FrameView v;
    v.camera = camera;
    v.view = camera.view();
    v.forward = glm::normalize(camera.target - camera.eye);
    v.right = glm::vec3(v.view[0][0], v.view[1][0], v.view[2][0]);
    v.upward = glm::vec3(v.view[0][1], v.view[1][1], v.view[2][1]);
    const float tanY = std::tan(camera.fovY * 0.5f);
    const float aspect = float(width) / float(height);
    v.frustum = Frustum{tanY * aspect, tanY, depthRange(camera, bounds)};
    v.focal = float(height) / (2.0f * tanY);
    v.radiusScale = radiusScale;
    return v;
}

Selection selectNodes(const NodeTree& tree, const FrameView& view, const SelectionSettings& settings,
                      std::uint64_t stamp, const std::function<NodeSelection&(NodeId)>& stateOf) {
    Walk walk(tree, view, settings, stamp, stateOf);
    for (const NodeId root : tree.roots()) walk.visit(root);
    Selection out = std::move(walk.result());
    // Breadth-first: coarsest level first, then largest on screen; ties by id (deterministic).
    const auto order = [](const WantedNode& a, const WantedNode& b) {
        return a.level != b.level ? a.level < b.level : a.size != b.size ? a.size > b.size : a.node < b.node;
    };
    std::sort(out.refine.begin(), out.refine.end(), order);
    std::sort(out.upload.begin(), out.upload.end(), order);
    return out;
}

SplatSizes measureSplats(const NodeTree& tree, std::span<const NodeId> drawn, const FrameView& view,
                         float threshold) {
    const Frustum& frustum = view.frustum;
    const float scale = 2.0f * view.radiusScale * view.focal;
    std::size_t over = 0;
    std::vector<float> sizes;
    for (const NodeId id : drawn) {
        const Node& node = tree.node(id);
        const PointSet& points = node.points;
        for (std::size_t i = 0; i < points.size(); ++i) {
            const glm::vec3 p = glm::vec3(view.view * glm::vec4(points.position[i], 1.0f));
            const float depth = -p.z;
            if (!(depth > frustum.range.near) || std::abs(p.x) > frustum.tanX * depth ||
                std::abs(p.y) > frustum.tanY * depth ||
                glm::dot(points.normal[i], points.position[i] - view.camera.eye) >= 0.0f)
                continue;
            const float size = scale * node.shape.splatRadius[i] / depth;
            sizes.push_back(size);
            over += size > threshold;
        }
    }
    SplatSizes out;
    if (sizes.empty()) return out;
    const auto middle = sizes.begin() + static_cast<std::ptrdiff_t>(sizes.size() / 2);
    std::nth_element(sizes.begin(), middle, sizes.end());
    out.medianPx = *middle;
    const auto p99 = sizes.begin() + static_cast<std::ptrdiff_t>(quantileIndex(sizes.size(), 0.99f));
    std::nth_element(middle, p99, sizes.end()); // past the median: the larger half
    out.p99Px = *p99;
    out.maxPx = *std::max_element(p99, sizes.end());
    out.overThreshold = double(over) / double(sizes.size());
    return out;
}

} // namespace pnsplat::engine
