#include "pnsplat/refine/point_set.h"

#include <cassert>

namespace pnsplat {

void PointSet::appendFrom(const PointSet& other, std::size_t i) {
    assert(hasRadius() == other.hasRadius() || empty());
    position.push_back(other.position[i]);
    normal.push_back(other.normal[i]);
    if (other.hasRadius()) radius.push_back(other.radius[i]);
    if (other.hasColour()) colour.push_back(other.colour[i]);
    if (other.hasCrease()) crease.push_back(other.crease[i]);
}

void PointSet::reserve(std::size_t n) {
    position.reserve(n);
    normal.reserve(n);
    radius.reserve(n);
    colour.reserve(n);
    if (hasCrease()) crease.reserve(n);
}

void PointSet::resize(std::size_t n) {
    const bool withRadius = hasRadius();
    const bool withColour = hasColour();
    const bool withCrease = hasCrease();
    position.resize(n);
    normal.resize(n);
    if (withRadius) radius.resize(n);
    if (withColour) colour.resize(n);
    if (withCrease) crease.resize(n);
}

} // namespace pnsplat
