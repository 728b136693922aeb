// Cleaning captured rotations: flips removed, the clip's noise estimated, spikes found and replaced,
// and a smoothing that stays within a deviation bound of every frame that is not a spike
// (docs/clean.md). Each piece is public; clean_rotations runs them in that order.
//
// Input: n frames, times (frames, strictly increasing) and unit quaternions (w, x, y, z at the array
// edges; normalized here, either sign). The formulas below use the times in units of their median
// spacing (τ = 0, 1, 2, … for one sample a frame; h_i, the smoothness λ and accelerations are in
// those units), and refuse a spacing beyond a factor 1e6 of the median one. Rotation vectors ρ map
// to rotations by exp(ρ/2) (angle |ρ|); log(q) below is the rotation vector of q (2·the quaternion
// log, angle in [0, π]). Angles are radians; the angle between two rotations is the geodesic angle
// angle_between(a, b) = 4·atan2(|a − b|, |a + b|) (quat.hpp).
//
// The bound is at the frames: the smoothed rows are within `deviation` of the input at every frame
// that is not a spike. Between frames nothing is claimed here: the result is dense per-frame keys,
// and a caller that reduces them proves its own bound between frames (reduce_keys_proved,
// reduce_curve_proved in reduce.hpp).
//
// Bad input throws InvalidArgument naming the argument and element: non-finite or zero-length
// quaternions ("quats[3]: zero-length quaternion"), non-finite or unsorted times ("times[4]: … is not
// after times[3] …"), fewer than 3 frames, a negative or non-finite deviation, noise or option.
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "quatcurve/euler.hpp"
#include "quatcurve/quat.hpp"

