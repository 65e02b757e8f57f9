// The one-point step of a level: paper sections 4 to 6, ALGORITHM.md §4 and §6 (see point_step.h).
#include "point_step.h"

#include <algorithm>
#include <cmath>

#include "level_cells.h"
#include "pnsplat/refine/pn_triangle.h"

namespace pnsplat {

namespace {

constexpr float kPi = std::numbers::pi_v<float>;
constexpr std::size_t kPrefetchAhead =
    16; // grid entries between a point's prefetch and its read: 1.03x over 8 (pinned A/B)
// Choice: a candidate competes for a gap of N'_p only if it splits it into two parts of at least
// this angle. Every fan triangle is shared by the fans of its three corners, so its candidate is
// computed up to three times (with rounding noise); once inserted by one corner it is a member of
// the others' N'_p, and its twins, a few ulps away in angle, must not be inserted again.
constexpr float kMinSplitAngle = kThetaC / 8.0f;

using Clock = std::chrono::steady_clock;

inline double secondsSince(Clock::time_point& t) {
    const Clock::time_point now = Clock::now();
    const double s = std::chrono::duration<double>(now - t).count();
    t = now;
    return s;
}

// The PN triangle (p, fan[a], fan[b]) without the control points of the edge fan[a] fan[b]
// (b021, b012); those on the edges from p come with the fan when the filter computed them.
inline PnTriangle fanTriangleFromP(glm::vec3 p, glm::vec3 n, const NeighbourSet& fan, std::uint32_t a,
                                   std::uint32_t b) {
    PnTriangle t;
    t.b300 = p;
    t.b030 = fan.position[a];
    t.b003 = fan.position[b];
    if (!fan.nearControl.empty()) {
        t.b210 = fan.nearControl[a];
        t.b120 = fan.farControl[a];
        t.b102 = fan.farControl[b];
        t.b201 = fan.nearControl[b];
        return t;
    }
    const EdgeControls ea = edgeControlPoints(p, n, fan.position[a], fan.normal[a]);
    const EdgeControls eb = edgeControlPoints(p, n, fan.position[b], fan.normal[b]);
    t.b210 = ea.ab;
    t.b120 = ea.ba;
    t.b102 = eb.ba;
    t.b201 = eb.ab;
    return t;
}

// The whole PN triangle (p, fan[a], fan[b]).
inline PnTriangle fanTriangle(glm::vec3 p, glm::vec3 n, const NeighbourSet& fan, std::uint32_t a,
                              std::uint32_t b) {
    PnTriangle t = fanTriangleFromP(p, n, fan, a, b);
    const EdgeControls e = edgeControlPoints(fan.position[a], fan.normal[a], fan.position[b], fan.normal[b]);
    t.b021 = e.ab;
    t.b012 = e.ba;
    return t;
}

// Crease points (section 6) carry two normals (`crease` is zero for an ordinary point). Seen from a
// surface of normal `towards`, a crease point shows the normal of its own side of the crease: the
// one closer to `towards`.
inline glm::vec3 facing(glm::vec3 normal, glm::vec3 crease, glm::vec3 towards) {
    if (crease == glm::vec3(0.0f)) return normal;
    return glm::dot(crease, towards) > glm::dot(normal, towards) ? crease : normal;
}

// Choice: two crease points lie on the same crease when their normals pair up within 45° (the
// paper defers to its dyadic predecessor, which compares normals too).
constexpr float kCreaseMatch = 0.70710678f; // cos 45°
// Choice: a crease segment's chord lies within 30° of the crease directions of both of its points
// (creaseNeighbours).
constexpr float kCreaseChord = 0.86602540f; // cos 30°
inline bool sameCrease(glm::vec3 n1, glm::vec3 n2, glm::vec3 m1, glm::vec3 m2) {
    return (glm::dot(n1, m1) > kCreaseMatch && glm::dot(n2, m2) > kCreaseMatch) ||
           (glm::dot(n1, m2) > kCreaseMatch && glm::dot(n2, m1) > kCreaseMatch);
}

// The crease direction n1 × n2 of a crease point, of unit length; zero where its two normals are
// less than 1° apart and the direction is undefined (validateForRefinement takes no pair more than
// 170° apart, so nearly opposite normals do not arise). Choice: such a point looks for no crease
// neighbours of its own (creaseNeighbours), and a segment that ends at it leaves it along the
// chord (splitSegments; fuzz_refine: a crease point whose second normal equalled its first gave
// NaN points).
inline glm::vec3 creaseDirection(glm::vec3 n1, glm::vec3 n2) {
    const glm::vec3 d = glm::cross(n1, n2);
    const float length2 = glm::dot(d, d);
    return length2 > kSin2Of1Degree ? d * (1.0f / std::sqrt(length2)) : glm::vec3(0.0f);
}

inline glm::u8vec3 meanColour(glm::u8vec3 a, glm::u8vec3 b, glm::u8vec3 c) {
    const glm::uvec3 sum = glm::uvec3(a) + glm::uvec3(b) + glm::uvec3(c);
    return glm::u8vec3((sum + glm::uvec3(1)) / 3u);
}

} // namespace

FuzzyParams PointStep::fuzzyParams(bool edgeControls) const {
    FuzzyParams fuzzy;
    fuzzy.thetaF = level_.options.thetaF;
    fuzzy.geodesicProjection = level_.options.neighbourhood == NeighbourhoodKind::Accurate;
    fuzzy.euclideanGeodesic = level_.options.euclideanGeodesic;
    fuzzy.edgeControls = edgeControls;
    return fuzzy;
}

// Whether q is the position of the point x being refined or of a point near it: of P(l) within
// its reach (the last collectNeighbourhood), or of N'_p or Y_p.
bool PointStep::coincidesWithNearby(glm::vec3 q, glm::vec3 x, const WorkerScratch& s) {
    if (q == x) return true;
    for (std::size_t j = 0; j < s.reachable; ++j)
        if (s.reachableFrom[s.inReach[j]].position == q) return true;
    const auto at = [&](const RingMember& m) { return m.position == q; };
    return std::any_of(s.ring.begin(), s.ring.end(), at) || std::any_of(s.outer.begin(), s.outer.end(), at);
}

// Whether q is the position of a child of `corner`, a corner of the fan triangle that made q:
// the same triangle in the corner's own fan makes the same PN centre, and the corner's children
// are not always among Y_p (p within the corner's fan reach, the corner not within p's).
// A corner within reach was refined before p or is refined after it, never at the same time
// (ALGORITHM.md §5.2), so its children are read whole.
bool PointStep::madeByCorner(glm::vec3 q, std::uint32_t corner) const {
    if (!out_.refined[corner]) return false;
    const ChildRange range = out_.childRange[corner];
    const NewPoint* children = out_.cellBase[range.cell] + range.begin;
    return std::any_of(children, children + range.count, [&](const NewPoint& c) { return c.position == q; });
}

// The points of P(l) that the refinement of a group of points (one cell, or one large point) may
// need: every point within reachFactor·r_max of the group's box, found once, into `nearby`. Each
// point of the group then picks its Euclidean neighbourhood from this short list, which costs far
// less than one search per point. reachFactor is 1 for the first search, kRetryReach for a
// point searched again wider (rare: a group of its own then), and kCreaseReach for a crease
// point's crease neighbours (findSegmentsOf, without a cell). The points of one colour cell (key
// `cell`) have r <= r_lim, so the box grown by kRetryReach·r_max < s stays within the 3×3×3 cells
// around theirs, read from the grid; a single large point is found through the bounding-sphere
// hierarchy (section 7). Both give the same set; its order does not matter (the neighbourhoods
// are sorted, and Y_p breaks ties in distance by storage position).
void PointStep::gatherNearby(std::span<const std::uint32_t> group, std::optional<std::uint64_t> cell,
                             float reachFactor, std::vector<NearbyPoint>& nearby, WorkerScratch& s) const {
    const PointSet& points = level_.points;
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(std::numeric_limits<float>::lowest());
    float largest = 0.0f;
    for (const std::uint32_t p : group) {
        lo = glm::min(lo, points.position[p]);
        hi = glm::max(hi, points.position[p]);
        largest = std::max(largest, level_.levelRadius[p]);
    }
    const float margin = reachFactor * largest;
    Clock::time_point t0;
    if (level_.options.profile) t0 = Clock::now();
    nearby.clear();
    if (!cell) {
        // The hierarchy rounds its bounds up relative to themselves, not to the margin: a sphere of
        // a small bound at the margin's distance could round out of reach. Asked a hair wider, it
        // visits every point within the margin; the exact test below keeps those.
        constexpr float kQueryRoundUp = 1.0f + 1.0f / (1u << 18);
        level_.hierarchy.queryBox(lo, hi, margin * kQueryRoundUp, s.stack, [&](std::uint32_t i, float d2) {
            if (d2 <= margin * margin) nearby.push_back(NearbyPoint{points.position[i], i, points.normal[i]});
        });
    } else {
        const std::uint64_t cx = *cell >> 42, cy = (*cell >> 21) & kCellCoordinateMask;
        const std::uint64_t cz = *cell & kCellCoordinateMask;
        const std::uint64_t z0 = cz > 0 ? cz - 1 : 0, z1 = std::min(cz + 1, kCellCoordinateMask);
        // Each column's start only moves forward from one cell to the next of larger key (with the
        // same offsets, a larger key gives larger column keys): search forward from the last one,
        // in steps that double, then by halves.
        if (s.columnsOf == kNoCell || *cell < s.columnsOf) s.columnStart.fill(0);
        s.columnsOf = *cell;
        const auto seek = [&](std::size_t from, std::uint64_t key) {
            std::size_t below = from, above = from; // gridKey[k] < key for every k < below
            for (std::size_t step = 1; above < level_.gridKey.size() && level_.gridKey[above] < key;
                 step *= 2) {
                below = above + 1;
                above += step;
            }
            const auto end =
                level_.gridKey.begin() + static_cast<std::ptrdiff_t>(std::min(above, level_.gridKey.size()));
            return static_cast<std::size_t>(
                std::lower_bound(level_.gridKey.begin() + static_cast<std::ptrdiff_t>(below), end, key) -
                level_.gridKey.begin());
        };
        for (std::uint64_t x = cx > 0 ? cx - 1 : 0; x <= std::min(cx + 1, kCellCoordinateMask); ++x) {
            for (std::uint64_t y = cy > 0 ? cy - 1 : 0; y <= std::min(cy + 1, kCellCoordinateMask); ++y) {
                // The cells (x, y, z0..z1) are consecutive in key order.
                const std::uint64_t last = packCell(x, y, z1);
                std::size_t& start = s.columnStart[3 * (x + 1 - cx) + (y + 1 - cy)];
                start = seek(start, packCell(x, y, z0));
                for (std::size_t k = start; k < level_.gridKey.size() && level_.gridKey[k] <= last; ++k) {
                    // The distance to the box as the hierarchy measures it.
                    const std::uint32_t i = level_.gridPoint[k];
                    if (k + kPrefetchAhead < level_.gridPoint.size()) {
                        __builtin_prefetch(&points.position[level_.gridPoint[k + kPrefetchAhead]]);
                        __builtin_prefetch(&points.normal[level_.gridPoint[k + kPrefetchAhead]]);
                    }
                    const glm::vec3 d = points.position[i] - glm::clamp(points.position[i], lo, hi);
                    if (glm::dot(d, d) <= margin * margin)
                        nearby.push_back(NearbyPoint{points.position[i], i, points.normal[i]});
                }
            }
        }
    }
    // Every point of the group reads the children of the refined points among these (and then
    // again from cache): start their loads, the child ranges first.
    for (const NearbyPoint& c : nearby) __builtin_prefetch(&out_.childRange[c.index]);
    for (const NearbyPoint& c : nearby) {
        if (!out_.refined[c.index]) continue;
        const ChildRange range = out_.childRange[c.index];
        const auto* children = reinterpret_cast<const char*>(out_.cellBase[range.cell] + range.begin);
        for (std::size_t line = 0; line < range.count * sizeof(NewPoint); line += 64)
            __builtin_prefetch(children + line);
    }
    if (level_.options.profile) s.times.neighbourhood += secondsSince(t0);
}

// Nε_p, N'_p and Y_p of p within `reach`. When more than options.maxNeighbours points pass, only
// the maxNeighbours nearest points within reach (ties by index) are kept and then checked against
// the validity cone, so N'_p and Y_p hold the children of those only. Returns whether it cut: a
// wider reach would keep the same points.
bool PointStep::gatherNeighbourhood(std::uint32_t p, const TangentFrame& frame, float reach,
                                    std::span<const NearbyPoint> candidates, WorkerScratch& s) const {
    collectNeighbourhood(p, frame, reach, candidates, s);
    const std::size_t cap = level_.options.maxNeighbours;
    if (s.fan.size() <= cap) return false;
    const glm::vec3 x = level_.points.position[p];
    const auto distance2 = [&](const NearbyPoint& c) { return glm::dot(c.position - x, c.position - x); };
    s.nearest.clear();
    for (const NearbyPoint& c : candidates)
        if (c.index != p && distance2(c) < reach * reach) s.nearest.push_back(c);
    if (s.nearest.size() <= cap) return false; // the same points (rounding aside)
    ++s.capped;
    const auto middle = s.nearest.begin() + static_cast<std::ptrdiff_t>(cap);
    std::nth_element(s.nearest.begin(), middle, s.nearest.end(),
                     [&](const NearbyPoint& a, const NearbyPoint& b) {
                         const float da = distance2(a), db = distance2(b);
                         return da != db ? da < db : a.index < b.index;
                     });
    s.nearest.erase(middle, s.nearest.end());
    collectNeighbourhood(p, frame, reach, s.nearest, s);
    return true;
}

// Nε_p, N'_p and Y_p of p among `candidates`; `frame` is the tangent frame of planeNormal(p).
// Crease points show the normal of p's side (facing); a crease point p pairs each neighbour with
// the closer of its own two normals for the validity cone.
void PointStep::collectNeighbourhood(std::uint32_t p, const TangentFrame& frame, float reach,
                                     std::span<const NearbyPoint> candidates, WorkerScratch& s) const {
    const PointSet& points = level_.points;
    const glm::vec3 x = points.position[p];
    const glm::vec3 n = frame.n;
    const bool creases = points.hasCrease();
    const bool creaseP = points.isCrease(p);
    const float r = level_.levelRadius[p];
    const float reach2 = reach * reach;
    const float r2 = r * r, inner2 = kLambda1 * kLambda1 * r2;
    s.scanned += candidates.size();
    s.fan.clear();
    s.ring.clear();
    s.outer.clear();
    // Nε_p (eq. 7): points of P(l) closer than r that pass the validity cone (eq. 6). Most
    // candidates are out of reach: they are sorted out first, without branches.
    s.inReach.resize(candidates.size());
    std::size_t inReach = 0;
    for (std::size_t k = 0; k < candidates.size(); ++k) {
        const glm::vec3 d = candidates[k].position - x;
        s.inReach[inReach] = static_cast<std::uint32_t>(k);
        inReach += static_cast<std::size_t>(glm::dot(d, d) < reach2) &
                   static_cast<std::size_t>(candidates[k].index != p);
    }
    s.reachableFrom = candidates;
    s.reachable = inReach;
    for (std::size_t j = 0; j < inReach; ++j) {
        const NearbyPoint& candidate = candidates[s.inReach[j]];
        const std::uint32_t i = candidate.index;
        glm::vec3 ni = candidate.normal, np = n;
        if (creases) {
            ni = facing(candidate.normal, points.crease[i], n);
            if (creaseP) {
                const glm::vec3 n1 = points.normal[p], n2 = points.crease[p];
                const glm::vec3 m1 = facing(candidate.normal, points.crease[i], n1);
                const glm::vec3 m2 = facing(candidate.normal, points.crease[i], n2);
                const bool first = glm::dot(n1, m1) >= glm::dot(n2, m2);
                np = first ? n1 : n2;
                ni = first ? m1 : m2;
            }
        }
        if (!validNeighbours(x, np, candidate.position, ni)) continue;
        s.fan.push(i, candidate.position, ni);
        // The points already inserted near p are the children of its neighbours (section 7). Only
        // points within p's reach are read here, and none of them is refined concurrently.
        if (!out_.refined[i]) continue;
        const ChildRange range = out_.childRange[i];
        const NewPoint* children = out_.cellBase[range.cell] + range.begin;
        for (std::uint32_t k = 0; k < range.count; ++k) {
            const glm::vec3 d = children[k].position - x;
            const float distance2 = glm::dot(d, d);
            // N'_p (section 5) within λ1·r, Y_p (eq. 10) beyond; neither at exactly λ1·r. The member
            // is written where it is stored (a copy from the stack stalled on store forwarding).
            if (!(distance2 < r2) || distance2 == inner2) continue;
            const bool inner = distance2 < inner2;
            RingMember& m = inner ? s.ring.emplace_back() : s.outer.emplace_back();
            m.cell = range.cell;
            m.local = range.begin + k;
            m.position = children[k].position;
            m.normal = facing(children[k].normal, children[k].crease, n);
            m.angle = inner ? frame.angleOf(d) : 0.0f; // Y_p's is needed only if it joins N'_p
            m.discardRadius = inner ? 0.0f : kLambda2 * children[k].radius;
        }
    }
}

// The plane a point is refined in: its normal, or for a crease point the bisector of its two.
glm::vec3 PointStep::planeNormal(std::uint32_t p) const {
    const PointSet& points = level_.points;
    return points.isCrease(p) ? glm::normalize(points.normal[p] + points.crease[p]) : points.normal[p];
}

// Creases (section 6): the corner normals of the fan triangle (p, fan[a], fan[b]), or false for
// a triangle across a crease, which would cut the edge off (the crease itself is filled by its
// segments). Choices: for a crease point p, a neighbour is on the side of the normal of p that
// it faces, or on the crease when it is a crease point of the same crease; a triangle takes the
// side of its corners, must not have two, and needs a corner off the crease. For an ordinary p,
// a triangle with a crease corner must have its other ordinary corner on p's side of it.
bool PointStep::creaseTriangleNormals(std::uint32_t p, const NeighbourSet& fan, std::uint32_t a,
                                      std::uint32_t b, glm::vec3 (&normals)[3]) const {
    const PointSet& points = level_.points;
    const std::uint32_t corner[2] = {fan.index[a], fan.index[b]};
    if (points.isCrease(p)) {
        const glm::vec3 n1 = points.normal[p], n2 = points.crease[p];
        int sides[2];
        for (int k = 0; k < 2; ++k) {
            const std::uint32_t i = corner[k];
            if (points.isCrease(i) && sameCrease(n1, n2, points.normal[i], points.crease[i]))
                sides[k] = -1;
            else
                sides[k] = glm::dot(n1, normals[1 + k]) >= glm::dot(n2, normals[1 + k]) ? 0 : 1;
        }
        if (sides[0] < 0 && sides[1] < 0) return false;
        if (sides[0] >= 0 && sides[1] >= 0 && sides[0] != sides[1]) return false;
        normals[0] = std::max(sides[0], sides[1]) == 0 ? n1 : n2;
        for (int k = 0; k < 2; ++k)
            normals[1 + k] = facing(points.normal[corner[k]], points.crease[corner[k]], normals[0]);
        return true;
    }
    for (int k = 0; k < 2; ++k) {
        const std::uint32_t c = corner[k], other = corner[1 - k];
        if (!points.isCrease(c) || points.isCrease(other)) continue;
        const glm::vec3 mine = normals[1 + k];
        const glm::vec3 theirs = mine == points.normal[c] ? points.crease[c] : points.normal[c];
        if (glm::dot(normals[2 - k], theirs) > glm::dot(normals[2 - k], mine)) return false;
    }
    return true;
}

void PointStep::makeCandidates(std::uint32_t p, const TangentFrame& frame, WorkerScratch& s) const {
    const PointSet& points = level_.points;
    const glm::vec3 x = points.position[p];
    const glm::vec3 n = points.normal[p];
    const bool creaseP = points.isCrease(p);
    const NeighbourSet& fan = s.fan;
    const std::size_t m = fan.size();
    s.candidates.clear();
    if (m < 2) return;
    for (std::uint32_t a = 0; a < m; ++a) {
        const auto b = static_cast<std::uint32_t>(nextIndex(a, m));
        // Boundary gap (section 6): no triangle across an opening wider than θb.
        if (sweep(fan.angle[a], fan.angle[b]) > level_.options.thetaB) continue;
        Candidate c;
        glm::vec3 normals[3];
        if (!triangleNormals(p, fan, a, b, normals)) continue;
        const glm::vec3 cog = centreOfGravity(x, fan.position[a], fan.position[b]);
        // L_p (eq. 12): cog + φ on the PN triangle (p, p_a, p_b); the plain centroid for the
        // baseline and for variant 4, which smooths only what it inserts. The fan's edge control
        // points were made with n_p: a crease point makes its triangles with its side's normal.
        if (!level_.options.smoothing || level_.options.centroidCandidates) {
            c.position = cog;
        } else {
            const PnTriangle t = creaseP ? makePnTriangle(x, normals[0], fan.position[a], normals[1],
                                                          fan.position[b], normals[2])
                                         : fanTriangle(x, n, fan, a, b);
            c.position = cog + smoothingDisplacement(t);
            c.b021 = t.b021;
            c.b012 = t.b012;
        }
        c.angle = frame.angleOf(c.position - x);
        c.a = a;
        c.b = b;
        s.candidates.push_back(c);
    }
}

// Whether consecutive fan neighbours leave an opening wider than θb around p (section 6).
bool PointStep::fanIsOpen(const NeighbourSet& fan) const {
    const std::size_t m = fan.size();
    if (m < 2) return true;
    for (std::size_t a = 0; a < m; ++a)
        if (sweep(fan.angle[a], fan.angle[nextIndex(a, m)]) > level_.options.thetaB) return true;
    return false;
}

// The point inserted for candidate c of p: its normal from the exact tangents of the PN triangle
// (section 3), its colour the mean of the corners' (section 8, figure 12).
NewPoint PointStep::newPointFrom(std::uint32_t p, const NeighbourSet& fan, const Candidate& c) const {
    const PointSet& points = level_.points;
    const glm::vec3 x = points.position[p];
    glm::vec3 n = points.normal[p], na = fan.normal[c.a], nb = fan.normal[c.b];
    const bool creaseP = points.isCrease(p);
    if (creaseP) {
        glm::vec3 normals[3];
        triangleNormals(p, fan, c.a, c.b, normals);
        n = normals[0], na = normals[1], nb = normals[2];
    }
    NewPoint np{c.position, glm::vec3(0.0f), 0.0f, glm::u8vec3(0)};
    if (!level_.options.smoothing) {
        np.normal = meanNormal(n, na, nb);
    } else {
        PnTriangle t;
        if (creaseP) {
            t = makePnTriangle(x, n, fan.position[c.a], na, fan.position[c.b], nb);
            if (level_.options.centroidCandidates) np.position = c.position + smoothingDisplacement(t);
        } else if (level_.options.centroidCandidates) {
            t = fanTriangle(x, n, fan, c.a, c.b);
            np.position = c.position + smoothingDisplacement(t);
        } else {
            t = fanTriangleFromP(x, n, fan, c.a, c.b);
            t.b021 = c.b021;
            t.b012 = c.b012;
        }
        np.normal = level_.meanNormals ? meanNormal(n, na, nb) : centreNormal(t, n, na, nb);
    }
    if (points.hasColour())
        np.colour =
            meanColour(points.colour[p], points.colour[fan.index[c.a]], points.colour[fan.index[c.b]]);
    return np;
}

// The "curved angle" between consecutive members of N'_p (eq. 5), or their plain angle
// (variant 2). A gap wider than π cannot be measured by unsigned angles: its counter-clockwise
// sweep is used, which is always above θc. Gaps are only compared with θc and ranked above it,
// so an angle surely below θc is not measured (curvedAngleUnlessSmall, angleAtUnlessSmall).
// Always inlined: refinePoint's x86-64-v3 clone calls it out of line otherwise.
inline float PointStep::gapValue(glm::vec3 x, const RingMember& a, const RingMember& b,
                                 std::size_t ringSize) const {
    const float s = ringSize == 1 ? kTwoPi : sweep(a.angle, b.angle);
    if (s > kPi) return s;
    if (level_.options.plainAngle) return angleAtUnlessSmall(x, a.position, b.position);
    return curvedAngleUnlessSmall(x, a.position, a.normal, b.position, b.normal);
}

void PointStep::insertIntoRing(std::vector<RingMember>& ring, const RingMember& m) const {
    auto at = std::upper_bound(ring.begin(), ring.end(), m,
                               [](const RingMember& u, const RingMember& v) { return u.angle < v.angle; });
    at = ring.insert(at, m);
    // The gaps before and after the new member change.
    const std::size_t k = static_cast<std::size_t>(at - ring.begin());
    ring[k].gapStale = true;
    ring[previousIndex(k, ring.size())].gapStale = true;
}

// Segments (section 6): a segment (a, b) receives two new points, at the thirds of the cubic
// Bézier curve a, c1, c2, b, at every odd step; never one at the middle. They are children of a;
// the one next to a joins N'_a. Boundary: c1, c2 are the edge control points of ALGORITHM.md §2.2 (tangents
// in the tangent planes); normal and colour interpolated along the curve (choice: the paper gives
// none for boundary points). Crease: the curve leaves each end along its crease direction n1 × n2,
// with the same |ab|/3 legs, and the new points are crease points whose two normals interpolate
// the ends' paired normals.
void PointStep::splitSegments(std::uint32_t p, std::uint32_t cell, std::uint32_t firstChild,
                              WorkerScratch& s) const {
    const PointSet& points = level_.points;
    const glm::vec3 x = points.position[p];
    const glm::vec3 n = points.normal[p], nc = creaseOf(p);
    const TangentFrame frame(planeNormal(p));
    for (std::uint32_t k = out_.segments->ofBegin[p]; k < out_.segments->ofBegin[p + 1]; ++k) {
        const std::uint32_t segment = out_.segments->of[k];
        const std::uint32_t b = out_.segments->list[segment].b;
        const glm::vec3 pb = points.position[b];
        glm::vec3 nb = points.normal[b], nbc = creaseOf(b);
        glm::vec3 c1, c2;
        if (out_.segments->list[segment].crease) {
            const glm::vec3 chord = pb - x;
            const float leg = glm::length(chord) / 3.0f;
            const float chord2 = glm::dot(chord, chord);
            const glm::vec3 along = chord2 >= std::numeric_limits<float>::min()
                                        ? chord * (1.0f / std::sqrt(chord2))
                                        : glm::vec3(0.0f);
            const auto directionAt = [&](glm::vec3 first, glm::vec3 second) {
                const glm::vec3 d = creaseDirection(first, second);
                return d == glm::vec3(0.0f) ? along : d;
            };
            glm::vec3 ta = directionAt(n, nc), tb = directionAt(nb, nbc);
            if (glm::dot(ta, chord) < 0.0f) ta = -ta;
            if (glm::dot(tb, chord) < 0.0f) tb = -tb;
            c1 = x + leg * ta;
            c2 = pb - leg * tb;
            if (glm::dot(n, nb) + glm::dot(nc, nbc) < glm::dot(n, nbc) + glm::dot(nc, nb)) std::swap(nb, nbc);
        } else {
            const EdgeControls e = edgeControlPoints(x, n, pb, nb);
            c1 = e.ab;
            c2 = e.ba;
        }
        out_.segments->child[segment] = out_.cellCount[cell] - firstChild;
        out_.segments->inserted[segment] = 0;
        glm::vec3 curve[2];
        for (int third = 1; third <= 2; ++third) {
            const float t = static_cast<float>(third) / 3.0f, u = 1.0f - t;
            curve[third - 1] = u * u * u * x + 3.0f * u * u * t * c1 + 3.0f * u * t * t * c2 + t * t * t * pb;
        }
        for (int third = 1; third <= 2; ++third) {
            const float t = static_cast<float>(third) / 3.0f;
            const glm::vec3 q = curve[third - 1];
            if (outsideRegion(q)) { // refineRegion: choice, as for candidates (refiner.h)
                ++s.outsideRegion;
                continue;
            }
            out_.segments->inserted[segment] |= static_cast<std::uint8_t>(1u << (third - 1));
            const glm::vec3 before = third == 1 ? x : curve[0], after = third == 1 ? curve[1] : pb;
            NewPoint np{q, glm::normalize((1.0f - t) * n + t * nb),
                        kRadiusMargin * std::max(glm::length(q - before), glm::length(q - after)),
                        glm::u8vec3(0)};
            if (out_.segments->list[segment].crease) np.crease = glm::normalize((1.0f - t) * nc + t * nbc);
            if (points.hasColour())
                np.colour = glm::u8vec3(
                    glm::round(glm::mix(glm::vec3(points.colour[p]), glm::vec3(points.colour[b]), t)));
            const std::uint32_t local = store(cell, np, PointSource{{p, b, b}, t}, s);
            ++s.inserted;
            ++s.boundaryInserted;
            // The first point joins N'_p (it fills the gap along the segment), unless it lies
            // farther than c_β,max · r_p: choice, as for Y_p's substitutes, so that r' stays within
            // the convergence bound of ALGORITHM.md §4.7 (a segment may be up to kCreaseReach · r long).
            if (third == 1 && withinConvergenceBound(p, q))
                insertIntoRing(s.ring, RingMember{cell, local, q, facing(np.normal, np.crease, frame.n),
                                                  frame.angleOf(q - x)});
        }
    }
}

// Crease neighbours of a crease point p (section 6): among the crease points of the same crease
// closer than kCreaseReach·r_p (`nearby` holds those), the nearest on each side along the crease
// direction n1 × n2. UINT32_MAX where there is none. Choices (ALGORITHM.md §6.4):
// - the chord to it lies within 30° of p's crease direction and of its own (kCreaseChord), so that
//   a point of a parallel crease, or of another crease across a corner, is not taken: within 45°
//   of p's alone, 8 of the fandisk's 142 segments ran across a face; now every chord lies within a
//   third of a spacing of an edge of its mesh, and points that follow a circle of 6 or more join;
// - not only those that pass the fuzzy filter into p's fan: an edge is sampled as sparsely as the
//   faces beside it, and the filtered first ring of a crease point often holds no crease point
//   ahead (on the fandisk the fans gave 61 segments; r, 1.5 r and 2 r gave 92, 123 and 142, and
//   2.2 r with the 30° rule 137). A crease line without a segment is left unfilled. A segment
//   longer than r_p needs splitSegments' guard on N'_p for the convergence bound (§4.7);
// - none for a point whose two normals are less than 1° apart (creaseDirection; before, such
//   points within 1° of parallel found neighbours along a direction made of rounding, and exactly
//   parallel ones none); as the far end, such a point is held to p's direction only.
std::array<std::uint32_t, 2> PointStep::creaseNeighbours(std::uint32_t p,
                                                         std::span<const NearbyPoint> nearby) const {
    const PointSet& points = level_.points;
    const glm::vec3 x = points.position[p], n1 = points.normal[p], n2 = points.crease[p];
    const glm::vec3 direction = creaseDirection(n1, n2);
    std::array<std::uint32_t, 2> ends{UINT32_MAX, UINT32_MAX};
    if (direction == glm::vec3(0.0f)) return ends;
    const float reach = kCreaseReach * level_.levelRadius[p];
    std::array<float, 2> nearest{std::numeric_limits<float>::max(), std::numeric_limits<float>::max()};
    for (const NearbyPoint& candidate : nearby) {
        const std::uint32_t i = candidate.index;
        if (i == p || !points.isCrease(i) || !sameCrease(n1, n2, points.normal[i], points.crease[i]))
            continue;
        const glm::vec3 d = candidate.position - x;
        const float along = glm::dot(d, direction), length = glm::length(d);
        const auto follows = [&](glm::vec3 crease) {
            return std::abs(glm::dot(d, crease)) > kCreaseChord * length;
        };
        if (!(length < reach) || !follows(direction)) continue;
        const glm::vec3 theirs = creaseDirection(points.normal[i], points.crease[i]);
        if (theirs != glm::vec3(0.0f) && !follows(theirs)) continue;
        const int end = along > 0.0f ? 0 : 1;
        if (length < nearest[end] || (length == nearest[end] && i < ends[end]))
            nearest[end] = length, ends[end] = i;
    }
    return ends;
}

// Nε_p filtered into p's fan (s.fan), N'_p and Y_p (s.ring, s.outer), with the wider second look
// at an open fan. `t0`: the profile's clock, advanced past the time counted.
void PointStep::findOneRing(std::uint32_t p, const TangentFrame& frame, Clock::time_point& t0,
                            WorkerScratch& s) const {
    const bool profile = level_.options.profile;
    const glm::vec3 x = level_.points.position[p], n = frame.n;
    const FuzzyParams fuzzy =
        fuzzyParams(level_.options.smoothing && !level_.options.centroidCandidates); // PN-centre candidates
    // A point far smaller than its cell's sub-cells finds its surroundings through the hierarchy,
    // as a large point does (kFineReach): the same points within reach (only their order differs,
    // which nothing downstream reads), without scanning the sub-cells' far denser crowd.
    const std::optional<std::uint64_t> cell =
        s.groupCell && level_.options.fineReach * level_.levelRadius[p] < s.nearbyGrid.side() ? std::nullopt
                                                                                              : s.groupCell;
    std::span<const NearbyPoint> nearby = s.nearby;
    if (cell) {
        s.nearbyGrid.select(x, level_.levelRadius[p], s.pointNearby);
        nearby = s.pointNearby;
    } else if (s.groupCell) {
        gatherNearby(std::span(&p, 1), std::nullopt, 1.0f, s.pointNearby, s);
        if (profile) t0 = Clock::now(); // gatherNearby counted its own time
        nearby = s.pointNearby;
    }
    const bool cut = gatherNeighbourhood(p, frame, level_.levelRadius[p], nearby, s);
    std::size_t neighbours = s.fan.size();
    if (profile) s.times.neighbourhood += secondsSince(t0);
    filterFuzzy(x, n, fuzzy, s.fan, s.neighbourhood);
    if (profile) s.times.filtering += secondsSince(t0);
    if (!cut && fanIsOpen(s.fan)) {
        // Choice: a fan open wider than θb may be a boundary, or a radius that fell short of the
        // natural first ring on one side (the radius update only reaches N'_p). Look once more
        // within kRetryReach·r before treating it as a boundary; the new one-ring then reaches
        // across, and the gap is filled at this level instead of staying a hole.
        ++s.retried;
        gatherNearby(std::span(&p, 1), cell, kRetryReach, s.wideNearby, s);
        if (profile) t0 = Clock::now(); // gatherNearby counted its own time
        gatherNeighbourhood(p, frame, kRetryReach * level_.levelRadius[p], s.wideNearby, s);
        neighbours = s.fan.size();
        if (profile) s.times.neighbourhood += secondsSince(t0);
        filterFuzzy(x, n, fuzzy, s.fan, s.neighbourhood);
        if (profile) s.times.filtering += secondsSince(t0);
    }
    s.neighbours += neighbours;
}

// Steps 1 and 2 of §4.6: the next candidate to insert into N'_p, or s.candidates.size() when N'_p
// is complete or no candidate fills what is open. Candidates leave L_p by being marked taken; the
// others keep their order; at least one is left.
std::size_t PointStep::nextCandidate(glm::vec3 x, WorkerScratch& s) const {
    std::vector<RingMember>& ring = s.ring;
    const std::vector<Candidate>& candidates = s.candidates;
    // 2. The candidate that best balances the sampling of the gap after ring[j]:
    //    max of min(∠p_j p p_k, ∠p_k p p_j+1), or candidates.size() when none is inside it; with
    //    `anyInside`, the first candidate found inside instead of the best.
    //    Choice: angles measured around n_p in the tangent plane (the plane that orders the fan),
    //    and only candidates inside the gap compete, so a point is never put into a gap other than
    //    the one being filled.
    const auto candidateIn = [&](std::size_t j, bool anyInside) {
        const RingMember& a = ring[j];
        const float gapSweep =
            ring.size() == 1 ? kTwoPi : sweep(a.angle, ring[nextIndex(j, ring.size())].angle);
        std::size_t best = candidates.size();
        float bestScore = -1.0f;
        for (std::size_t k = 0; k < candidates.size(); ++k) {
            if (candidates[k].taken) continue;
            const float into = sweep(a.angle, candidates[k].angle);
            const float score = std::min(into, gapSweep - into);
            if (score >= kMinSplitAngle && score > bestScore) {
                if (anyInside) return k;
                bestScore = score;
                best = k;
            }
        }
        return best;
    };
    // An empty N'_p is incomplete; every candidate fills it equally: the first one left.
    if (ring.empty()) {
        std::size_t first = 0;
        while (candidates[first].taken) ++first;
        return first;
    }
    // 1. The pair of consecutive members of N'_p with the largest curved angle that is not below
    //    θc (N'_p complete otherwise) and still has a candidate inside it. A gap with no candidate
    //    inside can never be chosen, and candidates only leave: it may be marked exhausted at once,
    //    and its curved angle is then never measured (the same choice). For speed only: a curved
    //    angle costs more than looking for a candidate in its gap, a plain angle (variant 2) less,
    //    so only the first is looked at first.
    const bool candidatesFirst = !level_.options.plainAngle;
    for (std::size_t j = 0; j < ring.size(); ++j) {
        if (!ring[j].gapStale) continue;
        ring[j].gapStale = false;
        ring[j].gapExhausted = candidatesFirst && candidateIn(j, true) == candidates.size();
        if (!ring[j].gapExhausted)
            ring[j].gapToNext = gapValue(x, ring[j], ring[nextIndex(j, ring.size())], ring.size());
    }
    for (;;) {
        std::size_t widest = ring.size();
        for (std::size_t j = 0; j < ring.size(); ++j) {
            if (ring[j].gapExhausted || ring[j].gapToNext < kThetaC) continue;
            if (widest == ring.size() || ring[j].gapToNext > ring[widest].gapToNext) widest = j;
        }
        if (widest == ring.size()) return candidates.size(); // complete, or nothing fills what is open
        const std::size_t chosen = candidateIn(widest, false);
        if (chosen < candidates.size()) return chosen;
        ring[widest].gapExhausted = true;
    }
}

// Step 3 of §4.6: whether candidate c falls into the discard space D_p (eq. 11); then the closest
// point of Y_p joins N'_p instead (ties broken by storage position).
bool PointStep::substituteIfDiscarded(std::uint32_t p, const TangentFrame& frame, const Candidate& c,
                                      WorkerScratch& s) const {
    std::size_t closest = s.outer.size();
    float closestDistance = std::numeric_limits<float>::max();
    bool discarded = false;
    for (std::size_t h = 0; h < s.outer.size(); ++h) {
        const float distance = glm::length(c.position - s.outer[h].position);
        if (distance < s.outer[h].discardRadius) discarded = true;
        const bool tie = distance == closestDistance && closest < s.outer.size() &&
                         storedBefore(s.outer[h], s.outer[closest]);
        if (distance < closestDistance || tie) {
            closestDistance = distance;
            closest = h;
        }
    }
    if (!discarded) return false;
    ++s.discarded;
    RingMember& y = s.outer[closest];
    y.angle = frame.angleOf(y.position - level_.points.position[p]);
    const bool present = std::any_of(s.ring.begin(), s.ring.end(), [&](const RingMember& m) {
        return m.cell == y.cell && m.local == y.local;
    });
    // Choice: a substitute farther than c_β,max · r from p would break the convergence bound of
    // section 8.1 (the proof assumes the farthest new neighbour is a PN centre); such a point is
    // left out and nothing joins N'_p.
    if (!present && withinConvergenceBound(p, y.position)) insertIntoRing(s.ring, y);
    return true;
}

// Step 3 of §4.6, the candidate kept: the new point made from c, stored in `cell` and put into
// N'_p, unless one of the choices below leaves it out. `phantoms` counts the members of N'_p that
// refineRegion does not store.
void PointStep::insertCandidate(std::uint32_t p, std::uint32_t cell, const TangentFrame& frame,
                                const Candidate& c, std::uint32_t& phantoms, WorkerScratch& s) const {
    const glm::vec3 x = level_.points.position[p];
    const NewPoint np = newPointFrom(p, s.fan, c);
    // Choice: a candidate farther than c_β,max · r from p is not inserted, as Y_p's substitutes
    // and the segments' first points are not put into N'_p: it would break the convergence
    // bound of section 8.1. The bound assumes a fan within r; after the wider second look (up
    // to kRetryReach · r) a PN centre can lie beyond it (1 in 118,000 on the fandisk). The
    // gap stays open for p's other candidates, and the far triangle's other corners, which
    // are closer to it, insert their own.
    if (!withinConvergenceBound(p, np.position)) {
        ++s.beyondBound;
        return;
    }
    // Choice: a point that would coincide with p or a point near it (of P(l) within reach, of
    // N'_p or of Y_p) is not inserted. The fuzzy filter can drop p's own child of the previous
    // level from its fan (normals far apart, as in noisy scans), and the fan triangle that
    // made that child then makes it again: one such duplicate in the nefertiti's 214,257
    // points, and in a quarter of small sets with normals tilted by up to 50° (fuzz_refine: its
    // radius then collapsed to 0). Such a point lies within p's reach, where the points of
    // P(l) were just scanned (collectNeighbourhood); with centroid candidates (variant 4) a
    // twin in Y_p can escape D_p, which is measured on the centroid.
    if (coincidesWithNearby(np.position, x, s) || madeByCorner(np.position, s.fan.index[c.a]) ||
        madeByCorner(np.position, s.fan.index[c.b])) {
        ++s.coincident;
        return;
    }
    // refineRegion: the neighbouring region inserts what lies in it (see refiner.h). Choice: the
    // candidate joins N'_p all the same, unstored, as the point the whole level would insert
    // there: p's radius reaches it, and the members beside it grow to reach it rather than
    // each other across the gap it leaves.
    if (outsideRegion(np.position)) {
        ++s.outsideRegion;
        insertIntoRing(s.ring, RingMember{kPhantomCell, phantoms++, np.position, np.normal,
                                          frame.angleOf(np.position - x)});
        return;
    }
    const std::uint32_t local = store(cell, np, PointSource{{p, s.fan.index[c.a], s.fan.index[c.b]}}, s);
    ++s.inserted;
    insertIntoRing(s.ring, RingMember{cell, local, np.position, np.normal, frame.angleOf(np.position - x)});
}

// Radii (section 5): r' = max_{j ∈ N'_p} |p - p_j|; each member grows to reach p and its two
// neighbours in the new ring. Choice for an empty N'_p (nothing found, nothing inserted: the
// paper's maximum is undefined): r' = c_β,max · r, so every radius still converges (8.1).
void PointStep::updateRadii(std::uint32_t p, std::span<const RingMember> ring) const {
    const glm::vec3 x = level_.points.position[p];
    if (ring.empty()) {
        out_.radius[p] = kCBetaMax * level_.levelRadius[p];
        return;
    }
    float newRadius = 0.0f;
    const std::size_t m = ring.size();
    // Each side of the ring measured once: |p_j - p_j+1| reaches both of its members.
    float before = glm::length(ring[0].position - ring[m - 1].position);
    for (std::size_t j = 0; j < m; ++j) {
        const glm::vec3 pj = ring[j].position;
        const float toP = glm::length(pj - x);
        newRadius = std::max(newRadius, toP);
        const float after = glm::length(pj - ring[nextIndex(j, m)].position);
        if (ring[j].cell != kPhantomCell) {
            float& rj = newPoint(ring[j]).radius;
            rj = std::max(rj, kRadiusMargin * std::max({toP, before, after}));
        }
        before = after;
    }
    out_.radius[p] = kRadiusMargin * newRadius;
}

// Refines p (§4): its one-ring, its segments' points, then candidates into N'_p until it is
// complete, and the radii.
void PointStep::refinePoint(std::uint32_t p, std::uint32_t cell, WorkerScratch& s) const {
    const bool profile = level_.options.profile;
    Clock::time_point t0;
    if (profile) t0 = Clock::now();
    const glm::vec3 x = level_.points.position[p];
    const TangentFrame frame(planeNormal(p));
    findOneRing(p, frame, t0, s);
    makeCandidates(p, frame, s);
    if (profile) s.times.interpolation += secondsSince(t0);
    // N'_p sorted around n_p; ties broken by storage position, which is deterministic.
    std::sort(s.ring.begin(), s.ring.end(), [](const RingMember& a, const RingMember& b) {
        return a.angle != b.angle ? a.angle < b.angle : storedBefore(a, b);
    });
    const std::uint32_t firstChild = out_.cellCount[cell];
    if (level_.splitsSegments) splitSegments(p, cell, firstChild, s);
    std::uint32_t phantoms = 0;
    double interpolationSeconds = 0;
    for (std::size_t remaining = s.candidates.size(); remaining > 0; --remaining) {
        const std::size_t chosen = nextCandidate(x, s);
        if (chosen == s.candidates.size()) break;
        s.candidates[chosen].taken = true;
        if (substituteIfDiscarded(p, frame, s.candidates[chosen], s)) continue;
        Clock::time_point ti;
        if (profile) ti = Clock::now();
        insertCandidate(p, cell, frame, s.candidates[chosen], phantoms, s);
        if (profile) interpolationSeconds += secondsSince(ti);
    }
    updateRadii(p, s.ring);
    s.reachable = 0; // reachableFrom may point into storage that the next point reuses
    out_.childRange[p] = ChildRange{cell, firstChild, out_.cellCount[cell] - firstChild};
    out_.refined[p] = 1;
    if (profile) {
        const double total = secondsSince(t0);
        s.times.selection += total - interpolationSeconds;
        s.times.interpolation += interpolationSeconds;
    }
}

// A cell's points find their surroundings together, from the grid; a large point alone, through
// the hierarchy (its reach may pass the 3×3×3 cells of the grid).
void PointStep::refineCell(const LevelCells& cells, std::uint32_t c, bool largeCell, WorkerScratch& s) const {
    const Cell cell = cells.cells[c];
    const CellKeys& keyed = cells.keyed;
    out_.cellBase[c] = s.arena.open();
    if (!out_.cellSources.empty()) out_.cellSources[c] = s.sources.open();
    if (largeCell) {
        s.groupCell.reset();
        for (std::uint32_t k = cell.begin; k < cell.end; ++k) {
            const std::uint32_t i = keyed[k].second;
            gatherNearby(std::span(&i, 1), std::nullopt, 1.0f, s.nearby, s);
            refinePoint(i, c, s);
        }
        return;
    }
    s.group.clear();
    for (std::uint32_t k = cell.begin; k < cell.end; ++k) s.group.push_back(keyed[k].second);
    s.groupCell = keyed[cell.begin].first;
    gatherNearby(s.group, s.groupCell, 1.0f, s.nearby, s);
    float largest = 0.0f;
    for (const std::uint32_t i : s.group) largest = std::max(largest, level_.levelRadius[i]);
    s.nearbyGrid.build(s.nearby, largest);
    for (std::uint32_t k = cell.begin; k < cell.end; ++k) refinePoint(keyed[k].second, c, s);
}

} // namespace pnsplat
