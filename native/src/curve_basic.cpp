// The one-segment-at-a-time methods: EULER (angles linear), QUAT_COMPONENTS and NLERP (components
// linear, then normalized), SLERP (constant angular speed).
#include <algorithm>
#include <cmath>
#include <type_traits>

#include "curve_impl.hpp"
#include "curve_simd.hpp"

namespace quatcurve::detail {

namespace {

int axis_index(char c) { return c - 'X'; }

// Quaternion of Euler angles a with axes (first, middle, last): q = q_last·q_middle·q_first, each
// q_axis(x) = (cos x/2, sin x/2 · e_axis). Continuous in a (no sign canonicalization), so the
// quaternions of a linear Euler path are sign-continuous. Also returns the partial products for
// the angular velocity.
struct EulerEval {
    Q4 q, q_last, q_last_mid;
};
inline Q4 axis_q4(int axis, double angle) {
    const double h = 0.5 * angle;
    Q4 q{std::cos(h), 0.0, 0.0, 0.0};
    // By name, not (&q.x)[axis]: indexing past a member is undefined, and Clang drops such stores.
    (axis == 0 ? q.x : axis == 1 ? q.y : q.z) = std::sin(h);
    return q;
}
inline EulerEval euler_eval(const int* ax, const Vec3& a) {
    EulerEval e;
    e.q_last = axis_q4(ax[2], a[ax[2]]);
    e.q_last_mid = mul(e.q_last, axis_q4(ax[1], a[ax[1]]));
    e.q = mul(e.q_last_mid, axis_q4(ax[0], a[ax[0]]));
    return e;
}
// Below this |p|² a lerped quaternion is normalized through its largest component (p may be tiny,
// or exactly 0 in the middle of opposite QUAT_COMPONENTS keys).
constexpr double kLerpTiny = 1e-200;
inline double max_abs(const Q4& p) {
    return std::fmax(std::fmax(std::fabs(p.w), std::fabs(p.x)), std::fmax(std::fabs(p.y), std::fabs(p.z)));
}
// p/|p| computed as (p/max|p_i|)/|…|; p = 0 gives (0, 1, 0, 0), as Blender's normalize_qt does.
inline Q4 normalized_small(Q4 p) {
    const double mx = max_abs(p);
    if (mx == 0.0) return {0.0, 1.0, 0.0, 0.0};
    p = {p.w / mx, p.x / mx, p.y / mx, p.z / mx};
    const double k = 1.0 / std::sqrt(p.w * p.w + p.x * p.x + p.y * p.y + p.z * p.z);
    return {p.w * k, p.x * k, p.y * k, p.z * k};
}

inline Vec3 unit(int axis, double value) {
    Vec3 v(0.0);
    v[axis] = value;
    return v;
}

}  // namespace

// Scales a non-zero quaternion by a power of two (exact) so that its largest component lies in [1, 2);
// returns the exponent removed.
int scale_to_unit_exponent(Q4& q) {
    const double m = std::fmax(std::fmax(std::fabs(q.w), std::fabs(q.x)), std::fmax(std::fabs(q.y), std::fabs(q.z)));
    const int e = std::ilogb(m);
    q = {std::ldexp(q.w, -e), std::ldexp(q.x, -e), std::ldexp(q.y, -e), std::ldexp(q.z, -e)};
    return e;
}

// NLERP / QUAT_COMPONENTS: p(s) = p[i] + s·(p[i+1] − p[i]) on the knots kt. Only p's direction is
// used, so both ends of a segment are scaled by one power of two (exact): raw keys of any size
// (Blender's channels, 1.7e308 or 1e-300) lerp without overflow or underflow. Ends whose sizes differ
// by more than 2^500 are brought to 2^500 apart, which changes the curve only within 2^-500 of a key
// (where the true angular velocity is beyond any sensible range).
void build_lerp(Curve::Impl& m, const std::vector<double>& kt, const std::vector<Quat>& p) {
    if (&kt != &m.kt) m.kt = kt;
    m.lerp.resize(kt.size() - 1);
    for (std::size_t i = 0; i + 1 < kt.size(); ++i) {
        Q4 a = q4(p[i]), b = q4(p[i + 1]);
        const int ea = scale_to_unit_exponent(a), eb = scale_to_unit_exponent(b);
        const int rel = std::max(-500, std::min(500, eb - ea));
        if (rel < 0) b = {std::ldexp(b.w, rel), std::ldexp(b.x, rel), std::ldexp(b.y, rel), std::ldexp(b.z, rel)};
        if (rel > 0) a = {std::ldexp(a.w, -rel), std::ldexp(a.x, -rel), std::ldexp(a.y, -rel), std::ldexp(a.z, -rel)};
        const Q4 c = mul(b, {a.w, -a.x, -a.y, -a.z});
        m.lerp[i] = {kt[i], kt[i + 1], 1.0 / (kt[i + 1] - kt[i]), a, b, Vec3(c.x, c.y, c.z)};
    }
}

// SLERP: q(s) = Q·exp(s·r/2) = Q·cos(sθ/2) + (Q·(0, r))·sin(sθ/2)/θ; ω = R(Q)·r/h.
void build_slerp(Curve::Impl& m) {
    const std::size_t S = m.kr.size();
    m.slerp.resize(S);
    for (std::size_t i = 0; i < S; ++i) {
        const double inv_h = 1.0 / (m.kt[i + 1] - m.kt[i]);
        const Vec3& r = m.kr[i];
        m.slerp[i] = {m.kt[i], inv_h, q4(m.kq[i]), mul(q4(m.kq[i]), {0.0, r.x, r.y, r.z}), glm::dot(r, r),
                      rot(m.kq[i], r) * inv_h};
    }
}

// EULER: angles linear between the keys as given (no wrapping: 0 → 720° turns twice).
void build_euler(Curve::Impl& m, const std::vector<double>& times, const std::vector<Vec3>& angles,
                 EulerOrder order) {
    const char* name = euler_order_name(order);
    for (int k = 0; k < 3; ++k) m.euler_axes[k] = axis_index(name[k]);
    m.kt = times;
    m.euler.resize(times.size() - 1);
    for (std::size_t i = 0; i + 1 < times.size(); ++i)
        m.euler[i] = {times[i], 1.0 / (times[i + 1] - times[i]), angles[i], angles[i + 1] - angles[i]};
    m.first_q = to_quat(euler_eval(m.euler_axes, angles.front()).q);
    m.last_q = to_quat(euler_eval(m.euler_axes, angles.back()).q);
}

// The segment's lerped 4-vector p at t (see LerpSeg).
inline Q4 lerp_at(const LerpSeg& g, double t) {
    const double s = (t - g.t0) * g.inv_h, r = (g.t1 - t) * g.inv_h;
    return {r * g.a.w + s * g.b.w, r * g.a.x + s * g.b.x, r * g.a.y + s * g.b.y, r * g.a.z + s * g.b.z};
}

// q = p/|p|; below |p|² = kLerpTiny through p's largest component (normalized_small). A zero p
// (only at the middle of exactly opposite QUAT_COMPONENTS keys) gives (0, 1, 0, 0), as Blender's
// normalize_qt does.
void sample_lerp(const Curve::Impl& m, const double* times, std::size_t n, double* out) {
    const LerpSeg* seg = m.lerp.data();
    drive(
        m.kt, times, n,
        [&](std::size_t i, std::size_t j, double t) {
            const Q4 p = lerp_at(seg[j], t);
            const double n2 = p.w * p.w + p.x * p.x + p.y * p.y + p.z * p.z;
            if (n2 > kLerpTiny) {
                const double k = 1.0 / std::sqrt(n2);
                store(Q4{p.w * k, p.x * k, p.y * k, p.z * k}, out + 4 * i);
            } else {
                store(normalized_small(p), out + 4 * i);
            }
        },
        [&](std::size_t i, bool before) { store(before ? m.first_q : m.last_q, out + 4 * i); });
}

// ω = 2·vec(ṗ·conj(p))/|p|² (the radial part of ṗ does not turn q) = 2·c/(h·|p|²) with
// c = vec(b·conj(a)), since vec(a·conj(a)) = 0; zero where p = 0; for a tiny p through p's largest
// component.
void velocity_lerp(const Curve::Impl& m, const double* times, std::size_t n, double* out) {
    const LerpSeg* seg = m.lerp.data();
    drive(
        m.kt, times, n,
        [&](std::size_t i, std::size_t j, double t) {
            const LerpSeg& g = seg[j];
            Q4 p = lerp_at(g, t);
            double n2 = p.w * p.w + p.x * p.x + p.y * p.y + p.z * p.z;
            double k = 2.0 * g.inv_h;
            if (!(n2 > kLerpTiny)) {  // p near 0: |p|² = mx²·|p/mx|², c/mx² taken in two steps
                const double mx = max_abs(p);
                if (mx == 0.0) {
                    store(Vec3(0.0), out + 3 * i);
                    return;
                }
                p = {p.w / mx, p.x / mx, p.y / mx, p.z / mx};
                n2 = p.w * p.w + p.x * p.x + p.y * p.y + p.z * p.z;
                store((k / n2) * ((g.c / mx) / mx), out + 3 * i);
                return;
            }
            store((k / n2) * g.c, out + 3 * i);
        },
        [&](std::size_t i, bool) { store(Vec3(0.0), out + 3 * i); });
}

// Per run of times in one segment, four samples at a time (curve_simd.hpp): q = A·C + B·K with
// (C, K) = exp_coeffs(s²θ²) (K·s); six series terms for a segment of θ ≤ 0.5, eight for θ ≤ 1.6,
// else ten (θ ≤ π: the segments are split at π; exp_terms). Every sample is evaluated on its own (no recurrence, no
// drift).
namespace {
QUATCURVE_INLINE void sample_slerp_body(const Curve::Impl& m, const double* times, std::size_t n, double* out) {
    const SlerpSeg* seg = m.slerp.data();
    drive_runs(
        m.kt, times, n,
        [&](std::size_t j, std::size_t i0, std::size_t i1) QUATCURVE_LAMBDA_INLINE {
            const SlerpSeg& g = seg[j];
            QUATCURVE_EXPECTS(g.r2 <= 10.0, "sample_slerp: segments turn at most π");
            auto eval = [&](auto terms) QUATCURVE_LAMBDA_INLINE {
                for_groups(times, i0, i1, out, [&](const V4& t, QV& q) QUATCURVE_LAMBDA_INLINE {
                    const V4 s = (t - g.t0) * g.inv_h;
                    V4 c, k;
                    exp_coeffs4<decltype(terms)::value>(s * s * g.r2, c, k);
                    combine(g.a, g.b, c, k * s, q);
                });
            };
            switch (exp_terms(g.r2)) {
                case 6: eval(std::integral_constant<int, 6>()); break;
                case 8: eval(std::integral_constant<int, 8>()); break;
                default: eval(std::integral_constant<int, 10>()); break;
            }
        },
        [&](std::size_t i, bool before) { store(before ? m.first_q : m.last_q, out + 4 * i); });
}
}  // namespace

QUATCURVE_VERSIONS(sample_slerp, (const Curve::Impl& m, const double* times, std::size_t n, double* out),
                   (m, times, n, out))

void velocity_slerp(const Curve::Impl& m, const double* times, std::size_t n, double* out) {
    drive(
        m.kt, times, n, [&](std::size_t i, std::size_t j, double) { store(m.slerp[j].omega, out + 3 * i); },
        [&](std::size_t i, bool) { store(Vec3(0.0), out + 3 * i); });
}

void sample_euler(const Curve::Impl& m, const double* times, std::size_t n, double* out) {
    drive(
        m.kt, times, n,
        [&](std::size_t i, std::size_t j, double t) {
            const EulerSeg& g = m.euler[j];
            const double s = (t - g.t0) * g.inv_h;
            store(euler_eval(m.euler_axes, g.a0 + s * g.da).q, out + 4 * i);
        },
        [&](std::size_t i, bool before) { store(before ? m.first_q : m.last_q, out + 4 * i); });
}

// R = R_last·R_middle·R_first, so ω = ȧ_last·e_last + R_last·(ȧ_middle·e_middle)
//                                    + R_last·R_middle·(ȧ_first·e_first).
void velocity_euler(const Curve::Impl& m, const double* times, std::size_t n, double* out) {
    const int* ax = m.euler_axes;
    drive(
        m.kt, times, n,
        [&](std::size_t i, std::size_t j, double t) {
            const EulerSeg& g = m.euler[j];
            const double s = (t - g.t0) * g.inv_h;
            const EulerEval e = euler_eval(ax, g.a0 + s * g.da);
            const Vec3 rate = g.da * g.inv_h;
            const Vec3 w = unit(ax[2], rate[ax[2]]) + rot(to_quat(e.q_last), unit(ax[1], rate[ax[1]])) +
                           rot(to_quat(e.q_last_mid), unit(ax[0], rate[ax[0]]));
            store(w, out + 3 * i);
        },
        [&](std::size_t i, bool) { store(Vec3(0.0), out + 3 * i); });
}

}  // namespace quatcurve::detail
