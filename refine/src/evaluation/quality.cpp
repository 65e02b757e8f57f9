// Quality metrics of `pnsplat eval` (see quality.h for the definitions). Not part of the paper.
//
// Structure: per-point work (closest surface point, nearest-neighbour spacing, coverage of the
// reference samples) runs in parallelForRanges over flat arrays, one slot per point; every reduction
// (sums, maxima, percentile) then runs sequentially in point order, so the report does not depend
// on the thread count. Closest points on a mesh come from a bounding-volume hierarchy of
// triangles searched branch and bound (exact: no search radius to guess, robust to a few huge
// triangles); nearest points come from nanoflann kd-trees.
#include "pnsplat/refine/evaluation/quality.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <span>
#include <string_view>

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include "../kd_tree.h"
#include "pnsplat/refine/angles.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/text.h"
#include "pnsplat/refine/worker_pool.h"

namespace pnsplat {
namespace {

constexpr float kInfinity = std::numeric_limits<float>::infinity();

// ---- Worker threads ----

// Per-point loops run on the pool (the project's one place for worker threads, worker_pool.h) in
// ranges of this many points; a body writes only to slots of its own range, so results never
// depend on which worker ran which range.
constexpr std::size_t kChunk = 2048;

// ---- Nearest points: the k-d tree of kd_tree.h ----

// A kd-tree over `cloud`'s positions, 16 points per leaf. The pragma silences a GCC 12 false
// positive (-Wnull-dereference inside std::vector::resize, inlined from nanoflann's buildIndex).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnull-dereference"
#endif
std::unique_ptr<KdTree> makePointTree(const KdCloud& cloud) {
    return std::make_unique<KdTree>(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16));
}
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

// Index and squared distance of the point of `tree` nearest to q.
std::pair<std::uint32_t, float> nearest(const KdTree& tree, glm::vec3 q) {
    std::uint32_t index = 0;
    float d2 = kInfinity;
    nanoflann::KNNResultSet<float, std::uint32_t> result(1);
    result.init(&index, &d2);
    tree.findNeighbors(result, &q.x, nanoflann::SearchParams());
    return {index, d2};
}

// ---- Geometry helpers ----

glm::vec3 closestOnSegment(glm::vec3 p, glm::vec3 a, glm::vec3 b, float& t) {
    const glm::vec3 ab = b - a;
    const float len2 = glm::dot(ab, ab);
    t = len2 > 0.0f ? std::clamp(glm::dot(p - a, ab) / len2, 0.0f, 1.0f) : 0.0f;
    return a + t * ab;
}

float length2(glm::vec3 v) {
    return glm::dot(v, v);
}

struct Box {
    glm::vec3 lo{kInfinity};
    glm::vec3 hi{-kInfinity};
    void grow(glm::vec3 p) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    void grow(const Box& b) {
        lo = glm::min(lo, b.lo);
        hi = glm::max(hi, b.hi);
    }
};

float boxDistance2(glm::vec3 p, glm::vec3 lo, glm::vec3 hi) {
    const glm::vec3 d = glm::max(glm::max(lo - p, p - hi), glm::vec3(0.0f));
    return glm::dot(d, d);
}

double diagonalOf(std::span<const glm::vec3> positions) {
    Box box;
    for (const glm::vec3& p : positions) box.grow(p);
    return positions.empty() ? 0.0 : glm::length(glm::dvec3(box.hi) - glm::dvec3(box.lo));
}

// Area-weighted vertex normals (sum of the un-normalised face cross products around a vertex,
// normalised): how ../shared/data made its reference normals. Isolated vertices get +z.
HugePageVector<glm::vec3> areaWeightedNormals(std::span<const glm::vec3> positions,
                                              const std::vector<glm::u32vec3>& triangles) {
    std::vector<glm::dvec3> sum(positions.size(), glm::dvec3(0.0));
    for (const glm::u32vec3& t : triangles) {
        const glm::dvec3 a(positions[t.x]), b(positions[t.y]), c(positions[t.z]);
        const glm::dvec3 n = glm::cross(b - a, c - a);
        sum[t.x] += n;
        sum[t.y] += n;
        sum[t.z] += n;
    }
    HugePageVector<glm::vec3> normals(positions.size());
    for (std::size_t i = 0; i < sum.size(); ++i) {
        const double len = glm::length(sum[i]);
        normals[i] = len > 0.0 ? glm::vec3(sum[i] / len) : glm::vec3(0.0f, 0.0f, 1.0f);
    }
    return normals;
}

} // namespace

