// Quality metrics of a refined point set against the true surface: the numbers `pnsplat eval`
// prints. Not part of the paper (section 8 judges its results by eye); these make "smooth, no
// holes, interpolates the input" measurable.
//
// Metrics (all per refined point unless said otherwise, reduced in a fixed order):
// - distance: from each refined point to the true surface (mean, RMS, max), in model units and
//   relative to the diagonal of the reference's bounding box;
// - normal error: angle in degrees between a refined normal and the true normal at the closest
//   surface point (mean, 95th percentile); orientation counts (a flipped normal is 180 degrees);
// - uniformity: coefficient of variation (std / mean) of the distance from each refined point to
//   its nearest other refined point (0 for a perfect grid);
// - holes: share of the reference points (dense samples of the true surface) farther than twice
//   the mean refined nearest-neighbour spacing from every refined point; holes_tangential is the
//   same test with distances measured in the sample's tangent plane (to the nearest 8 refined
//   points), which tells a gap in the sampling from a refined surface that lies slightly off the
//   true one (for a sparse input, the approximation error can exceed twice the refined spacing);
//   gaps is the same test against the refined points projected onto the true surface (their
//   closest points there), the uncovered surface as issue 27 defines it;
// - input preservation: whether every input point appears in the output with bit-identical
//   position and normal (the method is interpolatory, ALGORITHM.md §1.1), and how many do not; for an input
//   of positions only (its normals were estimated when it was refined), position alone.
//
// The true surface is one of:
// - analytic (`sphere:R`, `torus:R,r`, centred at the origin, torus axis z): exact distances and
//   normals; the hole test uses 200,000 near-uniform samples (Fibonacci sphere / area-correct
//   torus rings, see shapes.h);
// - a triangle mesh (a PLY with a `face` element, e.g. ../shared/data/*-mesh.ply): exact
//   point-to-triangle distance; the true normal is the closest triangle's vertex normals
//   interpolated with the barycentric coordinates of the closest point (the face normal where
//   that interpolation vanishes; always the face normal with EvalOptions::flatNormals); the
//   vertices are the hole test's reference points;
// - points only (a PLY without faces, e.g. *-reference.ply): an approximation. The closest
//   reference point q (Euclidean) stands for the surface: the distance is measured to q's tangent
//   plane, |(p - q) . n_q|, and the true normal is n_q.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/gtc/type_precision.hpp>
#include <glm/vec3.hpp>

#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/result.h"
#include "pnsplat/refine/shapes/shapes.h"

namespace pnsplat {

// The true surface of an evaluation. Build it with parseReference or meshReference.
struct Reference {
    std::string name;                       // as given: "sphere:1", "torus:1,0.25" or the file path
    std::optional<AnalyticSurface> surface; // set for an analytic reference
    PointSet points;                        // file references: vertices with unit normals
    std::vector<glm::u32vec3> triangles;    // mesh references: indices into `points`
    glm::dvec3 origin{0.0};                 // file references: `points` are stored less it (PlyData::origin)

    bool isAnalytic() const { return surface.has_value(); }
    bool isMesh() const { return !surface && !triangles.empty(); }
};

// Parses the `--reference` argument: `sphere:R` (R > 0), `torus:R,r` (R > r > 0), or else the
// path of a PLY file, which is read (with its faces). Fails with a one-line message for bad
// syntax, non-finite or out-of-range values, and anything readPly or meshReference rejects.
// Any thread may call it.
Result<Reference> parseReference(const std::string& spec);

// A mesh (or points-only, when `triangles` is empty) reference from vertices and triangles.
// Fails when an index is out of range. When `vertices` has no normals (normal.size() !=
// position.size()) they are computed as normalised area-weighted vertex normals (the
// construction of ../shared/data, whose meshes store no normals); a points-only reference needs
// normals. Triangles of zero area are kept (they only ever give a distance equal to an edge's).
Result<Reference> meshReference(PointSet vertices, std::vector<glm::u32vec3> triangles, std::string name);

// The closest point of the triangle (a, b, c) to p (Ericson, "Real-Time Collision Detection",
// 5.1.5), as barycentric weights of a, b, c (non-negative, summing to 1). Exact for degenerate
// triangles too. Any thread.
glm::vec3 closestPointBarycentric(glm::vec3 p, glm::vec3 a, glm::vec3 b, glm::vec3 c);
inline glm::vec3 closestPointOnTriangle(glm::vec3 p, glm::vec3 a, glm::vec3 b, glm::vec3 c) {
    const glm::vec3 w = closestPointBarycentric(p, a, b, c);
    return w.x * a + w.y * b + w.z * c;
}

// Exact closest-point queries against a triangle mesh: a bounding-volume hierarchy (axis-aligned
// boxes, median splits, 4 triangles per leaf) searched branch and bound. Construction copies the
// triangles; queries are const and may run from any number of threads at once.
class TriangleMeshIndex {
  public:
    struct Hit {
        glm::vec3 point;        // the closest surface point
        glm::vec3 barycentric;  // of `point` in `triangle`'s vertices
        std::uint32_t triangle; // index into the triangles given to the constructor
        float distanceSquared;
    };

