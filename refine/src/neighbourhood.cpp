// One-ring neighbourhoods: paper section 4 (eq. 7-9), ALGORITHM.md §3.
#include "pnsplat/refine/neighbourhood.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>

#include "pnsplat/refine/fast_math.h"
#include "pnsplat/refine/simd_clone.h"

namespace pnsplat {

TangentFrame::TangentFrame(glm::vec3 normal) : n(normal) {
    const float sign = std::copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z);
    const float b = n.x * n.y * a;
    u = glm::vec3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
    v = glm::vec3(b, sign + n.y * n.y * a, -n.y);
}

std::pair<float, float> widestGap(std::span<const float> angles) {
    constexpr float kTwoPi = 2.0f * std::numbers::pi_v<float>;
    if (angles.empty()) return {kTwoPi, 0.0f};
    float gap = kTwoPi - (angles.back() - angles.front());
    float bisector = angles.back() + 0.5f * gap;
    for (std::size_t k = 1; k < angles.size(); ++k)
        if (angles[k] - angles[k - 1] > gap) {
            gap = angles[k] - angles[k - 1];
            bisector = angles[k - 1] + 0.5f * gap;
        }
    return {gap, bisector};
}

void NeighbourSet::clear() {
    index.clear();
    position.clear();
    normal.clear();
    angle.clear();
    nearControl.clear();
    farControl.clear();
}

