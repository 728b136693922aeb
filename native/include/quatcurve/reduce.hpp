// Key reduction with a guaranteed angular error bound.
//
// Input: dense samples of a rotation — times (frames, strictly increasing) and quaternions
// (w, x, y, z), Euler angles (about X, Y, Z, radians, Blender order) or axis-angle channels (angle
// in radians, axis x, y, z). Output: the keys Blender should store on the rotation F-curves — one
// F-curve per channel (w, x, y, z; X, Y, Z angle; angle, x, y, z) —
// such that Blender's own evaluation of those keys stays within `tolerance` (radians, geodesic
// rotation angle, sign-invariant for quaternions) of EVERY input sample:
//
//   LINEAR  Blender evaluates each channel linearly between keys (float32), then, for quaternions,
//           normalizes the 4-vector (no hemisphere fix), for Euler builds the rotation from the
//           three angles, for axis-angle the rotation of the angle about the normalized axis (a
//           zero axis: the identity). Keys are input samples, stored as given (rounded to float32).
//   BEZIER  Blender's Bezier segment: a cubic in (frame, value) through the two keys with the left
//           key's right handle and the right key's left handle as inner control points. Handle
//           frames sit at 1/3 and 2/3 of each segment, where the frame is (up to float32 rounding of
//           the handle frames) linear in the curve parameter; a quaternion segment that cannot meet
//           the tolerance so, at tolerances from 0.01°, is tried with handle frames at 0.2 or 0.5 of
//           the segment from either key (the two never crossing: Blender plays them as stored), which
//           lets the curve speed up or slow down near a key. The handle values are fitted by weighted
//           least squares in the rotation metric, then by iterative reweighting toward the minimax
//           fit. Each segment has its own handles: tangents are broken at keys, so the F-curves need
//           handle_left_type = handle_right_type = 'FREE' (set the types BEFORE the coordinates, or
//           Blender recomputes the handles). Key values are input samples (float32).
//
// The bound is verified, not hoped for: after fitting, every input sample is evaluated exactly as
// Blender's fcurve_eval_keyframes does (blender_eval.hpp: float32 key frames, values and handles; float32 arithmetic;
// Blender's cubic root finder for the Bezier frame→parameter step; binary-search threshold 1e-4
// frames), and segments that exceed the bound are refitted or split (a key inserted) until every
// sample passes. The verification threshold keeps a margin of 2e-6 rad below `tolerance` (half the
// tolerance when that is below 4e-6): Blender's own float32 arithmetic may round differently from
// the emulation (its Bezier value is a float power-basis cubic, ~6e-7 per channel).
//
// Limits, stated: the keys themselves are input values rounded to float32, so a sample on a key is
// off by up to ~2.5e-7 rad; a tolerance below that cannot be met and keeps every key (max_error then
// reports the float32 floor). Between samples nothing is promised by this bound (reduce_keys_proved
// and reduce_curve_proved below prove one there against a reference); the fit is guarded there (see
// reduce.cpp): midway between samples the result stays within twice the tolerance plus a
// quarter of the local per-sample rotation step of the dense input's own LINEAR evaluation. Samples closer than 1e-4 frames to a key evaluate to that key in Blender.
// Quaternion input should be hemisphere-continuous (consecutive dot products ≥ 0; flip signs first
// if needed): values are kept as given, and Blender interpolates a sign flip through zero, so a flip
// forces keys on both sides of it. Non-unit quaternions are allowed (the reference rotation is the
// normalized sample; the stored values keep their scale).
//
// Key choice: greedy — from each key, the farthest end whose fitted segment passes (exponential then
// binary search), then a pass that removes keys whose neighbours can be joined. synchronized = true
// keeps the same frames on every channel (what glTF export and hand editing want); false gives each
// channel its own keys, fitted one channel after the other (quaternions w, x, y, z; Euler X, Y, Z),
// each against the others' fitted curves under a growing share of the tolerance, then once more
// removes the keys of the channels chosen first whose neighbours join under the whole tolerance
// against the others' final curves, and returns that or the synchronized result, whichever has
// fewer keys in total (the synchronized one on a tie). The synchronized choice is given up once its
// keys up to a sample outnumber the per-channel ones there (per channel) by a tenth and one key
// (reduce_impl.hpp, kPaceSlack): it then returns the per-channel result, even where the synchronized
// one would have caught up.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "quatcurve/blender_eval.hpp"
#include "quatcurve/bound.hpp"
#include "quatcurve/channels.hpp"
#include "quatcurve/curve.hpp"
#include "quatcurve/euler.hpp"
#include "quatcurve/types.hpp"

