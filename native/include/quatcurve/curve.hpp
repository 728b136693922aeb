// The orientation curve engine: keys (times in frames, orientations) → a curve sampled anywhere.
//
// Prepare / evaluate: the constructor validates the keys, builds the per-segment data of the chosen
// method once (O(keys)), and `sample` / `angular_velocity` then evaluate without allocating.
//
// Methods (the same identifier strings in C++, Python and the add-on):
//   EULER            each Euler angle linear between keys (Blender's Euler mode, LINEAR keys);
//                    only from Euler keys (Curve::from_euler).
//   QUAT_COMPONENTS  w, x, y, z each linear between the keys as given, then normalized, no
//                    hemisphere fix (Blender's quaternion mode, LINEAR keys, flips included).
//   NLERP            normalized lerp after the hemisphere fix.
//   SLERP            constant angular speed per segment; shortest path unless shortest_path = false
//                    (then the keyed path: the arc from q[i] to q[i+1] as stored, up to 360°).
//   SQUAD            Shoemake's spherical quadrangle; its inner control points are placed so that
//                    the angular velocity is continuous also for non-uniform key spacing.
//   CATMULL_ROM      spherical cubic Bezier in the cumulative form of Kim, Kim & Shin (1995),
//                    q(s) = b0·exp(β1(s)·d01)·exp(β2(s)·d12)·exp(β3(s)·d23): no logarithm at run
//                    time, hence no branch choice and no jump, whatever the tangents; C1.
//   TCB              Kochanek–Bartels on quaternions as in 3ds Max's TCB rotation: tension,
//                    continuity, bias (one value or one per key).
//
// Ease (every method): ease_in / ease_out per key in [0, 1], 3ds Max's Ease To / Ease From: a time
// warp within each key segment (curve_ease.cpp) that slows the motion into and out of a key without
// changing the path; at full ease (1) the angular velocity at the key is zero.
//
// Turns (every method except EULER and QUAT_COMPONENTS, which reproduce Blender's own channels):
// turns[i] extra signed full turns of the segment leaving key i (one value or one per key, whole
// numbers within ±10000; the last key's value is unused): the segment's rotation vector r[i] (from
// the keys, or from the Euler / axis-angle path, spins included) becomes r[i] + 2π·turns[i]·r̂[i], so
// its signed turn about r̂[i] is |r[i]| + 2π·turns[i] (−1 on a 30° segment: 330° the other way).
// A segment that turns by less than 1e-6 rad (identical keys) has no axis of its own: it takes the
// axis of the previous segment when that one turns by at least 1e-6 rad, else the next segment's
// (a segment's axis is the same vector in the frames of both its keys, and the still segment's two
// keys share one frame); with neither, InvalidArgument names the key. Such a segment turns
// 2π·turns[i] about that axis (its own rotation below 1e-6 rad added). Every method keeps the turns:
// the segment is split into sub-arcs along its axis as any turn beyond π (a turned segment of Euler
// keys too, so it no longer follows the Euler path's shape, only its turn).
//
// Tangents of SQUAD, TCB and CATMULL_ROM (curve_tangents.cpp has the rule in full): by default
// (clamped = true) time-scaled — the mean angular velocity over the two segments around a key —
// then clamped on the sphere as Blender's Auto Clamped handles are for scalars: a key where the
// motion holds or turns back gets a zero tangent, no tangent is longer than three times its
// segment's arc (Fritsch–Carlson), and every key segment obeys the path rule: its path is at most
// 1.5 × its keyed arc + 10° (kPathRuleFactor, kPathRuleSlack). So two equal keys hold still, and a
// short segment next to a long one does not overshoot. clamped = false gives the textbook tangents
// (Kochanek–Bartels' unequal-spacing adjustment; Barry–Goldman for CATMULL_ROM), unclamped.
// SPLINE_C2 is never clamped (it is exact C2): Curve::segment_paths reports its overshoot.
//   SPLINE_C2        cubic rotation vector per segment (local frame of its first key) with
//                    continuous angular velocity and angular acceleration at every key, for any key
//                    times; end velocities are the end segments' slerp velocities (as scipy's
//                    RotationSpline).
//
// Representation: every segment stores its relative rotation as a rotation vector r[i] with
// q[i+1] = q[i]·exp(r[i]/2), whose angle may exceed π. Keys from quaternions give |r| ≤ π (or up
// to 2π on SLERP's keyed path); keys from Euler angles give the turn of the Euler path, so spins
// survive. A segment turning more than π is split internally into equal sub-arcs of at most 2π/3
// along its turn (sub-keys that are never reported), so every method keeps the full turn.
//
// Key times and Euler keys the engine refuses (InvalidArgument naming the element), because double
// precision cannot follow them: consecutive keys closer than 1e-9 frames, farther than 1e12 frames,
// or closer than 2^-32 of their magnitude (t = 1, 1 + ulp: no sub-key or sample fits between them);
// for SQUAD, TCB, CATMULL_ROM and SPLINE_C2 also neighbouring spacings differing by more than 1e6
// times (their tangents carry one segment's velocity over the other). Euler angles beyond ±1e6 turns,
// or changing by more than 1e4 turns within one segment (the path is followed step by step).
//
// Loops (cyclic = true, every method): the keys span one period P = times.back() − times.front(),
// and the last key is the first one period later — the same rotation, either sign, within
// kLoopTolerance (1e-4 rad, float32 keys of angles up to ~1000 rad; the last key is then snapped
// onto the first, so the seam is exact); its segment may turn whole turns more (turns, or an Euler /
// axis-angle path that turns 0 → 360°). Anything else throws InvalidArgument naming both keys,
// their frames and the angle between them. The curve repeats: sample(t) is sample(t mod P) at every
// t, before, inside and after the keys (with the sign the curve has reached after whole periods, so
// the output stays sign-continuous across the seam; the rotation is the same), and the seam is a key
// like any other: SQUAD, TCB and CATMULL_ROM take the tangents of the first (= last) key from its
// neighbours across the seam (the key before the last, one period earlier; the second key, one
// period later; clamped as any key, one factor for both sides), SPLINE_C2 is solved as a periodic
// spline (C2 at the seam too, a cyclic block-tridiagonal solve), ease_out of the first key and
// ease_in of the last key act on the segments beside the seam. TCB's tension, continuity and bias
// at the seam are the first key's (the last key's are unused). A one-key loop is constant.
//
// Output: quaternions (w, x, y, z), sign-continuous along the curve (at a key the sample may be the
// key's negative, the same rotation); angular velocity in radians per frame in the world frame,
// computed analytically (q̇ = ½·ω·q). Outside [times.front(), times.back()] the curve is constant
// (Blender's constant extrapolation) with zero velocity, unless it is a loop, which repeats; one key
// gives a constant curve.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "quatcurve/euler.hpp"
#include "quatcurve/types.hpp"

