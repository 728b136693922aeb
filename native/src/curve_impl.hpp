// Private: the prepared data of a Curve and the sampling driver shared by native/src/curve*.cpp.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "curve_math.hpp"
#include "quatcurve/curve.hpp"
#include "quatcurve/errors.hpp"

namespace quatcurve {

namespace detail {

// p = r·a + s·b with s = (t − t0)/h, r = (t1 − t)/h, q = p/|p| (NLERP, QUAT_COMPONENTS);
// c = vec(b·conj(a)), so that ω = 2·c/(h·|p|²). The two weights make p exactly a multiple of a at t0
// and of b at t1 even when |a| and |b| differ by many orders of magnitude (a + s·(b − a) loses b to
// cancellation, and 1 − s at t1 may be an ulp instead of 0).
struct LerpSeg {
    double t0, t1, inv_h;
    Q4 a, b;
    Vec3 c;
};
// q(s) = a·cos(sθ/2) + b·sin(sθ/2)/θ with a = Q, b = Q·(0, r), θ² = r2 (SLERP).
struct SlerpSeg {
    double t0, inv_h;
    Q4 a, b;
    double r2;
    Vec3 omega;  // constant world angular velocity R(Q)·r/h
};
// Shoemake's quadrangle with control rotations a = Q·exp(α/2), b' = Q'·exp(β/2):
// A(s) = Q·exp(s r/2), B(s) = a·exp(s ψ/2), q = A·exp(g(s)·χ/2), χ = log(A⁻¹B), g = 2s(1−s).
struct SquadSeg {
    double t0, inv_h;
    Q4 A, BA;  // Q and Q·(0, r)
    Q4 a, Ba;  // a and a·(0, ψ)
    double r2, psi2;
    Vec3 r, psi;
    double speed;  // upper bounds on [0, 1] of the angular speed per unit s and of |d²q/ds²|
    double accel;  // (curve_bounds.cpp)
    // |r| + |α| + |ψ| ≤ 1 (α: a = Q·exp(α/2)): X = exp(−s r/2)·exp(α/2)·exp(s ψ/2) turns at most 1 rad,
    // so its log needs only atan's small-angle range (half angle ≤ 1/2, |vec X| ≤ 0.55·X.w).
    bool small_log;
};
// Spherical cubic Bezier with control rotations b0..b3 in the cumulative form (Kim, Kim & Shin):
// q(s) = sign·b0·exp(β1 d01/2)·exp(β2 d12/2)·exp(β3 d23/2), β1 = 1 − (1−s)³, β2 = 3s² − 2s³,
// β3 = s³; d01, d12, d23 the rotation vectors between consecutive control rotations (local frames);
// b0 carries the sign (±) that keeps the output sign-continuous across knots.
struct BezierSeg {
    double t0, inv_h;
    Q4 b0;
    Vec3 d01, d12, d23;
};
// q(s) = Q·exp(ρ(s)/2), ρ(s) = c1 s + c2 s² + c3 s³ (SPLINE_C2). Since exp(ρ/2) = (c, k·ρ) is linear
// in ρ, q = Q·c + k·v with v(s) = Q·(0, ρ(s)) = p1 s + p2 s² + p3 s³, p_i = Q·(0, c_i), and
// |v| = |ρ| (Q is a unit quaternion): the sampler needs no quaternion product.
struct SplineSeg {
    double t0, inv_h;
    Q4 Q;
    Vec3 c1, c2, c3;
    Q4 p1, p2, p3;
    double bound2;  // ≥ |ρ(s)|² on [0, 1] (from ρ's Bernstein control points): picks the exp series (exp_terms)
};
// Euler angles a0 + s·da (EULER).
struct EulerSeg {
    double t0, inv_h;
    Vec3 a0, da;
};

// Index j of the segment with knots[j] ≤ t < knots[j+1] (the last segment for t = knots.back()),
// for knots[0] ≤ t ≤ knots.back(); `hint` is the previous answer, so sorted times cost O(1) each.
QUATCURVE_INLINE std::size_t locate(const double* knots, std::size_t segments, double t, std::size_t& hint) {
    QUATCURVE_EXPECTS(segments >= 1 && hint < segments && t >= knots[0] && t <= knots[segments],
                      "locate: a time inside the knots and a hint naming a segment");
    std::size_t j = hint;
    if (t >= knots[j]) {
        if (j + 1 >= segments || t < knots[j + 1]) {
        } else if (j + 2 >= segments || t < knots[j + 2]) {
            ++j;
        } else {
            j = static_cast<std::size_t>(std::upper_bound(knots + j + 2, knots + segments, t) - knots) - 1;
        }
    } else {
        j = static_cast<std::size_t>(std::upper_bound(knots, knots + j, t) - knots) - 1;
    }
    hint = j;
    return j;
}

// A per-key option (one value for every key, or one per key) at key `key`.
inline double per_key(const std::vector<double>& v, int key) {
    return v.size() == 1 ? v[0] : v[static_cast<std::size_t>(key)];
}

[[noreturn]] inline void bad_time(std::size_t i) {
    throw InvalidArgument("times[" + std::to_string(i) + "]: not a finite number");
}

// Calls inside(i, j, t) for every time inside [knots.front(), knots.back()] (j its segment) and
// outside(i, before) for the others; non-finite times throw. (The four-wide samplers' driver,
// drive_runs, is in curve_simd.hpp.)
template <class Inside, class Outside>
inline void drive(const std::vector<double>& knots, const double* times, std::size_t n, Inside&& inside,
                  Outside&& outside) {
    const std::size_t segments = knots.size() - 1;
    const double first = knots.front(), last = knots.back();
    std::size_t hint = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const double t = times[i];
        if (t >= first && t <= last) {
            inside(i, locate(knots.data(), segments, t, hint), t);
        } else {
            if (!std::isfinite(t)) bad_time(i);
            outside(i, t < first);
        }
    }
}

}  // namespace detail

