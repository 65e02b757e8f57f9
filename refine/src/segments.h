// Boundary and crease segments (paper section 6, ALGORITHM.md §6): found from the neighbourhoods of
// P0 at the first level and kept explicitly. A segment is split by the refinement of its first
// point, `a`, at every odd level (the one-point step, point_step.h, inserts its thirds); this file
// finds them, indexes them by first point for a level, and replaces each by its three parts once
// the level's new points have their indices. Private to refine/src.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace pnsplat {

class PointStep;
class WorkerPool;
struct WorkerScratch;

struct Segment {
    std::uint32_t a, b;
    bool crease = false;
};

inline float segmentLength(const Segment& segment, std::span<const glm::vec3> position) {
    return glm::length(position[segment.b] - position[segment.a]);
}

struct Segments {
    std::vector<Segment> list;
    // The level's index (indexByFirstPoint): segment indices grouped by first point, and per point
    // of P(l) its range of them.
    std::vector<std::uint32_t> of, ofBegin;
    // Written by the refinement of each segment's first point: the offset of the segment's first new
    // point among a's children, and bit t set when its point at third t+1 was inserted.
    std::vector<std::uint32_t> child;
    std::vector<std::uint8_t> inserted;

    // Readies the level's index for `count` points.
    void indexByFirstPoint(std::uint32_t count);
    // Each segment becomes three, (a, q1), (q1, q2), (q2, b), without the points refineRegion left
    // out; one whose first point was skipped stays whole. `childBegin`: the index of each point's
    // first child in P(l+1).
    void split(std::span<const std::uint32_t> childBegin, std::span<const std::uint8_t> skipped);
};

// The segments of P0 (`count` points, the step's level), sorted by (a, b) with a < b, each once. The
// workers use one scratch each.
std::vector<Segment> findSegmentsOf(const PointStep& step, std::uint32_t count, WorkerPool& pool,
                                    std::span<WorkerScratch> scratch);

} // namespace pnsplat