namespace {

constexpr std::size_t kLanes = 8; // the filter's pair loop runs over arrays padded to this

// Scratch arrays only grow: every call writes entries [0, count) before reading them, and a
// resize down then up again would refill the tail at almost every point.
float* scratchArray(std::vector<float>& v, std::size_t count) {
    if (v.size() < count) v.resize(count);
    return v.data();
}

// Grows the three arrays of v to at least `count` entries (they only grow, as scratchArray's).
void grow(FlatVec3& v, std::size_t count) {
    scratchArray(v.x, count);
    scratchArray(v.y, count);
    scratchArray(v.z, count);
}

// The set's positions and normals as flat arrays (scratch.position, scratch.normal), for the
// loops below, which the compiler runs in SIMD lanes.
void splitCoordinates(const NeighbourSet& set, NeighbourhoodScratch& scratch) {
    const std::size_t count = set.size();
    FlatVec3 &q = scratch.position, &m = scratch.normal;
    grow(q, count);
    grow(m, count);
    for (std::size_t k = 0; k < count; ++k) {
        q.x[k] = set.position[k].x, q.y[k] = set.position[k].y, q.z[k] = set.position[k].z;
        m.x[k] = set.normal[k].x, m.y[k] = set.normal[k].y, m.z[k] = set.normal[k].z;
    }
}

// The edge control point of edgeControlPointFromThird (pn_triangle.h) at (ax, ay, az), normal
// (nx, ny, nz), from the edge's third (tx, ty, tz), bit for bit: the same operations in the same
// order, its branch a select, so that loops of it run in SIMD lanes.
[[gnu::always_inline]] inline void controlFromThird(float ax, float ay, float az, float nx, float ny,
                                                    float nz, float tx, float ty, float tz,
                                                    float thirdLength2, float& x, float& y, float& z) {
    const float along = tx * nx + ty * ny + tz * nz;
    const float ux = tx - along * nx, uy = ty - along * ny, uz = tz - along * nz;
    const float tangentLength2 = ux * ux + uy * uy + uz * uz;
    const float scale = std::sqrt(thirdLength2 / tangentLength2);
    const bool straight = (tangentLength2 <= 1e-12f * thirdLength2) | (tangentLength2 == 0.0f);
    x = straight ? ax + tx : ax + ux * scale;
    y = straight ? ay + ty : ay + uy * scale;
    z = straight ? az + tz : az + uz * scale;
}

// The edge control points of the PN curves from (p, n) to the `count` points q with normals m
// (edgeControlPoints, pn_triangle.h, bit for bit): near p into near..., near q into far....
[[gnu::always_inline]] inline void controlPointsFrom(glm::vec3 p, glm::vec3 n, std::size_t count,
                                                     const float* __restrict qx, const float* __restrict qy,
                                                     const float* __restrict qz, const float* __restrict mx,
                                                     const float* __restrict my, const float* __restrict mz,
                                                     float* __restrict nearX, float* __restrict nearY,
                                                     float* __restrict nearZ, float* __restrict farX,
                                                     float* __restrict farY, float* __restrict farZ) {
    for (std::size_t k = 0; k < count; ++k) {
        const float tx = (qx[k] - p.x) * (1.0f / 3.0f), ty = (qy[k] - p.y) * (1.0f / 3.0f),
                    tz = (qz[k] - p.z) * (1.0f / 3.0f);
        const float thirdLength2 = tx * tx + ty * ty + tz * tz;
        controlFromThird(p.x, p.y, p.z, n.x, n.y, n.z, tx, ty, tz, thirdLength2, nearX[k], nearY[k],
                         nearZ[k]);
        controlFromThird(qx[k], qy[k], qz[k], mx[k], my[k], mz[k], -tx, -ty, -tz, thirdLength2, farX[k],
                         farY[k], farZ[k]);
    }
}

// For every entry (splitCoordinates first): the tangent-plane coordinates around the frame of n
// (scratch.su/sv), the angles around n (set.angle) and, with `controls`, the edge control points
// of the PN curve from p (scratch.nearControl, scratch.farControl).
PNSPLAT_AVX2_CLONE void measure(glm::vec3 p, glm::vec3 n, NeighbourSet& set, bool controls,
                                NeighbourhoodScratch& scratch) {
    const TangentFrame frame(n);
    const std::size_t count = set.size();
    set.angle.resize(count);
    float* su = scratchArray(scratch.su, count);
    float* sv = scratchArray(scratch.sv, count);
    const float *qx = scratch.position.x.data(), *qy = scratch.position.y.data(),
                *qz = scratch.position.z.data();
    for (std::size_t k = 0; k < count; ++k) {
        const float dx = qx[k] - p.x, dy = qy[k] - p.y, dz = qz[k] - p.z;
        su[k] = dx * frame.u.x + dy * frame.u.y + dz * frame.u.z;
        sv[k] = dx * frame.v.x + dy * frame.v.y + dz * frame.v.z;
    }
    fastAtan2s(sv, su, set.angle.data(), count);
    if (!controls) return;
    FlatVec3 &near = scratch.nearControl, &far = scratch.farControl;
    grow(near, count);
    grow(far, count);
    controlPointsFrom(p, n, count, qx, qy, qz, scratch.normal.x.data(), scratch.normal.y.data(),
                      scratch.normal.z.data(), near.x.data(), near.y.data(), near.z.data(), far.x.data(),
                      far.y.data(), far.z.data());
}

// Rewrites `set` as its entries order[0..count) (a gather through scratch.sorted), with the edge
// control points that measure() left in scratch when `controls`.
void gather(NeighbourSet& set, const std::vector<std::uint32_t>& order, bool controls,
            NeighbourhoodScratch& scratch) {
    NeighbourSet& out = scratch.sorted;
    const std::size_t count = order.size();
    out.index.resize(count);
    out.position.resize(count);
    out.normal.resize(count);
    out.angle.resize(count);
    out.nearControl.resize(controls ? count : 0);
    out.farControl.resize(controls ? count : 0);
    for (std::size_t k = 0; k < count; ++k) {
        const std::uint32_t from = order[k];
        out.index[k] = set.index[from];
        out.position[k] = set.position[from];
        out.normal[k] = set.normal[from];
        out.angle[k] = set.angle[from];
    }
    if (controls) {
        const FlatVec3 &near = scratch.nearControl, &far = scratch.farControl;
        assert(near.x.size() >= set.size() && far.x.size() >= set.size());
        for (std::size_t k = 0; k < count; ++k) {
            const std::uint32_t from = order[k];
            out.nearControl[k] = {near.x[from], near.y[from], near.z[from]};
            out.farControl[k] = {far.x[from], far.y[from], far.z[from]};
        }
    }
    std::swap(set, out);
}

// Sorts the entries listed in scratch.order by angle; ties by index, so the order never depends
// on the order in which the neighbours were found. Insertion sort: fans are short.
void sortOrderByAngle(const NeighbourSet& set, NeighbourhoodScratch& scratch) {
    std::vector<std::uint32_t>& order = scratch.order;
    const auto before = [&](std::uint32_t a, std::uint32_t b) {
        return set.angle[a] != set.angle[b] ? set.angle[a] < set.angle[b] : set.index[a] < set.index[b];
    };
    for (std::size_t k = 1; k < order.size(); ++k) {
        const std::uint32_t moving = order[k];
        std::size_t j = k;
        for (; j > 0 && before(moving, order[j - 1]); --j) order[j] = order[j - 1];
        order[j] = moving;
    }
}

// The filter's arrays, allocated to a multiple of kLanes entries: the positions the badness is
// measured on (px, py, pz), their unit directions from p (dx, dy, dz) and tangent-plane
// coordinates (su, sv). Past the set's size (padding lanes) su = sv = 0, which puts an entry in
// neither Succ_i nor Pred_i (below); the other arrays hold leftovers of earlier sets there (zeros
// when they grew), computed on and never counted.
struct FilterArrays {
    const float *px, *py, *pz, *dx, *dy, *dz, *su, *sv;
};

// n rounded up to whole SIMD lanes: the length of the filter's arrays.
std::size_t paddedToLanes(std::size_t n) {
    return (n + kLanes - 1) / kLanes * kLanes;
}
void zeroPadding(float* array, std::size_t count) {
    std::fill(array + count, array + paddedToLanes(count), 0.0f);
}

// Whether entry i survives: w_i = max_{j ∈ Succ_i} w_ij + max_{j ∈ Pred_i} w_ij <= 1, w_ij from
// fuzzyBadness. Succ_i: the j whose signed angle ∠(q_i, p, q_j) lies in (0, π), Pred_i: those in
// (-π, 0), by the sign of the tangent-plane cross product q_i × q_j. Choice: a j in exactly the
// same direction as i counts as a successor; with the paper's open intervals a point straight
// behind another (w_ij = 1.5) would be in neither set and survive.
// Branch-free, kLanes entries at a time into per-lane maxima, so that the loop runs in SIMD lanes:
// coincident points (j = i included) give a zero vector and w = 0, which changes no maximum. The
// entries are taken a block of kBlock at a time and the test ends as soon as it has failed: the
// maxima only grow, so the decision is that of the whole set. For sets larger than a block
// (sets of at most kBlock entries go to survivorsOfSmallSet, with the same terms).
constexpr std::size_t kBlock = 8 * kLanes;

// The pair (i, j): b = p_i - p_j, j's unit direction from p, and the tangent-plane products
// cross = q_i × q_j and ahead = q_i · q_j. Adds w_ij to i's running maxima over Succ_i and Pred_i.
// Always inlined: called out of line from the loops of both filters, they ran 19 % slower (pinned
// A/B on `pnsplat bench refine`'s sphere, faster variants).
[[gnu::always_inline]] inline void addPair(float bx, float by, float bz, float djx, float djy, float djz,
                                           float cross, float ahead, float sinThetaF, float inverseSin,
                                           float& worstSucc, float& worstPred) {
    const float length2 = bx * bx + by * by + bz * bz;
    const float length = std::sqrt(length2 > 1e-30f ? length2 : 1e-30f);
    const float sinIJ = (djx * bx + djy * by + djz * bz) / length; // p_i behind p_j
    float w = 0.5f * (sinIJ * inverseSin + 1.0f);
    w = sinIJ >= -sinThetaF ? w : 0.0f;
    w = length2 > 0.0f ? w : 0.0f;
    // One mask for Succ_i (a select chain of the same result compiled to three blends).
    const float succ = (cross > 0.0f) | ((cross == 0.0f) & (ahead > 0.0f)) ? w : 0.0f;
    const float pred = cross < 0.0f ? w : 0.0f;
    worstSucc = succ > worstSucc ? succ : worstSucc;
    worstPred = pred > worstPred ? pred : worstPred;
}

inline bool survives(const FilterArrays& a, std::size_t i, std::size_t count, float sinThetaF) {
    const float* __restrict px = a.px;
    const float* __restrict py = a.py;
    const float* __restrict pz = a.pz;
    const float* __restrict dx = a.dx;
    const float* __restrict dy = a.dy;
    const float* __restrict dz = a.dz;
    const float* __restrict su = a.su;
    const float* __restrict sv = a.sv;
    const float inverseSin = 1.0f / sinThetaF;
    const float pix = px[i], piy = py[i], piz = pz[i], sui = su[i], svi = sv[i];
    float worstSucc[kLanes] = {}, worstPred[kLanes] = {};
    for (std::size_t begin = 0; begin < count; begin += kBlock) {
        const std::size_t end = paddedToLanes(std::min(begin + kBlock, count));
        for (std::size_t lanes = begin; lanes < end; lanes += kLanes) {
            for (std::size_t l = 0; l < kLanes; ++l) {
                const std::size_t j = lanes + l;
                addPair(pix - px[j], piy - py[j], piz - pz[j], dx[j], dy[j], dz[j], sui * sv[j] - svi * su[j],
                        sui * su[j] + svi * sv[j], sinThetaF, inverseSin, worstSucc[l], worstPred[l]);
            }
        }
        float succ = 0.0f, pred = 0.0f;
        for (std::size_t l = 0; l < kLanes; ++l) {
            succ = std::max(succ, worstSucc[l]);
            pred = std::max(pred, worstPred[l]);
        }
        if (succ + pred > 1.0f) return false;
    }
    return true;
}

// The entries of [0, count) that survive, in increasing order, into `kept`; returns how many.
PNSPLAT_AVX2_CLONE std::size_t survivors(const FilterArrays& arrays, std::size_t count, float sinThetaF,
                                         std::uint32_t* kept) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < count; ++i) {
        kept[n] = static_cast<std::uint32_t>(i);
        n += survives(arrays, i, count, sinThetaF) ? 1 : 0;
    }
    return n;
}

