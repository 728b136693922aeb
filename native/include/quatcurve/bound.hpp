// A bound at every instant: the largest angle between two motions over a whole time range, proved
// from finitely many evaluations.
//
// A motion is a rotation R(t), as a unit quaternion q(t), that can be evaluated at any time, with
// known upper bounds over any interval of its angular speed |ω| and of |q̈| (Motion::bounds), and the
// times where it may turn a corner (breaks: keys). For two motions A and B on an interval [t0, t1]
// with d(t) = angle(A(t), B(t)) (the geodesic angle, sign-invariant), two bounds hold at every time:
//
//   first order:  d(t) ≤ d(t0) + angle(A(t0), A(t)) + angle(B(t0), B(t)) ≤ d(t0) + L·(t − t0)
//                 (the triangle inequality in SO(3), L = |ω_A| + |ω_B| bounds), and the same from t1,
//                 so max d ≤ (d(t0) + d(t1) + L·h)/2;
//   second order: e(t) = q_A(t) − σ·q_B(t) (σ = ±1 fixed on the interval) is C1 between breaks with
//                 |ë| ≤ S = |q̈_A| + |q̈_B| bounds, so |e(t)| ≤ max(|e(t0)|, |e(t1)|) + S·h²/8
//                 (linear interpolation's error), and an angle is 4·asin(|e|/2) at most.
//
//   channels:     two quaternion playbacks (Motion::raw_channels, both at float32 frames) are
//                 q = a/|a| with a(t) the four channel values, polynomial pieces between keys. For
//                 λ(t) > 0 linear on the interval (λ_i = a_A·σa_B/|a_B|² at each end, so that D
//                 there is the perpendicular part alone) and σ = ±1 fixed, D(t) = a_A(t) − λ(t)σ·a_B(t)
//                 has |D̈_c| ≤ k_A,c + max λ·k_B,c + 2|λ'|·r_B,c from the channels' own first and
//                 second derivative bounds (the DIFFERENCE of the two motions: their normalizations'
//                 terms never enter), so |D(t)| ≤ max(|D(t0)|, |D(t1)|) + |D̈|·h²/8; the angle θ
//                 between the 4-vectors a_A and σ·a_B has sin θ ≤ |D|/|a_A| and sin θ ≤ |D|/(λ|a_B|)
//                 (the distance from either point to the other's ray), with |a(t)| ≥ min(|a(t0)|,
//                 |a(t1)|) − max|a'|·h/2; the rotation angle is at most 2θ. Blender's snap to a key
//                 (a frame within 1e-4 of it shows the key's value) is a step off the polynomial of at
//                 most the rate × 1e-4, added where an interval meets a key's snap zone in part (twice:
//                 at the ends and inside); such an interval that fails is split at the zone's edges,
//                 where the step does not shrink with the interval. Two such playbacks take this bound
//                 alone, their keys as the only breaks (no snap edges to evaluate).
//
// The smallest of them is the interval's bound (the channels bound alone between two quaternion
// playbacks). Where it is above the tolerance the interval is
// halved (its midpoint evaluated) until it passes, an evaluated time is above the tolerance (a
// violation: reported, not refined further), or it is shorter than `min_step` (unproven: reported).
// Every interval's bound is a true upper bound of d on it, so PlaybackBound::bound is an upper bound
// of d at EVERY time in [times.front(), times.back()] — not only at the evaluated ones — whatever the
// verdict.
//
// Blender's side (PlaybackMotion) is Blender's F-curve evaluation (blender_eval.hpp) of the keys of a
// rotation's channels. Each channel's first and second derivatives are bounded from its Bezier control
// points (the hodographs' convex hulls over the interval's curve parameters; y(t) = y(u(t)) with
// x(u) = t), then the rotation mode combines them (Euler: |ω| ≤ Σ|θ'|, |α| ≤ Σ|θ''| + (Σ|θ'|)²;
// quaternion: q = a/|a| with |a| bounded from below on the interval, |q̇| ≤ |a'|/|a|,
// |q̈| ≤ 2|a''|/|a| + 5|a'|²/|a|²; axis-angle: q = (cos θ/2, sin θ/2·n), n = v/|v|,
// |q̈| ≤ ¼θ'² + ½|θ''| + |θ'||n'| + |n''|). Blender evaluates at float32 frames and snaps a frame
// within 1e-4 of a key to the key's value: both are steps, not slopes, and jump_bound adds them to the
// interval they fall in — except between two playbacks (the key reducer's proof, reduce.hpp), which
// Blender evaluates at the same float32 frame; 2e-6 rad covers Blender's float32 arithmetic (as the
// key reducer's verification margin, reduce.hpp).
#pragma once

