// The worker threads (worker_pool.h): every item and every graph node runs exactly once, a node
// only after all of its predecessors have finished, and an exception thrown on any worker (out of
// memory, for one) reaches the caller.
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <memory>
#include <new>
#include <random>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "pnsplat/refine/worker_pool.h"
#include "test_random.h"

namespace pnsplat {
namespace {

TEST(WorkerPool, ParallelForRunsEveryItemOnce) {
    for (const unsigned threads : {1u, 2u, 8u}) {
        WorkerPool pool(threads);
        std::vector<std::atomic<int>> runs(1000);
        pool.parallelFor(runs.size(), [&](std::size_t item, unsigned worker) {
            EXPECT_LT(worker, pool.size());
            runs[item].fetch_add(1);
        });
        for (const std::atomic<int>& r : runs) EXPECT_EQ(r.load(), 1);
    }
}

// The TaskGraph of successor lists (waitCount counted from them).
TaskGraph graphOf(const std::vector<std::vector<std::uint32_t>>& successors) {
    TaskGraph graph;
    graph.waitCount.assign(successors.size(), 0);
    graph.successorBegin.push_back(0);
    for (const std::vector<std::uint32_t>& list : successors) {
        for (const std::uint32_t s : list) {
            graph.successors.push_back(s);
            ++graph.waitCount[s];
        }
        graph.successorBegin.push_back(static_cast<std::uint32_t>(graph.successors.size()));
    }
    return graph;
}

// A random acyclic graph (edges from lower to higher node numbers, listed in a shuffled order of
// nodes so that ready nodes are not simply the first ones), with a fixed seed.
TaskGraph randomGraph(std::uint32_t nodes, double edgeChance, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::vector<std::uint32_t> rank(nodes);
    for (std::uint32_t k = 0; k < nodes; ++k) rank[k] = k;
    std::shuffle(rank.begin(), rank.end(), rng);
    std::vector<std::vector<std::uint32_t>> successors(nodes);
    for (std::uint32_t a = 0; a < nodes; ++a)
        for (std::uint32_t b = a + 1; b < nodes; ++b)
            if (test::uniform01(rng) < edgeChance) successors[rank[a]].push_back(rank[b]);
    return graphOf(successors);
}

// Each node takes a stamp from one counter when it starts and when it ends: a successor must
// start after every predecessor has ended.
void expectOrderRespected(const TaskGraph& graph, unsigned threads) {
    WorkerPool pool(threads);
    std::atomic<std::uint64_t> clock{0};
    const auto start = std::make_unique<std::atomic<std::uint64_t>[]>(graph.size());
    const auto end = std::make_unique<std::atomic<std::uint64_t>[]>(graph.size());
    std::vector<std::atomic<int>> runs(graph.size());
    runGraph(pool, graph, [&](std::uint32_t node, unsigned) {
        start[node] = clock.fetch_add(1);
        runs[node].fetch_add(1);
        volatile std::uint32_t spin = 0; // a little work, so that nodes overlap
        for (std::uint32_t k = 0; k < 200 * (node % 7); ++k) spin = spin + k;
        end[node] = clock.fetch_add(1);
    });
    for (std::uint32_t node = 0; node < graph.size(); ++node) {
        EXPECT_EQ(runs[node].load(), 1) << "node " << node;
        for (std::uint32_t k = graph.successorBegin[node]; k < graph.successorBegin[node + 1]; ++k)
            EXPECT_LT(end[node].load(), start[graph.successors[k]].load())
                << node << " -> " << graph.successors[k];
    }
}

TEST(WorkerPool, RunGraphRunsNodesOnceAfterTheirPredecessors) {
    for (const unsigned threads : {1u, 2u, 8u}) {
        expectOrderRespected(randomGraph(400, 0.01, 7), threads); // sparse: many ready at once
        expectOrderRespected(randomGraph(200, 0.2, 11), threads); // dense: long waits
        expectOrderRespected(randomGraph(300, 0.0, 13), threads); // no edges
    }
}

TEST(WorkerPool, RunGraphOfAChainIsSequential) {
    const std::uint32_t nodes = 100;
    std::vector<std::vector<std::uint32_t>> successors(nodes);
    for (std::uint32_t k = 0; k + 1 < nodes; ++k) successors[k].push_back(k + 1);
    const TaskGraph chain = graphOf(successors);
    WorkerPool pool(2);
    std::vector<std::uint32_t> order;
    runGraph(pool, chain, [&](std::uint32_t node, unsigned) { order.push_back(node); }); // never concurrent
    ASSERT_EQ(order.size(), nodes);
    for (std::uint32_t k = 0; k < nodes; ++k) EXPECT_EQ(order[k], k);
}

// A task that throws on a worker thread: without the pool catching it, std::terminate (the
// program dies of SIGABRT). Worker 0, the caller, waits until another worker has thrown, so the
// throw happens off the calling thread; the exception arrives in the caller and the pool works on.
TEST(WorkerPool, ParallelForRethrowsAWorkersExceptionInTheCaller) {
    for (const unsigned threads : {2u, 8u}) {
        WorkerPool pool(threads);
        ASSERT_EQ(pool.size(), threads);
        std::atomic<bool> thrown{false};
        EXPECT_THROW(pool.parallelFor(1000,
                                      [&](std::size_t, unsigned worker) {
                                          if (worker != 0) {
                                              thrown = true;
                                              throw std::bad_alloc();
                                          }
                                          while (!thrown) std::this_thread::yield();
                                      }),
                     std::bad_alloc);
        std::vector<std::atomic<int>> runs(100);
        pool.parallelFor(runs.size(), [&](std::size_t item, unsigned) { runs[item].fetch_add(1); });
        for (const std::atomic<int>& r : runs) EXPECT_EQ(r.load(), 1);
    }
}

// A node that throws in the middle of a chain: the nodes after it wait for it forever without the
// pool's care (and the caller unwinds past the graph's arrays while they spin on them). With it,
// runGraph throws, and no node after the failed one runs.
TEST(WorkerPool, RunGraphStopsAtANodeThatThrows) {
    const std::uint32_t nodes = 100;
    std::vector<std::vector<std::uint32_t>> successors(nodes);
    for (std::uint32_t k = 0; k + 1 < nodes; ++k) successors[k].push_back(k + 1);
    const TaskGraph chain = graphOf(successors);
    for (const unsigned threads : {1u, 2u, 8u}) {
        WorkerPool pool(threads);
        std::uint32_t last = 0;
        EXPECT_THROW(runGraph(pool, chain,
                              [&](std::uint32_t node, unsigned) {
                                  last = node;
                                  if (node == 50) throw std::bad_alloc();
                              }),
                     std::bad_alloc);
        EXPECT_EQ(last, 50u);
    }
}

TEST(WorkerPool, RunGraphOfNoNodesReturns) {
    WorkerPool pool(2);
    TaskGraph empty;
    empty.successorBegin.push_back(0);
    bool ran = false;
    runGraph(pool, empty, [&](std::uint32_t, unsigned) { ran = true; });
    EXPECT_FALSE(ran);
}

} // namespace
} // namespace pnsplat
