// Boundary and crease segments: paper section 6, ALGORITHM.md §6 (see segments.h).
#include "segments.h"

#include <algorithm>
#include <array>

#include "pnsplat/refine/worker_pool.h"
#include "point_step.h"

namespace pnsplat {

void Segments::indexByFirstPoint(std::uint32_t count) {
    ofBegin.assign(count + 1, 0);
    for (const Segment& segment : list) ++ofBegin[segment.a + 1];
    for (std::uint32_t i = 0; i < count; ++i) ofBegin[i + 1] += ofBegin[i];
    of.resize(list.size());
    std::vector<std::uint32_t> fill(ofBegin.begin(), ofBegin.end() - 1);
    for (std::uint32_t k = 0; k < list.size(); ++k) of[fill[list[k].a]++] = k;
    child.assign(list.size(), 0);
    inserted.assign(list.size(), 0);
}

void Segments::split(std::span<const std::uint32_t> childBegin, std::span<const std::uint8_t> skipped) {
    std::vector<Segment> parts;
    parts.reserve(3 * list.size());
    for (std::uint32_t k = 0; k < list.size(); ++k) {
        const Segment segment = list[k];
        if (skipped[segment.a]) {
            parts.push_back(segment);
            continue;
        }
        std::uint32_t from = segment.a, next = childBegin[segment.a] + child[k];
        for (unsigned t = 0; t < 2; ++t) {
            if (!(inserted[k] & (1u << t))) continue;
            parts.push_back(Segment{from, next, segment.crease});
            from = next++;
        }
        parts.push_back(Segment{from, segment.b, segment.crease});
    }
    list = std::move(parts);
}

// The segments of section 6, from the neighbourhoods of P0. Boundary: potential boundary points are those
// whose fan leaves an opening wider than θb (after the wider second search); the two fan
// neighbours at the ends of the opening, when they are potential boundary points too, make
// boundary segments with the point. Crease: each crease point with its crease neighbours (within
// kCreaseReach times its radius, creaseNeighbours).
std::vector<Segment> findSegmentsOf(const PointStep& step, std::uint32_t count, WorkerPool& pool,
                                    std::span<WorkerScratch> scratch) {
    const LevelView& level = step.level();
    std::vector<std::uint8_t> potential(count, 0);
    std::vector<std::array<std::uint32_t, 2>> ends(count), creaseEnds(count, {UINT32_MAX, UINT32_MAX});
    const FuzzyParams fuzzy = step.fuzzyParams(false);
    pool.parallelFor(count, [&](std::size_t item, unsigned worker) {
        const auto p = static_cast<std::uint32_t>(item);
        WorkerScratch& s = scratch[worker];
        const glm::vec3 x = level.points.position[p], n = step.planeNormal(p);
        const TangentFrame frame(n);
        // A crease point gathers once for its wider look and its crease neighbours, whichever
        // reaches farther (each picks its own reach from the list).
        const bool crease = level.points.isCrease(p);
        step.gatherNearby(std::span(&p, 1), std::nullopt,
                          crease ? std::max(kRetryReach, kCreaseReach) : kRetryReach, s.nearby, s);
        bool open = true;
        for (const float reach : {level.levelRadius[p], kRetryReach * level.levelRadius[p]}) {
            const bool cut = step.gatherNeighbourhood(p, frame, reach, s.nearby, s);
            filterFuzzy(x, n, fuzzy, s.fan, s.neighbourhood);
            if (!step.fanIsOpen(s.fan)) {
                open = false;
                break;
            }
            if (cut) break; // a wider search would keep the same neighbours
        }
        if (crease) creaseEnds[p] = step.creaseNeighbours(p, s.nearby);
        const std::size_t m = s.fan.size();
        if (!level.options.boundaries || !open || m < 2)
            return; // closed, or isolated: no direction to follow
        std::size_t widest = 0;
        for (std::size_t a = 1; a < m; ++a)
            if (sweep(s.fan.angle[a], s.fan.angle[nextIndex(a, m)]) >
                sweep(s.fan.angle[widest], s.fan.angle[nextIndex(widest, m)]))
                widest = a;
        potential[p] = 1;
        ends[p] = {s.fan.index[widest], s.fan.index[nextIndex(widest, m)]};
    });
    std::vector<Segment> segments;
    for (std::uint32_t p = 0; p < count; ++p) {
        if (potential[p])
            for (const std::uint32_t q : ends[p])
                if (potential[q]) segments.push_back(Segment{std::min(p, q), std::max(p, q), false});
        for (const std::uint32_t q : creaseEnds[p])
            if (q != UINT32_MAX) segments.push_back(Segment{std::min(p, q), std::max(p, q), true});
    }
    // A pair found both ways, or as a boundary and a crease, is one segment (a crease if either).
    std::sort(segments.begin(), segments.end(), [](const Segment& u, const Segment& v) {
        return u.a != v.a ? u.a < v.a : u.b != v.b ? u.b < v.b : u.crease > v.crease;
    });
    segments.erase(std::unique(segments.begin(), segments.end(),
                               [](const Segment& u, const Segment& v) { return u.a == v.a && u.b == v.b; }),
                   segments.end());
    return segments;
}

} // namespace pnsplat