// Sine squared of the smallest angle (between ab and ac) below which a triangle counts as thin.
constexpr float kThinTriangle = 1e-4f;

namespace {

// Exact closest point of a thin or degenerate triangle: the best of the orthogonal projection
// onto the plane (when it falls inside, solved in double) and the closest points of the three
// edges. Rarely used, so simple rather than fast.
glm::vec3 closestPointThinTriangle(glm::vec3 p, glm::vec3 a, glm::vec3 b, glm::vec3 c) {
    glm::vec3 best{1.0f, 0.0f, 0.0f};
    double bestD2 = glm::dot(glm::dvec3(p - a), glm::dvec3(p - a));
    const glm::dvec3 da(a), dab = glm::dvec3(b) - da, dac = glm::dvec3(c) - da, dap = glm::dvec3(p) - da;
    const double d00 = glm::dot(dab, dab), d01 = glm::dot(dab, dac), d11 = glm::dot(dac, dac);
    const double d20 = glm::dot(dap, dab), d21 = glm::dot(dap, dac);
    const double denom = d00 * d11 - d01 * d01;
    if (denom > 0.0) {
        const double v = (d11 * d20 - d01 * d21) / denom, w = (d00 * d21 - d01 * d20) / denom;
        if (v >= 0.0 && w >= 0.0 && v + w <= 1.0) {
            const glm::dvec3 q = da + v * dab + w * dac;
            const double d2 = glm::dot(glm::dvec3(p) - q, glm::dvec3(p) - q);
            if (d2 < bestD2) {
                bestD2 = d2;
                best = glm::vec3(glm::dvec3(1.0 - v - w, v, w));
            }
        }
    }
    const glm::vec3 corners[3] = {a, b, c};
    for (int e = 0; e < 3; ++e) {
        const int i = e, j = (e + 1) % 3;
        float t = 0.0f;
        const glm::dvec3 q(closestOnSegment(p, corners[i], corners[j], t));
        const double d2 = glm::dot(glm::dvec3(p) - q, glm::dvec3(p) - q);
        if (d2 < bestD2) {
            bestD2 = d2;
            best = glm::vec3(0.0f);
            best[i] = 1.0f - t;
            best[j] = t;
        }
    }
    return best;
}

} // namespace

// ---- Closest point on a triangle (Ericson, Real-Time Collision Detection, 5.1.5) ----

glm::vec3 closestPointBarycentric(glm::vec3 p, glm::vec3 a, glm::vec3 b, glm::vec3 c) {
    // Ericson's d1 ... d6: the edges ab and ac against p as seen from a, b and c.
    const glm::vec3 ab = b - a, ac = c - a, ap = p - a, bp = p - b, cp = p - c;
    const float d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
    const float d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
    const float d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
    if (d1 <= 0.0f && d2 <= 0.0f) return {1.0f, 0.0f, 0.0f}; // vertex region a
    if (d3 >= 0.0f && d4 <= d3) return {0.0f, 1.0f, 0.0f};   // vertex region b

    const float vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0f && d1 >= 0.0f && d3 <= 0.0f) { // edge region ab
        const float v = d1 / (d1 - d3);
        return {1.0f - v, v, 0.0f};
    }
    if (d6 >= 0.0f && d5 <= d6) return {0.0f, 0.0f, 1.0f}; // vertex region c

    const float vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0f && d2 >= 0.0f && d6 <= 0.0f) { // edge region ac
        const float w = d2 / (d2 - d6);
        return {1.0f - w, 0.0f, w};
    }

    const float va = d3 * d6 - d5 * d4;
    if (va <= 0.0f && d4 - d3 >= 0.0f && d5 - d6 >= 0.0f) { // edge region bc
        const float w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return {0.0f, 1.0f - w, w};
    }

    // Face region. Ericson's formulas are accurate unless the triangle is very thin, when the
    // rounding errors of va, vb, vc (of the order of the squared edge lengths times epsilon) are
    // as large as their sum |ab x ac|^2. Thin or degenerate triangles take the slow exact path.
    const float sum = va + vb + vc;
    const glm::vec3 n = glm::cross(ab, ac);
    if (glm::dot(n, n) > kThinTriangle * glm::dot(ab, ab) * glm::dot(ac, ac) && sum > 0.0f) {
        const float v = vb / sum, w = vc / sum;
        return {1.0f - v - w, v, w};
    }
    return closestPointThinTriangle(p, a, b, c);
}

