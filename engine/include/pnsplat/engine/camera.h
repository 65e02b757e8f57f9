// A pinhole camera and the view and projection it gives. Angles in radians; right-handed view
// space looking down -z; Vulkan clip space (y down, depth 0 at near to 1 at far).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/ext/vector_double3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

namespace pnsplat::engine {

struct Camera {
    glm::vec3 eye{0.0f, 0.0f, 3.0f};
    glm::vec3 target{0.0f};
    glm::vec3 up{0.0f, 1.0f, 0.0f};
    float fovY = 0.7f; // vertical field of view

    // False when eye and target coincide, up is parallel to the view direction, a value is not
    // finite, or fovY is outside (0, π).
    bool valid() const;
    glm::mat4 view() const;
    bool operator==(const Camera&) const = default;
};

// The camera as text: eye, target and up, nine numbers separated by commas, each in its shortest
// form that reads back as the same float (what `pnsplat render --camera` takes and prints). With an
// origin (PlyData::origin: the model is held less it), eye and target in the file's coordinates,
// origin + position in double, to about a millionth of their distance.
std::string cameraText(const Camera& camera, glm::dvec3 origin = glm::dvec3(0.0));

// A bounding sphere (of a model or a node).
struct Sphere {
    glm::vec3 centre{0.0f};
    float radius = 0.0f;
};

// The sphere centred on the bounding box of the points (all, or those of `indices`) through the
// farthest of them: what a scene and its nodes are framed and culled by. Not finite when the
// points spread beyond single precision; {0, 0} for no points.
Sphere boundingSphere(std::span<const glm::vec3> positions);
Sphere boundingSphere(std::span<const glm::vec3> positions, std::span<const std::uint32_t> indices);

// Where a framing camera stands, as unit axis directions (±x, ±y or ±z) from the model's centre:
// `up` is the picture's vertical, `front` (perpendicular to it) points toward the eye.
struct Viewpoint {
    glm::vec3 up{0.0f, 1.0f, 0.0f};
    glm::vec3 front{0.0f, 0.0f, 1.0f};
    bool upFromBase = false;   // chooseViewpoint: up chosen as the model's base (else given or the default)
    bool frontFlipped = false; // chooseViewpoint: the eye moved off a side filled by one flat face, or that
                               // no normal faces
};

// The thresholds of chooseViewpoint.
inline constexpr float kThinnerThanZ = 0.6f;   // another axis's extent over z's, to look along it
inline constexpr float kBaseHeight = 0.03f;    // a base: points this share of the height above the lowest
inline constexpr float kMinBaseShare = 0.2f;   // a base's rectangle over the model's, to stand on it
inline constexpr float kHeadOnCosine = 0.985f; // a normal within 10 degrees of the view axis faces it
inline constexpr float kFlatFaceShare = 0.1f;  // of the points facing one side head-on: a flat face

// A viewpoint that shows a model's shape, from its points alone (a model's files carry no up axis):
// 1. The eye looks along a thin axis of the model's bounding box, so that it sees a broad side:
//    z, as usual, unless the model's extent along x or y is below kThinnerThanZ
//    times its extent along z (then the thinner of x and y: a bust's or an animal's profile, a
//    flat part's face; a head stays seen from the front). Given `up`, the thinner of the two
//    axes across it, z before y before x on a tie.
// 2. Without `up`: the model stands on its broadest base. For each of the four directions
//    across the view axis, the base is the points within kBaseHeight of the model's height along
//    it above the lowest point, and its share is the area of their bounding rectangle across that
//    direction over the model's; a base counts when the mean of all points lies over it. The
//    direction of the largest share of at least kMinBaseShare is up (a bust or a statue on its
//    plinth); else +y, or +z when the eye looks along y. Scans keep the axes they were made in,
//    so a base is rarely tilted; where no base stands out, the usual +y holds.
// 3. The eye is on the + side of the view axis unless one flat face fills that side: at least
//    kFlatFaceShare of the points have a normal within 10 degrees of the axis (kHeadOnCosine) and
//    more than twice as many as on the - side face it (a CAD part's flat back), and the - side has
//    something to show: at least kFlatFaceShare of the normals face it; and on the - side when the
//    + side has nothing to show. A flat scan (a terrain tile, a façade: every normal on one side)
//    is seen from the side its normals face; splats are one-sided, and from the other side the
//    picture was blank. `normals` may be empty (the + side),
//    else has one unit normal per position.
// No points: the default viewpoint (+y up, eye on +z). Any thread; O(points).
Viewpoint chooseViewpoint(std::span<const glm::vec3> positions, std::span<const glm::vec3> normals,
                          std::optional<glm::vec3> up = std::nullopt);

// A camera that frames `bounds` whole in an image of the given aspect (width / height), looking
// at its centre from `view.front`, turned by `orbit` about `view.up` and raised by `elevation`
// towards it (radians; |elevation| < π/2). The default viewpoint looks along -z from +z, y up.
Camera frameSphere(const Sphere& bounds, float aspect, float fovY, float orbit, const Viewpoint& view = {},
                   float elevation = 0.0f);

// Near and far distances that enclose `bounds` seen from `camera` (near stays positive when the
// eye is inside the sphere).
struct DepthRange {
    float near, far;
};
DepthRange depthRange(const Camera& camera, const Sphere& bounds);

glm::mat4 projection(float fovY, float aspect, DepthRange range);

// The `quantile` (in [0, 1]) of the diameters on screen, in pixels (2 r f / depth, f = height /
// (2 tan(fovY / 2)), as the engine measures splats), of the splats in the view of `camera` in a
// width × height image that face its eye; 0 when none does.
float splatDiameterQuantile(std::span<const glm::vec3> positions, std::span<const glm::vec3> normals,
                            std::span<const float> radii, const Camera& camera, std::uint32_t width,
                            std::uint32_t height, float quantile);

// The splats that cannot change the picture of `camera` in a width × height image: facing away
// (the passes skip them: splat_common.glsl's frontFacing) or wholly outside the view (the ball of
// radius × radiusScale about the centre misses the view pyramid, or lies behind the eye). Both
// tests keep a margin of rounding, so that on the compute path the picture drawn without them is
// the picture drawn with them, bit for bit (its sums are integers). Ascending indices, for
// removePoints: a picture of more splats than one buffer of the device holds (`render` of a deep
// refinement, bench settle's reference) needs only those in view. Any thread; O(points).
std::vector<std::uint32_t> splatsOutOfPicture(std::span<const glm::vec3> positions,
                                              std::span<const glm::vec3> normals,
                                              std::span<const float> radii, const Camera& camera,
                                              std::uint32_t width, std::uint32_t height, float radiusScale);

// View-space frustum test of a bounding sphere (centre already in view space).
struct Frustum {
    float tanX, tanY; // half-angle tangents: x / -z and y / -z at the edges
    DepthRange range;
    bool intersects(glm::vec3 viewCentre, float radius) const;
};

} // namespace pnsplat::engine
