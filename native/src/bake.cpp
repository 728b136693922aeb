// A bake's per-target native work and its worker threads (native/include/quatcurve/bake.hpp).
#include "quatcurve/bake.hpp"

#include <algorithm>
#include <string>
#include <utility>

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
    : frames_(std::move(frames)),
      queue_([this](const BakeJob& job) { return bake_keys(job, frames_); }, std::min(threads, jobs.size()), window) {
    for (BakeJob& job : jobs) queue_.push(std::move(job));
    queue_.close();
}

BakedKeys BakeQueue::next() {
    if (queue_.remaining() == 0) throw InvalidArgument("BakeQueue: every job was taken already");
    return queue_.next();
}

}  // namespace quatcurve
