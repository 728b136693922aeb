// Private inline math of the curve engine (not part of the public API): tight quaternion kernels for
// the sampling loops, SO(3) Jacobians of the exponential map, and "jets" (a rotation with its world
// angular velocity) that carry exact derivatives through the methods' constructions.
//
// Conventions: rotation vectors ρ (angle |ρ|, any size) map to quaternions by exp(ρ/2); world
// angular velocity ω satisfies q̇ = ½·ω·q. Left Jacobian: d/dt exp(ρ/2) = ½·(J_l(ρ)·ρ̇)·exp(ρ/2).
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "numbers.hpp"
#include "quatcurve/types.hpp"

namespace quatcurve::detail {

// ---- preconditions -----------------------------------------------------------------------------------
// QUATCURVE_EXPECTS(cond, what) states a precondition of a private kernel: the ranges its formulas
// need. Callers guarantee them (the public API validates input and splits segments so they hold);
// the sanitizer build (QUATCURVE_ASSERTS, CMake's QUATCURVE_SANITIZE) checks them and aborts with
// the condition, so a broken guarantee is found where it breaks, not as a wrong number downstream.
[[noreturn]] inline void precondition_failed(const char* cond, const char* what, const char* file, int line) {
    std::fprintf(stderr, "quatcurve: precondition failed: %s (%s) at %s:%d\n", what, cond, file, line);
    std::abort();
}
#ifdef QUATCURVE_ASSERTS
#define QUATCURVE_EXPECTS(cond, what) \
    ((cond) ? void(0) : ::quatcurve::detail::precondition_failed(#cond, what, __FILE__, __LINE__))
#else
#define QUATCURVE_EXPECTS(cond, what) ((void)0)
#endif

// Always inlined, also where the optimizer would not: a hot sampler's helpers and lambdas must be
// compiled inside each of its versions (QUATCURVE_VERSIONS; an out-of-line copy is baseline x86-64
// code).
// On a lambda: [&](…) QUATCURVE_LAMBDA_INLINE {…}.
#define QUATCURVE_INLINE inline __attribute__((always_inline))
#define QUATCURVE_LAMBDA_INLINE __attribute__((always_inline))

using numbers::kPi;
using numbers::kTwoPi;

// ---- quaternion kernels (plain double arithmetic, no calls into GLM's generic code) ------------------
struct Q4 {
    double w, x, y, z;
};

inline Q4 q4(const Quat& q) { return {q.w, q.x, q.y, q.z}; }
inline Quat to_quat(const Q4& q) { return Quat(q.w, q.x, q.y, q.z); }

// Hamilton product a·b.
inline Q4 mul(const Q4& a, const Q4& b) {
    return {a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
            a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
            a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
            a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}
// conj(a)·b.
inline Q4 cmul(const Q4& a, const Q4& b) { return mul({a.w, -a.x, -a.y, -a.z}, b); }

inline Quat qmul(const Quat& a, const Quat& b) { return to_quat(mul(q4(a), q4(b))); }
inline Quat qconj(const Quat& q) { return Quat(q.w, -q.x, -q.y, -q.z); }
inline double qdot(const Quat& a, const Quat& b) { return a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z; }

// R(q)·v for a unit quaternion: v + 2w(u×v) + 2u×(u×v).
inline Vec3 rot(const Quat& q, const Vec3& v) {
    const Vec3 u(q.x, q.y, q.z);
    const Vec3 t = 2.0 * glm::cross(u, v);
    return v + q.w * t + glm::cross(u, t);
}
inline Vec3 rot_inv(const Quat& q, const Vec3& v) { return rot(qconj(q), v); }

// Taylor coefficients: cos x = Σ (−1)^n x^2n/(2n)!, sin x/x = Σ (−1)^n x^2n/(2n+1)!, n ≤ 11.
inline constexpr double kTaylorCos[12] = {
    1.0, -1.0 / 2, 1.0 / 24, -1.0 / 720, 1.0 / 40320, -1.0 / 3628800, 1.0 / 479001600,
    -1.0 / 87178291200.0, 1.0 / 20922789888000.0, -1.0 / 6402373705728000.0,
    1.0 / 2432902008176640000.0, -1.0 / 1124000727777607680000.0};
inline constexpr double kTaylorSinc[12] = {
    1.0, -1.0 / 6, 1.0 / 120, -1.0 / 5040, 1.0 / 362880, -1.0 / 39916800,
    1.0 / 6227020800.0, -1.0 / 1307674368000.0, 1.0 / 355687428096000.0,
    -1.0 / 121645100408832000.0, 1.0 / 51090942171709440000.0,
    -1.0 / 25852016738884976640000.0};

// cos x and sin x/x from x² by the first N terms of their series (Horner).
template <int N>
inline void taylor_cos_sinc(double x2, double& cq, double& sq) {
    cq = kTaylorCos[N - 1];
    sq = kTaylorSinc[N - 1];
#pragma GCC unroll 12
    for (int n = N - 2; n >= 0; --n) {
        cq = cq * x2 + kTaylorCos[n];
        sq = sq * x2 + kTaylorSinc[n];
    }
}

// c = cos(θ/2) and k = sin(θ/2)/θ from θ² (so exp(ρ/2) = (c, k·ρ) with θ = |ρ|), without sqrt.
// For θ ≤ 2π: Taylor series of the quarter angle x = θ/4 (|x| ≤ π/2, truncation below 1e-19;
// eight terms instead of twelve for θ ≤ 1.6, x² ≤ 0.16, truncation below 3e-20 — the common case of
// samples within a segment), then the double-angle step c = cos²x − sin²x, k = 2·cos x·sin x/θ.
// Beyond 2π: libm.
inline void exp_coeffs(double theta2, double& c, double& k) {
    QUATCURVE_EXPECTS(theta2 >= 0.0 && theta2 < 1e300, "exp_coeffs: θ² finite and non-negative");
    if (theta2 <= kTwoPi * kTwoPi) {
        const double x2 = theta2 * (1.0 / 16.0);
        double cq, sq;
        if (theta2 <= 2.56) {
            taylor_cos_sinc<8>(x2, cq, sq);
        } else {
            taylor_cos_sinc<12>(x2, cq, sq);
        }
        sq *= 0.25;  // sin x / θ, since θ = 4x
        c = cq * cq - theta2 * sq * sq;
        k = 2.0 * cq * sq;
    } else {
        const double theta = std::sqrt(theta2);
        c = std::cos(0.5 * theta);
        k = std::sin(0.5 * theta) / theta;
    }
}

inline Q4 exp_half(const Vec3& rho) {
    double c, k;
    exp_coeffs(glm::dot(rho, rho), c, k);
    return {c, k * rho.x, k * rho.y, k * rho.z};
}
inline Quat qexp(const Vec3& rho) { return to_quat(exp_half(rho)); }

// atan(x) for 0 ≤ x ≤ 0.66 divided by x: the rational approximation of Cephes' atan
// (atan x = x + x·z·P(z)/Q(z), z = x²), relative error about 1e-16.
inline double atan_over_x_small(double x) {
    const double z = x * x;
    const double p = (((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z -
                       7.500855792314704667340e1) * z - 1.228866684490136173410e2) * z -
                     6.485021904942025371773e1;
    const double q = ((((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z +
                       4.328810604912902668951e2) * z + 4.853903996359136964868e2) * z +
                     1.945506571482613964425e2;
    return 1.0 + z * p / q;
}

// φ/n with φ = atan2(n, w) ∈ [0, π/2], for n ≥ 0, w ≥ 0, n² + w² ≈ 1 (a unit quaternion's vector
// length and scalar after the hemisphere fix). Finite at n = 0 (→ 1/w). No libm call.
inline double atan2_over_n(double n, double w) {
    QUATCURVE_EXPECTS(n >= 0.0 && w >= 0.0 && std::fabs(n * n + w * w - 1.0) <= 1e-6,
                      "atan2_over_n: a unit quaternion's |v| and w, both non-negative");
    if (n <= 0.66 * w) return atan_over_x_small(n / w) / w;   // small angles, including n = 0
    if (w <= 0.66 * n) {                                      // near π/2: π/2 − atan(w/n)
        const double x = w / n;
        return (0.5 * kPi - x * atan_over_x_small(x)) / n;
    }
    const double y = (n - w) / (n + w);                       // |y| ≤ 0.21: π/4 + atan(y)
    return (0.25 * kPi + y * atan_over_x_small(std::fabs(y))) / n;
}

// Rotation vector of the rotation q (unit, either sign): angle in [0, π].
inline Vec3 rotvec_principal(const Quat& q) {
    double w = q.w;
    Vec3 v(q.x, q.y, q.z);
    if (w < 0.0) {
        w = -w;
        v = -v;
    }
    const double n = std::sqrt(glm::dot(v, v));
    return 2.0 * atan2_over_n(n, w) * v;
}

// 2·atan2(n, w)/n for any sign of w (angle in [0, 2π)); n = 0 with w < 0 (q = −1) gives 0.
inline double atan2_over_n_any(double n, double w) {
    if (w >= 0.0) return atan2_over_n(n, w);
    return n > 0.0 ? kPi / n - atan2_over_n(n, -w) : 0.0;
}

// Logarithm of the unit quaternion q as it stands, without a hemisphere flip: rotation vector of
// angle 2·atan2(|v|, w) ∈ [0, 2π). Continuous in q except at q = −1, so a path whose quaternions
// cross w = 0 does not jump (the flip of rotvec_principal would turn it by 2π there).
inline Vec3 rotvec_unflipped(const Quat& q) {
    const Vec3 v(q.x, q.y, q.z);
    return 2.0 * atan2_over_n_any(std::sqrt(glm::dot(v, v)), q.w) * v;
}

// The rotation vector of the rotation q (either sign) nearest to ref: principal χ0 = θ0·u, then
// χ = u·(θ0 + 2πk) with k the whole number of turns that brings it nearest to ref. When q is the
// identity the axis is ref's own.
inline Vec3 rotvec_near(const Quat& q, const Vec3& ref) {
    const Vec3 chi0 = rotvec_principal(q);
    const double t0 = std::sqrt(glm::dot(chi0, chi0));
    Vec3 u;
    if (t0 > 1e-300) {
        u = chi0 / t0;
    } else {
        const double rn = std::sqrt(glm::dot(ref, ref));
        if (rn == 0.0) return chi0;
        u = ref / rn;
    }
    const double k = std::nearbyint((glm::dot(ref, u) - t0) / kTwoPi);
    return (t0 + kTwoPi * k) * u;
}

// Rotation angle between the unit quaternions a and b (w, x, y, z arrays; either sign), in [0, π]:
// 4·atan2(|a − b|, |a + b|) with b taken in a's hemisphere, accurate also for tiny angles (where
// 2·acos(a·b) loses half its digits).
// |a − b|² and |a + b|² with b taken in a's hemisphere (angle_between, chord angles).
inline void chord_squares(const double* a, const double* b, double& d2, double& s2) {
    const double sign = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] < 0.0 ? -1.0 : 1.0;
    d2 = 0.0;
    s2 = 0.0;
    for (int k = 0; k < 4; ++k) {
        const double d = a[k] - sign * b[k], s = a[k] + sign * b[k];
        d2 += d * d;
        s2 += s * s;
    }
}

inline double angle_between(const double* a, const double* b) {
    double d2, s2;
    chord_squares(a, b, d2, s2);
    return 4.0 * std::atan2(std::sqrt(d2), std::sqrt(s2));
}

// ---- Jacobians of the exponential map ----------------------------------------------------------------
// A = (1−cos θ)/θ², B = (θ−sin θ)/θ³, C = (1 − (θ/2)·cot(θ/2))/θ², Ã = A'/θ, B̃ = B'/θ; series below
// θ = 0.5 (enough terms for 1e-17), closed forms above (1−cos θ written as 2 sin²(θ/2)).
struct JacCoeffs {
    double A, B, C, At, Bt;
};
inline JacCoeffs jac_coeffs(double theta2, bool need_C = true) {
    JacCoeffs j{};
    if (theta2 < 0.25) {
        const double t = theta2;
        j.A = 0.5 + t * (-1.0 / 24 + t * (1.0 / 720 + t * (-1.0 / 40320 + t * (1.0 / 3628800 - t / 479001600.0))));
        j.B = 1.0 / 6 + t * (-1.0 / 120 + t * (1.0 / 5040 + t * (-1.0 / 362880 + t * (1.0 / 39916800 - t / 6227020800.0))));
        j.C = 1.0 / 12 + t * (1.0 / 720 + t * (1.0 / 30240 + t * (1.0 / 1209600 + t * (1.0 / 47900160.0))));
        j.At = -1.0 / 12 + t * (1.0 / 180 + t * (-1.0 / 6720 + t * (1.0 / 453600 - t * (10.0 / 479001600.0))));
        j.Bt = -1.0 / 60 + t * (1.0 / 1260 + t * (-1.0 / 60480 + t * (1.0 / 4989600 - t * (10.0 / 6227020800.0))));
    } else {
        const double th = std::sqrt(theta2);
        const double sh = std::sin(0.5 * th), ch = std::cos(0.5 * th);
        const double omc = 2.0 * sh * sh, s = 2.0 * sh * ch;
        j.A = omc / theta2;
        j.B = (th - s) / (theta2 * th);
        j.C = need_C ? (1.0 - 0.5 * th * ch / sh) / theta2 : 0.0;
        j.At = s / (theta2 * th) - 2.0 * omc / (theta2 * theta2);
        j.Bt = omc / (theta2 * theta2) - 3.0 * (th - s) / (theta2 * theta2 * th);
    }
    return j;
}

// J_l(ρ)·v = v + A ρ×v + B ρ×(ρ×v)
inline Vec3 jl_apply(const Vec3& rho, const Vec3& v) {
    const JacCoeffs j = jac_coeffs(glm::dot(rho, rho), false);
    const Vec3 a = glm::cross(rho, v);
    return v + j.A * a + j.B * glm::cross(rho, a);
}
// J_l(ρ)⁻¹·v = v − ½ ρ×v + C ρ×(ρ×v)   (|ρ| < 2π)
inline Vec3 jl_inv_apply(const Vec3& rho, const Vec3& v) {
    QUATCURVE_EXPECTS(glm::dot(rho, rho) < kTwoPi * kTwoPi, "jl_inv_apply: |ρ| < 2π (C is singular at 2π)");
    const JacCoeffs j = jac_coeffs(glm::dot(rho, rho));
    const Vec3 a = glm::cross(rho, v);
    return v - 0.5 * a + j.C * glm::cross(rho, a);
}

inline Mat3 skew(const Vec3& v) {
    Mat3 m(0.0);  // m[col][row]
    m[1][0] = -v.z;
    m[2][0] = v.y;
    m[0][1] = v.z;
    m[2][1] = -v.x;
    m[0][2] = -v.y;
    m[1][2] = v.x;
    return m;
}
// J_r(ρ) = I − A K + B K² and J_r(ρ)⁻¹ = I + ½ K + C K², K = [ρ]×.
inline Mat3 jr_matrix(const Vec3& rho) {
    const JacCoeffs j = jac_coeffs(glm::dot(rho, rho), false);
    const Mat3 K = skew(rho);
    return Mat3(1.0) - j.A * K + j.B * (K * K);
}
inline Mat3 jr_inv_matrix(const Vec3& rho) {
    QUATCURVE_EXPECTS(glm::dot(rho, rho) < kTwoPi * kTwoPi, "jr_inv_matrix: |ρ| < 2π (C is singular at 2π)");
    const JacCoeffs j = jac_coeffs(glm::dot(rho, rho));
    const Mat3 K = skew(rho);
    return Mat3(1.0) + 0.5 * K + j.C * (K * K);
}

// ---- jets: values with their time derivatives --------------------------------------------------------
struct RJet {  // rotation q with world angular velocity w (q̇ = ½ w q)
    Quat q;
    Vec3 w;
};
struct VJet {  // rotation vector v with derivative d
    Vec3 v;
    Vec3 d;
};

inline RJet jconst(const Quat& q) { return {q, Vec3(0.0)}; }
inline RJet jmul(const RJet& a, const RJet& b) { return {qmul(a.q, b.q), a.w + rot(a.q, b.w)}; }
inline RJet jinv(const RJet& a) { return {qconj(a.q), -rot_inv(a.q, a.w)}; }
inline RJet jexp(const VJet& x) { return {qexp(x.v), jl_apply(x.v, x.d)}; }
// Rotation vector of X (branch nearest ref) with its derivative J_l⁻¹(χ)·ω.
inline VJet jlog_near(const RJet& X, const Vec3& ref) {
    const Vec3 chi = rotvec_near(X.q, ref);
    return {chi, jl_inv_apply(chi, X.w)};
}
inline VJet jlog(const RJet& X) {
    const Vec3 chi = rotvec_principal(X.q);
    return {chi, jl_inv_apply(chi, X.w)};
}
inline VJet jlog_unflipped(const RJet& X) {
    const Vec3 chi = rotvec_unflipped(X.q);
    return {chi, jl_inv_apply(chi, X.w)};
}
// (g, ġ)·x
inline VJet jscale(double g, double gd, const VJet& x) { return {g * x.v, gd * x.v + g * x.d}; }

}  // namespace quatcurve::detail
