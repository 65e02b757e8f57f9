// An oriented point set (a set of splats), stored as flat parallel arrays (structure of arrays) so
// that per-point loops touch only the attributes they use; large arrays are whole huge pages
// (HugePageVector, huge_pages.h), and functions read them as spans.
//
// Units are the model's own; normals are unit length; a radius is the splat radius, which the
// refinement requires to reach at least the farthest neighbour of the point's natural first ring
// (ALGORITHM.md §1.2). Colours are 8-bit sRGB as stored in PLY files. A crease point (ALGORITHM.md §6.1) is
// one point with two normals: `normal` and `crease`, the normal of the surface on the other side of the
// crease; ordinary points of a set with creases have a zero `crease`.
//
// Attributes are the other scalar properties of the file the points came from (a scanner's
// `intensity`, a `confidence`, ...): each a name, the type it had in the file and one value per
// point, held as a double, which every PLY type holds exactly (8- to 32-bit integers, float and
// double), so a file's values read back and are written back bit for bit. A point the refinement
// inserts gets the mean of its triangle's corners, or the interpolation of its segment's ends, as
// colour does (ALGORITHM.md §2.6), rounded to what the type holds (representable). A set without
// attributes pays nothing for them: every per-point loop tests `attributes.empty()` once.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/type_precision.hpp>
#include <glm/vec3.hpp>

#include "pnsplat/refine/huge_pages.h"

namespace pnsplat {

// The scalar types of point file properties (PLY's char uchar short ushort int uint float double).
enum class ScalarType : std::uint8_t { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

// The bytes of a value of `type` in a binary file.
std::size_t scalarTypeBytes(ScalarType type);

// `value` as `type` holds it: integers rounded to nearest (halves away from zero) and clamped to
// the type's range (NaN to 0), float rounded to the nearest float, double unchanged.
double representable(ScalarType type, double value);

// An attribute of every point of a set (see the top of this file).
struct Attribute {
    std::string name;
    ScalarType type = ScalarType::Float32;
    HugePageVector<double> values; // per point, each representable(type, ...)
};

struct PointSet {
    HugePageVector<glm::vec3> position;
    HugePageVector<glm::vec3> normal;   // empty only when read without normals (see estimateNormals)
    HugePageVector<float> radius;       // empty when the source gave none (see estimateRadii)
    HugePageVector<glm::u8vec3> colour; // empty when the model has no colour
    HugePageVector<glm::vec3> crease;   // second normals; empty when no point is a crease point
    std::vector<Attribute> attributes;  // other scalar properties, distinct names; each sized like `position`

    std::size_t size() const { return position.size(); }
    bool empty() const { return position.empty(); }
    bool hasNormal() const { return !normal.empty(); }
    bool hasRadius() const { return !radius.empty(); }
    bool hasColour() const { return !colour.empty(); }
    bool hasCrease() const { return !crease.empty(); }
    bool isCrease(std::size_t i) const { return hasCrease() && crease[i] != glm::vec3(0.0f); }
    bool hasAttributes() const { return !attributes.empty(); }

    // Appends point i of `other`; both sets must carry the same optional attributes (the same
    // attribute names and types in the same order), except that an empty set without attributes
    // takes on those of `other`.
    void appendFrom(const PointSet& other, std::size_t i) {
        appendCoreFrom(other, i);
        if (other.hasAttributes()) appendAttributesFrom(other, i);
    }
    void reserve(std::size_t n);
    // Resizes every attribute the set carries (normals too, unless a non-empty set has none).
    void resize(std::size_t n);

  private:
    void appendCoreFrom(const PointSet& other, std::size_t i);
    void appendAttributesFrom(const PointSet& other, std::size_t i);
};

// The axis-aligned bounding box of `positions` (empty: lo above hi), its longest side and its
// diagonal.
struct Bounds {
    glm::vec3 lo{std::numeric_limits<float>::max()}, hi{std::numeric_limits<float>::lowest()};
    float extent() const { return std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z}); }
    float diagonal() const { return glm::distance(lo, hi); }
};
Bounds boundsOf(std::span<const glm::vec3> positions);

// Whether two sets carry the same attributes: names and types, in the same order.
bool sameAttributes(const PointSet& a, const PointSet& b);
// Attributes named and typed like those of `model`, without values.
std::vector<Attribute> emptyAttributesLike(const PointSet& model);

// Removes the points of the ascending indices `drop` from `points`, keeping the others' order and
// every attribute. Any thread, one set at a time.
void removePoints(PointSet& points, std::span<const std::uint32_t> drop);

// The points' indices in lexicographic order of position (x, then y, then z), equal positions by
// index: coincident points are adjacent, the first of each group its smallest index.
std::vector<std::uint32_t> orderByPosition(const PointSet& points);

// The indices of `positions` in order along a Morton curve over their box (morton.h): points close
// in space are mostly close in the order. Ties (one cell) keep the given order.
std::vector<std::uint32_t> mortonOrder(std::span<const glm::vec3> positions);

// Removes every point whose position equals (==) an earlier one's (a scan's repeated samples),
// keeping the first of each with all its attributes, in input order. The refinement needs
// distinct positions (validateForRefinement): two coincident points would each insert the same
// new points. O(n log n); any thread, one set at a time.
struct CoincidentRemoval {
    std::size_t points = 0; // removed
    // Of them, those with another normal, radius, colour, crease or attribute value: lost.
    std::size_t withOtherAttributes = 0;
};
CoincidentRemoval removeCoincident(PointSet& points);

// The smallest j > i with position j equal to position i, for the smallest such i, or nothing:
// whether, and where, a set has coincident points.
struct CoincidentPair {
    std::size_t first = 0, second = 0;
};
std::optional<CoincidentPair> findCoincident(const PointSet& points);

} // namespace pnsplat