// survivors() for sets of at most kBlock entries, the same decisions bit for bit: kLanes entries i
// at a time in the lanes and every j in turn, so that each lane ends with the maxima of its own
// entry (no reduction across lanes, no test per entry). The pair terms are survives(), addPair;
// lanes past the set are computed on and not kept.
PNSPLAT_AVX2_CLONE std::size_t survivorsOfSmallSet(const FilterArrays& a, std::size_t count, float sinThetaF,
                                                   std::uint32_t* kept) {
    const float inverseSin = 1.0f / sinThetaF;
    std::size_t n = 0;
    for (std::size_t lanes = 0; lanes < count; lanes += kLanes) {
        float worstSucc[kLanes] = {}, worstPred[kLanes] = {};
        for (std::size_t j = 0; j < count; ++j) {
            const float pjx = a.px[j], pjy = a.py[j], pjz = a.pz[j], djx = a.dx[j], djy = a.dy[j],
                        djz = a.dz[j];
            const float suj = a.su[j], svj = a.sv[j];
            for (std::size_t l = 0; l < kLanes; ++l) {
                const std::size_t i = lanes + l;
                addPair(a.px[i] - pjx, a.py[i] - pjy, a.pz[i] - pjz, djx, djy, djz,
                        a.su[i] * svj - a.sv[i] * suj, a.su[i] * suj + a.sv[i] * svj, sinThetaF, inverseSin,
                        worstSucc[l], worstPred[l]);
            }
        }
        for (std::size_t l = 0; l < kLanes && lanes + l < count; ++l) {
            kept[n] = static_cast<std::uint32_t>(lanes + l);
            n += worstSucc[l] + worstPred[l] > 1.0f ? 0 : 1;
        }
    }
    return n;
}

