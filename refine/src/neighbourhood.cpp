// One-ring neighbourhoods: paper section 4 (eq. 7-9), ALGORITHM.md §3.
#include "pnsplat/refine/neighbourhood.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>

#include "pnsplat/refine/fast_math.h"
#include "pnsplat/refine/pn_triangle.h"
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

// Angles around n (and tangent-plane coordinates in scratch.su/sv) of every entry, and the edge
// control points when asked for.
void measure(glm::vec3 p, glm::vec3 n, NeighbourSet& set, bool withControls, NeighbourhoodScratch& scratch) {
    const TangentFrame frame(n);
    const std::size_t count = set.size();
    set.angle.resize(count);
    float* su = scratchArray(scratch.su, count);
    float* sv = scratchArray(scratch.sv, count);
    for (std::size_t k = 0; k < count; ++k) {
        const glm::vec3 d = set.position[k] - p;
        su[k] = glm::dot(d, frame.u);
        sv[k] = glm::dot(d, frame.v);
    }
    fastAtan2s(sv, su, set.angle.data(), count);
    set.nearControl.resize(withControls ? count : 0);
    set.farControl.resize(withControls ? count : 0);
    if (!withControls) return;
    for (std::size_t k = 0; k < count; ++k) {
        const EdgeControls e = edgeControlPoints(p, n, set.position[k], set.normal[k]);
        set.nearControl[k] = e.ab;
        set.farControl[k] = e.ba;
    }
}

// Rewrites `set` as its entries order[0..count) (a gather through scratch.sorted).
void gather(NeighbourSet& set, const std::vector<std::uint32_t>& order, NeighbourhoodScratch& scratch) {
    NeighbourSet& out = scratch.sorted;
    const std::size_t count = order.size();
    const bool controls = !set.nearControl.empty();
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
        for (std::size_t k = 0; k < count; ++k) {
            out.nearControl[k] = set.nearControl[order[k]];
            out.farControl[k] = set.farControl[order[k]];
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
    const float successor = cross > 0.0f ? w : 0.0f;
    const float sameDirection = ahead > 0.0f ? w : 0.0f;
    const float succ = cross == 0.0f ? sameDirection : successor;
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

} // namespace

void sortFan(glm::vec3 p, glm::vec3 n, NeighbourSet& set, NeighbourhoodScratch& scratch) {
    measure(p, n, set, true, scratch);
    scratch.order.resize(set.size());
    for (std::uint32_t k = 0; k < set.size(); ++k) scratch.order[k] = k;
    sortOrderByAngle(set, scratch);
    gather(set, scratch.order, scratch);
}

void filterFuzzy(glm::vec3 p, glm::vec3 n, const FuzzyParams& params, NeighbourSet& set,
                 NeighbourhoodScratch& scratch) {
    const std::size_t count = set.size();
    const bool geodesic = params.geodesicProjection && !params.euclideanGeodesic;
    measure(p, n, set, geodesic || params.edgeControls, scratch);
    // The positions the badness is measured on, and their unit directions from p, as flat arrays
    // (x, y, z apart) for the O(k²) loop (survivorsOfSmallSet, or survives for large sets).
    const std::size_t paddedCount = paddedToLanes(count);
    float* px = scratchArray(scratch.px, paddedCount);
    float* py = scratchArray(scratch.py, paddedCount);
    float* pz = scratchArray(scratch.pz, paddedCount);
    float* dx = scratchArray(scratch.dx, paddedCount);
    float* dy = scratchArray(scratch.dy, paddedCount);
    float* dz = scratchArray(scratch.dz, paddedCount);
    for (std::size_t k = 0; k < count; ++k) {
        const glm::vec3 d = set.position[k] - p;
        glm::vec3 y = set.position[k];
        if (params.geodesicProjection) {
            // q'_i = p + G(p,p_i) · normalize(q_i - p), q_i the orthogonal projection on the tangent
            // plane, G = 2/3 |p p_i| + |b_{p,i} - b_{i,p}| (or |p p_i| for variant 1).
            const glm::vec3 tangent = d - glm::dot(d, n) * n;
            const float tangentLength = glm::length(tangent);
            const float g =
                params.euclideanGeodesic
                    ? glm::length(d)
                    : controlPolygonLength(p, set.position[k], set.nearControl[k], set.farControl[k]);
            if (tangentLength > 0.0f) y = p + tangent * (g / tangentLength);
        }
        const glm::vec3 direction = glm::normalize(y - p);
        px[k] = y.x, py[k] = y.y, pz[k] = y.z;
        dx[k] = direction.x, dy[k] = direction.y, dz[k] = direction.z;
    }

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
    gather(set, scratch.order, scratch);
}

} // namespace pnsplat
