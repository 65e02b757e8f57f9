// The worker threads of the refinement, in one place.
//
// Contract: a WorkerPool owns `threads - 1` threads; the thread that calls parallelFor is worker 0
// and takes part. parallelFor(count, task) runs task(item, worker) once for every item in
// [0, count), items handed out dynamically, and returns when all are done (the return
// synchronises with every task). Which worker runs which item varies from run to run: tasks must
// write only memory that no other item of the same call reads or writes, and results must not
// depend on `worker` except through per-worker scratch memory. parallelFor is not reentrant and
// must be called from one thread at a time.
//
// Exceptions: when a task throws (std::bad_alloc on any worker, for one), the pool stops handing
// out items; parallelFor waits for the items already running and rethrows the first exception in
// the calling thread, where it unwinds as if the caller had thrown it. The pool stays usable.
#pragma once

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace pnsplat {

class WorkerPool {
  public:
    // threads = 0 picks std::thread::hardware_concurrency(). Threads that the system refuses to
    // start (out of memory for their stacks, or a limit on processes) are left out: size() counts
    // those running, and results do not depend on it.
    explicit WorkerPool(unsigned threads);
    ~WorkerPool();
    WorkerPool(const WorkerPool&) = delete;
    WorkerPool& operator=(const WorkerPool&) = delete;

    unsigned size() const { return static_cast<unsigned>(threads_.size()) + 1; }

    void parallelFor(std::size_t count, const std::function<void(std::size_t item, unsigned worker)>& task);

  private:
    void workerLoop(unsigned worker);
    void runItems(unsigned worker);

    std::vector<std::thread> threads_;
    std::mutex mutex_;
    std::condition_variable wake_;
    std::condition_variable done_;
    const std::function<void(std::size_t, unsigned)>* task_ = nullptr;
    std::size_t count_ = 0;
    std::atomic<std::size_t> next_{0};
    std::uint64_t generation_ = 0;
    unsigned busy_ = 0;
    bool stopping_ = false;
    std::exception_ptr failure_; // the first exception a task of the current call threw
};

// A dependency graph of tasks for runGraph: node k waits for waitCount[k] predecessors, and its
// successors are successors[successorBegin[k], successorBegin[k + 1]). It must be acyclic, and
// waitCount[k] must be the number of times k is listed as a successor.
struct TaskGraph {
    std::vector<std::uint32_t> waitCount;
    std::vector<std::uint32_t> successorBegin; // nodes + 1 entries
    std::vector<std::uint32_t> successors;
    std::size_t size() const { return waitCount.size(); }
};

// Runs task(node, worker) once for every node of `graph` on the pool's workers, each node after all
// of its predecessors have returned (their writes are visible to it), and returns when all are
// done. Nodes that do not depend on each other run in any order, concurrently: they must not write
// what the other reads or writes. A worker with no node ready waits (yielding) for one. Same
// calling rules as parallelFor; when a task throws, the nodes not yet started never start (those
// waiting for it stop waiting) and runGraph rethrows the first exception.
void runGraph(WorkerPool& pool, const TaskGraph& graph,
              const std::function<void(std::uint32_t node, unsigned worker)>& task);

// pool.parallelFor over consecutive ranges of `chunk` items: body(begin, end, worker) for every
// range [begin, end) of [0, n) (the last may be shorter), under parallelFor's contract.
template <typename Body>
void parallelForRanges(WorkerPool& pool, std::size_t n, std::size_t chunk, const Body& body) {
    pool.parallelFor((n + chunk - 1) / chunk, [&](std::size_t item, unsigned worker) {
        body(item * chunk, std::min(n, (item + 1) * chunk), worker);
    });
}

} // namespace pnsplat