// Sets larger than a block: the filter's arrays copied in order of Euclidean distance from p
// (ties by index) into scratch.byDistanceArrays, the order into scratch.byDistance. A far entry
// is usually behind one of the nearest few, so survives() ends after a block or two: about O(k)
// instead of O(k²) pairs for wide neighbourhoods (radii much larger than the sampling, up to
// RefineOptions::maxNeighbours entries). Padding lanes as in the originals.
FilterArrays sortedByDistance(glm::vec3 p, const FilterArrays& arrays, const NeighbourSet& set,
                              NeighbourhoodScratch& scratch) {
    const std::size_t count = set.size();
    std::vector<std::uint32_t>& byDistance = scratch.byDistance;
    std::vector<float>& distance2 = scratch.distance2;
    byDistance.resize(count);
    distance2.resize(count);
    for (std::uint32_t k = 0; k < count; ++k) {
        byDistance[k] = k;
        const glm::vec3 d = set.position[k] - p;
        distance2[k] = glm::dot(d, d);
    }
    std::sort(byDistance.begin(), byDistance.end(), [&](std::uint32_t a, std::uint32_t b) {
        return distance2[a] != distance2[b] ? distance2[a] < distance2[b] : set.index[a] < set.index[b];
    });
    const std::size_t padded = paddedToLanes(count);
    std::vector<float>& sorted = scratch.byDistanceArrays;
    if (sorted.size() < 8 * padded) sorted.resize(8 * padded);
    const float* from[8] = {arrays.px, arrays.py, arrays.pz, arrays.dx,
                            arrays.dy, arrays.dz, arrays.su, arrays.sv};
    for (std::size_t a = 0; a < 8; ++a)
        for (std::size_t k = 0; k < count; ++k) sorted[a * padded + k] = from[a][byDistance[k]];
    float* base = sorted.data();
    zeroPadding(base + 6 * padded, count); // su
    zeroPadding(base + 7 * padded, count); // sv
    return FilterArrays{base,
                        base + padded,
                        base + 2 * padded,
                        base + 3 * padded,
                        base + 4 * padded,
                        base + 5 * padded,
                        base + 6 * padded,
                        base + 7 * padded};
}

