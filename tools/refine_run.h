// Level-by-level refinement with a progress bar, and its input and options, shared by `refine` and
// `render --refine-levels`.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "pnsplat/refine/input.h"
#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/refiner.h"

namespace CLI {
class App;
}

namespace pnsplat::tools {

struct RefineRun {
    PointSet points;
    std::size_t inputPoints = 0;          // refined from: the input's distinct positions, outliers left out
    unsigned levels = 0;                  // levels run, the hole filling's and evening out's included
    unsigned evenOutLevels = 0;           // adaptive levels of evenOut after them (part of `levels`)
    unsigned holeFillingLevels = 0;       // adaptive levels filling the holes before them (part of `levels`)
    double seconds = 0.0;                 // time spent refining (not estimating radii)
    std::size_t cappedNeighbourhoods = 0; // over all levels (LevelStats), a sign of radii too large
    unsigned firstCappedLevel = 0;        // the first level (1: the first run) that cut one; 0: none
    std::size_t enlargedRadii = 0;        // rim points of the holes to fill (enlargeAroundHole)
    std::size_t holes = 0;                // holes filled: given, and found (`holesFound` of them)
    std::size_t holesFound = 0;           // by findHoles (RefineJob::fillHolesUpTo)
    std::size_t holesLeftOpen = 0;        // closed rims findHoles found wider than the size asked
    std::size_t maxNeighbours = 0;        // the bound the neighbourhoods were cut to (RefineOptions)
    bool radiiEstimated = false;          // the input's radii were estimated (completeInput)
    std::size_t turnedNormals = 0;        // flipped input normals turned back (completeInput)
    std::size_t outliers = 0;             // isolated input points left out (completeInput, findOutliers)
};

// The largest hole `--fill-holes` fills: a length in model units, or (relative) a multiple of the
// input's median nearest-point distance; 0: none.
struct HoleSize {
    float value = 0.0f;
    bool relative = false;
};

// What to refine and how far: `holes`, and those findHoles finds up to `fillHolesUpTo`, are
// filled first (enlargeAroundHoles, fillHoles; paper figure 9); then `levels` uniform levels, stopping early
// once `targetPoints` (0: no target) is reached or a level inserts nothing; then the points above
// `evenOutFactor` times the median radius are evened out (evenOut; 0: not at all). A job whose estimated
// output (memory_budget.h) exceeds `maxPoints`, or with 0 what memoryLimits() leave room for, is refused
// before it starts.
struct RefineJob {
    RefineOptions options;
    unsigned levels = 0;
    std::size_t targetPoints = 0;
    float evenOutFactor = 0.0f;
    std::vector<Hole> holes;
    HoleSize fillHolesUpTo;
    bool estimateRadii = false; // replace the input's radii by estimated ones
    bool keepNormals = false;   // refuse flipped input normals instead of turning them back
    bool keepOutliers = false;  // refine isolated input points too instead of leaving them out
    std::size_t maxPoints = 0;
    glm::dvec3 origin{0.0}; // the points are stored less it (PlyData::origin): messages add it back
};

// `--fill-hole X,Y,Z,R` on `cmd` (repeatable, one ball per occurrence), collected into `holes`,
// and `--fill-holes SIZE` into `upTo` (parseHoleSize).
void addFillHoleOptions(CLI::App& cmd, std::vector<std::string>& holes, std::string& upTo);
// `--fill-holes SIZE` alone, for the real-time engine's commands (withHolesFilled).
void addFillHolesOption(CLI::App& cmd, std::string& upTo);
// `points` (completed: completeInput) with the holes findHoles finds up to `upTo` filled as
// `refine --fill-holes` fills them (fillHoles; no uniform level), for the real-time engine, which
// refines from there; unchanged when upTo.value is 0. Says what it found on stderr, as refine does.
// `origin`: the points' (PlyData::origin), for the holes' places in the file's coordinates.
PointSet withHolesFilled(PointSet points, const HoleSize& upTo, const std::string& inputName,
                         glm::dvec3 origin = glm::dvec3(0.0));
// `--fill-holes`'s SIZE: a positive finite length ("0.05"), or a multiple of the spacing ("20x");
// empty: none. Anything else is a CommandError (a usage error) naming the option and the text.
HoleSize parseHoleSize(std::string_view text);
// `--max-points N` on `cmd`, into `maxPoints` (RefineJob::maxPoints).
void addMaxPointsOption(CLI::App& cmd, std::size_t& maxPoints);
// The holes of the option's texts, in the file's coordinates: their centres are stored less the
// points' `origin` (PlyData::origin). A text that is not four finite numbers with R > 0 is a
// CommandError (a usage error) naming the option and the text.
std::vector<Hole> parseHoles(const std::vector<std::string>& texts, glm::dvec3 origin = glm::dvec3(0.0));

// `--keep-normals` on `cmd`, into `keep`.
void addKeepNormalsOption(CLI::App& cmd, bool& keep);
// `--keep-outliers` on `cmd`, into `keep`.
void addKeepOutliersOption(CLI::App& cmd, bool& keep);

// `--columns NAME,...` on `cmd` (text inputs), into `columns` (PointFileOptions::columns).
void addColumnsOption(CLI::App& cmd, std::vector<std::string>& columns);

// The points of a point file (PLY, PCD or text: point_file.h; "-": standard input) for refinement
// or rendering: normals may be absent (completeInput estimates them); `columns` names a text
// file's columns (empty: its header line or their number). A bad file is a CommandError. What the
// file holds beyond the points (other properties, fields, columns and elements) is named in a
// warning on stderr, PCD points left out for a NaN position in a note; a PLY file's header
// comments are returned in `comments` when given, for the output to carry on, and the points'
// origin (PlyData::origin: coordinates far from 0, with a note) in `origin`.
PointSet readInput(const std::string& path, std::vector<std::string>* comments = nullptr,
                   const std::vector<std::string>& columns = {}, glm::dvec3* origin = nullptr);

// Completes an input (pnsplat::completeInput, input.h), with a note on stderr for the repeated
// positions dropped, for outliers left out, for normals estimated and for flipped normals turned
// back; its errors are a CommandError naming `inputName`. The notes give places in the file's
// coordinates: `origin` (PlyData::origin) + position.
InputCompletion completeInput(PointSet& points, unsigned threads, const std::string& inputName,
                              const InputOptions& options = {}, glm::dvec3 origin = glm::dvec3(0.0));

// Refuses (CommandError naming `inputName`) a job whose estimated output is above job.maxPoints,
// or with 0 above what the memory budget leaves room for, saying what it would make and need.
void checkFits(const PointSet& points, const RefineJob& job, const std::string& inputName);

// Checks that the job fits (RefineJob::maxPoints), completes the input (completeInput,
// job.estimateRadii, job.keepNormals and job.keepOutliers), checks it, then runs the job. Errors, running out
// of memory included, are a CommandError naming `inputName`.
RefineRun refineWithProgress(PointSet points, RefineJob job, const std::string& inputName);

} // namespace pnsplat::tools
