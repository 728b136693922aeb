// The fewest slerp keys for dense quaternion samples: what a glTF LINEAR rotation sampler plays.
//
// glTF 2.0 (Appendix C, "Spherical Linear Interpolation") plays a LINEAR rotation sampler between
// keys v_k, v_k+1 at t ∈ [0, 1] as
//
//   a = arccos(|v_k · v_k+1|),  s = sign(v_k · v_k+1),
//   v(t) = sin(a·(1 − t))/sin(a) · v_k + s · sin(a·t)/sin(a) · v_k+1
//
// (the shortest way round between the two rotations, whatever their signs). gltf_slerp computes it;
// reduce_slerp chooses keys among the samples so that this evaluation stays within `tolerance` of
// every sample.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "quatcurve/bound.hpp"
#include "quatcurve/types.hpp"

namespace quatcurve {

// The glTF slerp above on â = a/|a| and b̂ = b/|b|, for t in [0, 1] (any finite t extrapolates along
// the same great circle). The angle is taken as 2·atan2(|â − s·b̂|, |â + s·b̂|) (= arccos|â·b̂|,
// accurate near 0); below 1e-7 rad the formula's limit (â·(1 − t) + s·b̂·t, normalized) is used.
// The result is unit. Throws InvalidArgument on zero or non-finite a, b.
Quat gltf_slerp(const Quat& a, const Quat& b, double t);

struct SlerpKeys {
    std::vector<std::size_t> indices;  // kept samples, increasing; first and last included
    std::vector<Quat> quats;           // the kept samples, normalized, each in the hemisphere of the one before
    double max_error = 0.0;            // largest angle (radians) between a sample and the keys' slerp
};

// Keys among dense samples (times strictly increasing and finite, any unit; quats finite, nonzero)
// such that gltf_slerp between consecutive kept keys, at each sample's time, stays within
// `tolerance` (radians, geodesic angle, finite, ≥ 0) of every sample (angle_between: sign-invariant).
//
// Key choice: greedy from the first sample. From key i the end j grows by doubling while the segment
// (i, j) passes, then a binary search between the last passing and the first failing end; the
// largest end found to pass is kept. Every kept segment is verified on every sample inside it, so the
// bound holds whatever the motion; the count is not always the minimum (a longer segment can pass
// where a shorter one failed). Two samples give both; one sample gives it; constant motion gives
// the first and the last. A motion that turns more than 180° between samples cannot be played by
// slerp between those samples: both stay keys and max_error reports the miss.
//
// Samples are compared as given (their rounding is the caller's: pass times and quaternions as the
// file will store them, e.g. float32, to verify what a reader evaluates). Throws InvalidArgument
// naming the argument and element ("times[3]: not increasing", "quats[2]: zero-length quaternion",
// "tolerance: must be finite and >= 0", "quats: 3 rows for 4 times").
//
// cyclic: the samples are one period of a loop (curve.hpp "Loops"): the last sample is the first
// rotation one period later (within kLoopTolerance, either sign; otherwise InvalidArgument names both
// samples, their times and the angle). The first and last samples stay keys and the last key is the
// first key's rotation exactly (in the hemisphere of the key before it), so a player that loops the
// keys (glTF: the animation repeated) joins the seam without a step; slerp segments are independent,
// so the error across the seam is that of the segments on either side.
SlerpKeys reduce_slerp(const std::vector<double>& times, const std::vector<Quat>& quats, double tolerance,
                       bool cyclic = false);

// The rotation glTF plays from slerp keys at each of `at` (in the keys' unit): the keys (their quaternions
// rounded to float32, as a file stores them) between the two around t; before the first key the
// first, after the last the last; cyclic keys (one period) repeat, t wrapped into their range. key
// times increasing, at least one key. Throws InvalidArgument for sizes that differ or no key.
std::vector<Quat> play_slerp_keys(const std::vector<double>& key_times, const std::vector<Quat>& keys,
                                  const std::vector<double>& at, bool cyclic = false);

// ---- slerp keys proved at every instant --------------------------------------------------------------
// reduce_slerp holds its keys to the samples. reduce_slerp_proved holds them to a REFERENCE motion
// (bound.hpp: a method's curve, or Blender's playback of a rotation's keys) at EVERY time from
// times[0] to times[-1]:
//   1. the reference at `times` (its sign-continuous rotations) reduced by reduce_slerp at 90% of the
//      tolerance (the rest is room for the proof between samples);
//   2. the keys' slerp (a SLERP Curve through them: glTF's formula, bi-invariant, so a player's
//      A·q·B of them is the same motion turned) proved against the reference by prove_within;
//   3. where that fails — the times above the tolerance and the middle of each interval left
//      unproven — the reference there becomes a sample (an eighth of the interval in from a sample it
//      lies by; no closer than 1/1024 frame to another), and the reduction runs again; at most 8
//      rounds.
// Keys sit on samples (the given ones and those added). The proof of the last round is returned
// whatever its verdict: its bound holds at every instant of the range. `cyclic`: as reduce_slerp
// (the reference's first and last rotations one loop's seam). Times in the reference's unit (frames);
// `file_unit` > 0 (seconds per frame, for a file that stores float32 seconds) makes every added sample
// a time the file stores exactly, float32(t·file_unit)/file_unit, as the given ones should be: the
// keys then play at the times proved. `excluded`: spans (sorted, disjoint) whose sample intervals are
// left out of the proof — a playback's own quaternion sign flips, where Blender turns through the
// flip and the slerp keys rightly take the short way; they are returned in ProvedSlerpKeys::excluded. Throws InvalidArgument as reduce_slerp, and for fewer than
// two times or a file_unit that is negative or not finite.
struct ProvedSlerpKeys {
    std::vector<double> times;  // the samples of the last round: the given ones and those added
    SlerpKeys keys;             // indices into `times`
    PlaybackBound proof;        // the keys' slerp against the reference over [times[0], times[-1]]
    std::vector<std::pair<double, double>> excluded;  // sample intervals left out of the proof
    int rounds = 0;             // reductions made (1: the first was proved)
};

ProvedSlerpKeys reduce_slerp_proved(const Motion& reference, const std::vector<double>& times, double tolerance,
                                    bool cyclic = false, double file_unit = 0.0,
                                    std::vector<std::pair<double, double>> excluded = {});

// The spans of a quaternion playback's own sign flips, for reduce_slerp_proved's `excluded`: where two
// neighbouring `times` see its channel values (as Blender evaluates them, before normalizing) in
// opposite hemispheres, the key segment around them (from the key before to the key after).
std::vector<std::pair<double, double>> quaternion_flips(const PlaybackMotion& playback, const std::vector<double>& times);

}  // namespace quatcurve