// The positions the badness is measured on (px, py, pz) and their unit directions from p (dx, dy,
// dz), for every entry (measure() first). Projected (`Projection`), the geodesic projections
// q'_i = p + G(p,p_i) · normalize(q_i - p), q_i the orthogonal projection on the tangent plane,
// G = 2/3 |p p_i| + |b_{p,i} - b_{i,p}| (`Geodesic`, from measure()'s control points) or |p p_i|
// (`Euclidean`, variant 1); else the points themselves (`Points`). The loop runs in SIMD lanes and
// computes the bits of the glm expressions it replaced: dot products summed x, y, then z, lengths
// as their square roots, normalize as v · (1 / |v|).
enum class Projection { Points, Euclidean, Geodesic };
template <Projection kind>
[[gnu::always_inline]] inline void
projectForFilter(glm::vec3 p, glm::vec3 n, std::size_t count, const NeighbourhoodScratch& scratch,
                 float* __restrict px, float* __restrict py, float* __restrict pz, float* __restrict dx,
                 float* __restrict dy, float* __restrict dz) {
    const float* __restrict qx = scratch.position.x.data();
    const float* __restrict qy = scratch.position.y.data();
    const float* __restrict qz = scratch.position.z.data();
    const float* __restrict nearX = scratch.nearControl.x.data();
    const float* __restrict nearY = scratch.nearControl.y.data();
    const float* __restrict nearZ = scratch.nearControl.z.data();
    const float* __restrict farX = scratch.farControl.x.data();
    const float* __restrict farY = scratch.farControl.y.data();
    const float* __restrict farZ = scratch.farControl.z.data();
    for (std::size_t k = 0; k < count; ++k) {
        float yx = qx[k], yy = qy[k], yz = qz[k];
        if constexpr (kind != Projection::Points) {
            const float ex = qx[k] - p.x, ey = qy[k] - p.y, ez = qz[k] - p.z;
            const float along = ex * n.x + ey * n.y + ez * n.z;
            const float tx = ex - along * n.x, ty = ey - along * n.y, tz = ez - along * n.z;
            const float tangentLength = std::sqrt(tx * tx + ty * ty + tz * tz);
            const float length = std::sqrt(ex * ex + ey * ey + ez * ez);
            float g = length;
            if constexpr (kind == Projection::Geodesic) {
                const float cx = farX[k] - nearX[k], cy = farY[k] - nearY[k], cz = farZ[k] - nearZ[k];
                g = (2.0f / 3.0f) * length + std::sqrt(cx * cx + cy * cy + cz * cz);
            }
            const float scale = g / tangentLength;
            const bool projected = tangentLength > 0.0f;
            yx = projected ? p.x + tx * scale : yx;
            yy = projected ? p.y + ty * scale : yy;
            yz = projected ? p.z + tz * scale : yz;
        }
        const float vx = yx - p.x, vy = yy - p.y, vz = yz - p.z;
        const float inverse = 1.0f / std::sqrt(vx * vx + vy * vy + vz * vz);
        px[k] = yx, py[k] = yy, pz[k] = yz;
        dx[k] = vx * inverse, dy[k] = vy * inverse, dz[k] = vz * inverse;
    }
}
PNSPLAT_AVX2_CLONE void projectForFilter(glm::vec3 p, glm::vec3 n, const FuzzyParams& params,
                                         std::size_t count, const NeighbourhoodScratch& scratch, float* px,
                                         float* py, float* pz, float* dx, float* dy, float* dz) {
    if (!params.geodesicProjection)
        projectForFilter<Projection::Points>(p, n, count, scratch, px, py, pz, dx, dy, dz);
    else if (params.euclideanGeodesic)
        projectForFilter<Projection::Euclidean>(p, n, count, scratch, px, py, pz, dx, dy, dz);
    else
        projectForFilter<Projection::Geodesic>(p, n, count, scratch, px, py, pz, dx, dy, dz);
}

} // namespace

