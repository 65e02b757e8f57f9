// Worker threads with a generation counter: each parallelFor wakes all workers once.
#include "pnsplat/refine/worker_pool.h"

#include <memory>
#include <system_error>
#include <utility>

namespace pnsplat {

WorkerPool::WorkerPool(unsigned threads) {
    if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
    threads_.reserve(threads - 1);
    try {
        for (unsigned w = 1; w < threads; ++w) threads_.emplace_back([this, w] { workerLoop(w); });
    } catch (const std::system_error&) {
        // The system refused a thread (EAGAIN: no memory for its stack, or too many processes):
        // the pool works with those started.
    }
}

WorkerPool::~WorkerPool() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : threads_) t.join();
}

void WorkerPool::runItems(unsigned worker) {
    for (;;) {
        const std::size_t item = next_.fetch_add(1, std::memory_order_relaxed);
        if (item >= count_) return;
        try {
            (*task_)(item, worker);
        } catch (...) {
            std::lock_guard lock(mutex_);
            if (!failure_) failure_ = std::current_exception();
            next_.store(count_, std::memory_order_relaxed); // start no further item
            return;
        }
    }
}

void WorkerPool::workerLoop(unsigned worker) {
    std::uint64_t seen = 0;
    for (;;) {
        {
            std::unique_lock lock(mutex_);
            wake_.wait(lock, [&] { return stopping_ || generation_ != seen; });
            if (stopping_) return;
            seen = generation_;
        }
        runItems(worker);
        {
            std::lock_guard lock(mutex_);
            if (--busy_ == 0) done_.notify_one();
        }
    }
}

void WorkerPool::parallelFor(std::size_t count, const std::function<void(std::size_t, unsigned)>& task) {
    if (count == 0) return;
    if (threads_.empty() || count == 1) {
        for (std::size_t item = 0; item < count; ++item) task(item, 0);
        return;
    }
    {
        std::lock_guard lock(mutex_);
        task_ = &task;
        count_ = count;
        next_.store(0, std::memory_order_relaxed);
        busy_ = static_cast<unsigned>(threads_.size());
        ++generation_;
    }
    wake_.notify_all();
    runItems(0);
    std::unique_lock lock(mutex_);
    done_.wait(lock, [&] { return busy_ == 0; });
    task_ = nullptr;
    if (failure_) std::rethrow_exception(std::exchange(failure_, nullptr));
}

// Node k of the ready list is run by item k of a parallelFor: items are taken in increasing order,
// so when item k is taken every earlier item has been taken, and it waits only while the nodes
// run so far have not yet released a k-th ready node; an acyclic graph always has one more.
void runGraph(WorkerPool& pool, const TaskGraph& graph,
              const std::function<void(std::uint32_t, unsigned)>& task) {
    const std::size_t count = graph.size();
    constexpr std::uint32_t kNotYet = UINT32_MAX;
    const auto waiting = std::make_unique<std::atomic<std::uint32_t>[]>(count);
    const auto ready = std::make_unique<std::atomic<std::uint32_t>[]>(count);
    std::atomic<std::size_t> readyEnd{0};
    std::atomic<bool> failed{false}; // a task threw: the nodes after it will never be ready
    const auto release = [&](std::uint32_t node) {
        ready[readyEnd.fetch_add(1, std::memory_order_relaxed)].store(node, std::memory_order_release);
    };
    for (std::size_t k = 0; k < count; ++k) {
        waiting[k].store(graph.waitCount[k], std::memory_order_relaxed);
        ready[k].store(kNotYet, std::memory_order_relaxed);
    }
    for (std::uint32_t k = 0; k < count; ++k)
        if (graph.waitCount[k] == 0) release(k);
    pool.parallelFor(count, [&](std::size_t item, unsigned worker) {
        std::uint32_t node;
        while ((node = ready[item].load(std::memory_order_acquire)) == kNotYet) {
            if (failed.load(std::memory_order_relaxed)) return;
            std::this_thread::yield();
        }
        try {
            task(node, worker);
        } catch (...) {
            failed.store(true, std::memory_order_relaxed);
            throw;
        }
        for (std::uint32_t k = graph.successorBegin[node]; k < graph.successorBegin[node + 1]; ++k) {
            const std::uint32_t next = graph.successors[k];
            if (waiting[next].fetch_sub(1, std::memory_order_acq_rel) == 1) release(next);
        }
    });
}

} // namespace pnsplat