namespace quatcurve {

enum class Method { EULER, QUAT_COMPONENTS, NLERP, SLERP, SQUAD, CATMULL_ROM, TCB, SPLINE_C2 };

// "EULER" … "SPLINE_C2"; anything else throws InvalidArgument listing the valid names.
Method parse_method(const std::string& name);
const char* method_name(Method method);
// All identifiers, in the order of the enum.
const std::vector<std::string>& method_names();

// The version of the hot samplers this process runs: 4 (x86-64-v4, AVX-512), 3 (x86-64-v3, AVX2 and
// FMA) or 0 (the baseline: any x86-64, or a build without the versions, such as arm64). Found from
// the CPU and the system (cpuid, xgetbv) at the first sampling; QUATCURVE_CPU_LEVEL=0 or 3 in the
// environment caps it. The versions give the same results to ~1e-15 rad (FMA contraction).
int cpu_level();

// Options of the methods. A per-key option holds one value (global) or one value per key.
struct CurveOptions {
    bool shortest_path = true;                 // SLERP
    bool clamped = true;                       // SQUAD, TCB, CATMULL_ROM (see "Tangents" above)
    std::vector<double> tension{0.0};          // TCB, each in [-1, 1]
    std::vector<double> continuity{0.0};       // TCB, each in [-1, 1]
    std::vector<double> bias{0.0};             // TCB, each in [-1, 1]
    std::vector<double> ease_in{0.0};          // every method, each in [0, 1] (3ds Max "Ease To" / 50)
    std::vector<double> ease_out{0.0};         // every method, each in [0, 1] (3ds Max "Ease From" / 50)
    std::vector<double> turns{0.0};            // all but EULER, QUAT_COMPONENTS: whole numbers (see "Turns")
    bool cyclic = false;                       // every method: a closed curve (see "Loops")
};

// Loops: the largest angle (radians) between the first and the last key of a cyclic curve.
constexpr double kLoopTolerance = 1e-4;

// Names of the options `method` takes: "ease_in", "ease_out", "cyclic" for every method; "turns" for every
// method but EULER and QUAT_COMPONENTS; "shortest_path" for SLERP; "clamped" for SQUAD, TCB and
// CATMULL_ROM; "tension", "continuity", "bias" for TCB.
std::vector<std::string> option_names(Method method);
// Sets option `name` of `options` from `values` (a bool is {0} or {1}). Throws InvalidArgument for
// an unknown name, a name `method` does not take, an empty or non-finite value, or a bool that is
// not 0/1. Ranges and per-key lengths are checked by the Curve constructor.
void set_option(CurveOptions& options, Method method, const std::string& name,
                const std::vector<double>& values);

// The path rule: a key segment whose keys are `arc` radians apart should turn at most
// kPathRuleFactor·arc + kPathRuleSlack radians along the way.
constexpr double kPathRuleFactor = 1.5;
constexpr double kPathRuleSlack = 10.0 * 3.141592653589793238462643383279502884 / 180.0;

// One key segment's keyed arc (the angle between its keys along the curve's chosen path; for Euler
// keys that turn a full turn or more, the turn of the chain of sub-keys on the Euler path, so spins
// count in full) and the length of the sampled path, both in radians.
struct SegmentPath {
    double arc;
    double length;
    // length ≤ kPathRuleFactor·arc + kPathRuleSlack
    bool obeys_path_rule() const { return length <= kPathRuleFactor * arc + kPathRuleSlack; }
};

class Curve {
public:
    // Keys from quaternions (w, x, y, z; normalized here). times strictly increasing and finite with
    // the spacing limits above, quats finite and non-zero (any size: QUAT_COMPONENTS lerps them as
    // given, without overflow), same count ≥ 1. EULER throws (it needs Euler keys).
    Curve(std::vector<double> times, const std::vector<Quat>& quats, Method method = Method::SLERP,
          CurveOptions options = {});
    // Raw form: n times, n quaternions as 4n doubles (w, x, y, z).
    Curve(const double* times, const double* wxyz, std::size_t n, Method method,
          CurveOptions options = {});

