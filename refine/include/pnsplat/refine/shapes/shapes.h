// Procedural models for tests, demos and `pnsplat eval`: sphere and torus samplings with exact
// normals, a capped cylinder with crease points, the embedded default model of the README's first command,
// and exact analytic descriptions of the sphere and torus (closest point, distance, normal) for error
// measurements.
//
// Not from the paper (which uses scanned models); the sampling patterns are the usual ones:
// Fibonacci spiral (Swinbank & Purser 2006) for near-uniform sphere points, area-correct
// parametric sampling for the torus (area element r (R + r cos v) du dv).
//
// Every function is deterministic: random samplings take an explicit seed and draw from
// std::mt19937_64 with the project's own conversion to [0,1) (std::uniform_real_distribution
// differs between standard libraries), so a seed gives the same points on every platform.
// Returned sets carry positions and unit normals; `radius` is left empty (the refinement
// estimates radii) and only the default model and the bumpy sphere fill `colour`. Any thread may call any
// function.
#pragma once

#include <cstddef>
#include <cstdint>

#include <glm/vec3.hpp>

#include "pnsplat/refine/point_set.h"

namespace pnsplat {

// n points of a near-uniform Fibonacci spiral on the sphere of radius `radius` centred at the
// origin; normals are the exact outward radial directions. Precondition: radius > 0.
PointSet sampleSphereUniform(std::size_t n, float radius);

// n independent uniform random points (by area) on the sphere of radius `radius` at the origin,
// with exact outward normals. Precondition: radius > 0.
PointSet sampleSphereRandom(std::size_t n, float radius, std::uint64_t seed);

// The torus used by the samplers and AnalyticSurface: axis z, centred at the origin, the tube
// circle (radius R, the "major" radius) in the z = 0 plane, tube radius r. Parametrised as
// (u around the axis, v around the tube) -> ((R + r cos v) cos u, (R + r cos v) sin u, r sin v).
//
// n independent random points uniform by AREA on the torus (u uniform; v by rejection on the
// density R + r cos v), with exact outward normals. Precondition: R > r > 0.
PointSet sampleTorusRandom(std::size_t n, float R, float r, std::uint64_t seed);

// Exactly n near-uniform points on the torus: rings equally spaced in v, each ring holding a
// number of points proportional to its circumference R + r cos v (so the sampling is correct by
// area), consecutive rings rotated by the golden angle. Exact outward normals.
// Precondition: R > r > 0.
PointSet sampleTorusUniform(std::size_t n, float R, float r);

// A closed cylinder with sharp rims (ALGORITHM.md §6): axis z, radius R, z in [-H/2, H/2], flat caps.
// rimPoints points on each rim circle, which are crease points (normal: the radial side normal,
// crease: the cap's ±z); the side and the caps sampled in rings of about the same spacing
// 2πR / rimPoints (caps with a centre point); exact normals. Precondition: rimPoints >= 3,
// R > 0, H > 0.
PointSet sampleCappedCylinder(std::size_t rimPoints, float R, float H);

// A terrestrial scan of a gently rolling terrain, z = 0.5 sin(0.3 x) cos(0.2 y), seen from above
// its centre: n points at ranges log-uniform from `nearest` to `farthest` about the z axis and at
// uniform angles, so that the density falls with the square of the range (a near field a hundred
// thousand times as dense as the far field), with exact upward normals. Precondition:
// 0 < nearest < farthest.
PointSet sampleTerrainScan(std::size_t n, double nearest, double farthest, std::uint64_t seed);
// That terrain's height at (x, y).
double terrainHeight(double x, double y);

// `count` equilateral triangles of side 1e14, 1e20 apart along x, normals +x: squared distances
// past single precision, which the k-d searches of the input's completion do not find (the
// fuzzer's case; tests/hole_detection_test.cpp and the fuzz seeds).
PointSet farApartTriangles(std::size_t count);

// The embedded default model (the README's first command, scripts/demo.sh): a closed star-shaped
// surface x(d) = rho(d) d over unit directions d, rho(d) = 1 + body(d) + ridges(d) + horns(d),
// with detail that a sparse sampling loses: 12 ridges around the y axis (amplitude 0.06, about
// 0.5 apart at the equator), four thin horns (0.5 to 0.75 high, about 0.15 radians wide), and
// three colours (a blue-green body, an orange band whose ridge crests are lighter, red horns).
// makeDefaultModel is its sparse, irregular sampling: kDefaultModelPoints points from a jittered
// Fibonacci spiral of directions (fixed seed), analytic outward normals, colours; units: the
// body's mean radius is about 1, the horns reach about 1.85 from the origin.
// sampleDefaultModel samples the same surface with n points (n >= 1) the same way, so that a dense
// version (say 300,000 points) is the ground truth of pictures of the sparse one.
inline constexpr std::size_t kDefaultModelPoints = 1500;
inline constexpr std::uint64_t kDefaultModelSeed = 0x5EED2026u;
PointSet makeDefaultModel();
PointSet sampleDefaultModel(std::size_t n, std::uint64_t seed = kDefaultModelSeed);

// The surface point of the default model in the unit direction `direction` (need not be exactly
// unit: it is normalised first; must not be zero). Lets tests check the normals against finite
// differences of the surface.
glm::vec3 defaultModelSurface(glm::vec3 direction);

// The "bumpy sphere", the default model until issue 26 (tests use it as a smooth, coloured,
// sparse surface): x(d) = rho(d) d, rho(d) = 1 + 0.25 f(d), with f a sum of low-order
// spherical-harmonic-like polynomials (|f| <= 1, so rho is in [0.75, 1.25]). 2,000 points from a
// jittered Fibonacci spiral (fixed seed), analytic outward normals, and colours from a hue that
// follows the bump value f. Units: the mean radius is 1.
PointSet makeBumpySphere();
// Its surface point in the direction `direction` (as defaultModelSurface).
glm::vec3 bumpySphereSurface(glm::vec3 direction);

// An exact analytic surface: a sphere of radius R, or the torus described above (major radius R,
// tube radius r), both centred at `centre`, torus axis along z. Functions are const and may be
// called from any thread. Degenerate queries get a fixed, documented answer instead of NaN.
struct AnalyticSurface {
    enum class Kind { Sphere, Torus };

    Kind kind = Kind::Sphere;
    float R = 1.0f; // sphere radius, or torus major radius (> 0)
    float r = 0.0f; // torus tube radius (0 < r < R); unused for a sphere
    glm::vec3 centre{0.0f};

    static AnalyticSurface sphere(float radius) { return {Kind::Sphere, radius, 0.0f, glm::vec3(0.0f)}; }
    static AnalyticSurface torus(float majorRadius, float tubeRadius) {
        return {Kind::Torus, majorRadius, tubeRadius, glm::vec3(0.0f)};
    }

    // The point of the surface closest to p. At the sphere's centre the answer is the +z pole;
    // on the torus axis it is taken towards +x; on the tube circle it is the outer (+radial) point.
    glm::vec3 closestPoint(glm::vec3 p) const;
    // Unsigned Euclidean distance from p to the surface (computed in double, returned as float).
    float distance(glm::vec3 p) const;
    // Signed distance: negative inside (implicit function with unit gradient).
    float signedDistance(glm::vec3 p) const;
    // Unit outward normal of the surface at closestPoint(p).
    glm::vec3 normalAt(glm::vec3 p) const;
    // Length of the diagonal of the surface's axis-aligned bounding box.
    float boundingDiagonal() const;
    // Total area (4 pi R^2, or 4 pi^2 R r).
    double area() const;
};

} // namespace pnsplat