// ---- TriangleMeshIndex ----

TriangleMeshIndex::TriangleMeshIndex(std::span<const glm::vec3> positions,
                                     const std::vector<glm::u32vec3>& triangles) {
    assert(!triangles.empty());
    const std::size_t n = triangles.size();
    std::vector<Box> boxes(n);
    std::vector<glm::vec3> centroids(n);
    for (std::size_t i = 0; i < n; ++i) {
        const glm::u32vec3 t = triangles[i];
        assert(t.x < positions.size() && t.y < positions.size() && t.z < positions.size());
        boxes[i].grow(positions[t.x]);
        boxes[i].grow(positions[t.y]);
        boxes[i].grow(positions[t.z]);
        centroids[i] = (positions[t.x] + positions[t.y] + positions[t.z]) / 3.0f;
    }
    order_.resize(n);
    for (std::size_t i = 0; i < n; ++i) order_[i] = static_cast<std::uint32_t>(i);
    nodes_.reserve(2 * (n / 2 + 1));

    // Depth-first build: the left child directly follows its parent.
    constexpr std::uint32_t kLeafSize = 4;
    struct Builder {
        std::vector<Node>& nodes;
        std::vector<std::uint32_t>& order;
        const std::vector<Box>& boxes;
        const std::vector<glm::vec3>& centroids;

        void build(std::uint32_t first, std::uint32_t count) {
            Box bounds, centres;
            for (std::uint32_t i = first; i < first + count; ++i) {
                bounds.grow(boxes[order[i]]);
                centres.grow(centroids[order[i]]);
            }
            const auto self = static_cast<std::uint32_t>(nodes.size());
            nodes.push_back({bounds.lo, bounds.hi, first, count});
            if (count <= kLeafSize) return;
            const glm::vec3 extent = centres.hi - centres.lo;
            const int axis =
                extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
            const std::uint32_t half = count / 2;
            auto begin = order.begin() + first;
            std::nth_element(begin, begin + half, begin + count, [&](std::uint32_t a, std::uint32_t b) {
                return centroids[a][axis] < centroids[b][axis] ||
                       (centroids[a][axis] == centroids[b][axis] && a < b);
            });
            nodes[self].count = 0;
            build(first, half);
            nodes[self].index = static_cast<std::uint32_t>(nodes.size());
            build(first + half, count - half);
        }
    };
    Builder{nodes_, order_, boxes, centroids}.build(0, static_cast<std::uint32_t>(n));

    corners_.resize(3 * n);
    for (std::size_t s = 0; s < n; ++s) {
        const glm::u32vec3 t = triangles[order_[s]];
        corners_[3 * s + 0] = positions[t.x];
        corners_[3 * s + 1] = positions[t.y];
        corners_[3 * s + 2] = positions[t.z];
    }
}