#include <algorithm>
#include <cstddef>
#include <utility>
#include <vector>

#include "quatcurve/blender_eval.hpp"
#include "quatcurve/channels.hpp"
#include "quatcurve/curve.hpp"
#include "quatcurve/types.hpp"

namespace quatcurve {

class Motion {
public:
    virtual ~Motion() = default;
    // The unit quaternion at t, sign-continuous in t.
    virtual Quat at(double t) const = 0;
    // at() at each of n times into out: the same bits, computed together where the motion can (a
    // Curve samples four times at a time).
    virtual void at_many(const double* t, std::size_t n, Quat* out) const {
        for (std::size_t i = 0; i < n; ++i) out[i] = at(t[i]);
    }
    // Upper bounds of |ω| (radians per frame) and |q̈| (per frame²) at every time in [t0, t1], t0 ≤ t1
    // (a corner at a break inside the interval is not covered: prove_within splits there).
    virtual void bounds(double t0, double t1, double& speed, double& accel) const = 0;
    // An upper bound of the angle of the steps the motion takes inside [t0, t1] (0: continuous),
    // given its speed bound there.
    virtual double jump_bound(double /*t0*/, double /*t1*/, double /*speed*/) const { return 0.0; }
    // The times where the motion may turn a corner, sorted.
    virtual std::vector<double> breaks() const { return {}; }
    // The breaks within [t0, t1], sorted: those of breaks() there, unless the motion has breaks
    // beyond any finite list (a loop, Curve "Loops", repeats its corners every period).
    virtual std::vector<double> breaks_within(double t0, double t1) const;
    // Quaternion channels (bound.hpp, "channels"): the four values a at t that at(t) normalizes;
    // bounds over [t0, t1] (no key strictly inside) of each channel's |a_c'| and |a_c''| (its
    // polynomial pieces there, and to any key within the snap distance of an end) and of the steps
    // off them (|a_c(t) − the piece at t|: the snap to a key, float32 flat segments); and the key
    // frames (the corners of a). False / empty: not such a playback (the other two bounds apply).
    virtual bool raw_channels(double /*t*/, double* /*a*/) const { return false; }
    virtual bool raw_bounds(double /*t0*/, double /*t1*/, double* /*rate*/, double* /*curvature*/,
                            double* /*step*/) const {
        return false;
    }
    virtual std::vector<double> raw_keys() const { return {}; }
    // The frames strictly inside (t0, t1) where the snap zone of a key that [t0, t1] meets in part
    // begins or ends, and the frames just outside it (where the channels bound splits such an
    // interval: its step there does not shrink with the interval).
    virtual void raw_snap_edges(double /*t0*/, double /*t1*/, std::vector<double>& /*out*/) const {}
    // Whether the motion is evaluated at float32 frames (Blender's playback): at(t) is at(float(t)).
    // Two such motions show the same float32 frame at any time, so between neighbouring float32
    // frames their angle is the angle at one of them.
    virtual bool float32_frames() const { return false; }
};

// A Curve as a motion (Curve::motion_bounds; Curve::corner_times are the breaks).
class CurveMotion : public Motion {
public:
    explicit CurveMotion(const Curve& curve) : curve_(curve) {}
    Quat at(double t) const override;
    void at_many(const double* t, std::size_t n, Quat* out) const override;
    void bounds(double t0, double t1, double& speed, double& accel) const override {
        curve_.motion_bounds(t0, t1, speed, accel);
    }
    std::vector<double> breaks() const override { return curve_.corner_times(); }
    std::vector<double> breaks_within(double t0, double t1) const override { return curve_.corner_times(t0, t1); }

private:
    const Curve& curve_;
};

// A Curve as a motion that owns its copy of the curve (for a motion kept beyond the caller's curve).
class OwnedCurveMotion : public Motion {
public:
    explicit OwnedCurveMotion(Curve curve) : curve_(std::move(curve)), motion_(curve_) {}
    OwnedCurveMotion(const OwnedCurveMotion&) = delete;
    OwnedCurveMotion& operator=(const OwnedCurveMotion&) = delete;
    Quat at(double t) const override { return motion_.at(t); }
    void at_many(const double* t, std::size_t n, Quat* out) const override { motion_.at_many(t, n, out); }
    void bounds(double t0, double t1, double& speed, double& accel) const override {
        motion_.bounds(t0, t1, speed, accel);
    }
    std::vector<double> breaks() const override { return motion_.breaks(); }
    std::vector<double> breaks_within(double t0, double t1) const override { return motion_.breaks_within(t0, t1); }

private:
    Curve curve_;
    CurveMotion motion_;
};

// A motion whose breaks are computed once and found by binary search (proofs of many pieces of one
// motion: prove_within asks each piece's proof for the breaks within it).
class KeptBreaks : public Motion {
public:
    explicit KeptBreaks(const Motion& m) : m_(m), breaks_(m.breaks()) {}
    Quat at(double t) const override { return m_.at(t); }
    void at_many(const double* t, std::size_t n, Quat* out) const override { m_.at_many(t, n, out); }
    void bounds(double t0, double t1, double& speed, double& accel) const override { m_.bounds(t0, t1, speed, accel); }
    double jump_bound(double t0, double t1, double speed) const override { return m_.jump_bound(t0, t1, speed); }
    bool float32_frames() const override { return m_.float32_frames(); }
    std::vector<double> breaks() const override { return breaks_; }
    std::vector<double> breaks_within(double t0, double t1) const override {
        return {std::lower_bound(breaks_.begin(), breaks_.end(), t0), std::upper_bound(breaks_.begin(), breaks_.end(), t1)};
    }

private:
    const Motion& m_;
    std::vector<double> breaks_;
};

// The rotation Blender plays from the keys of a rotation's F-curves (channel_count(mode) of them,
// in channel order): each channel evaluated as blender_evaluate does, the rotation built as Blender
// builds it (a zero quaternion is (0, 1, 0, 0) after Blender's normalize; a zero axis no rotation).
// Throws InvalidArgument for a channel count that does not fit the mode or keys check_fcurve_keys
// refuses.
class PlaybackMotion : public Motion {
public:
    PlaybackMotion(std::vector<FCurveKeys> channels, KeyInterpolation interpolation, const RotationMode& mode);
    Quat at(double t) const override;
    void bounds(double t0, double t1, double& speed, double& accel) const override;
    double jump_bound(double t0, double t1, double speed) const override;
    std::vector<double> breaks() const override;  // every channel's key frames
    bool float32_frames() const override { return true; }
    bool raw_channels(double t, double* a) const override;                        // quaternion mode
    bool raw_bounds(double t0, double t1, double* rate, double* curvature, double* step) const override;
    std::vector<double> raw_keys() const override;  // quaternion mode: every channel's key frames
    void raw_snap_edges(double t0, double t1, std::vector<double>& out) const override;
    // The channel values Blender shows at t (channel_count(mode) of them).
    void values(double t, double* out) const;
    // Upper bounds of |d value/d frame| and |d² value/d frame²| of channel c at every frame in
    // [t0, t1] between its keys (+∞ where a Bezier segment's frame stops advancing).
    void channel_bounds(std::size_t c, double t0, double t1, double& rate, double& curvature) const;

private:
    // Channel values of the last few frames evaluated (values): not thread-safe, one proof at a time.
    static constexpr std::size_t kCache = 8;
    struct Cached {
        float frame = 0.0f;
        bool valid = false;
        double values[4] = {0.0, 0.0, 0.0, 0.0};
    };
    mutable Cached cache_[kCache];
    mutable std::size_t next_ = 0;
    // |d(a + sign·c)/dt| bound of channels a and c on [t0, t1] where they share one Bezier segment.
    bool combined_rate(std::size_t a, std::size_t c, double sign, double t0, double t1, double& rate) const;
    // The Euler speed bound that sees the first and last axes align near gimbal lock (bound.cpp).
    double euler_speed(double t0, double t1, const double* r) const;

