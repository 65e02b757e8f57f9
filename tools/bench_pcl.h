// PCL's moving least squares upsampling (pcl::MovingLeastSquares), the point of comparison of
// `bench refine` (issue 28). Declared always, defined in bench_pcl.cpp, which is compiled only
// with PNSPLAT_WITH_PCL (then PNSPLAT_HAS_PCL is defined): the only file that includes PCL.
#pragma once

#include <cstddef>
#include <string>

#include "pnsplat/refine/point_set.h"

namespace pnsplat::tools {

// SAMPLE_LOCAL_PLANE: every input point's MLS fit (a plane from the points within searchRadius, a
// polynomial of polynomialOrder over it) is sampled on a square grid of `step` within
// `upsamplingRadius` of the point, each sample projected onto the polynomial. Lengths are in the
// model's units.
struct PclMlsSettings {
    double searchRadius = 0.0;
    double upsamplingRadius = 0.0;
    double step = 0.0;
    int polynomialOrder = 2;
};

// Settings for `input` (positions only; PCL's MLS fits its own planes and ignores input normals)
// whose output comes nearest `target` points: the radii from the input's spacing (bench_pcl.cpp),
// the step searched for by running the upsampling several times (on `threads` threads; none of it
// timed). Any thread; `input` must hold at least 3 points.
PclMlsSettings choosePclMlsSettings(const PointSet& input, std::size_t target, unsigned threads);

struct PclMlsRun {
    PointSet output;      // positions and MLS normals, each normal turned to the nearest input point's side
    double seconds = 0.0; // wall clock of MovingLeastSquares::process() alone (its k-d tree included)
};

// One upsampling of `input` with `settings` on `threads` threads (OpenMP, setNumberOfThreads).
PclMlsRun runPclMls(const PointSet& input, const PclMlsSettings& settings, unsigned threads);

// "SAMPLE_LOCAL_PLANE, ..." : the method and settings in words, for the JSON record.
std::string describePclMls(const PclMlsSettings& settings);

} // namespace pnsplat::tools
