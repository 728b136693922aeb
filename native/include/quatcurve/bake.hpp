// A bake's per-target native work, and worker threads that do it while the caller writes the
// targets already done.
//
// A target's work (bake_keys): the curve through its keys, the key segments that break the path
// rule, and the curve's F-curve keys at the bake's frames (sample_channel_keys). Targets are
// independent, so a BakeQueue's results are those of bake_keys bit for bit whatever its thread
// count. Its worker threads never call back into the caller: a Python caller keeps the GIL while
// it writes keys into Blender, and the workers never wait for it (Python worker threads would, at
// every step between two native calls).
//
// Conventions as everywhere (docs/conventions.md): quaternion keys (w, x, y, z), Euler angles (about X, Y, Z) in
// Blender's order semantics, axis-angle keys (angle, x, y, z), radians, time in frames.
#pragma once

#include <cstddef>
#include <vector>

#include "quatcurve/channels.hpp"
#include "quatcurve/curve.hpp"
#include "quatcurve/work_queue.hpp"

namespace quatcurve {

// One target of a bake.
struct BakeJob {
    RotationMode keys_mode;       // the keys' channels: quaternion, an Euler order or axis-angle
    std::vector<double> times;    // key frames (as Curve requires them)
    std::vector<double> values;   // times.size() rows of channel_count(keys_mode) values
    Method method = Method::SLERP;
    CurveOptions options;
    RotationMode output;          // the rotation mode of the keys written
    std::vector<double> reference;   // reference rows of sample_channel_keys (empty: none)
    std::size_t reference_rows = 0;
};

// What bake_keys makes of a job.
struct BakedKeys {
    std::size_t channels = 0;  // C = channel_count(job.output)
    std::vector<float> keys;   // (C, n, 2): per output channel, n (frame, value) pairs (sample_channel_keys)
    std::vector<std::pair<std::size_t, SegmentPath>> path_rule_breaks;   // Curve::path_rule_breaks
};

// The job's curve (Curve for quaternion keys, Curve::from_euler, Curve::from_axis_angle) sampled at
// frames (n) as sample_channel_keys does, with its path-rule breaks. Throws InvalidArgument: the
// curve constructor's message for bad keys or options; "the <METHOD> curve: …" for a bad reference
// or a value that is not finite in float32.
BakedKeys bake_keys(const BakeJob& job, const std::vector<double>& frames);

// Jobs run on worker threads, taken in order by one consumer (WorkQueue: threads 0 runs each job in
// next(); at most `window` ≥ 1 finished ahead of the consumer; a job's error is rethrown by the next()
// that takes it; the destructor lets running jobs finish and joins the workers).
class BakeQueue {
public:
    BakeQueue(std::vector<double> frames, std::vector<BakeJob> jobs, std::size_t threads, std::size_t window);

    std::size_t size() const { return queue_.size(); }
    // Jobs not yet taken.
    std::size_t remaining() const { return queue_.remaining(); }
    // The next job's result, in job order: waits for it (or computes it without workers). Throws
    // the job's error, or InvalidArgument when every job was taken already.
    BakedKeys next();

private:
    const std::vector<double> frames_;
    WorkQueue<BakeJob, BakedKeys> queue_;
};

}  // namespace quatcurve