    std::vector<FCurveKeys> channels_;
    KeyInterpolation interpolation_;
    RotationMode mode_;
    // Every channel holds the same key frames, as the fit's and the reducer's synchronized keys do:
    // values() evaluates them together (blender_evaluate_shared), bounds() finds their segment once
    // and bounds their frame parameter once per handle frames (all_channel_bounds).
    bool shared_frames_ = false;
    void all_channel_bounds(double t0, double t1, double* rate, double* curvature) const;
    // A Bezier segment's control points as Blender evaluates them (segment_controls).
    struct SegmentControls {
        bool bezier = false;  // false: Blender's flat-segment shortcut
        double x[4], y[4];
    };
    // Per channel, what the proof's channel bounds looked up last (its intervals come in time order,
    // mostly within one segment): where the searches of the key frames ended, the segment's controls,
    // and Blender's curve parameter at the last two frames asked for on that segment.
    struct ChannelCache {
        std::size_t snap = 0, segment = 0;      // std::lower_bound / std::upper_bound results
        std::size_t j = static_cast<std::size_t>(-1);
        SegmentControls controls;               // segment j's (segment_controls)
        double spread = 0.0;                    // its four stored control values' max − min (float32)
        float frame[2] = {0.0f, 0.0f}, u[2] = {0.0f, 0.0f};
        int known = 0, next = 0;                // parameters held, the slot written next
        std::size_t snap_key = static_cast<std::size_t>(-1);
        double snap_edges[5] = {};              // raw_snap_edges' frames around key snap_key (snap_edges)
    };
    mutable ChannelCache channel_cache_[4];
    const ChannelCache& segment(std::size_t c, std::size_t j) const;
    // Blender's curve parameter at `frame` on channel c's segment last found by segment().
    float parameter(std::size_t c, float frame) const;
    bool may_be_flat(std::size_t c, double lo, double hi, double magnitude) const;
};

struct PlaybackBound {
    double bound = 0.0;         // radians: d(t) ≤ bound at every t in [times.front(), times.back()]
    double max_evaluated = 0.0;  // radians: the largest d at an evaluated time
    double worst_time = 0.0;     // the interval end or evaluated time where `bound` was reached
    std::vector<double> violations;                    // evaluated times with d > tolerance
    std::vector<std::pair<double, double>> unproven;   // intervals shorter than min_step still above it
    std::size_t evaluations = 0;
    bool proven() const { return violations.empty() && unproven.empty(); }
};

// Proves d(t) = angle(a(t), b(t)) ≤ tolerance at every t in [times.front(), times.back()] (see
// above): times sorted, at least one; tolerance ≥ 0; min_step > 0. The result's bound holds whatever
// the verdict. max_evaluations caps the work (intervals left then count as unproven). Throws
// InvalidArgument for unsorted or non-finite times or a bad tolerance, min_step or cap.
PlaybackBound prove_within(const Motion& a, const Motion& b, const std::vector<double>& times, double tolerance,
                           double min_step = 1.0 / 1024.0, std::size_t max_evaluations = 2'000'000);

// A proof that failed (`proof`, of prove_within(a, b, times, …)) made tight: prove_within stops
// halving an interval at a violating end, so its bound there is that whole interval's, up to π,
// however close the motions stay. Proved again at a level just above the largest distance evaluated
// (5 % over it, raised by half while a proof at it fails, six times at most; each with min_step and
// max_evaluations), the bound comes within that margin of the motions' distance: the least of the
// bounds found (each holds at every instant, whatever its verdict) is kept with its worst time, the
// evaluations are added, and the violations and unproven intervals stay those of the tolerance (it
// still reads as not proved). A proof already proved is left as it is.
void tighten_proof(const Motion& a, const Motion& b, const std::vector<double>& times, double min_step,
                   std::size_t max_evaluations, PlaybackBound& proof);

}  // namespace quatcurve