void sortFan(glm::vec3 p, glm::vec3 n, NeighbourSet& set, NeighbourhoodScratch& scratch) {
    splitCoordinates(set, scratch);
    measure(p, n, set, true, scratch);
    scratch.order.resize(set.size());
    for (std::uint32_t k = 0; k < set.size(); ++k) scratch.order[k] = k;
    sortOrderByAngle(set, scratch);
    gather(set, scratch.order, true, scratch);
}

void filterFuzzy(glm::vec3 p, glm::vec3 n, const FuzzyParams& params, NeighbourSet& set,
                 NeighbourhoodScratch& scratch) {
    const std::size_t count = set.size();
    const bool geodesic = params.geodesicProjection && !params.euclideanGeodesic;
    const bool controls = geodesic || params.edgeControls;
    splitCoordinates(set, scratch);
    measure(p, n, set, controls, scratch);
    // The positions the badness is measured on, and their unit directions from p, as flat arrays
    // (x, y, z apart) for the O(k²) loop (survivorsOfSmallSet, or survives for large sets).
    const std::size_t paddedCount = paddedToLanes(count);
    float* px = scratchArray(scratch.px, paddedCount);
    float* py = scratchArray(scratch.py, paddedCount);
    float* pz = scratchArray(scratch.pz, paddedCount);
    float* dx = scratchArray(scratch.dx, paddedCount);
    float* dy = scratchArray(scratch.dy, paddedCount);
    float* dz = scratchArray(scratch.dz, paddedCount);
    projectForFilter(p, n, params, count, scratch, px, py, pz, dx, dy, dz);

    float* su = scratchArray(scratch.su, paddedCount);
    float* sv = scratchArray(scratch.sv, paddedCount);
    zeroPadding(su, count);
    zeroPadding(sv, count);
    const bool byDistance = count > kBlock;
    const FilterArrays arrays{px, py, pz, dx, dy, dz, su, sv};
    const FilterArrays measured = byDistance ? sortedByDistance(p, arrays, set, scratch) : arrays;
    std::vector<std::uint32_t>& order = scratch.order;
    order.resize(count);
    const float sinThetaF = std::sin(params.thetaF);
    order.resize(byDistance ? survivors(measured, count, sinThetaF, order.data())
                            : survivorsOfSmallSet(measured, count, sinThetaF, order.data()));
    if (byDistance)
        for (std::uint32_t& k : order) k = scratch.byDistance[k];
    sortOrderByAngle(set, scratch);
    gather(set, scratch.order, controls, scratch);
}

} // namespace pnsplat