    // Preconditions: every index < positions.size(); at least one triangle.
    TriangleMeshIndex(std::span<const glm::vec3> positions, const std::vector<glm::u32vec3>& triangles);

    Hit closest(glm::vec3 p) const;
    std::size_t triangleCount() const { return order_.size(); }

  private:
    struct Node {
        glm::vec3 lo, hi;
        std::uint32_t index; // leaf: first triangle slot; inner node: right child (left is next)
        std::uint32_t count; // leaf: number of triangles (> 0); inner node: 0
    };
    std::vector<Node> nodes_;
    std::vector<glm::vec3> corners_;   // 3 per triangle slot, in leaf order
    std::vector<std::uint32_t> order_; // triangle index of each slot
};

inline constexpr glm::u8vec3 kGapColour{255, 0, 0};
inline constexpr glm::u8vec3 kOffSurfaceColour{255, 170, 0};

struct EvalOptions {
    unsigned threads = 0;                  // worker threads; 0 = std::thread::hardware_concurrency
    std::size_t analyticSamples = 200'000; // dense reference samples of an analytic surface
    // A mesh reference's true normal is its closest triangle's own (facing like the vertex
    // normals there), not the vertex normals interpolated: for CAD parts with sharp edges, whose
    // vertex normals average the faces on both sides (../shared/data's fandisk), so that near an
    // edge they reward rounding it off.
    bool flatNormals = false;
};

struct QualityReport {
    std::string reference;           // Reference::name
    std::size_t points = 0;          // refined points
    std::size_t referencePoints = 0; // points of the hole test (vertices, or analytic samples)
    std::size_t referenceTriangles = 0;
    double diagonal = 0.0; // bounding-box diagonal of the reference (model units)

    // p99: the nearest-rank 99th percentile (a flap or a stray point shows there before the mean).
    double distanceMean = 0.0, distanceRms = 0.0, distanceP99 = 0.0, distanceMax = 0.0; // model units
    double distanceMeanRel = 0.0, distanceRmsRel = 0.0, distanceP99Rel = 0.0,
           distanceMaxRel = 0.0; // / diagonal

    double normalErrorMeanDeg = 0.0, normalErrorP95Deg = 0.0, normalErrorMaxDeg = 0.0;

    double spacingMean = 0.0;     // mean nearest-neighbour distance of the refined points
    double uniformityCv = 0.0;    // std / mean of those distances (population std)
    double holes = 0.0;           // share in [0, 1] of reference points not covered
    double holesTangential = 0.0; // the same, distances measured in the sample's tangent plane
    // The share of samples farther than twice spacingMean from every refined point projected onto
    // the true surface (its closest point there; for reference points, onto the nearest one's
    // tangent plane): the uncovered true surface, wherever the refined one lies (issue 27's "gaps
    // on the true surface").
    double gaps = 0.0;
    std::size_t holeReferencePoints = 0;
    // The samples that are holes or gaps, coloured kGapColour where they are gaps (the true
    // surface uncovered) and kOffSurfaceColour where they are holes only (the refined surface
    // passes there, off the true one): where the holes are, to look at.
    PointSet holePoints;

    bool hasInput = false; // the fields below are meaningful only with an input
    std::size_t inputPoints = 0;
    bool inputPreserved = false;
    std::size_t inputMissing = 0; // input points without a bit-identical twin in the output
};

// Evaluates `refined` against `reference`, and its interpolation of `input` when given.
// Preconditions: refined has at least 2 points with normals; input (when given) may lack them;
// reference comes from parseReference / meshReference. Per-point work runs on options.threads
// threads; the report is identical for every thread count (per-point results go to arrays
// reduced sequentially in point order). Any thread may call it; it starts its own WorkerPool
// (worker_pool.h) for the call.
// Cost: O((N + M) log) with N refined and M reference points; about a second per million
// refined points against a 270k-triangle mesh on a few cores.
QualityReport evaluateQuality(const PointSet& refined, const Reference& reference, const PointSet* input,
                              const EvalOptions& options = {});

// The report as one JSON object with stable keys:
// {"points", "reference", "reference_points", "reference_triangles", "diagonal",
//  "distance": {"mean", "rms", "p99", "max", "mean_rel", "rms_rel", "p99_rel", "max_rel"},
//  "normal_error_deg": {"mean", "p95", "max"}, "spacing_mean", "uniformity_cv", "holes", "holes_tangential",
//  "gaps", "input_points", "input_preserved", "input_missing"}; the input_* values are null without an
// input. Non-finite numbers are written as null. Ends without a newline.
std::string toJson(const QualityReport& report);

} // namespace pnsplat
