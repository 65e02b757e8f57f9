// What a refinement will make and need, and what memory the machine grants: the check `pnsplat
// refine` makes before it starts, since a run that does not fit would otherwise end only levels
// (minutes, hours) later, in an allocation failure or in the system's out-of-memory killer.
// Growth per level: paper section 5 (a √3 step inserts about two points per point).
//
// Measured (Release, x86-64, on ../shared/data and the default model; VmPeak, the address space,
// which `ulimit -v` bounds, and VmHWM, the resident memory):
//  - points per uniform level: 2.76 to 3.02 times those before it, over four levels 2.80 to 2.87
//    on average for the random inputs and 2.95 to 3.01 for the uniform ones; kLevelGrowth = 3;
//  - memory per output point at the last level (the refiner's arrays, the hierarchy, the level's
//    per-point arrays and arenas, vectors grown by doubling): 133 bytes of address space and 95
//    resident for x y z nx ny nz radius (28 bytes in the file), 147 and 89 with colour (31), 178
//    and 124 with crease normals (41): kMemoryPerFileByte = 5 times the point's bytes in the file;
//  - per worker thread: 82 MiB of address space (a malloc arena reserves 64 MiB, the stack 8 MiB,
//    the level's arena blocks 8 MiB): kMemoryPerThread = 84 MiB, counted for the first thread too
//    (what the program itself takes: 50 MiB). Little of it is resident: each thread after the first
//    adds 1.5 to 2.1 MiB (VmHWM of the sparse bunny's 5 levels on 16 and 64 threads, of igea-600's
//    3 levels on 16, against one thread): kResidentPerThread = 4 MiB, so that physical memory and a
//    control group's limit do not refuse many threads for their address space.
// Any thread may call these functions.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace pnsplat {

inline constexpr double kLevelGrowth = 3.0;
inline constexpr double kMemoryPerFileByte = 5.0;
inline constexpr double kMemoryPerThread = 84.0 * (1 << 20);
inline constexpr double kResidentPerThread = 4.0 * (1 << 20);

// What a refinement will do: from `inputPoints`, `levels` uniform levels, stopping at the first
// that reaches `targetPoints` (0: no target), then evening out with `evenOutFactor` (0: none; see
// refiner.h, evenOut) on `threads` workers (0: all hardware threads). Hole filling is not counted:
// it adds as many points as the holes' area holds at the density around them (14 % more for the
// hole of igea-4000-uniform-hole.ply).
struct RefinementPlan {
    std::size_t inputPoints = 0;
    unsigned levels = 0;
    std::size_t targetPoints = 0;
    float evenOutFactor = 0.0f;
    bool colour = false, crease = false; // the points carry colours, crease normals
    // Attributes (PointSet::attributes): how many, and their bytes in the file. In memory each is a
    // double, counted as 8 bytes of the file (kMemoryPerFileByte times that: rather above what the
    // values, their growth and the level's record of each new point's corners take).
    std::size_t attributes = 0, attributeFileBytes = 0;
    unsigned threads = 0;
};

struct RefinementEstimate {
    double points = 0.0;        // in the output
    double fileBytes = 0.0;     // of the binary PLY written
    double memoryBytes = 0.0;   // address space at the peak (the last level)
    double residentBytes = 0.0; // resident memory at the peak: the same but for the threads
};

// Rather above than below what the run takes: kLevelGrowth per level; with a target, at most
// kLevelGrowth times the target (the level before it had fewer points); evening out multiplies
// by 1.05 + 1.5 · max(0, 2 / factor - 1) (measured on the random inputs after 3 levels: 2.34 to
// 2.47 at factor 1, 1.14 to 1.24 at 1.5, 1.00 to 1.02 at 2). Values may be far beyond any machine
// (600 points and 64 levels: 2e33 points); they are doubles for that reason.
RefinementEstimate estimateRefinement(const RefinementPlan& plan);

// A limit on the memory a run may take: the physical memory and the control group's memory limit
// (cgroup v2 memory.max or v1 memory.limit_in_bytes, as a container sees them) bound resident
// memory; the address-space limit (ulimit -v, RLIMIT_AS) and the data limit (ulimit -d,
// RLIMIT_DATA) bound address space. `source` names it for messages ("physical memory", "the
// address-space limit (ulimit -v)", ...).
struct MemoryBudget {
    double bytes = 0.0;
    std::string source;
    bool addressSpace = false;
};
// Every limit that applies: the physical memory first, then those of the others that are set.
std::vector<MemoryBudget> memoryLimits();

// The most output points whose estimate (estimateRefinement's resident memory, or its address
// space for a limit of address space) fits within `limit`, 0 when not even the threads do.
std::size_t pointsWithin(const MemoryBudget& limit, const RefinementPlan& plan);

} // namespace pnsplat
