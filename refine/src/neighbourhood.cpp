// One-ring neighbourhoods: paper section 4 (eq. 7-9), SPEC.md section 3.
#include "pnsplat/refine/neighbourhood.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

#include "pnsplat/refine/fast_math.h"
#include "pnsplat/refine/pn_triangle.h"

namespace pnsplat {

TangentFrame::TangentFrame(glm::vec3 normal) : n(normal) {
    const float sign = std::copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z);
    const float b = n.x * n.y * a;
    u = glm::vec3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
    v = glm::vec3(b, sign + n.y * n.y * a, -n.y);
}


void NeighbourSet::clear() {
    index.clear();
    position.clear();
    normal.clear();
    angle.clear();
}

void NeighbourSet::push(std::uint32_t i, glm::vec3 p, glm::vec3 n) {
    index.push_back(i);
    position.push_back(p);
    normal.push_back(n);
}

void NeighbourSet::compact(const std::vector<std::uint8_t>& keep) {
    std::size_t out = 0;
    const bool withAngle = angle.size() == index.size();
    for (std::size_t k = 0; k < index.size(); ++k) {
        if (!keep[k]) continue;
        index[out] = index[k];
        position[out] = position[k];
        normal[out] = normal[k];
        if (withAngle) angle[out] = angle[k];
        ++out;
    }
    index.resize(out);
    position.resize(out);
    normal.resize(out);
    angle.resize(withAngle ? out : 0);
}

float fuzzyBadness(glm::vec3 p, glm::vec3 pi, glm::vec3 pj, float sinThetaF) {
    const glm::vec3 a = pj - p;
    const glm::vec3 b = pi - pj;
    const float denominator = std::sqrt(glm::dot(a, a) * glm::dot(b, b));
    if (!(denominator > 0.0f)) return 0.0f;
    const float sinAlpha = glm::dot(a, b) / denominator;
    if (sinAlpha < -sinThetaF) return 0.0f;
    return 0.5f * (sinAlpha / sinThetaF + 1.0f);
}

namespace {

// Sorts set by its angles (ties by index, so the order never depends on the input order).
void sortByAngle(NeighbourSet& set, NeighbourhoodScratch& scratch) {
    const std::size_t count = set.size();
    scratch.order.resize(count);
    for (std::uint32_t k = 0; k < count; ++k) scratch.order[k] = k;
    std::sort(scratch.order.begin(), scratch.order.end(), [&](std::uint32_t a, std::uint32_t b) {
        if (set.angle[a] != set.angle[b]) return set.angle[a] < set.angle[b];
        return set.index[a] < set.index[b];
    });
    NeighbourSet& sorted = scratch.sorted;
    sorted.clear();
    for (std::uint32_t k : scratch.order) {
        sorted.push(set.index[k], set.position[k], set.normal[k]);
        sorted.angle.push_back(set.angle[k]);
    }
    std::swap(set, sorted);
}

} // namespace

void sortFan(glm::vec3 p, glm::vec3 n, NeighbourSet& set, NeighbourhoodScratch& scratch) {
    const TangentFrame frame(n);
    set.angle.resize(set.size());
    for (std::size_t k = 0; k < set.size(); ++k) set.angle[k] = frame.angleOf(set.position[k] - p);
    sortByAngle(set, scratch);
}

void filterFuzzy(glm::vec3 p, glm::vec3 n, const FuzzyParams& params, NeighbourSet& set,
                 NeighbourhoodScratch& scratch) {
    const std::size_t count = set.size();
    const TangentFrame frame(n);
    set.angle.resize(count);
    scratch.projected.resize(count);
    scratch.direction.resize(count);
    for (std::size_t k = 0; k < count; ++k) {
        const glm::vec3 d = set.position[k] - p;
        set.angle[k] = frame.angleOf(d);
        glm::vec3 y = set.position[k];
        if (params.geodesicProjection) {
            // q'_i = p + G(p,p_i) · normalize(q_i - p), q_i the orthogonal projection on the tangent plane.
            const glm::vec3 tangent = d - glm::dot(d, n) * n;
            const float tangentLength = glm::length(tangent);
            const float g = params.euclideanGeodesic ? glm::length(d)
                                                     : geodesicDistance(p, n, set.position[k], set.normal[k]);
            y = tangentLength > 0.0f ? p + tangent * (g / tangentLength) : set.position[k];
        }
        scratch.projected[k] = y;
        scratch.direction[k] = glm::normalize(y - p);
    }

    // w_i = max_{j ∈ Succ_i} w_ij + max_{j ∈ Pred_i} w_ij, Succ_i the j whose signed angle
    // ∠(q_i, p, q_j) lies in (0, π), Pred_i those in (-π, 0).
    const float sinThetaF = std::sin(params.thetaF);
    constexpr float kPi = std::numbers::pi_v<float>;
    scratch.worstSucc.assign(count, 0.0f);
    scratch.worstPred.assign(count, 0.0f);
    for (std::size_t i = 0; i < count; ++i) {
        const glm::vec3 yi = scratch.projected[i];
        for (std::size_t j = 0; j < count; ++j) {
            if (j == i) continue;
            // Inline fuzzyBadness with the precomputed direction of p_j.
            const glm::vec3 b = yi - scratch.projected[j];
            const float bLength2 = glm::dot(b, b);
            if (!(bLength2 > 0.0f)) continue;
            const float sinAlpha = glm::dot(scratch.direction[j], b) / std::sqrt(bLength2);
            if (sinAlpha < -sinThetaF) continue;
            const float w = 0.5f * (sinAlpha / sinThetaF + 1.0f);
            float delta = set.angle[j] - set.angle[i];
            if (delta <= -kPi) delta += 2.0f * kPi;
            else if (delta > kPi) delta -= 2.0f * kPi;
            if (delta > 0.0f && delta < kPi) scratch.worstSucc[i] = std::max(scratch.worstSucc[i], w);
            else if (delta < 0.0f && delta > -kPi) scratch.worstPred[i] = std::max(scratch.worstPred[i], w);
        }
    }
    scratch.keep.resize(count);
    for (std::size_t i = 0; i < count; ++i) scratch.keep[i] = scratch.worstSucc[i] + scratch.worstPred[i] <= 1.0f;
    set.compact(scratch.keep);
    sortByAngle(set, scratch);
}

} // namespace pnsplat
