// Level-by-level refinement with a progress bar, and its input and options, shared by `refine` and
// `render --refine-levels`.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/refiner.h"

namespace CLI {
class App;
}

namespace pnsplat::tools {

struct RefineRun {
    PointSet points;
    std::size_t inputPoints = 0;          // refined from: the input's distinct positions (completeInput)
    unsigned levels = 0;                  // levels run, the hole filling's and evening out's included
    unsigned evenOutLevels = 0;           // adaptive levels of evenOut after them (part of `levels`)
    unsigned holeFillingLevels = 0;       // adaptive levels filling the holes before them (part of `levels`)
    double seconds = 0.0;                 // time spent refining (not estimating radii)
    std::size_t cappedNeighbourhoods = 0; // over all levels (LevelStats), a sign of radii too large
    std::size_t enlargedRadii = 0;        // rim points of the holes to fill (enlargeAroundHole)
    std::size_t maxNeighbours = 0;        // the bound the neighbourhoods were cut to (RefineOptions)
    bool radiiEstimated = false;          // the input's radii were estimated (completeInput)
};

// What to refine and how far: `holes` are filled first (enlargeAroundHoles, fillHoles; paper
// figure 9); then `levels` uniform levels, stopping early once `targetPoints` (0: no target) is
// reached or a level inserts nothing; then the points above `evenOutFactor` times the median
// radius are evened out (evenOut; 0: not at all).
struct RefineJob {
    RefineOptions options;
    unsigned levels = 0;
    std::size_t targetPoints = 0;
    float evenOutFactor = 0.0f;
    std::vector<Hole> holes;
    bool estimateRadii = false; // replace the input's radii by estimated ones
};

// `--fill-hole X,Y,Z,R` on `cmd` (repeatable, one ball per occurrence), collected into `holes`.
void addFillHoleOption(CLI::App& cmd, std::vector<std::string>& holes);
// The holes of the option's texts; a text that is not four finite numbers with R > 0 is a
// CommandError (a usage error) naming the option and the text.
std::vector<Hole> parseHoles(const std::vector<std::string>& texts);

// The points of a PLY file for refinement or rendering: normals may be absent (completeInput
// estimates them). A bad file is a CommandError.
PointSet readInput(const std::string& path);

// Completes an input (pnsplat::completeInput, input.h), with a note on stderr for the repeated
// positions dropped and for normals estimated; its errors are a CommandError naming `inputName`.
// Returns whether the radii were estimated.
bool completeInput(PointSet& points, unsigned threads, const std::string& inputName,
                   bool replaceRadii = false);

// Completes the input (completeInput, job.estimateRadii), checks it (CommandError naming
// `inputName`), then runs the job.
RefineRun refineWithProgress(PointSet points, RefineJob job, const std::string& inputName);

} // namespace pnsplat::tools
