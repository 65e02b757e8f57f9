// Outliers of a scan: points isolated at the scale of its sampling (ALGORITHM.md §9.7; not in the
// paper, which assumes a clean input). A stray point in the air, with whatever normal it has, is a
// point of the surface as far as the refinement knows: its neighbours' balls and its own reach
// across the gap, and the PN triangles it makes are flaps (issue 27: 1 % of the bunny's points
// added at random in its box, three levels, put the refined points 3.3 times as far from the
// mesh on average, and 0.21 of the diagonal at most).
//
// With d_i the mean distance of point i to its k nearest points, m the median of the d_i and
// sigma = 1.4826 · MAD (their median absolute deviation: a standard deviation for a normal
// distribution), point i is an outlier when
//   1. d_i > max(m + alpha · sigma, rho · m): statistical outlier removal as PCL's
//      StatisticalOutlierRemoval and Open3D's remove_statistical_outlier do it, with the median and
//      the MAD instead of the mean and the standard deviation, which the outliers inflate; but not
//      where i lies in a sparse sheet: its k nearest's own d_j have an upper median of at least
//      d_i / kOutlierLocalRatio, their plane is flat and i lies on it (a terrestrial scan's far
//      field, whose spacing grows with the range: rule 1 alone cut 13 % of such a scan); or
//   2. it lies farther than beta · max(d_i, m) from the plane of its k nearest points (their
//      centroid and direction of least variance): a point a few spacings above the surface, which
//      its density alone does not give away.
// Both rules then run again over the points left, up to kOutlierPasses passes in all, until a pass
// finds none: stray points near each other shield each other (one among another's nearest tilts
// their plane until it passes near the other, and keeps the other's d_i down), and the first pass
// finds the more isolated of them.
// The constants and the measurements behind them: ALGORITHM.md §9.7.
//
// Thread use: any thread; runs on the given number of worker threads (0 = all), with a result that
// does not depend on it. Positions must be finite.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "pnsplat/refine/point_set.h"

namespace pnsplat {

// Measured on the clean inputs of ../shared/data, the embedded default model, and the inputs with
// 1 % and 5 % of points added at random in their boxes (ALGORITHM.md §9.7). Every clean input keeps
// every point; about two thirds of the added points go on the bunny, the lion and the nefertiti.
// k: with 8, one clean nefertiti point goes at any alpha that removes outliers; with 16, fewer
// outliers are found (rule 2's plane then reaches wider).
inline constexpr unsigned kOutlierNearest = 12;
// alpha: the largest (d_i - m) / sigma of a clean input is 9.4 (the nefertiti's sparse patches).
inline constexpr double kOutlierDeviations = 10.0;
// rho: uniform samplings have a sigma of 5 % of m, so alpha alone would cut the default model's
// sparse horn tips (d_i up to 2.5 m) and a mesh's sparse vertices; clean inputs reach 2.0 m (3.6 for
// the nefertiti, which alpha keeps).
inline constexpr double kOutlierRatio = 3.0;
// beta: the largest offset of a clean point from its neighbours' plane is 0.75 d_i (the fandisk's
// edges). The max(d_i, m) keeps points of locally dense patches, whose d_i is small.
inline constexpr double kOutlierOffset = 0.8;
// A sparse sheet (rule 1's exception), measured on clean scans whose density falls with the square
// of the range (a terrain seen from 0.5 to 50 and to 200 units; a point's d_i over its neighbours'
// upper median: 0.67 to 2.3, higher where the sampling leaves gaps) and on the sparse inputs with 1 %,
// 5 % and 15 % of points added in their boxes (ALGORITHM.md §9.7): with a flatness under 0.02 the
// exception spares no added point that rule 1 finds at any ratio up to 3; at 1.6 it still cut a
// sparse terrain's gaps. Flatness: the smallest eigenvalue of the k nearest's spread over the middle
// one (0.00-0.04 on the terrain; a clean bunny's median is 0.02, its 99th percentile 0.6, so curved
// sparse patches are not spared). On the plane: within this share of d_i.
inline constexpr double kOutlierLocalRatio = 2.5;
inline constexpr double kOutlierFlatness = 0.02;
inline constexpr double kOutlierOnPlane = 0.2;
// Passes of rules 1 and 2 (the first over every point, each next over the points the ones before
// left): with 1 % and 5 % added to the bunny, the lion and the nefertiti the third pass finds the
// last ones, and the clean inputs lose nothing in any pass (ALGORITHM.md §9.7).
inline constexpr unsigned kOutlierPasses = 4;
// Sets of at most this many points are left alone: a handful of points has no sampling scale to
// be isolated at.
inline constexpr std::size_t kOutlierMinPoints = 4 * (kOutlierNearest + 1);
// The largest k that outlierDistances takes.
inline constexpr unsigned kOutlierMaxNearest = 64;

// For each of the n positions, the mean distance to its k nearest other positions (a coincident
// position counts, at distance 0), in double precision; n values. Needs 1 <= k <=
// kOutlierMaxNearest and k < n (else every value is 0). Infinity for a point some of whose k
// nearest lie too far to measure (squared distances past single precision, about 1e19 apart).
std::vector<double> outlierDistances(std::span<const glm::vec3> positions, unsigned k, unsigned threads = 0);

struct OutlierParams {
    unsigned nearest = kOutlierNearest;        // k
    double deviations = kOutlierDeviations;    // alpha
    double ratio = kOutlierRatio;              // rho
    double offset = kOutlierOffset;            // beta (0: rule 2 off, and rule 1 spares no sparse sheet)
    double localRatio = kOutlierLocalRatio;    // a sparse sheet: d_i at most this times its nearest's median
    double flatness = kOutlierFlatness;        // ... their plane flatter than this
    double onPlane = kOutlierOnPlane;          // ... and i within this times d_i of it
    unsigned passes = kOutlierPasses;          // 0 or 1: one pass
    std::size_t minPoints = kOutlierMinPoints; // at most this many points: none is an outlier
};

struct OutlierSearch {
    std::vector<std::uint32_t> outliers; // their indices, ascending
    double median = 0.0;    // m, the median of the d_i (0 when the set was left alone): the first pass's
    double threshold = 0.0; // max(m + alpha · sigma, rho · m): d_i above it is an outlier, in the first pass
};

// The outliers among `positions` (rules 1 and 2 above). Positions should be distinct
// (removeCoincident): a point repeated k times is as isolated as a point alone. O(n log n).
OutlierSearch findOutliers(std::span<const glm::vec3> positions, unsigned threads = 0,
                           const OutlierParams& params = {});

} // namespace pnsplat
