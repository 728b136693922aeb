// Rotation channels: the values Blender keys for a rotation in each rotation mode, and the sampling
// policies of the add-on's tasks (bake, reduce, compare).
//
// Modes, as Blender's rotation_mode: "QUATERNION" (w, x, y, z), the six Euler orders "XYZ" … "ZYX"
// (angles about X, Y, Z whatever the order; see euler.hpp) and "AXIS_ANGLE" (angle, x, y, z).
// Radians, time in frames. Quaternions (w, x, y, z).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "quatcurve/euler.hpp"
#include "quatcurve/quat.hpp"

namespace quatcurve {

struct RotationMode {
    enum class Kind { quaternion, euler, axis_angle } kind = Kind::quaternion;
    EulerOrder order = EulerOrder::XYZ;  // for Kind::euler
};

// "QUATERNION", "XYZ" … "ZYX", "AXIS_ANGLE"; anything else throws InvalidArgument naming them.
RotationMode parse_rotation_mode(const std::string& name);
// 4 for quaternion and axis-angle, 3 for Euler.
std::size_t channel_count(const RotationMode& mode);

// ---- channel values → quaternions ------------------------------------------------------------------
// The rotation Blender builds from one row of channel values: the quaternion normalized, the Euler
// product of euler.hpp, axis-angle (angle, axis) with the axis normalized. Throws on a zero-length
// quaternion or axis and on non-finite values ("values[3]: zero-length quaternion").
Quat channels_to_quat(const double* values, const RotationMode& mode, std::size_t row = 0);

// ---- quaternions → continuous channel values --------------------------------------------------------
// How Euler angles follow a sequence of orientations.
enum class EulerBranch {
    // Each sample compatible with its reference (when given) by euler_compat, then filtered forward
    // and backward from the sample farthest from gimbal lock (euler_filter): no flips or 2π jumps,
    // and a locked sample takes the member of its family nearest its neighbour. For baked curves.
    continuous,
    // As Blender's Quaternion.to_euler: the first sample to_euler(order) (or to_euler(order,
    // reference) when given), each next one to_euler(order, previous result); with one reference per
    // sample, each to_euler(order, its reference). What Blender's own tools key.
    blender,
};

// In place: q[i] negated where q[i]·q[i−1] < 0, so neighbours share a hemisphere (the same
// rotations); the first takes the sign nearer `reference` when given (q[0]·reference < 0 flips it).
void hemisphere_continuous(Quat* q, std::size_t n, const Quat* reference = nullptr);

// Channel values (n rows of channel_count(mode)) of the n orientations q, continuous along them.
// reference: nullptr, one row of channel values, or (Euler only) n rows — one per sample:
// - QUATERNION: hemisphere_continuous, the first sample's sign nearest the reference row.
// - AXIS_ANGLE: of hemisphere-continuous quaternions, (angle, axis) with the axis kept on its
//   predecessor's side ((axis, angle) ≡ (−axis, −angle)) and the angle unwrapped (angles 2π apart are
//   q and −q); where the rotation is within 1e-7 of the identity the axis is undefined and the
//   nearest defined axis before it (else after it) is kept. The reference row chooses the first
//   sample's axis side and the angle's turn.
// - Euler: see EulerBranch; one reference row applies to every sample.
// Throws on zero-length q or non-finite reference values.
std::vector<double> quats_to_channels(const std::vector<Quat>& q, const RotationMode& mode,
                                      const double* reference = nullptr, std::size_t reference_rows = 0,
                                      EulerBranch branch = EulerBranch::continuous);

class Curve;
enum class Method;
struct CurveOptions;

// The curve of `method` through keys given as channel values of `mode`: n times and n rows of
// channel_count(mode) values. Quaternion keys go to the Curve constructor as stored (QUAT_COMPONENTS
// lerps them unnormalized, as Blender does), Euler keys to Curve::from_euler and axis-angle keys to
// Curve::from_axis_angle, so the turns of Euler and axis-angle paths beyond 180° survive. Throws
// InvalidArgument for a values count that is not n rows, and as those constructors do.
Curve curve_from_channels(const std::vector<double>& times, const std::vector<double>& values,
                          const RotationMode& mode, Method method, const CurveOptions& options);

// The F-curve keys of `curve` sampled at `frames` (n) in rotation mode `mode`: out holds, per channel,
// n (frame, value) float32 pairs as Blender stores keys — (C, n, 2) — the values those of
// quats_to_channels(curve sampled at frames, mode, reference, reference_rows) rounded to float32.
// Quaternion keys stream through a small buffer, a block of samples at a time (hemisphere continuity
// looks only at the sample before), so a dense bake makes no sample-sized temporaries; Euler and
// axis-angle choose their branches over the whole path and convert it at once. Returns false when a
// value is not finite in float32; throws as quats_to_channels on a bad reference.
bool sample_channel_keys(const Curve& curve, const double* frames, std::size_t n, const RotationMode& mode,
                         const double* reference, std::size_t reference_rows, float* out);

// AXIS_ANGLE channels of the samples q of a path from the key `start` to the key `end` (channel rows
// (angle, x, y, z); q[0] is start's rotation and q[n-1] end's): as quats_to_channels with reference
// `start`, when that arrives at `end` as keyed (angle within π, axis on its side). Otherwise — a path
// that passes near the identity, where the axis is undefined, comes out on the other representation
// ((a, v) ≡ (4πk − a, −v)), which no continuous channel path along it avoids — the samples from
// `split` on are lifted backwards from `end`, the split chosen so that the one jump (channels
// interpolated from the forward lift at split-1 to the backward one at split) leaves the samples'
// arc least: astride the path's closest approach to the identity, where every axis gives nearly the
// same rotation, the axis keeps its direction and the angle passes the multiple of 2π. `split`, when given,
// receives the index of the first sample taken from the backward lift (q.size() when none is). Throws
// on zero-length q or non-finite start / end.
std::vector<double> axis_angle_span_channels(const std::vector<Quat>& q, const double* start, const double* end,
                                             std::size_t* split = nullptr);

// ---- sampling policies --------------------------------------------------------------------------------
// The frames a bake keys: start, start + step, … while within end (1e-9 of a step of slack), and end
// itself when the last is more than 1e-6 frames short of it. Throws on non-finite bounds, end < start
// or step < 1. Every policy throws rather than return more than 1e8 frames.
std::vector<double> step_frames(double start, double end, double step);
// Compare's samples over a keyed range: the grid first key + m/per_frame up to the last key (1e-9 of
// slack), without grid points within 1e-4 frames of a key or on another sample's float32 frame,
// merged with the key frames (sorted; every sample on a float32 frame of its own).
// key_frames must increase; per_frame ≥ 1.
std::vector<double> sample_frames(const std::vector<double>& key_frames, int per_frame);
// Reduce's samples: every whole frame from the first key to the last, and every key frame (sorted,
// unique). key_frames must increase.
std::vector<double> whole_frame_samples(const std::vector<double>& key_frames);
// Handles of keys on straight segments (Blender LINEAR keys drawn as Bezier): each handle a third of
// the way to the neighbouring key, the first and last keys mirroring their only segment; a lone key
// gets flat handles one frame wide. Writes n (frame, value) pairs to left and right; throws when a
// handle overflows double precision.
void segment_handles(const double* frames, const double* values, std::size_t n, double* left, double* right);

}  // namespace quatcurve