    // Keys from Euler angles (ax, ay, az) in `order`. Every segment keeps the turn of its Euler
    // path: its relative rotation is the rotation vector that follows the path continuously, so
    // 0 → 720° about Z turns twice, and a path of at most 180° gives the shortest rotation. Angles
    // within ±1e6 turns, changing by at most 1e4 turns per segment.
    static Curve from_euler(std::vector<double> times, const std::vector<Vec3>& angles,
                            EulerOrder order, Method method = Method::SLERP,
                            CurveOptions options = {});
    static Curve from_euler(const double* times, const double* angles, std::size_t n,
                            EulerOrder order, Method method, CurveOptions options = {});

    // Keys from axis-angle channels (angle, x, y, z) as Blender keys them: the rotation of `angle`
    // about the normalized axis (a zero axis is refused). Every segment keeps the turn of its
    // axis-angle path — the four channels linear between the keys, the axis normalized — followed
    // continuously as a rotation vector, so 0 → 720° about Z turns twice and 350° → 10° about Z turns
    // back 340° (as Blender's own channels do); a turn beyond π is split along the segment's rotation
    // vector. Angles within ±1e6 turns, changing by at most 1e4 turns per segment. values: 4n doubles.
    static Curve from_axis_angle(std::vector<double> times, const std::vector<double>& values,
                                 Method method = Method::SLERP, CurveOptions options = {});

