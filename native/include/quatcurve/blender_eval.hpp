// Blender's F-curve evaluation of LINEAR and BEZIER keys, emulated operation for operation in float32
// (blenkernel/intern/fcurve.cc: fcurve_eval_keyframes, fcurve_eval_keyframes_interpolate,
// BKE_fcurve_bezt_binarysearch_index_ex, BKE_fcurve_correct_bezpart, findzero, solve_cubic,
// berekeny; BLI_easing_linear_ease), so that Python and C++ can know what Blender will show for a set
// of keys without running Blender. The key reducer (reduce.hpp) verifies its bound with it.
//
// What is emulated, for an F-curve with keys at increasing frames f_0 < … < f_{K-1}:
//   - constant extrapolation (Blender's default): at or before f_0 the first key's value, at or after
//     f_{K-1} the last key's value;
//   - a frame within 1e-4 frames of a key (Blender's binary-search threshold, float32 compare) takes
//     that key's value — so a segment is never evaluated closer than 1e-4 to its keys;
//   - LINEAR: change·time/duration + begin in float32; a zero-length segment gives its first value;
//   - BEZIER: the cubic with control points (key, right handle of the left key, left handle of the
//     right key, key). Handles whose frame reaches farther than the segment's length are scaled back
//     to it at evaluation time (correct_bezpart: each handle on its own, direction kept; the stored
//     handles are untouched). The frame→parameter root is found by Cardano in double from float
//     coefficients (the first root in [-1e-10, 1.000001]), the value is the float32 power-basis
//     cubic. A segment whose four values agree within FLT_EPSILON is flat (its first value); 0 when
//     the root finder finds no root, as in Blender.
// Per-key interpolation, easing modes, F-curve modifiers, cyclic and linear extrapolation are not
// emulated (the reducer writes none of them).
//
// Checked against fcurve.evaluate() of Blender 3.4.1, 4.5.15 and 5.0.1 (tests/blender/test_blender_eval.py,
// 600 random F-curves, ~300,000 frames each): identical to the last bit in all three, so no version
// differences to document.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace quatcurve {

// Interpolation of every segment of an F-curve (Blender's keyframe interpolation names).
enum class KeyInterpolation { LINEAR, BEZIER };

// "LINEAR" or "BEZIER"; anything else throws InvalidArgument naming `interpolation`.
KeyInterpolation parse_key_interpolation(const std::string& name);
const char* key_interpolation_name(KeyInterpolation interpolation);

// The keys of one F-curve as Blender stores them. Frames, values and handles are read as float32
// (Blender's storage) wherever they are used, so float64 inputs are rounded first, as
// foreach_set would.
struct FCurveKeys {
    std::vector<double> frames;  // K key frames, strictly increasing (as float32)
    std::vector<double> values;  // K key values
    // BEZIER: absolute (frame, value) per key, interleaved [f0, v0, f1, v1, ...] (2K numbers).
    // LINEAR ignores them (may be empty).
    std::vector<double> handle_left;
    std::vector<double> handle_right;
};

// Throws InvalidArgument naming the array and element unless `keys` can be evaluated: frames and
// values of one length, every number finite and float32-representable, frames increasing, and
// for BEZIER 2K handle numbers on each side. The evaluators below assume this (they do not check).
void check_fcurve_keys(const FCurveKeys& keys, KeyInterpolation interpolation);

// The value Blender shows for `keys` at `frame` (float32 arithmetic, see above). No keys give 0.
float blender_evaluate(const FCurveKeys& keys, KeyInterpolation interpolation, float frame);

// blender_evaluate at every frame of `frames` (any order; each rounded to float32) into out.
void blender_evaluate(const FCurveKeys& keys, KeyInterpolation interpolation,
                      const std::vector<double>& frames, std::vector<double>& out);

// The same for non-decreasing `frames`, in one walk over the keys; bit-identical to the pointwise
// form. param_cache (optional) holds the Bezier curve parameter per frame: filled when reuse is
// false, read when reuse is true — valid only for keys with the same key and handle frames as the
// ones that filled it (the parameter depends on frames alone).
void blender_evaluate_sorted(const FCurveKeys& keys, KeyInterpolation interpolation,
                             const std::vector<double>& frames, std::vector<double>& out,
                             std::vector<float>* param_cache = nullptr, bool reuse = false);

// blender_evaluate_sorted for `count` channels that share their key frames (as float32), each into
// out[s·stride + c] for frame s: one walk over the keys for all of them, each segment's control
// points read once, and the Bezier curve parameter found once per frame for the channels whose
// handle frames agree (recomputed for one whose do not). Bit-identical to evaluating each channel
// on its own.
void blender_evaluate_sorted_shared(const FCurveKeys* const* channels, int count,
                                    KeyInterpolation interpolation, const std::vector<double>& frames,
                                    double* out, std::size_t stride);

// blender_evaluate of `count` channels that share their key frames (as float32) at one frame, into
// out[c]: Blender's binary search once for all of them, and the Bezier curve parameter found once
// for the channels whose segment's handle frames agree (recomputed for one whose do not).
// Bit-identical to blender_evaluate of each channel.
void blender_evaluate_shared(const FCurveKeys* const* channels, int count, KeyInterpolation interpolation,
                             float frame, double* out);

// The curve parameter Blender's root finder returns for `frame` in a Bezier segment whose key and
// handle frames are q0, q1, q2, q3 (after correct_bezpart; findzero's first root); -1 when it finds
// none.
float blender_bezier_parameter(float frame, float q0, float q1, float q2, float q3);

}  // namespace quatcurve