// Hot samplers come in three versions — x86-64-v4 (AVX-512: 32 vector registers, so far fewer spills
// of their 256-bit vectors), x86-64-v3 (AVX2, FMA) and the baseline x86-64 — and run the one the CPU
// has, found once at the first call (cpu_level). Written out rather than left to GCC's target_clones,
// so that clang builds them too: zig's clang builds the packaged modules, and its compiler-rt lacks
// the CPU detection target_clones calls (__cpu_indicator_init). Define QUATCURVE_NO_MULTIVERSION to
// build the baseline only. QUATCURVE_MULTIVERSION is 1 where the versions exist.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && !defined(QUATCURVE_NO_MULTIVERSION)
#define QUATCURVE_MULTIVERSION 1
#define QUATCURVE_X86_64_V3 "avx,avx2,bmi,bmi2,f16c,fma,lzcnt,movbe,popcnt,sse3,ssse3,sse4.1,sse4.2"
#define QUATCURVE_TARGET_V3 __attribute__((target(QUATCURVE_X86_64_V3)))
#define QUATCURVE_TARGET_V4 \
    __attribute__((target(QUATCURVE_X86_64_V3 ",avx512f,avx512bw,avx512cd,avx512dq,avx512vl")))
#else
#define QUATCURVE_MULTIVERSION 0
#endif

// Which version runs: cpu_level() (curve.hpp; curve.cpp). QUATCURVE_CPU_LEVEL=0 or 3 in the
// environment caps it, so the tests run every version on one machine.

// `void name params`, running name##_body(args) — a QUATCURVE_INLINE function — compiled for each
// level. `attrs`: more attributes of every version.
#if QUATCURVE_MULTIVERSION
#define QUATCURVE_VERSIONS_WITH(attrs, name, params, args)                    \
    attrs QUATCURVE_TARGET_V4 static void name##_v4 params { name##_body args; } \
    attrs QUATCURVE_TARGET_V3 static void name##_v3 params { name##_body args; } \
    attrs static void name##_v0 params { name##_body args; }                  \
    void name params {                                                        \
        static const int level = cpu_level();                                 \
        if (level >= 4) {                                                     \
            name##_v4 args;                                                   \
        } else if (level >= 3) {                                              \
            name##_v3 args;                                                   \
        } else {                                                              \
            name##_v0 args;                                                   \
        }                                                                     \
    }
