// The refinement workers of the real-time refinement (node_workers.h).
#include "pnsplat/refine/node_workers.h"

#include <cassert>
#include <ctime>

#ifdef __linux__
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace pnsplat {
namespace {
// The calling thread's processor time in seconds (jobSeconds), where the system keeps it; else the
// wall-clock time.
double threadSeconds() {
#ifdef CLOCK_THREAD_CPUTIME_ID
    timespec t{};
    if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t) == 0) return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
#endif
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
} // namespace

NodeWorkers::NodeWorkers(unsigned threads, const NodeSettings& settings, int nice) : settings_(settings) {
    assert(threads >= 1);
    threads_.reserve(threads);
    for (unsigned t = 0; t < threads; ++t) threads_.emplace_back([this, nice] { loop(nice); });
}

NodeWorkers::~NodeWorkers() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
        queue_.clear();
    }
    wake_.notify_all();
    for (std::thread& t : threads_) t.join();
}

void NodeWorkers::loop(int nice) {
#ifdef __linux__
    // Linux schedules threads one by one: this thread only; a failure leaves the priority as it was.
    if (nice != 0)
        setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)),
                    getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid))) + nice);
#else
    (void)nice;
#endif
    for (;;) {
        NodeJob job;
        {
            std::unique_lock lock(mutex_);
            wake_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
            if (stopping_) return;
            job = std::move(queue_.front());
            queue_.pop_front();
            ++running_;
        }
        const double jobStart = threadSeconds();
        NodeJobResult result = NodeTree::run(std::move(job), settings_);
        const double jobTime = threadSeconds() - jobStart;
        {
            std::lock_guard lock(mutex_);
            jobSeconds_ += jobTime;
            results_.push_back(std::move(result));
            --running_;
            if (running_ == 0 && queue_.empty()) busy_ += std::chrono::steady_clock::now() - busySince_;
        }
        done_.notify_all();
    }
}

void NodeWorkers::submit(std::vector<NodeJob> jobs) {
    if (jobs.empty()) return;
    outstanding_ += jobs.size();
    {
        std::lock_guard lock(mutex_);
        if (running_ == 0 && queue_.empty()) busySince_ = std::chrono::steady_clock::now();
        for (NodeJob& job : jobs) queue_.push_back(std::move(job));
    }
    wake_.notify_all();
}

std::vector<NodeJobResult> NodeWorkers::takeResults() {
    std::vector<NodeJobResult> taken;
    {
        std::lock_guard lock(mutex_);
        taken.swap(results_);
    }
    outstanding_ -= taken.size();
    return taken;
}

double NodeWorkers::busySeconds() {
    std::lock_guard lock(mutex_);
    auto busy = busy_;
    if (running_ > 0 || !queue_.empty()) busy += std::chrono::steady_clock::now() - busySince_;
    return std::chrono::duration<double>(busy).count();
}

double NodeWorkers::jobSeconds() {
    std::lock_guard lock(mutex_);
    return jobSeconds_;
}

void NodeWorkers::waitIdle() {
    std::unique_lock lock(mutex_);
    done_.wait(lock, [&] { return queue_.empty() && running_ == 0; });
}

bool NodeWorkers::waitIdleFor(std::chrono::milliseconds limit) {
    std::unique_lock lock(mutex_);
    return done_.wait_for(lock, limit, [&] { return queue_.empty() && running_ == 0; });
}

} // namespace pnsplat
