// The refinement workers of the real-time refinement: threads that run node jobs (node_tree.h)
// while the render thread draws.
//
// Contract: submit() hands jobs to the pool in the order given (the caller sorts them: the
// engine's breadth-first priority); each runs NodeTree::run on one worker thread, alone, and its
// result waits in a queue until takeResults(). A job's result depends only on the job, so which
// worker runs it and how many there are changes nothing. Workers may run below the render thread's
// priority where the system allows (Linux: a nice value for their threads), so that a busy pool
// does not steal the frame. submit, takeResults, outstanding, waitIdle and waitIdleFor are for one
// thread (the render thread).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <thread>
#include <vector>

#include "pnsplat/refine/node_tree.h"

namespace pnsplat {

class NodeWorkers {
  public:
    // threads >= 1; nice: added to the workers' nice value (0: the render thread's priority).
    NodeWorkers(unsigned threads, const NodeSettings& settings, int nice = 0);
    ~NodeWorkers(); // drops the jobs not started, waits for the running ones
    NodeWorkers(const NodeWorkers&) = delete;
    NodeWorkers& operator=(const NodeWorkers&) = delete;

    unsigned threads() const { return static_cast<unsigned>(threads_.size()); }
    void submit(std::vector<NodeJob> jobs);
    // The results of the jobs finished since the last call, in the order they finished.
    std::vector<NodeJobResult> takeResults();
    // Jobs submitted whose results have not been taken yet (waiting, running or finished).
    std::size_t outstanding() const { return outstanding_; }
    // Waits until every submitted job has finished.
    void waitIdle();
    // Waits until every submitted job has finished or `limit` has passed; whether they have.
    bool waitIdleFor(std::chrono::milliseconds limit);
    // Seconds, since the pool was made, during which a job was waiting or running: the time the
    // refinement queue was not empty, measured when jobs are handed over and when the last one
    // finishes (a result waiting for takeResults does not count).
    double busySeconds();
    // Processor seconds the jobs finished so far have taken, summed over the workers: each job's
    // thread CPU time (where the system keeps it, as Linux and the BSDs do; elsewhere its
    // wall-clock time). Unlike busySeconds, a job waiting for a processor (the render thread's or
    // lavapipe's) does not count, so points generated over it is the refinement's own rate per core
    // (a little under it: jobs whose result is dropped, their node released meanwhile, count too).
    double jobSeconds();

  private:
    void loop(int nice);

    NodeSettings settings_;
    std::vector<std::thread> threads_;
    std::mutex mutex_;
    std::condition_variable wake_, done_;
    std::deque<NodeJob> queue_;
    std::vector<NodeJobResult> results_;
    std::size_t running_ = 0;
    // Busy time (busySeconds): the intervals closed so far, and the start of the open one.
    std::chrono::steady_clock::duration busy_{};
    std::chrono::steady_clock::time_point busySince_{};
    double jobSeconds_ = 0.0;     // jobSeconds
    std::size_t outstanding_ = 0; // render thread only
    bool stopping_ = false;
};

} // namespace pnsplat