TriangleMeshIndex::Hit TriangleMeshIndex::closest(glm::vec3 p) const {
    Hit best{glm::vec3(0.0f), glm::vec3(1.0f, 0.0f, 0.0f), 0, kInfinity};
    std::uint32_t bestSlot = 0;
    // Depth is about log2(triangles / 4) for median splits; 64 covers any realistic mesh.
    std::array<std::pair<std::uint32_t, float>, 64> stack;
    std::size_t top = 0;
    std::uint32_t node = 0;
    float nodeD2 = boxDistance2(p, nodes_[0].lo, nodes_[0].hi);
    for (;;) {
        if (nodeD2 < best.distanceSquared) {
            const Node& nd = nodes_[node];
            if (nd.count > 0) {
                for (std::uint32_t s = nd.index; s < nd.index + nd.count; ++s) {
                    const glm::vec3 a = corners_[3 * s], b = corners_[3 * s + 1], c = corners_[3 * s + 2];
                    const glm::vec3 w = closestPointBarycentric(p, a, b, c);
                    const glm::vec3 q = w.x * a + w.y * b + w.z * c;
                    const float d2 = length2(p - q);
                    if (d2 < best.distanceSquared) {
                        best = {q, w, 0, d2};
                        bestSlot = s;
                    }
                }
            } else {
                const std::uint32_t left = node + 1, right = nd.index;
                const float dl = boxDistance2(p, nodes_[left].lo, nodes_[left].hi);
                const float dr = boxDistance2(p, nodes_[right].lo, nodes_[right].hi);
                const bool leftFirst = dl <= dr;
                const std::uint32_t nearChild = leftFirst ? left : right, farChild = leftFirst ? right : left;
                const float nearD2 = leftFirst ? dl : dr, farD2 = leftFirst ? dr : dl;
                if (farD2 < best.distanceSquared) {
                    assert(top < stack.size());
                    stack[top++] = {farChild, farD2};
                }
                node = nearChild;
                nodeD2 = nearD2;
                continue;
            }
        }
        if (top == 0) break;
        std::tie(node, nodeD2) = stack[--top];
    }
    best.triangle = order_[bestSlot];
    return best;
}

// ---- References ----

Result<Reference> meshReference(PointSet vertices, std::vector<glm::u32vec3> triangles, std::string name) {
    if (vertices.empty()) return Error{fmt::format("reference {}: no points", name)};
    const std::size_t n = vertices.size();
    for (std::size_t i = 0; i < triangles.size(); ++i) {
        const glm::u32vec3 t = triangles[i];
        if (t.x >= n || t.y >= n || t.z >= n)
            return Error{fmt::format("reference {}: face {} uses vertex {} but there are only {} vertices",
                                     name, i, std::max({t.x, t.y, t.z}), n)};
    }
    bool normalsUsable = vertices.normal.size() == n;
    for (std::size_t i = 0; normalsUsable && i < n; ++i) {
        const float len = glm::length(vertices.normal[i]);
        normalsUsable = std::isfinite(len) && std::abs(len - 1.0f) < 1e-3f;
    }
    if (!normalsUsable) {
        if (triangles.empty())
            return Error{fmt::format("reference {}: points without (unit) normals and no faces", name)};
        vertices.normal = areaWeightedNormals(vertices.position, triangles);
    }
    Reference ref;
    ref.name = std::move(name);
    ref.points = std::move(vertices);
    ref.triangles = std::move(triangles);
    return ref;
}

