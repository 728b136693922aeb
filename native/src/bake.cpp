// A bake's per-target native work and its worker threads (native/include/quatcurve/bake.hpp).
#include "quatcurve/bake.hpp"

#include <algorithm>
#include <string>

#include "quatcurve/errors.hpp"

namespace quatcurve {

BakedKeys bake_keys(const BakeJob& job, const std::vector<double>& frames) {
    const Curve curve = curve_from_channels(job.times, job.values, job.keys_mode, job.method, job.options);
    BakedKeys baked;
    baked.path_rule_breaks = curve.path_rule_breaks();
    const std::size_t n = frames.size();
    baked.channels = channel_count(job.output);
    baked.keys.resize(baked.channels * n * 2);
    const std::string prefix = std::string("the ") + method_name(job.method) + " curve: ";
    bool finite = true;
    try {
        finite = sample_channel_keys(curve, frames.data(), n, job.output,
                                     job.reference.empty() ? nullptr : job.reference.data(), job.reference_rows,
                                     baked.keys.data());
    } catch (const InvalidArgument& error) {
        throw InvalidArgument(prefix + error.what());
    }
    if (!finite) throw InvalidArgument(prefix + "the curve gave non-finite channel values");
    return baked;
}

BakeQueue::BakeQueue(std::vector<double> frames, std::vector<BakeJob> jobs, std::size_t threads, std::size_t window)
    : frames_(std::move(frames)), jobs_(std::move(jobs)), slots_(jobs_.size()), window_(window) {
    if (window_ < 1) throw InvalidArgument("window: must be at least 1");
    threads = std::min(threads, jobs_.size());
    workers_.reserve(threads);
    try {
        for (std::size_t i = 0; i < threads; ++i) workers_.emplace_back([this] { work(); });
    } catch (...) {  // no thread to be had (std::system_error): stop the ones started, as the destructor would
        stop();
        throw;
    }
}

BakeQueue::~BakeQueue() { stop(); }

void BakeQueue::stop() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stopping_ = true;
    }
    room_.notify_all();
    for (std::thread& worker : workers_) worker.join();
    workers_.clear();
}

std::size_t BakeQueue::remaining() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return jobs_.size() - taken_;
}

void BakeQueue::work() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
        room_.wait(lock, [this] {
            return stopping_ || started_ == jobs_.size() || started_ < taken_ + window_;
        });
        if (stopping_ || started_ == jobs_.size()) return;
        const std::size_t j = started_++;
        lock.unlock();
        Slot slot;
        try {
            slot.result = bake_keys(jobs_[j], frames_);
        } catch (...) {
            slot.error = std::current_exception();
        }
        lock.lock();
        slot.done = true;
        slots_[j] = std::move(slot);
        finished_.notify_all();
    }
}

BakedKeys BakeQueue::next() {
    std::unique_lock<std::mutex> lock(mutex_);
    const std::size_t j = taken_;
    if (j == jobs_.size()) throw InvalidArgument("BakeQueue: every job was taken already");
    Slot slot;
    if (workers_.empty()) {
        ++taken_;
        lock.unlock();
        try {
            slot.result = bake_keys(jobs_[j], frames_);
        } catch (...) {
            slot.error = std::current_exception();
        }
    } else {
        finished_.wait(lock, [&] { return slots_[j].done; });
        slot = std::move(slots_[j]);
        ++taken_;
        lock.unlock();
        room_.notify_all();
    }
    jobs_[j] = BakeJob();  // its keys are not needed again (no worker touches a taken job)
    if (slot.error) std::rethrow_exception(slot.error);
    return std::move(slot.result);
}

}  // namespace quatcurve