namespace quatcurve {

// ---- 1. flips ------------------------------------------------------------------------------------
// hemisphere_continuous (channels.hpp) over q[0..n): each quaternion negated where its dot with the
// one before (already fixed) is negative — decided on the normalized rotations, so any finite
// magnitude works; every rotation is unchanged. Returns the number of consecutive pairs whose sign
// relation was repaired (input dot < 0). Quaternions are kept as given (not normalized); a
// zero-length or non-finite one throws.
std::size_t remove_quat_flips(Quat* q, std::size_t n);
// euler_filter (euler.hpp) over n triples (angles about X, Y, Z; radians): each row moved to the
// equivalent angles (same rotation) nearest the row before, which removes flips between the two
// Euler solutions and 2π jumps. Returns the number of consecutive pairs whose step changed (the
// shift applied to a row differs from the row before's). Throws on non-finite angles.
std::size_t remove_euler_flips(Vec3* angles, std::size_t n, EulerOrder order);

// ---- 2. noise ------------------------------------------------------------------------------------
// The clip's per-frame rotation noise σ (radians): the RMS angle by which a frame is off its true
// rotation, for white isotropic noise q_i = truth_i·exp(ε_i/2), ε_i ~ N(0, s²·I₃), so σ² = E|ε|² = 3s².
//
// Residual of frame i (0 < i < n−1): r_i = log(P_i⁻¹·q_i), a rotation vector, P_i the prediction of
// frame i from its neighbours that find_spikes uses (below): the cubic through the rotation vectors
// of its two neighbours on each side, P_i = q_ref·exp(Σ_k w_k·ρ_k/2). (The geodesic second
// difference — P_i the slerp of the two nearest neighbours — carries half the angular acceleration
// per frame², which on fast motion outweighs the noise: 3.3° on a turn of 21°/frame read as 4° of
// noise where there was 1°; the cubic leaves a fourth-derivative term, 0.1° there.)
// To first order in the noise r_i = ε_i − Σ_k w_k·ε_k + b_i, b_i the motion's own departure from the
// cubic. So for white noise r_i ~ N(0, s²·g_i²·I₃) with g_i² = 1 + Σ_k w_k² (evenly spaced frames:
// w = (−1/6, 2/3, 2/3, −1/6), g² = 35/18), and |r_i|/(s·g_i) follows the chi distribution with 3
// degrees of freedom, whose median is m₃ = 1.53817…. The estimate is robust (a spike spoils up to
// 5 residuals, a median ignores them):
//     σ = √3 · median_i(|r_i| / g_i) / m₃.
// On data without noise it measures b_i (tiny for smooth motion; 0 for a uniform rotation).
// Throws for fewer than 3 frames.
double estimate_rotation_noise(const std::vector<double>& times, const std::vector<Quat>& q);

// ---- 3. spikes -----------------------------------------------------------------------------------
struct SpikeOptions {
    // A frame is a spike when it departs from its neighbours' prediction by more than
    // threshold·σ·g (and the motion's own scales, below), g the prediction's noise gain. For white
    // noise a clean frame's departure exceeds 3·σ·g with probability about 6e-6.
    double threshold = 3.0;
    // Longest run of consecutive spike frames (≥ 1): a run is predicted across from its neighbours.
    std::size_t max_run = 3;
    // Departures below this are never spikes, however low the noise (9°: the motion's own one-frame
    // events — a foot's flick at a plant — depart from the cubic by up to 8.1° in the shared
    // 30–120 fps capture without noise; smaller spikes are left to the smoother's bound).
    double min_angle = 0.15707963267948966;
};

struct Spikes {
    std::vector<std::size_t> frames;   // sample indices, increasing
    std::vector<double> departures;    // per spike frame: angle to the curve through its neighbours
};

// Frames, and runs of up to max_run frames, whose rotation departs from what their neighbours
// predict by much more than the noise σ (estimate_rotation_noise, or the caller's).
//
// Prediction of a window of frames i..j: the two nearest non-spike frames on each side (near the
// clip's ends, more from the other side: four in all when the clip has them), their rotation
// vectors in the tangent space of the nearest one, ρ_k = log(q_ref⁻¹·q_k), and the Lagrange
// polynomial through (t_k, ρ_k) — a cubic, interpolating inside the clip and extrapolating at its
// ends, so the motion's acceleration does not read as a departure — evaluated at each window frame:
// q_ref·exp(P(t)/2). Its noise gain g(t) = √(1 + Σ_k w_k(t)²), w_k the Lagrange weights, scales the
// threshold (a noise-only departure has RMS σ·g: g = 1.39 for one frame inside the clip, far more
// when extrapolating, so spikes at the clip's very ends must be larger to be found). On a uniform
// rotation about a fixed axis the prediction is the slerp of the neighbours.
//
// Where the captured motion itself turns faster than a cubic through its neighbours follows (a
// jerky stretch of a clip, a foot's plant), the motion raises the limit. A departure must exceed,
// besides threshold·σ·g:
// - 2·Q₉₀·g, Q₉₀ the 90th percentile over the clip of the frames' |r_i|/g_i (the residuals of
//   estimate_rotation_noise): for white noise 2.9σ·g, more where the motion departs from the cubic
//   at more than a tenth of its frames;
// - the motion's own speed there (the median angle between consecutive frames over the ten frames
//   3 to 7 frames before and after the window, beyond the neighbours a spike in it moves): a
//   reversal at 8°/frame departs 5.3° from the cubic and is not a spike.
// A run of L frames needs 1 + (L − 1)/2 times those: predicted across a gap, it is less sure. And
// every departure must exceed min_angle, times g/g₀ where the cubic extrapolates (fewer than two
// nodes on a side, at the clip's ends; g₀ = 1.39 the gain inside the clip).
//
// After the search, every marked frame is scored again alone with the other marks in place and
// unmarked below its limit (a frame marked while a spike among its nodes threw its prediction off),
// and the search runs again on what is left, until nothing changes.
//
// Search: every window of 1..max_run unmarked frames is scored by the smallest over its frames of
// departure / limit; the best window above 1 is marked, the windows near it
// scored again (the spike no longer predicts its neighbours), until none is above 1. A window is
// only marked if the run of marked frames it joins stays within max_run. The departures returned
// are those from the final prediction (the curve replace_spikes puts there).
Spikes find_spikes(const std::vector<double>& times, const std::vector<Quat>& q, double noise,
                   const SpikeOptions& options = {});

// q with each run of `frames` (sample indices, increasing) replaced by the prediction from the
// run's neighbours, as find_spikes predicts. Throws for an index out of range or not increasing,
// or a run without two non-spike neighbours.
std::vector<Quat> replace_spikes(const std::vector<double>& times, const std::vector<Quat>& q,
                                 const std::vector<std::size_t>& frames);

// ---- 4. smoothing within a deviation bound --------------------------------------------------------
struct SmoothOptions {
    // λ of the smoother (below); none: the λ in [1e-3, 1e10] that minimizes Stein's unbiased estimate
    // of the mean squared angle to the truth over the bound frames for white noise of RMS angle σ,
    //     SURE(λ) = (Σ_i dev_i² + 2·σ²·tr S_λ)/m − σ²,
    // dev_i the angle to the input, m the bound frames, S_λ = (W + λ·AᵀMA)⁻¹·W the linearized
    // smoother (its diagonal from the L·D·Lᵀ factors); a grid of decades, then golden section to 0.01
    // in log₁₀ λ.
    std::optional<double> smoothness;
    // σ for the automatic λ (radians); none: estimate_rotation_noise of q (when smoothness is not
    // given).
    std::optional<double> noise;
    // Frames left free (spikes): no deviation bound, next to no weight (1e-8): the smoother fills them.
    std::vector<std::size_t> free_frames;
};

struct Smoothed {
    std::vector<Quat> q;            // hemisphere-continuous
    double smoothness = 0.0;        // λ used
    double max_deviation = 0.0;     // largest angle to the input over the bound frames
    std::size_t pulled = 0;         // frames whose weight was raised to keep them within the bound
    std::size_t kept = 0;           // frames left at their input rotation after the last round
};

// Rotations within `deviation` (radians) of q at every frame not in free_frames (checked exactly
// with angle_between), following a Whittaker–Reinsch smoother on the rotation group:
//     minimize Σ_i w_i·|log(p_i⁻¹·q_i)|² + λ·Σ_i μ_i·|a_i|²,
// a_i = (ω_i/h_i − ω_{i−1}/h_{i−1})·2/(h_{i−1} + h_i) the angular acceleration from the body-frame
// steps ω_i = log(p_i⁻¹·p_{i+1}), h_i = τ_{i+1} − τ_i, μ_i = (h_{i−1} + h_i)/2 (evenly spaced frames:
// the second difference ω_i − ω_{i−1}). Solved by Gauss–Newton in body-frame increments
// p_i ← p_i·exp(δ_i/2) with the first-order steps ω_i + δ_{i+1} − δ_i: each step one pentadiagonal
// system (W + λ·AᵀMA)·δ = W·e − λ·AᵀM·a shared by the three components, O(n).
// The bound: frames beyond 0.98·deviation get their weight raised (×max(4, 2·(d/0.98·deviation)²))
// and the system is solved again, up to 30 rounds; a frame still beyond `deviation` after that is
// set to its input rotation (`kept`). deviation 0 returns q itself (hemisphere-continuous).
Smoothed smooth_rotations(const std::vector<double>& times, const std::vector<Quat>& q, double deviation,
                          const SmoothOptions& options = {});

// ---- 5. everything -------------------------------------------------------------------------------
struct CleanOptions {
    std::optional<double> noise;      // σ (radians); none: estimate_rotation_noise
    std::optional<double> deviation;  // radians; none: deviation_factor·σ
    double deviation_factor = 2.5;    // a white-noise frame is beyond 2.5·σ with probability 3e-4
    bool spikes = true;               // find and replace spikes
    SpikeOptions spike;
    bool smooth = true;               // smooth within the deviation
    std::optional<double> smoothness; // λ; none: by the risk estimate (SmoothOptions::smoothness)
};

struct CleanResult {
    std::vector<Quat> q;                      // n rows, hemisphere-continuous
    std::vector<std::size_t> spike_frames;    // sample indices
    std::vector<double> spike_departures;     // radians, per spike frame
    double noise = 0.0;                       // σ used (estimated or given)
    double deviation = 0.0;                   // bound used at the non-spike frames
    double max_deviation = 0.0;               // largest angle to the input over the non-spike frames
    std::size_t flips = 0;                    // sign flips removed (remove_quat_flips)
    double smoothness = 0.0;                  // λ used (0 when not smoothed)
    std::size_t pulled = 0;                   // frames the bound pulled back (Smoothed::pulled)
};

// remove_quat_flips → estimate_rotation_noise (unless given) → find_spikes + replace_spikes →
// smooth_rotations with the spikes free. The result is within `deviation` of the input at every
// non-spike frame (max_deviation ≤ deviation).
CleanResult clean_rotations(const std::vector<double>& times, const std::vector<Quat>& q,
                            const CleanOptions& options = {});

}  // namespace quatcurve
