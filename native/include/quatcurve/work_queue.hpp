// Worker threads that run independent jobs while one consumer takes the results in job order: a
// bake's targets (BakeQueue), a refit's targets (FitQueue).
//
// The workers never call back into the consumer: a Python consumer keeps the GIL while it reads and
// writes Blender data, and the workers never wait for it (Python worker threads would, at every step
// between two native calls). Jobs may be pushed while the workers run (a consumer reading targets
// one by one hands each over as soon as it is read); results come back in the order of the pushes,
// whatever the thread count, so they are those of running the jobs one after the other.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

#include "quatcurve/errors.hpp"

namespace quatcurve {

// threads: worker threads (0: each job runs in next(), on the consumer's thread). window: how many
// jobs the workers may finish ahead of the consumer (≥ 1; bounds the memory of finished results).
// A job's error is rethrown by the next() that takes it; the other jobs are unaffected. The
// destructor lets running jobs finish, starts no more, and joins the workers, so a consumer may stop
// early (an error while writing) and drop the queue.
template <class Job, class Result>
class WorkQueue {
public:
    using Work = std::function<Result(const Job&)>;

    WorkQueue(Work work, std::size_t threads, std::size_t window) : work_(std::move(work)), window_(window) {
        if (window_ < 1) throw InvalidArgument("window: must be at least 1");
        workers_.reserve(threads);
        try {
            for (std::size_t i = 0; i < threads; ++i) workers_.emplace_back([this] { run(); });
        } catch (...) {  // no thread to be had (std::system_error): stop the ones started, as the destructor would
            stop();
            throw;
        }
    }
    ~WorkQueue() { stop(); }
    WorkQueue(const WorkQueue&) = delete;
    WorkQueue& operator=(const WorkQueue&) = delete;

    // Adds a job after those pushed before. Throws InvalidArgument after close().
    void push(Job job) {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            if (closed_) throw InvalidArgument("the queue is closed: no job can be added");
            slots_.emplace_back();  // first: a worker finds a slot for every job it sees
            try {
                jobs_.push_back(std::move(job));
            } catch (...) {  // no memory: the queue stays as it was
                slots_.pop_back();
                throw;
            }
        }
        room_.notify_one();
    }
    // No more jobs: the workers end once the pushed ones are done.
    void close() {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            closed_ = true;
        }
        room_.notify_all();
    }
    // Jobs pushed so far, and those not yet taken by next().
    std::size_t size() const {
        std::lock_guard<std::mutex> lock(mutex_);
        return jobs_.size();
    }
    std::size_t remaining() const {
        std::lock_guard<std::mutex> lock(mutex_);
        return jobs_.size() - taken_;
    }
    // The next job's result, in push order: waits for it (or computes it without workers). Throws
    // the job's error, or InvalidArgument when every job pushed was taken already.
    Result next() {
        std::unique_lock<std::mutex> lock(mutex_);
        const std::size_t j = taken_;
        if (j == jobs_.size()) throw InvalidArgument("every job pushed was taken already");
        Slot slot;
        if (workers_.empty()) {
            ++taken_;
            Job& job = jobs_[j];
            lock.unlock();
            compute(job, slot);
            lock.lock();
        } else {
            finished_.wait(lock, [&] { return slots_[j].done; });
            slot = std::move(slots_[j]);
            ++taken_;
            room_.notify_all();
        }
        jobs_[j] = Job();  // not needed again (no worker touches a taken job)
        lock.unlock();
        if (slot.error) std::rethrow_exception(slot.error);
        return std::move(slot.result);
    }

private:
    struct Slot {
        bool done = false;
        Result result{};
        std::exception_ptr error;
    };

    void compute(const Job& job, Slot& slot) {
        try {
            slot.result = work_(job);
        } catch (...) {
            slot.error = std::current_exception();
        }
        slot.done = true;
    }

    void run() {
        std::unique_lock<std::mutex> lock(mutex_);
        for (;;) {
            room_.wait(lock, [this] {
                return stopping_ || (started_ == jobs_.size() && closed_) ||
                       (started_ < jobs_.size() && started_ < taken_ + window_);
            });
            if (stopping_ || started_ == jobs_.size()) return;
            const std::size_t j = started_++;
            const Job& job = jobs_[j];  // a deque's elements stay put while others are pushed
            lock.unlock();
            Slot slot;
            compute(job, slot);
            lock.lock();
            slots_[j] = std::move(slot);
            finished_.notify_all();
        }
    }

    void stop() {  // no more jobs started; running ones finish; workers joined
        {
            std::lock_guard<std::mutex> lock(mutex_);
            stopping_ = true;
        }
        room_.notify_all();
        for (std::thread& worker : workers_) worker.join();
        workers_.clear();
    }

    const Work work_;
    const std::size_t window_;
    std::deque<Job> jobs_;
    std::deque<Slot> slots_;
    mutable std::mutex mutex_;
    std::condition_variable finished_;   // a slot is done (the consumer waits)
    std::condition_variable room_;       // a job was pushed or taken, or the queue closes or stops (workers wait)
    std::size_t started_ = 0;            // jobs handed to workers so far
    std::size_t taken_ = 0;              // jobs taken by next() so far
    bool closed_ = false;
    bool stopping_ = false;
    std::vector<std::thread> workers_;
};

}  // namespace quatcurve