#else
#define QUATCURVE_VERSIONS_WITH(attrs, name, params, args) \
    void name params { name##_body args; }
#endif
#define QUATCURVE_VERSIONS(name, params, args) QUATCURVE_VERSIONS_WITH(, name, params, args)

struct Curve::Impl {
    // Knots after splitting the segments that turn more than π (keys plus sub-keys).
    std::vector<double> kt;    // knot times
    std::vector<Quat> kq;      // sign-continuous knot rotations, kq[i+1] = kq[i]·exp(kr[i]/2)
    std::vector<Vec3> kr;      // relative rotation vector of each knot segment (local frame)
    std::vector<int> kkey;     // key index of each knot, −1 for a sub-key
    std::vector<int> kseg;     // key segment of each knot segment

    std::vector<detail::LerpSeg> lerp;
    std::vector<detail::SlerpSeg> slerp;
    std::vector<detail::SquadSeg> squad;
    std::vector<detail::BezierSeg> bezier;
    std::vector<detail::SplineSeg> spline;
    std::vector<detail::EulerSeg> euler;
    int euler_axes[3] = {0, 1, 2};  // first, middle, last axis of the Euler order

    // Ease (every method, curve_ease.cpp): per key segment, ease_out of its first key and ease_in
    // of its second key; `eased` when any is non-zero.
    bool eased = false;
    std::vector<double> ease_a, ease_b;

    Quat first_q, last_q;  // constant extrapolation

    // Loops (curve.hpp "Loops"): times wrap into [kt.front(), kt.back()) with period P; the curve
    // at the end of a period is period_sign × the curve at its start (either sign is the same
    // rotation), so a time k periods on is sampled with period_sign^k.
    bool cyclic = false;
    double period = 0.0, period_sign = 1.0;

    // Set by the builders whose construction already measured every key segment against the path
    // rule (the clamped tangent methods, curve_tangents.cpp) or whose path is its keyed arc (SLERP,
    // NLERP): Curve::path_rule_breaks then has nothing left to sample.
    bool path_rule_proven = false;

    // Upper bounds of the angular speed (radians per frame) and of |d²q/dt²| (per frame², q the unit
    // quaternion), before ease, on each knot segment of kt (curve_bounds.cpp: Curve::speed_bound,
    // Curve::accel_bound).
    std::vector<double> kspeed, kaccel;
};

namespace detail {
// A loop's time t wrapped into [first, first + period) (the last key's time maps to the first's),
// and the count of whole periods taken off, as a double.
inline double wrap_time(const Curve::Impl& m, double t, double& periods) {
    const double first = m.kt.front(), last = m.kt.back(), P = m.period;
    double k = std::floor((t - first) / P);
    double w = t - k * P;
    if (w < first) {  // the division rounded up
        w += P;
        k -= 1.0;
    }
    if (w >= last) {  // the division rounded down, or t is at a period's end
        w -= P;
        k += 1.0;
    }
    periods = k;
    return std::clamp(w, first, last);
}

// Builders and evaluators, one family per file.
void build_lerp(Curve::Impl& m, const std::vector<double>& kt, const std::vector<Quat>& p);  // curve.cpp
void build_slerp(Curve::Impl& m);                                                            // curve.cpp
void build_euler(Curve::Impl& m, const std::vector<double>& times, const std::vector<Vec3>& angles,
                 EulerOrder order);                                                          // curve.cpp
void build_spline(Curve::Impl& m);                                            // curve_spline.cpp
// kspeed from the built segments of whichever family is in use (curve_bounds.cpp).
void build_speed_bounds(Curve::Impl& m);
// The speed and |d²q/ds²| bounds of a quadrangle segment per unit s (curve_bounds.cpp), from its
// tangents' control angles |α| = |out − r|/2, |β| = |r − in|/2 (make_squad_seg).
void squad_bounds(const Vec3& r, double alpha, double beta, const Vec3& psi, double& speed, double& accel);

// Ease (curve_ease.cpp): set_ease fills ease_a/ease_b from the options; ease_times writes the warped
// time of every time into warped (and dt'/dt into rate when not null).
void set_ease(Curve::Impl& m, const CurveOptions& options, std::size_t keys);
void ease_times(const Curve::Impl& m, const std::vector<double>& key_times, const double* times, std::size_t n,
                double* warped, double* rate);

// SQUAD, TCB and CATMULL_ROM: knot tangents (curve_tangents.cpp), then the method's segments.
// A tangent is a rotation vector per unit segment parameter s in its knot's local frame: out[j]
// leaves knot j into knot segment j, in[j] arrives at knot j from knot segment j − 1.
struct KnotTangents {
    std::vector<Vec3> out, in;
};
void build_tangent_curve(Curve::Impl& m, Method method, const CurveOptions& options);  // curve_tangents.cpp
// The keyed arc of every key segment: the sum of its knot segments' angles — the angle between its
// keys, or for a spin from Euler keys the turn of the geodesic chain through its sub-keys.
std::vector<double> key_arcs(const Curve::Impl& m);
SquadSeg make_squad_seg(const Curve::Impl& m, std::size_t i, const Vec3& out, const Vec3& in);  // curve_squad.cpp
Q4 squad_at(const SquadSeg& g, double s);                                                      // curve_squad.cpp
// The segment g at s = k/samples, k = 0 … samples (4 ≤ samples ≤ kMaxSegmentSamples), as sample()
// computes them (at s = 0 up to the sign of a zero component, see curve_squad.cpp), by component: w[k] = out[k], x[k] = out[kSegmentColumn + k], y[k] at
// 2·kSegmentColumn + k, z[k] at 3·kSegmentColumn + k (curve_squad.cpp).
constexpr std::size_t kMaxSegmentSamples = 64;
constexpr std::size_t kSegmentColumn = kMaxSegmentSamples + 1;
void sample_squad_segment(const SquadSeg& g, std::size_t samples, double* out);
BezierSeg make_bezier_seg(const Curve::Impl& m, std::size_t i, const Vec3& out, const Vec3& in);  // curve_catmull_rom.cpp
Q4 bezier_at(const BezierSeg& g, double s);                                                       // curve_catmull_rom.cpp
void chain_bezier_signs(Curve::Impl& m);                                                          // curve_catmull_rom.cpp

// Every family's samplers have the signature of Sampler: (prepared curve, n times, n outputs of
// 4 (orientation) or 3 (angular velocity) doubles).
using Sampler = void(const Curve::Impl& m, const double* t, std::size_t n, double* out);
Sampler sample_lerp, velocity_lerp;      // curve_basic.cpp
Sampler sample_slerp, velocity_slerp;    // curve_basic.cpp
Sampler sample_euler, velocity_euler;    // curve_basic.cpp
Sampler sample_squad, velocity_squad;    // curve_squad.cpp
Sampler sample_bezier, velocity_bezier;  // curve_catmull_rom.cpp
Sampler sample_spline, velocity_spline;  // curve_spline.cpp

inline std::vector<double> key_arcs(const Curve::Impl& m) {
    std::vector<double> arcs(m.kseg.empty() ? 0 : static_cast<std::size_t>(m.kseg.back()) + 1, 0.0);
    for (std::size_t j = 0; j < m.kseg.size(); ++j) arcs[static_cast<std::size_t>(m.kseg[j])] += glm::length(m.kr[j]);
    return arcs;
}

inline void store(const Q4& q, double* out) {
    out[0] = q.w;
    out[1] = q.x;
    out[2] = q.y;
    out[3] = q.z;
}
inline void store(const Quat& q, double* out) { store(q4(q), out); }
inline void store(const Vec3& v, double* out) {
    out[0] = v.x;
    out[1] = v.y;
    out[2] = v.z;
}
}  // namespace detail

}  // namespace quatcurve