namespace quatcurve {

// The keys of one F-curve, as Blender stores them (blender_eval.hpp evaluates them as Blender does).
// Every frame and value is float32-representable (Blender stores floats), so writing them with
// foreach_set from float32 arrays is exact:
//   frames = float32(times[indices]), values = float32(channel value at indices);
//   BEZIER: handle_left/handle_right absolute (frame, value) per key. The first key's left handle
//   and the last key's right handle only shape extrapolation, which is constant (Blender's
//   default): they mirror the inner handle. LINEAR: empty.
struct ReducedChannel : FCurveKeys {
    std::vector<std::size_t> indices;  // kept input samples, increasing; first and last included
};

struct ReducedKeys {
    KeyInterpolation interpolation = KeyInterpolation::LINEAR;
    bool synchronized = true;              // every channel has the same indices
    std::vector<ReducedChannel> channels;  // 4 (w, x, y, z), 3 (angles about X, Y, Z) or 4 (angle, x, y, z)
    double max_error = 0.0;                // largest error over all input samples (radians), emulated
    std::size_t key_count() const;         // sum of keys over channels (Blender's keyframe_points)
};

// Reduce quaternion samples. times: n strictly increasing finite frames, still strictly increasing
// once rounded to float32 (Blender's frame storage); quats: n finite nonzero
// quaternions; tolerance: finite, ≥ 0 radians. tolerance 0 keeps every sample; constant motion gives
// two keys (one for n = 1). Throws InvalidArgument naming the argument and element ("times[5]: not
// increasing", "quats[3]: zero-length quaternion", "tolerance: must be finite and >= 0").
ReducedKeys reduce_keys(const std::vector<double>& times, const std::vector<Quat>& quats,
                        double tolerance, KeyInterpolation interpolation = KeyInterpolation::LINEAR,
                        bool synchronized = true);

// Reduce Euler samples (angles about X, Y, Z in radians, Blender order). The bound is on the rotation
// Blender builds from the three evaluated angles. Angles are kept as given: pass a continuous
// sequence (euler_filter) or every 2π jump forces keys.
ReducedKeys reduce_keys_euler(const std::vector<double>& times, const std::vector<Vec3>& angles,
                              EulerOrder order, double tolerance,
                              KeyInterpolation interpolation = KeyInterpolation::LINEAR,
                              bool synchronized = true);

// Reduce axis-angle samples: values[k] = (angle, x, y, z) as Blender's rotation_axis_angle (radians;
// the axis need not be unit: Blender normalizes it, and the fit may let its length drift). The bound
// is on the rotation Blender builds from the four evaluated channels. Values are kept as given: pass
// a continuous sequence (quats_to_channels 'AXIS_ANGLE') — an angle jump above π or an axis turning
// over between two samples forces keys on both sides. Throws as reduce_keys, and for a non-finite
// value or a zero-length axis ("values[3]: zero-length axis").
ReducedKeys reduce_keys_axis_angle(const std::vector<double>& times, const std::vector<Vec4>& values,
                                   double tolerance, KeyInterpolation interpolation = KeyInterpolation::LINEAR,
                                   bool synchronized = true);

// ---- fitting with given keys ---------------------------------------------------------------------
// The same solver with keys the caller fixes: every sample listed in `forced` (indices, strictly
// increasing) is a key of every channel, with its value as given — an animator's own keys — and
// the reducer inserts as few keys between them as the tolerance needs (the first and last samples
// are always keys; reduce_keys is fit_keys with no forced keys). An inserted key keeps at least
// `min_gap` frames from every forced key (Blender 4.x merges keys closer than 0.01 frames on
// fcurve.update()); a segment with no sample far enough from its forced ends keeps no inserted key
// and max_error reports what it reaches. BEZIER handles are fitted per segment (FREE handles), so a
// forced key's two handles are set too. Throws InvalidArgument for a forced index out of range or
// not increasing, and for min_gap < 0, besides reduce_keys' own checks.
ReducedKeys fit_keys(const std::vector<double>& times, const std::vector<Quat>& quats,
                     const std::vector<std::size_t>& forced, double tolerance,
                     KeyInterpolation interpolation = KeyInterpolation::BEZIER, bool synchronized = false,
                     double min_gap = 0.01);
ReducedKeys fit_keys_euler(const std::vector<double>& times, const std::vector<Vec3>& angles, EulerOrder order,
                           const std::vector<std::size_t>& forced, double tolerance,
                           KeyInterpolation interpolation = KeyInterpolation::BEZIER, bool synchronized = false,
                           double min_gap = 0.01);
ReducedKeys fit_keys_axis_angle(const std::vector<double>& times, const std::vector<Vec4>& values,
                                const std::vector<std::size_t>& forced, double tolerance,
                                KeyInterpolation interpolation = KeyInterpolation::BEZIER,
                                bool synchronized = false, double min_gap = 0.01);

// ---- a reduction proved at every instant ---------------------------------------------------------
// The bound above holds at the samples. These reduce against a REFERENCE that can be evaluated at any
// time — the original keys' own playback (Blender's evaluation of them, bound.hpp's PlaybackMotion),
// or a method's curve — and prove with prove_within (bound.hpp) that the reduced keys' playback
// stays within `tolerance` of it at EVERY time from the first sample to the last:
//   1. reduce the samples as reduce_keys* does, at 93% of the tolerance (90% below 0.01°; the rest
//      is the room the proof between samples needs), with the reference midway between each two
//      samples as a further sample;
//   2. prove the reduced playback against the reference between the samples;
//   3. where that fails — the times where the angle is above the tolerance, and the middle of every
//      interval left unproven — add samples (there and at the quarters of the sample intervals
//      around: the reference's channel values, continuous with the sample before) and repair the
//      keys on them: every segment keeps its keys and handles, and those where a sample fails are
//      refitted or split as verification does (reduce_impl::repair) in the second round, where the
//      proof added at most half as many samples as there were, the repair meets the share and keeps
//      at most a tenth more keys (and one per channel); the samples are reduced afresh otherwise, in
//      later rounds and where Euler rows were chained again; at most 8 rounds.
// Keys sit on given samples: the samples added (midpoints, the proof's) are checked like the others
// and become candidates for keys only between two given samples where keys on given samples cannot
// meet them (a Euler path sweeping through gimbal lock within a frame). The proof of the last
// reduction is returned whatever its verdict: its bound holds at every instant of the proved spans
// either way.
//
// The original's own sign flips (reduce_keys_proved, quaternion mode): where the original's stored
// quaternions lie in opposite hemispheres at two neighbouring samples, Blender interpolates the four
// channels through near zero — a fast turn of up to 360° inside that interval, which no
// hemisphere-continuous reduction follows. There the result keeps the original's keys instead: from
// the last sample before the flip where every channel has a key (a channel of one key is constant and
// counts as keyed everywhere) to the first one after it — the first or last sample where there is
// none — each channel's keys in that span are copied bit for bit (frames, values with their stored
// signs, handles; a constant channel gets two keys holding its value at the span's ends), and their
// segments keep the original's interpolation (`copied_interpolation`). Blender's playback of the
// span is then the original's, exactly: that is the proof there, and the bound covers it. The pieces
// between the spans are reduced and proved as above, each on its own, from the quaternion signs the
// original stores there; a piece's end keys sit on the span's end keys with their values, so a key
// at a span's end has the left handle of the part before it and the right handle of the part after.
// The samples' values are taken with the sign of the original's playback at their time.
//
// Where the proof fails after every round (reduce_keys_proved: keys a few hundredths of a frame
// apart, a violation just outside a key's snap zone, nearer a sample than a sample may be added), the
// original's keys are copied there too, as around a flip: the span from the samples on either side of
// each failing time, 1 sample more on each side, widened to samples where every channel has a key;
// the pieces between reduced again; then 4 and 16 samples more while a piece stays unproved.
//
// Never more keys than the original, never unproved (reduce_keys_proved): where the result would keep
// more keys than the original's channels hold (a constant channel counting two) or is still unproved,
// every channel's keys lie within [times.front(), times.back()] and the tolerance is above 0, the
// result is the original's keys copied whole as one span (as above; proof bound 0).
//
// tolerance 0 keeps every sample (as reduce_keys does) and proves nothing between them: the proof
// then has bound +∞ and the whole range unproven.
struct ProvedKeys {
    // The reduced keys (max_error: at `times`, emulated). A key whose frame lies in a `copied` span
    // [f0, f1) has the interpolation `copied_interpolation` (the segment after it is the original's),
    // every other key `keys.interpolation`. Handles on every key where either is BEZIER (sides no
    // BEZIER segment uses lie on the straight segment, segment_handles).
    ReducedKeys keys;
    PlaybackBound proof;  // the reduced playback against the reference over the reduced pieces, merged
    std::vector<std::pair<double, double>> copied;  // frame spans whose keys are the original's (flips, unproved)
    KeyInterpolation copied_interpolation = KeyInterpolation::LINEAR;
    std::vector<double> times;  // the samples of the last reduction: the given ones, those added, copied key frames
    int rounds = 0;             // rounds made (1: the first was proved); with copied spans, the most of a piece
};

// Reduce the samples (times, values: n rows of channel_count(mode) channel values, Blender's
// evaluation of `original`) of a rotation whose keys are `original` (channel_count(mode) F-curves,
// every segment of each `original_interpolation`; the channels of `mode` in order), proved against
// the original's own playback at every time from the first sample to the last, the original's sign
// flips included (copied, above). Quaternion values take the sign the original stores at their time,
// and each reduced piece is hemisphere-continuous; Euler and axis-angle values are kept as given.
// one_key_channels: where the keys are the whole result (no copied span) and not synchronized, a
// channel that one value meets at every sample keeps one key, at times[0] with flat handles
// (reduce_impl::flatten_channels); false keeps each channel's first and last key (a loop's period,
// whose Cycles modifiers repeat each channel's own key range). Throws InvalidArgument as
// PlaybackMotion (the original keys), as reduce_keys* (times, values, tolerance), and for a values
// count that is not n rows.
ProvedKeys reduce_keys_proved(const std::vector<FCurveKeys>& original, KeyInterpolation original_interpolation,
                              const RotationMode& mode, const std::vector<double>& times,
                              const std::vector<double>& values, double tolerance,
                              KeyInterpolation interpolation = KeyInterpolation::BEZIER, bool synchronized = false,
                              bool one_key_channels = true);

// The same against a method's curve: values are the curve's rotations at `times` as channel values of
// `mode` (quats_to_channels, with whatever reference the caller chose: they are kept as given, made
// hemisphere-continuous for quaternions); a sample the proof adds takes the curve's rotation there
// as channel values continuous with the sample before, and Euler rows are then made one compatible
// chain again (euler_filter_from_anchor: the row farthest from gimbal lock keeps its values), so no
// change of branch is left between two samples where the path swings past gimbal lock between
// frames. Nothing is copied (`copied` is empty).
ProvedKeys reduce_curve_proved(const Curve& curve, const RotationMode& mode, const std::vector<double>& times,
                               const std::vector<double>& values, double tolerance,
                               KeyInterpolation interpolation = KeyInterpolation::BEZIER, bool synchronized = false,
                               bool one_key_channels = true);

// A change of rotation mode proved at every instant (the add-on's convert): the samples (times,
// values: n rows of channel_count(to) values, Blender's playback of `original` there turned into
// `to`'s channels, continuous from sample to sample) reduced to BEZIER keys in mode `to` per channel,
// with a key on every `forced` sample (indices into times, increasing; no inserted key within
// min_gap frames of one), and their playback proved against the original's own (channel_count(from)
// F-curves of mode `from`, every segment of `original_interpolation`) at every time from the first
// sample to the last, round after round as reduce_keys_proved does; a sample the proof adds takes the
// original's rotation there as `to`'s channels, continuous with the sample before (Euler rows
// chained again as reduce_curve_proved's). Nothing is
// copied: Blender swings through a quaternion original's own sign flip, and the keys follow that swing
// as far as the proof reaches (its bound says how far). Throws InvalidArgument as reduce_keys_proved,
// for a tolerance that is not above 0 and for forced indices that do not increase within the samples.
ProvedKeys convert_keys_proved(const std::vector<FCurveKeys>& original, KeyInterpolation original_interpolation,
                               const RotationMode& from, const RotationMode& to, const std::vector<double>& times,
                               const std::vector<double>& values, const std::vector<std::size_t>& forced,
                               double tolerance, double min_gap);

}  // namespace quatcurve
