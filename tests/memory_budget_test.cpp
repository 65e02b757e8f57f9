// The estimate behind `pnsplat refine`'s refusal (memory_budget.h) against real refinements: it
// must not fall below the points a run makes, nor lie far above them.
#include "pnsplat/refine/memory_budget.h"

#include <iostream>
#include <vector>

#include <gtest/gtest.h>

#include "pnsplat/refine/input.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/refiner.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "test_data.h"

namespace pnsplat {
namespace {

// Refines `input` level by level (two threads), comparing each level's count with the estimate.
void expectEstimateCovers(PointSet input, const char* name, unsigned levels) {
    ASSERT_TRUE(completeInput(input, 2).ok());
    RefinementPlan plan;
    plan.inputPoints = input.size();
    plan.colour = input.hasColour();
    Refiner refiner(std::move(input), RefineOptions{.threads = 2});
    for (plan.levels = 1; plan.levels <= levels; ++plan.levels) {
        refiner.refineLevel();
        const double made = static_cast<double>(refiner.points().size());
        const double estimate = estimateRefinement(plan).points;
        std::cout << "    " << name << ", " << plan.levels << " level(s): " << made << " points, estimate "
                  << estimate << "\n";
        EXPECT_GE(estimate, 0.97 * made) << name << ", level " << plan.levels;
        EXPECT_LE(estimate, 1.25 * made) << name << ", level " << plan.levels;
    }
}

TEST(MemoryBudget, EstimateFollowsTheRefinement) {
    expectEstimateCovers(makeDefaultModel(), "default model", 4);
    expectEstimateCovers(sampleSphereUniform(600, 1.0f), "sphere", 4);
    if (std::filesystem::exists(test::dataDir() / "bunny-3500-random.ply"))
        expectEstimateCovers(readPly(test::dataDir() / "bunny-3500-random.ply")->points, "bunny (random)", 3);
    else
        std::cout << "    (bunny-3500-random.ply not in ../shared/data: skipped)\n";
}

TEST(MemoryBudget, TargetAndEvenOutAndThreads) {
    RefinementPlan plan;
    plan.inputPoints = 1000;
    plan.levels = 64;
    plan.targetPoints = 50000;
    EXPECT_DOUBLE_EQ(estimateRefinement(plan).points, 150000.0); // at most 3 times the target
    plan.targetPoints = 500;
    EXPECT_DOUBLE_EQ(estimateRefinement(plan).points, 1000.0); // reached already: no level runs
    plan.targetPoints = 0;
    plan.levels = 2;
    plan.evenOutFactor = 2.0f;
    EXPECT_DOUBLE_EQ(estimateRefinement(plan).points, 9000.0 * 1.05);
    plan.evenOutFactor = 1.0f;
    EXPECT_DOUBLE_EQ(estimateRefinement(plan).points, 9000.0 * 2.55);
    // Memory: 5 times the 28 bytes of a point in the file, and 84 MiB of address space per thread,
    // of which 4 MiB resident for each thread after the first.
    plan.evenOutFactor = 0.0f;
    plan.threads = 2;
    EXPECT_DOUBLE_EQ(estimateRefinement(plan).memoryBytes, 9000.0 * 140.0 + 2.0 * kMemoryPerThread);
    EXPECT_DOUBLE_EQ(estimateRefinement(plan).residentBytes,
                     9000.0 * 140.0 + kMemoryPerThread + kResidentPerThread);
    const MemoryBudget addressSpace{2.0 * kMemoryPerThread + 140.0 * 1000.0, "ulimit -v", true};
    EXPECT_EQ(pointsWithin(addressSpace, plan), 1000u);
    EXPECT_EQ(pointsWithin({kMemoryPerThread, "ulimit -v", true}, plan), 0u);
    // Resident memory: the threads after the first take 4 MiB each, so that 1,000 threads do not
    // refuse a small input for their 84 GB of address space (they did).
    EXPECT_EQ(pointsWithin({addressSpace.bytes, "physical memory", false}, plan),
              1000u + static_cast<std::size_t>((kMemoryPerThread - kResidentPerThread) / 140.0));
    plan.threads = 1000;
    EXPECT_GT(pointsWithin({8e9, "physical memory", false}, plan), 10'000'000u);
    EXPECT_EQ(pointsWithin({8e9, "ulimit -v", true}, plan), 0u);
    plan.threads = 2;
    plan.colour = plan.crease = true;
    EXPECT_DOUBLE_EQ(estimateRefinement(plan).fileBytes, 9000.0 * 44.0);
    // Attributes, a float and a uchar: 5 bytes in the file, a double each in memory.
    plan.colour = plan.crease = false;
    plan.attributes = 2;
    plan.attributeFileBytes = 5;
    EXPECT_DOUBLE_EQ(estimateRefinement(plan).fileBytes, 9000.0 * 33.0);
    EXPECT_DOUBLE_EQ(estimateRefinement(plan).memoryBytes, 9000.0 * 5.0 * 44.0 + 2.0 * kMemoryPerThread);
}

TEST(MemoryBudget, BudgetIsPositiveAndNamesItsSource) {
    const std::vector<MemoryBudget> limits = memoryLimits();
    ASSERT_FALSE(limits.empty());
    EXPECT_EQ(limits[0].source, "physical memory");
    EXPECT_FALSE(limits[0].addressSpace);
    for (const MemoryBudget& limit : limits) {
        std::cout << "    " << limit.bytes / 1e9 << " GB, set by " << limit.source << "\n";
        EXPECT_GT(limit.bytes, 0.0);
        EXPECT_FALSE(limit.source.empty());
    }
}

} // namespace
} // namespace pnsplat