    // Orientation at each of n times into out (4n doubles, w, x, y, z). Any order of times (sorted
    // times take the fast path); non-finite times throw.
    void sample(const double* times, std::size_t n, double* out_wxyz) const;
    std::vector<Quat> sample(const std::vector<double>& times) const;
    // World-frame angular velocity (radians per frame) at each of n times into out (3n doubles).
    // At a key the velocity of the segment that starts there (of the last segment at the last key).
    void angular_velocity(const double* times, std::size_t n, double* out_xyz) const;
    std::vector<Vec3> angular_velocity(const std::vector<double>& times) const;
    // An upper bound of the angular speed |ω| (radians per frame) at every time in [t0, t1]
    // (t0 ≤ t1; 0 outside the keys, where the curve is constant; a loop's wrap to its period), from each knot segment's own data
    // (native/src/curve_bounds.cpp has the bound of every method); +∞ where none is known (a
    // QUAT_COMPONENTS segment through a zero quaternion). What lets a check at finitely many times
    // prove a bound between them (bound.hpp).
    double speed_bound(double t0, double t1) const;
    // Upper bounds, at every time in [t0, t1], of |ω| (radians per frame) and of |q̈| (the second
    // derivative of the curve's unit quaternion, per frame²; between keys — at a key a C0 method
    // turns a corner, so intervals should end there). +∞ where none is known.
    void motion_bounds(double t0, double t1, double& speed, double& accel) const;
    // The times where the curve may turn a corner, sorted: the keys, and the sub-keys of segments
    // split because they turn more than π (a Euler or axis-angle path is followed through them, so
    // SLERP and NLERP change direction there), mapped through the ease warp.
    std::vector<double> corner_times() const;
    // The corner times within [t0, t1] (t0 ≤ t1): corner_times() inside it, and for a loop those of
    // every period that meets it (the seam's keys included, where every period starts).
    std::vector<double> corner_times(double t0, double t1) const;

    // Per key segment (keys − 1 of them): keyed arc and path length, the path measured as the sum
    // of the angles between `samples_per_segment` + 1 equally spaced samples of every knot segment
    // (a lower bound of the true length that converges to it). samples_per_segment ≥ 1.
    std::vector<SegmentPath> segment_paths(std::size_t samples_per_segment = 64) const;
    // The key segments (index, arc and path) whose segment_paths() length breaks the path rule. Nothing is
    // sampled where the construction settled it: SLERP and NLERP run along the keyed arc, and the
    // clamped SQUAD, TCB and CATMULL_ROM measured every key segment against the rule when they
    // were built (2% inside it, the same 64 samples per knot segment; curve_tangents.cpp).
    std::vector<std::pair<std::size_t, SegmentPath>> path_rule_breaks() const;

    Method method() const { return method_; }
    const CurveOptions& options() const { return options_; }
    const std::vector<double>& times() const { return times_; }
    // The keys: normalized input quaternions, or for Euler (axis-angle) keys the quaternion of each
    // key with the sign that follows the Euler (axis-angle) path.
    const std::vector<Quat>& quats() const { return quats_; }
    bool has_euler_keys() const { return !angles_.empty(); }
    const std::vector<Vec3>& euler_angles() const { return angles_; }
    EulerOrder euler_order() const { return order_; }
    // Relative rotation vector of each key segment (local frame of its first key), size keys - 1;
    // with turns, the turned one (q[i+1] = ±q[i]·exp(r[i]/2)).
    const std::vector<Vec3>& segment_rotvecs() const { return rotvecs_; }
    // Whether key segment k of this curve is key segment other_k of `other` bit for bit: the same
    // method, key times, knots, the method's data of each knot segment and its bounds, and ease (a
    // loop: also the same period and seam). Such a segment samples the same at every time. False for
    // an index beyond either curve's segments.
    bool same_key_segment(std::size_t k, const Curve& other, std::size_t other_k) const;

    // Implementation data, defined in native/src/curve_impl.hpp.
    struct Impl;
    ~Curve();
    Curve(const Curve&);
    Curve(Curve&&) noexcept;
    Curve& operator=(const Curve&);
    Curve& operator=(Curve&&) noexcept;

private:
    Curve(Method method, CurveOptions options);
    void build();
    void build_knots(const std::vector<Vec3>& extra);
    void close_loop();
    void bounds_within(double t0, double t1, double& speed, double& accel) const;

    Method method_;
    CurveOptions options_;
    std::vector<double> times_;
    std::vector<Quat> quats_;
    std::vector<Quat> raw_;        // keys as given (QUAT_COMPONENTS lerps these)
    std::vector<Vec3> angles_;     // Euler keys, empty for quaternion keys
    EulerOrder order_ = EulerOrder::XYZ;
    std::vector<Vec3> path_rotvecs_;  // axis-angle keys: each segment's lifted path, else empty
    std::vector<Vec3> rotvecs_;
    std::unique_ptr<Impl> impl_;
};

}  // namespace quatcurve
