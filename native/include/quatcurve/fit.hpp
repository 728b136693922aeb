// Fitting Blender F-curves through an animator's keys (the add-on's fit and live refit): the samples
// a fit matches, the channel values along the curve that join the keys as keyed, and the solver.
//
// One call does what a refit computes, without Python in between (so worker threads run it whole,
// without the GIL): Curve (the method through the keys) → samples every 1/subframes frame and at
// every key → channel values of the target's rotation mode → fit_keys with the keys forced.
#pragma once

#include <cstddef>
#include <memory>
#include <vector>

#include "quatcurve/bound.hpp"
#include "quatcurve/channels.hpp"
#include "quatcurve/curve.hpp"
#include "quatcurve/reduce.hpp"
#include "quatcurve/work_queue.hpp"

namespace quatcurve {

// The samples a fit matches: every 1/subframes frame from the first key to the last (1e-9 of slack
// at the ends) without grid points within 1e-6 frames of a key or on another sample's float32 frame,
// merged with the key frames (sorted; every sample on a float32 frame of its own). key_frames must
// increase; subframes ≥ 1.
std::vector<double> fit_sample_frames(const std::vector<double>& key_frames, int subframes);

// A change of representation inside key segment `segment` (see fit_through_keys), at sample `frame`:
// of Euler branch, or of the axis-angle angle's turn.
struct EulerSwitch {
    std::size_t segment;
    double frame;
};

struct KeyFit {
    std::vector<double> times;        // the samples: fit_sample_frames, and the times the proof added
    std::vector<std::size_t> forced;  // the index in `times` of every key
    ReducedKeys keys;                 // the fitted keys (fit_keys*); max_error is at `times` only
    std::vector<EulerSwitch> switches;   // Euler branch / axis-angle turn changes between keys
    PlaybackBound proof;              // Blender's playback of `keys` against the curve at every instant
    // Each key segment's own proof (proof is their union), and what the fit was made from: a later
    // fit of the same target reuses the key segments that did not change (fit_through_keys' previous).
    std::vector<PlaybackBound> segment_proofs;
    std::shared_ptr<const Curve> curve;
    std::vector<double> key_frames, key_values;
    RotationMode mode;
    int subframes = 0;
    double tolerance = 0.0, min_gap = 0.0;
    std::size_t refitted = 0;  // key segments this call fitted (the others were the previous fit's)
};

// The fit of `curve` (through the keys at key_frames) in rotation mode `mode`: key_values holds K
// rows of channel_count(mode) values, as the fit writes them — quaternion keys with the sign the
// curve reaches them with, Euler and axis-angle keys as keyed (their turns are the curve's). The
// channel values between two keys follow the curve and join the keys as keyed:
// - QUATERNION: the curve's sign at the segment's first key, scaled by the two keys' norms
//   interpolated along the segment (stored non-unit keys stay as they are);
// - Euler: each segment continuous from its first key (quats_to_channels with that key as reference);
// - AXIS_ANGLE: axis_angle_span_channels from key to key, the axis scaled by the keys' axis lengths
//   interpolated along the segment.
// Then fit_keys (BEZIER, per channel) with every key forced, within 90% of the tolerance at the
// samples; inserted keys keep min_gap frames from them.
//
// The bound at every instant: prove_within (bound.hpp) then bounds the angle between Blender's
// playback of the keys and the curve over the WHOLE range from the first key to the last, not only
// at the samples; the times where it fails (or cannot be proved) become samples and the fit runs
// again, up to 8 rounds. fit.proof.bound is the proved bound, whatever the verdict (above the
// tolerance only where keys closer than min_gap would be needed, or where Euler channels must change
// branch between keys). A key segment left unproved is fitted again alone at 60 % and 30 % of the
// tolerance at the samples (more room for the proof between them), and where it still fails it is
// proved again just above the largest distance evaluated on it, so its bound is within a few percent
// of what the playback does there, not the bound of the interval the proof stopped at (fit.cpp:
// fit_span, tighten_failed).
//
// Euler branches: each segment's channels follow the curve continuously from its first key (or
// back from its second). Where that reaches the other key on another Euler branch, the channels
// change branch once: beside a key at gimbal lock (where the first and last angles move together
// without moving the rotation; a sample 1.05·min_gap from such a key keeps the change short), else at
// the sample nearest gimbal lock (fit.switches lists both), and the proof bounds what that costs.
// A change no nearer than 5° to the lock is refused (InvalidArgument naming the keys' frames).
// Axis-angle the same way: where the path reaches the second key's values only on another turn of
// the angle (or with the axis reversed), the channels change at the jump that leaves the samples'
// arc least (axis_angle_span_channels: astride the path's closest approach to the rest pose, where
// every axis is the same rotation); a change at a sample further than 5° from the rest pose, or
// one that would play a whole turn between two samples, is refused naming the keys' frames. A key
// at the rest pose (angle a multiple of 2π: any axis) gets the sample beside it, as a key at gimbal
// lock does, where its axis turns to the path's. Keys keep their values: the curve is made from
// them, so a refit sees the same path.
//
// A refit (`previous`: the last fit of the same target, after an edit of its keys): every channel's
// playback on a key segment depends only on the keys and handles inside it, so a key segment whose
// two keys (frames and values) and whose curve (Curve::same_key_segment: the method's data of the
// segment, bit for bit) are the previous fit's keeps the previous fit's keys, handles, samples and
// proof there; the others are fitted and proved as above, run by run of changed segments (a run's
// end keys keep their outer handles). SQUAD, TCB and CATMULL_ROM change at most the two segments
// on either side of a moved key, SLERP and NLERP the two beside it; SPLINE_C2 changes every
// segment up to where the change falls below the last bit. Nothing is reused when the mode,
// subframes, tolerance (beyond a float32 rounding of it) or min_gap differ. The result is what a fit of the whole range proves: its
// bound holds at every instant from the first key to the last. Throws InvalidArgument for fewer
// than two keys, mismatched sizes, a tolerance that is not above 0, and whatever the steps throw.
KeyFit fit_through_keys(const Curve& curve, const std::vector<double>& key_frames,
                        const std::vector<double>& key_values, const RotationMode& mode, int subframes,
                        double tolerance, double min_gap = 0.01, const KeyFit* previous = nullptr);

// A target's whole fit in one call (the add-on's fit and live refit run it on worker threads, without
// the GIL): the curve of `method` through keys given as channel values of `mode` (curve_from_channels,
// K rows of channel_count(mode) values as stored), then fit_through_keys. Quaternion keys are first
// given the sign the curve reaches them with — a key whose 4-vector dot product with the curve at its
// frame is below 0 is negated (the same rotation; Blender lerps the stored channels, so the sign
// decides the path between keys) — Euler and axis-angle keys are fitted as keyed (their turns are the
// curve's). KeyFit::curve and KeyFit::key_values are that curve and the keys as the fit writes them.
// Throws InvalidArgument as curve_from_channels and fit_through_keys do.
KeyFit fit_channels(const std::vector<double>& key_frames, const std::vector<double>& key_values,
                    const RotationMode& mode, Method method, const CurveOptions& options, int subframes,
                    double tolerance, double min_gap = 0.01, const KeyFit* previous = nullptr);

// One target of a FitQueue: fit_channels' arguments. `previous` must outlive the job (the queue's
// owner keeps it until the job is taken).
struct FitJob {
    std::vector<double> key_frames, key_values;
    RotationMode mode;
    Method method = Method::SLERP;
    CurveOptions options;
    int subframes = 1;
    double tolerance = 0.0, min_gap = 0.01;
    const KeyFit* previous = nullptr;
};

// fit_channels of each job pushed, on worker threads, taken in push order (WorkQueue): a refit of
// many targets hands each over as soon as it is read, and writes each result while the workers fit
// the next ones. The results are fit_channels' bit for bit, whatever the thread count.
class FitQueue {
public:
    FitQueue(std::size_t threads, std::size_t window);
    void push(FitJob job) { queue_.push(std::move(job)); }
    void close() { queue_.close(); }
    std::size_t size() const { return queue_.size(); }
    std::size_t remaining() const { return queue_.remaining(); }
    // The next job's KeyFit: waits for it. Throws the job's error (fit_channels'), or InvalidArgument
    // when every job pushed was taken already.
    KeyFit next() { return queue_.next(); }

private:
    WorkQueue<FitJob, KeyFit> queue_;
};

}  // namespace quatcurve
