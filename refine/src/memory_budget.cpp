// Estimates of a refinement's output and memory, and the memory the machine grants (see
// memory_budget.h for the measurements behind the constants). Growth per level: paper section 5.
#include "pnsplat/refine/memory_budget.h"

#include <algorithm>
#include <fstream>
#include <thread>
#include <utility>

#include <sys/resource.h>
#include <unistd.h>

namespace pnsplat {

namespace {

// Bytes of one point in the binary PLY that writePly makes: x y z nx ny nz radius as floats, then
// nx2 ny2 nz2 and the crease flag, then red green blue, then the attributes.
double pointFileBytes(const RefinementPlan& plan) {
    return 28.0 + (plan.crease ? 13.0 : 0.0) + (plan.colour ? 3.0 : 0.0) +
           static_cast<double>(plan.attributeFileBytes);
}

// The bytes of the file that stand for a point's memory (kMemoryPerFileByte times them): an
// attribute's as the 8 bytes of its double.
double pointMemoryBytes(const RefinementPlan& plan) {
    return pointFileBytes(plan) - static_cast<double>(plan.attributeFileBytes) +
           8.0 * static_cast<double>(plan.attributes);
}

double threadCount(const RefinementPlan& plan) {
    return plan.threads != 0 ? plan.threads : std::max(1u, std::thread::hardware_concurrency());
}

// The threads' part of the estimate: address space, or resident memory.
double threadBytes(const RefinementPlan& plan, bool addressSpace) {
    return addressSpace ? kMemoryPerThread * threadCount(plan)
                        : kMemoryPerThread + kResidentPerThread * (threadCount(plan) - 1.0);
}

// The first number in a control group's limit file; 0 when absent or "max" (no limit).
double cgroupLimit(const char* path) {
    std::ifstream in(path);
    double bytes = 0.0;
    return in >> bytes ? bytes : 0.0;
}

} // namespace

RefinementEstimate estimateRefinement(const RefinementPlan& plan) {
    const auto input = static_cast<double>(plan.inputPoints);
    double points = input;
    for (unsigned level = 0; level < plan.levels; ++level) points *= kLevelGrowth;
    if (plan.targetPoints != 0) {
        const auto target = static_cast<double>(plan.targetPoints);
        points = input >= target ? input : std::min(points, kLevelGrowth * target);
    }
    if (plan.evenOutFactor > 0.0f)
        points *= 1.05 + 1.5 * std::max(0.0, 2.0 / static_cast<double>(plan.evenOutFactor) - 1.0);
    RefinementEstimate estimate;
    estimate.points = points;
    estimate.fileBytes = points * pointFileBytes(plan);
    const double pointBytes = kMemoryPerFileByte * pointMemoryBytes(plan) * points;
    estimate.memoryBytes = pointBytes + threadBytes(plan, true);
    estimate.residentBytes = pointBytes + threadBytes(plan, false);
    return estimate;
}

std::vector<MemoryBudget> memoryLimits() {
    std::vector<MemoryBudget> limits{
        {static_cast<double>(sysconf(_SC_PHYS_PAGES)) * static_cast<double>(sysconf(_SC_PAGESIZE)),
         "physical memory", false}};
    for (const char* path : {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"})
        if (const double bytes = cgroupLimit(path); bytes > 0.0 && bytes < limits[0].bytes)
            limits.push_back({bytes, "the control group's memory limit", false});
    for (const auto& [resource, source] : {std::pair{RLIMIT_AS, "the address-space limit (ulimit -v)"},
                                           std::pair{RLIMIT_DATA, "the data-size limit (ulimit -d)"}}) {
        rlimit limit{};
        if (getrlimit(resource, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY)
            limits.push_back({static_cast<double>(limit.rlim_cur), source, true});
    }
    return limits;
}

std::size_t pointsWithin(const MemoryBudget& limit, const RefinementPlan& plan) {
    const double points =
        (limit.bytes - threadBytes(plan, limit.addressSpace)) / (kMemoryPerFileByte * pointMemoryBytes(plan));
    return points > 0.0 ? static_cast<std::size_t>(points) : 0;
}

} // namespace pnsplat