Result<Reference> parseReference(const std::string& spec) {
    const std::string_view text = spec;
    auto analytic = [&](AnalyticSurface surface) {
        Reference ref;
        ref.name = spec;
        ref.surface = surface;
        return ref;
    };
    if (text.starts_with("sphere:")) {
        const auto radius = parseFloat(text.substr(7));
        if (!radius || !(*radius > 0.0f))
            return Error{fmt::format("bad reference '{}': expected sphere:R with a radius R > 0", spec)};
        return analytic(AnalyticSurface::sphere(*radius));
    }
    if (text.starts_with("torus:")) {
        const std::string_view args = text.substr(6);
        const std::size_t comma = args.find(',');
        const auto major = comma == std::string_view::npos ? std::nullopt : parseFloat(args.substr(0, comma));
        const auto tube = comma == std::string_view::npos ? std::nullopt : parseFloat(args.substr(comma + 1));
        if (!major || !tube)
            return Error{fmt::format("bad reference '{}': expected torus:R,r with two numbers", spec)};
        if (!(*tube > 0.0f && *major > *tube))
            return Error{fmt::format("bad reference '{}': a torus needs R > r > 0", spec)};
        return analytic(AnalyticSurface::torus(*major, *tube));
    }
    // Not a file and shaped like "word:..." (a mistyped kind): say what is accepted.
    const std::size_t colon = text.find(':');
    if (colon != std::string_view::npos && colon > 0 && !std::filesystem::exists(spec) &&
        std::all_of(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(colon),
                    [](char ch) { return (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z'); }))
        return Error{fmt::format("bad reference '{}': expected sphere:R, torus:R,r or a PLY file", spec)};

    auto data = readPly(spec, {.readFaces = true});
    if (!data) return data.error();
    Result<Reference> ref = meshReference(std::move(data->points), std::move(data->triangles), spec);
    if (ref) ref->origin = data->origin;
    return ref;
}

// ---- Evaluation ----

namespace {

// What the evaluation's steps read.
struct Evaluation {
    const PointSet& refined;
    const Reference& reference;
    const EvalOptions& options;
    WorkerPool& pool;
};

// The normal error of refined point i against the true normal, in degrees (a crease point's error
// is that of the closer of its two normals).
float normalError(const PointSet& refined, std::size_t i, glm::vec3 truth) {
    double a = angleInDegrees(refined.normal[i], truth);
    if (refined.isCrease(i)) a = std::min(a, angleInDegrees(refined.crease[i], truth));
    return static_cast<float>(a);
}

// Each measure fills, per refined point, its distance to the true surface, its normal error and
// its projection onto the surface (the closest point).
void measureAgainstAnalytic(const Evaluation& eval, std::span<float> distance, std::span<float> angle,
                            std::span<glm::vec3> projected) {
    const AnalyticSurface& s = *eval.reference.surface;
    const PointSet& refined = eval.refined;
    parallelForRanges(eval.pool, refined.size(), kChunk, [&](std::size_t begin, std::size_t end, unsigned) {
        for (std::size_t i = begin; i < end; ++i) {
            distance[i] = s.distance(refined.position[i]);
            projected[i] = s.closestPoint(refined.position[i]);
            angle[i] = normalError(refined, i, s.normalAt(refined.position[i]));
        }
    });
}

void measureAgainstMesh(const Evaluation& eval, std::span<float> distance, std::span<float> angle,
                        std::span<glm::vec3> projected) {
    const PointSet& refined = eval.refined;
    const std::vector<glm::u32vec3>& triangles = eval.reference.triangles;
    const auto& vp = eval.reference.points.position;
    const auto& vn = eval.reference.points.normal;
    const TriangleMeshIndex mesh(vp, triangles);
    parallelForRanges(eval.pool, refined.size(), kChunk, [&](std::size_t begin, std::size_t end, unsigned) {
        for (std::size_t i = begin; i < end; ++i) {
            const TriangleMeshIndex::Hit hit = mesh.closest(refined.position[i]);
            const glm::u32vec3 t = triangles[hit.triangle];
            glm::vec3 normal =
                hit.barycentric.x * vn[t.x] + hit.barycentric.y * vn[t.y] + hit.barycentric.z * vn[t.z];
            if (!(length2(normal) > 1e-12f)) normal = glm::cross(vp[t.y] - vp[t.x], vp[t.z] - vp[t.x]);
            if (!(length2(normal) > 0.0f)) normal = vn[t.x];
            if (eval.options.flatNormals) {
                const glm::vec3 face = glm::cross(vp[t.y] - vp[t.x], vp[t.z] - vp[t.x]);
                if (length2(face) > 0.0f) normal = glm::dot(face, normal) < 0.0f ? -face : face;
            }
            distance[i] = std::sqrt(hit.distanceSquared);
            projected[i] = hit.point;
            angle[i] = normalError(refined, i, normal);
        }
    });
}

// Points only: the nearest reference point's tangent plane stands for the surface.
void measureAgainstPoints(const Evaluation& eval, std::span<float> distance, std::span<float> angle,
                          std::span<glm::vec3> projected) {
    const PointSet& refined = eval.refined;
    const PointSet& reference = eval.reference.points;
    const KdCloud cloud{reference.position};
    const std::unique_ptr<KdTree> tree = makePointTree(cloud);
    parallelForRanges(eval.pool, refined.size(), kChunk, [&](std::size_t begin, std::size_t end, unsigned) {
        for (std::size_t i = begin; i < end; ++i) {
            const std::uint32_t q = nearest(*tree, refined.position[i]).first;
            const glm::vec3 nq = reference.normal[q];
            const float offset = glm::dot(refined.position[i] - reference.position[q], nq);
            distance[i] = std::abs(offset);
            projected[i] = refined.position[i] - offset * nq;
            angle[i] = normalError(refined, i, nq);
        }
    });
}

// Nearest-rank percentiles: the smallest value with at least that share of the points at or
// below it (reorders `values`).
double percentile(std::vector<float>& values, double share) {
    const double dn = static_cast<double>(values.size());
    const auto rank = static_cast<std::size_t>(std::ceil(share * dn)) - 1;
    std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(rank), values.end());
    return static_cast<double>(values[rank]);
}

// The report's distances and normal errors from the per-point values (reorders them).
void summariseErrors(std::vector<float>& distance, std::vector<float>& angle, QualityReport& report) {
    const std::size_t n = distance.size();
    double sum = 0.0, sum2 = 0.0, maxDistance = 0.0, angleSum = 0.0, angleMax = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        const double d = distance[i];
        sum += d;
        sum2 += d * d;
        maxDistance = std::max(maxDistance, d);
        angleSum += static_cast<double>(angle[i]);
        angleMax = std::max(angleMax, static_cast<double>(angle[i]));
    }
    const double dn = static_cast<double>(n);
    report.distanceMean = sum / dn;
    report.distanceRms = std::sqrt(sum2 / dn);
    report.distanceMax = maxDistance;
    report.distanceMeanRel = report.distanceMean / report.diagonal;
    report.distanceRmsRel = report.distanceRms / report.diagonal;
    report.distanceMaxRel = report.distanceMax / report.diagonal;
    report.normalErrorMeanDeg = angleSum / dn;
    report.normalErrorMaxDeg = angleMax;
    report.normalErrorP95Deg = percentile(angle, 0.95);
    report.distanceP99 = percentile(distance, 0.99);
    report.distanceP99Rel = report.distanceP99 / report.diagonal;
}

// 2. Uniformity: nearest other refined point of each refined point, into `spacing`; the report's
// mean spacing and its coefficient of variation.
void measureUniformity(const Evaluation& eval, const KdTree& refinedTree, std::span<float> spacing,
                       QualityReport& report) {
    const PointSet& refined = eval.refined;
    const std::size_t n = refined.size();
    parallelForRanges(eval.pool, n, kChunk, [&](std::size_t begin, std::size_t end, unsigned) {
        for (std::size_t i = begin; i < end; ++i) {
            std::array<std::uint32_t, 2> index{};
            std::array<float, 2> d2{};
            nanoflann::KNNResultSet<float, std::uint32_t> result(2);
            result.init(index.data(), d2.data());
            refinedTree.findNeighbors(result, &refined.position[i].x, nanoflann::SearchParams());
            // The point itself is one of the two (first, unless a duplicate ties at distance 0).
            spacing[i] = std::sqrt(index[0] == i ? d2[1] : d2[0]);
        }
    });
    const double dn = static_cast<double>(n);
    double spacingSum = 0.0;
    for (std::size_t i = 0; i < n; ++i) spacingSum += static_cast<double>(spacing[i]);
    const double spacingMean = spacingSum / dn;
    double deviation2 = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        const double deviation = static_cast<double>(spacing[i]) - spacingMean;
        deviation2 += deviation * deviation;
    }
    report.spacingMean = spacingMean;
    report.uniformityCv = spacingMean > 0.0 ? std::sqrt(deviation2 / dn) / spacingMean
                                            : std::numeric_limits<double>::quiet_NaN();
}

// Uniform samples of an analytic reference, with their normals.
PointSet analyticSamplesOf(const AnalyticSurface& s, std::size_t count) {
    PointSet samples = s.kind == AnalyticSurface::Kind::Sphere ? sampleSphereUniform(count, s.R)
                                                               : sampleTorusUniform(count, s.R, s.r);
    for (glm::vec3& p : samples.position) p += s.centre;
    return samples;
}

// 3. Holes: reference samples with no refined point within twice the mean spacing; gaps: the same
// with the refined points `projected` onto the true surface.
void measureHoles(const Evaluation& eval, const KdTree& refinedTree, std::span<const glm::vec3> projected,
                  double spacingMean, QualityReport& report) {
    const Reference& reference = eval.reference;
    PointSet analyticSamples;
    if (reference.isAnalytic())
        analyticSamples = analyticSamplesOf(*reference.surface, eval.options.analyticSamples);
    const auto& samples = reference.isAnalytic() ? analyticSamples.position : reference.points.position;
    const std::size_t m = samples.size();
    report.referencePoints = m;
    // The tangential variant measures the offset to the nearest of the kTangentialNearest refined
    // points in the sample's tangent plane only, so that a refined surface lying a little off the
    // true one (the approximation error of a sparse input) does not count as a hole.
    const auto& sampleNormals = reference.isAnalytic() ? analyticSamples.normal : reference.points.normal;
    const auto threshold2 = static_cast<float>(4.0 * spacingMean * spacingMean);
    constexpr std::size_t kTangentialNearest = 8;
    const KdCloud projectedCloud{projected};
    const std::unique_ptr<KdTree> projectedTree = makePointTree(projectedCloud);
    std::vector<std::uint8_t> uncovered(m), uncoveredTangential(m), uncoveredProjected(m);
    parallelForRanges(eval.pool, m, kChunk, [&](std::size_t begin, std::size_t end, unsigned) {
        std::array<std::uint32_t, kTangentialNearest> index;
        std::array<float, kTangentialNearest> d2;
        for (std::size_t j = begin; j < end; ++j) {
            const glm::vec3 q = samples[j];
            const std::size_t found =
                refinedTree.knnSearch(&q.x, kTangentialNearest, index.data(), d2.data());
            uncovered[j] = found == 0 || d2[0] > threshold2;
            float tangential2 = kInfinity;
            for (std::size_t k = 0; k < found; ++k) {
                const glm::vec3 d = eval.refined.position[index[k]] - q;
                const float along = glm::dot(d, sampleNormals[j]);
                tangential2 = std::min(tangential2, glm::dot(d, d) - along * along);
            }
            uncoveredTangential[j] = tangential2 > threshold2;
            uncoveredProjected[j] = nearest(*projectedTree, q).second > threshold2;
        }
    });
    std::size_t holes = 0, holesTangential = 0, gaps = 0;
    for (std::size_t j = 0; j < m; ++j)
        holes += uncovered[j], holesTangential += uncoveredTangential[j], gaps += uncoveredProjected[j];
    report.holeReferencePoints = holes;
    for (std::size_t j = 0; j < m; ++j) {
        if (!uncovered[j] && !uncoveredProjected[j]) continue;
        report.holePoints.position.push_back(samples[j]);
        report.holePoints.normal.push_back(sampleNormals[j]);
        report.holePoints.colour.push_back(uncoveredProjected[j] ? kGapColour : kOffSurfaceColour);
    }
    report.holes = m > 0 ? static_cast<double>(holes) / static_cast<double>(m) : 0.0;
    report.holesTangential = m > 0 ? static_cast<double>(holesTangential) / static_cast<double>(m) : 0.0;
    report.gaps = m > 0 ? static_cast<double>(gaps) / static_cast<double>(m) : 0.0;
}

// 4. Input preservation: each input point's 6 floats, bit for bit, among the output's.
void measureInputPreservation(const PointSet& refined, const PointSet& input, QualityReport& report) {
    using Key = std::array<std::uint32_t, 6>;
    const bool byNormal = input.hasNormal(); // an input of positions only: by position alone
    auto keyOf = [&](const PointSet& set, std::size_t i) {
        const glm::vec3 p = set.position[i], q = byNormal ? set.normal[i] : glm::vec3(0.0f);
        return Key{std::bit_cast<std::uint32_t>(p.x), std::bit_cast<std::uint32_t>(p.y),
                   std::bit_cast<std::uint32_t>(p.z), std::bit_cast<std::uint32_t>(q.x),
                   std::bit_cast<std::uint32_t>(q.y), std::bit_cast<std::uint32_t>(q.z)};
    };
    // The input is small: sort its keys, look every output point up, mark what is found.
    std::vector<std::pair<Key, std::uint32_t>> keys(input.size());
    for (std::size_t i = 0; i < keys.size(); ++i) keys[i] = {keyOf(input, i), static_cast<std::uint32_t>(i)};
    std::sort(keys.begin(), keys.end());
    std::vector<std::uint8_t> found(keys.size(), 0);
    for (std::size_t i = 0; i < refined.size() && !keys.empty(); ++i) {
        const Key k = keyOf(refined, i);
        auto it = std::lower_bound(keys.begin(), keys.end(), k,
                                   [](const auto& entry, const Key& key) { return entry.first < key; });
        for (; it != keys.end() && it->first == k; ++it)
            found[static_cast<std::size_t>(it - keys.begin())] = 1;
    }
    report.hasInput = true;
    report.inputPoints = input.size();
    report.inputMissing = static_cast<std::size_t>(std::count(found.begin(), found.end(), std::uint8_t{0}));
    report.inputPreserved = report.inputMissing == 0;
}

} // namespace

QualityReport evaluateQuality(const PointSet& refined, const Reference& reference, const PointSet* input,
                              const EvalOptions& options) {
    const std::size_t n = refined.size();
    assert(n >= 2 && refined.normal.size() == n);
    assert(reference.isAnalytic() || !reference.points.empty());
    WorkerPool pool(options.threads);
    const Evaluation eval{refined, reference, options, pool};

    QualityReport report;
    report.reference = reference.name;
    report.points = n;
    report.referenceTriangles = reference.triangles.size();
    report.diagonal = reference.isAnalytic() ? static_cast<double>(reference.surface->boundingDiagonal())
                                             : diagonalOf(reference.points.position);

    // 1. Distance to the true surface and normal error, per refined point.
    std::vector<float> distance(n), angle(n);
    std::vector<glm::vec3> projected(n);
    if (reference.isAnalytic())
        measureAgainstAnalytic(eval, distance, angle, projected);
    else if (reference.isMesh())
        measureAgainstMesh(eval, distance, angle, projected);
    else
        measureAgainstPoints(eval, distance, angle, projected);
    summariseErrors(distance, angle, report);

    const KdCloud refinedCloud{refined.position};
    const std::unique_ptr<KdTree> refinedTree = makePointTree(refinedCloud);
    std::vector<float>& spacing = distance; // reuse the array
    measureUniformity(eval, *refinedTree, spacing, report);
    measureHoles(eval, *refinedTree, projected, report.spacingMean, report);
    if (input) measureInputPreservation(refined, *input, report);
    return report;
}

std::string toJson(const QualityReport& r) {
    const auto inputValue = [&](auto value) {
        return r.hasInput ? fmt::format("{}", value) : std::string("null");
    };
    return fmt::format(
        "{{\"points\": {}, \"reference\": {}, \"reference_points\": {}, \"reference_triangles\": {}, "
        "\"diagonal\": {}, "
        "\"distance\": {{\"mean\": {}, \"rms\": {}, \"p99\": {}, \"max\": {}, \"mean_rel\": {}, "
        "\"rms_rel\": {}, \"p99_rel\": {}, \"max_rel\": {}}}, "
        "\"normal_error_deg\": {{\"mean\": {}, \"p95\": {}, \"max\": {}}}, "
        "\"spacing_mean\": {}, \"uniformity_cv\": {}, \"holes\": {}, \"holes_tangential\": {}, \"gaps\": {}, "
        "\"input_points\": {}, \"input_preserved\": {}, \"input_missing\": {}}}",
        r.points, jsonString(r.reference), r.referencePoints, r.referenceTriangles, jsonNumber(r.diagonal),
        jsonNumber(r.distanceMean), jsonNumber(r.distanceRms), jsonNumber(r.distanceP99),
        jsonNumber(r.distanceMax), jsonNumber(r.distanceMeanRel), jsonNumber(r.distanceRmsRel),
        jsonNumber(r.distanceP99Rel), jsonNumber(r.distanceMaxRel), jsonNumber(r.normalErrorMeanDeg),
        jsonNumber(r.normalErrorP95Deg), jsonNumber(r.normalErrorMaxDeg), jsonNumber(r.spacingMean),
        jsonNumber(r.uniformityCv), jsonNumber(r.holes), jsonNumber(r.holesTangential), jsonNumber(r.gaps),
        inputValue(r.inputPoints), inputValue(r.inputPreserved), inputValue(r.inputMissing));
}

} // namespace pnsplat
