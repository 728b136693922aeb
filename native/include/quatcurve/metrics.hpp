// Metrics over sampled orientation paths, used to compare interpolation methods with each other and
// with Blender's own Euler and quaternion modes.
//
// A path is sampled at strictly increasing times t[0..N) (frames) with orientations q[0..N) (any
// nonzero quaternions, normalized here; q and -q are the same rotation). Key times k[0..K) are a
// strictly increasing subset of the sample times (matched within 1e-6 frames); segment j is the
// time span [k[j], k[j+1]]. Every angle is in radians; speeds are radians per frame. Formatting
// (degrees, max/mean) belongs to the caller.
//
// Bad input throws InvalidArgument naming the argument and element ("quats[3]: zero-length
// quaternion", "times[5]: not increasing", "key_times[2]: not a sample time").
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "quatcurve/euler.hpp"
#include "quatcurve/types.hpp"

namespace quatcurve {

// ---- deviation --------------------------------------------------------------------------------
// out[i] = angle_between(path[i], reference[i]): geodesic, sign-invariant, in [0, π].
// Lengths must match.
std::vector<double> angular_deviation(const std::vector<Quat>& path,
                                      const std::vector<Quat>& reference);

// ---- speed --------------------------------------------------------------------------------------
// Mean angular speed over each sampling interval: s[i] = angle_between(q[i], q[i+1]) / (t[i+1] - t[i]),
// i < N-1 (belongs to the interval's midpoint). Exact for constant-speed paths; for a smooth path
// it is the speed at the midpoint up to O(dt²). N ≥ 2. A speed beyond double range (an interval of
// subnormal length, e.g. 5e-324 frames) throws InvalidArgument naming the interval's end.
std::vector<double> interval_speeds(const std::vector<double>& times, const std::vector<Quat>& quats);

// Per segment j: max/min of the speed at every sample in [k[j], k[j+1]], estimated from the interval
// speeds of that segment only (interpolated between interval midpoints, extrapolated to the keys:
// O(dt²), exact for constant speed). 1.0 means constant speed; a segment that does not move at all
// (max = 0) also gives 1.0; one whose speed reaches 0 (below 1e-12 of its maximum) while moving
// elsewhere gives +inf, as Blender's Bezier keys do where all channels have flat handles.
// Returns K-1 ratios (none when K < 2).
std::vector<double> segment_speed_ratios(const std::vector<double>& times,
                                         const std::vector<Quat>& quats,
                                         const std::vector<double>& key_times);

// Same ratio from given angular velocities w[i] (world frame, radians per frame) at the sample
// times: the speeds |w[i]| of the samples strictly inside each segment (a sample at a key belongs to
// both neighbours and would mix them). A segment with no sample strictly inside gives NaN.
std::vector<double> segment_speed_ratios_from_velocity(const std::vector<double>& times,
                                                       const std::vector<Vec3>& velocities,
                                                       const std::vector<double>& key_times);

// ---- length -------------------------------------------------------------------------------------
// Σ angle_between(q[i], q[i+1]): the sampled path's length (a lower bound of the true length,
// exact for paths that are geodesic between samples). Applied to the key orientations it is the sum
// of key-to-key geodesic angles, the shortest length any interpolation through those keys can have.
// 0 for fewer than two samples.
double path_length(const std::vector<Quat>& quats);

// ---- continuity at keys -------------------------------------------------------------------------
// One-sided angular velocity and acceleration at each key, estimated from the samples on each side
// (never across a neighbouring key): rotation vectors r(s) = 2·log(q(k+s)·q(k)⁻¹) (world frame, q(k+s)
// put in q(k)'s hemisphere) are fitted by r(s) = ω·s + ½α·s² (+ c·s³ when three samples are
// available on that side), so ω is the world-frame angular velocity and α = r''(0) the angular
// acceleration (exactly ω'(0), since r' × r' = 0). With h the sample spacing the errors are O(h³)/O(h²)
// with three samples per side, O(h²)/O(h) with two; with one sample only ω is estimated (O(h)).
// The jump at key j is |ω⁺ - ω⁻| and |α⁺ - α⁻|; NaN at the first and last key (one side only) and
// where a side lacks the samples the estimate needs.
struct KeyJumps {
    std::vector<double> velocity;      // K values, radians per frame
    std::vector<double> acceleration;  // K values, radians per frame²
};
KeyJumps key_jumps(const std::vector<double>& times, const std::vector<Quat>& quats,
                   const std::vector<double>& key_times);

// ---- gimbal lock --------------------------------------------------------------------------------
// gimbal_distance (euler.hpp) per sample: how far the order's middle angle is from ±π/2; 0 is locked.
std::vector<double> gimbal_distances(const std::vector<Vec3>& angles, EulerOrder order);
// Same for orientations: the distance depends only on the rotation (both Euler solutions share it).
std::vector<double> gimbal_distances(const std::vector<Quat>& quats, EulerOrder order);

// The closest approach to gimbal lock and the sample times where it happens: every time whose
// distance is within `tolerance` (radians, ≥ 0) of the minimum. Needs N ≥ 1 samples.
struct GimbalApproach {
    double distance = 0.0;
    std::vector<double> times;
};
GimbalApproach closest_gimbal_approach(const std::vector<double>& times,
                                       const std::vector<double>& distances, double tolerance);

// ---- everything for one path --------------------------------------------------------------------
// The metrics compare reports per source, from the samples of the path, of the reference path
// (SLERP) at the same times, and of the keys. `key_quats` are the key orientations (K of them) whose
// path_length is `key_path_length`; when empty, the path's own samples at the key times are used.
struct PathMetrics {
    std::vector<double> deviation;       // N: angle from the reference per sample
    double max_deviation = 0.0;
    double max_deviation_time = 0.0;     // first sample time where it is reached
    double mean_deviation = 0.0;
    std::vector<double> speeds;          // N-1 interval speeds
    std::vector<double> segment_speed_ratios;  // K-1
    double speed_ratio = 1.0;            // max of segment_speed_ratios (1.0 when K < 2)
    double path_length = 0.0;
    double key_path_length = 0.0;        // Σ key-to-key geodesic angles
    double path_length_ratio = 1.0;      // path_length / key_path_length; keys within 1e-9 rad:
                                         // inf if the path moves, else 1.0
    KeyJumps key_jumps;
    double max_velocity_jump = 0.0;      // over the interior keys where it was estimated (0 if none)
    double max_velocity_jump_time = 0.0; // the key time where it is reached (k[0] if none)
    double max_acceleration_jump = 0.0;
    double max_acceleration_jump_time = 0.0;
};
PathMetrics path_metrics(const std::vector<double>& times, const std::vector<Quat>& quats,
                         const std::vector<double>& key_times, const std::vector<Quat>& reference,
                         const std::vector<Quat>& key_quats = {});

// ---- validation shared by the functions above ---------------------------------------------------
// Throws unless every time is finite and strictly increasing ("times[5]: not increasing").
void check_increasing(const std::vector<double>& times, const std::string& name);
// Index of each key time among the sample times; throws "key_times[j]: not a sample time".
std::vector<std::size_t> key_sample_indices(const std::vector<double>& times,
                                            const std::vector<double>& key_times);

}  // namespace quatcurve
