// SPLINE_C2: per knot segment i a cubic rotation vector ρ_i(s) in the local frame of knot i,
// q(s) = q_i·exp(ρ_i(s)/2), with ρ_i(0) = 0, ρ_i(1) = r_i. The unknowns are the body angular
// velocities w_j at the knots (per frame); with a = h_i·w_i and b = h_i·J_r(r_i)⁻¹·w_{i+1},
//   ρ_i(s) = a·s + (3r − 2a − b)·s² + (a + b − 2r)·s³,
// which makes the angular velocity continuous by construction (ω_body = J_r(ρ)·ρ̇). Continuity of the
// angular acceleration at every interior knot j,
//   [D(r_{j−1}; b_{j−1})·b_{j−1} + J_r(r_{j−1})·ρ''_{j−1}(1)]/h_{j−1}² = ρ''_j(0)/h_j²
// (D(r; v) the derivative of J_r at r along v), is a block-tridiagonal system, nonlinear through the
// D-term, solved by Newton's method. End velocities: the end segments' slerp velocities r/h (as
// scipy's RotationSpline), so two keys give SLERP.
//
// A loop (curve.hpp "Loops") has no ends: its knot 0 and knot S are one knot (the same rotation, so
// the same body frame: w_S = w_0), the condition holds there too, and the S unknowns w_0 … w_{S−1}
// form a cyclic block-tridiagonal system (row j couples w_{j−1}, w_j, w_{j+1}, indices mod S). It is
// solved by bordering, as Blender's BLI_tridiagonal_solve_cyclic reduces its cyclic system to
// ordinary ones: w_0 … w_{S−2} = p + P·w_{S−1} from the ordinary block-tridiagonal rows 0 … S−2
// (their coupling to w_{S−1} moved to the right-hand side as three more columns), then row S−1
// gives w_{S−1} from one 3×3 block.
//
// The solve is checked: Newton stops when its step is below 1e-12 of the largest knot velocity; where
// 50 whole steps do not get there (or meet a singular pivot block), it starts again with damped
// steps, then by continuation in the D-term (solve_spline). A solve that ends neither converged nor
// with every residual below 1e-9 of its terms' size throws InvalidArgument naming the keys around the
// knot (the curve is not built half-way). Preconditions: every knot
// segment turns at most π (Curve splits longer ones), so J_r⁻¹ exists; knot times increase.
#include <cmath>
#include <cstdio>
#include <string>
#include <type_traits>

#include "curve_impl.hpp"
#include "curve_simd.hpp"

namespace quatcurve::detail {

namespace {

// N(b) = D(r; b)·b = −Ã(r·b)(r×b) + B̃(r·b)·r×(r×b) + B·b×(r×b) and its Jacobian dN/db.
struct NTerm {
    Vec3 value;
    Mat3 jac;
};
NTerm n_term(const Vec3& r, const Vec3& b, const JacCoeffs& j) {
    const Vec3 rb = glm::cross(r, b);
    const double rdb = glm::dot(r, b);
    NTerm out;
    out.value = -j.At * rdb * rb + j.Bt * rdb * glm::cross(r, rb) + j.B * glm::cross(b, rb);
    for (int k = 0; k < 3; ++k) {
        Vec3 d(0.0);
        d[k] = 1.0;
        const Vec3 rd = glm::cross(r, d);
        out.jac[k] = -j.At * (r[k] * rb + rdb * rd) + j.Bt * (r[k] * glm::cross(r, rb) + rdb * glm::cross(r, rd)) +
                     j.B * (glm::cross(d, rb) + glm::cross(b, rd));
    }
    return out;
}

}  // namespace

namespace {

// "keys i and j" (or "the sub-key between keys i and j") around knot j, for error messages.
std::string knot_name(const Curve::Impl& m, std::size_t j) {
    if (m.kkey[j] >= 0) return "key " + std::to_string(m.kkey[j]) + " (frame " + std::to_string(m.kt[j]) + ")";
    const int seg = m.kseg[j - 1];
    return "the sub-key at frame " + std::to_string(m.kt[j]) + " between keys " + std::to_string(seg) + " and " +
           std::to_string(seg + 1);
}

// A residual for a message, to three significant digits (a small one is not "0.000000").
std::string three_digits(double x) {
    char text[32];
    std::snprintf(text, sizeof text, "%.3g", x);
    return text;
}

// Inverse of a 3×3 pivot block, refused when singular or not finite.
Mat3 checked_inverse(const Mat3& a, const Curve::Impl& m, std::size_t knot) {
    const double det = glm::determinant(a);
    double scale = 0.0;
    for (int c = 0; c < 3; ++c) scale = std::fmax(scale, glm::length(a[c]));
    if (!std::isfinite(det) || !(std::fabs(det) > 1e-14 * scale * scale * scale))
        throw InvalidArgument("SPLINE_C2: the C2 solve is singular at " + knot_name(m, knot) +
                              " (pivot determinant " + std::to_string(det) + "); the keys around it cannot be "
                              "joined with continuous angular acceleration");
    return glm::inverse(a);
}

// The segments from the knot velocities w (S + 1 of them).
void make_spline_segments(Curve::Impl& m, const std::vector<double>& h, const std::vector<Mat3>& E,
                          const std::vector<Vec3>& w) {
    const std::size_t S = m.kr.size();
    m.spline.resize(S);
    for (std::size_t i = 0; i < S; ++i) {
        const Vec3& r = m.kr[i];
        const Vec3 a = h[i] * w[i], b = h[i] * (E[i] * w[i + 1]);
        const Vec3 c2 = 3.0 * r - 2.0 * a - b, c3 = a + b - 2.0 * r;
        // ρ's Bernstein control points on [0, 1] are 0, a/3, (2a + c2)/3 and ρ(1) = r; ρ(s) is a convex
        // combination of them, so |ρ(s)| ≤ the largest of their lengths (1e-12 more for rounding).
        const double b1 = glm::length(a) / 3.0, b2 = glm::length(2.0 * a + c2) / 3.0, b3 = glm::length(a + c2 + c3);
        const double bound = (1.0 + 1e-12) * std::fmax(std::fmax(b1, b2), b3);
        const Q4 Q = q4(m.kq[i]);
        m.spline[i] = {m.kt[i], 1.0 / h[i], Q, a, c2, c3, mul(Q, {0.0, a.x, a.y, a.z}), mul(Q, {0.0, c2.x, c2.y, c2.z}),
                       mul(Q, {0.0, c3.x, c3.y, c3.z}), bound * bound};
    }
}

// The system of the C2 condition (see the top) at knot velocities w: one row per interior knot of an
// open spline (knots 1 … S−1; w_0 and w_S fixed), one per knot of a loop (knots 0 … S−1; w_S = w_0).
// Row r: F_r = G − S_j at its knot j, and the blocks of its Jacobian, L_r (∂/∂w_{j−1}), D_r (∂/∂w_j),
// U_r (∂/∂w_{j+1}).
struct C2System {
    std::vector<double> h;
    std::vector<Mat3> E, Jr;
    std::vector<JacCoeffs> jc;
    double share = 1.0;  // of the D-term (solve_spline's continuation; the condition itself at 1)
};
struct C2Rows {
    std::vector<Mat3> L, D, U;
    std::vector<Vec3> F;
    double residual = 0.0;  // the largest |F_r| relative to its terms' size
    std::size_t worst = 0;  // its knot
    double merit = 0.0;     // Σ|F_r|²
};

void c2_rows(const Curve::Impl& m, const C2System& sys, const std::vector<Vec3>& w, C2Rows& out) {
    const std::size_t S = m.kr.size(), R = m.cyclic ? S : S - 1;
    const std::vector<double>& h = sys.h;
    out.L.resize(R);
    out.D.resize(R);
    out.U.resize(R);
    out.F.resize(R);
    out.residual = 0.0;
    out.worst = m.cyclic ? 0 : 1;
    out.merit = 0.0;
    for (std::size_t r = 0; r < R; ++r) {
        const std::size_t j = m.cyclic ? r : r + 1;  // the knot
        const std::size_t i = j == 0 ? S - 1 : j - 1;  // the segment arriving at it (across a loop's seam)
        const Vec3& rv = m.kr[i];
        const Vec3 a = h[i] * w[i], b = h[i] * (sys.E[i] * w[j]);
        NTerm nt = n_term(rv, b, sys.jc[i]);
        if (sys.share != 1.0) {
            nt.value *= sys.share;
            nt.jac *= sys.share;
        }
        const Vec3 G = (nt.value + sys.Jr[i] * (-6.0 * rv + 2.0 * a + 4.0 * b)) / (h[i] * h[i]);
        const Vec3& r1 = m.kr[j];
        const Vec3 a1 = h[j] * w[j], b1 = h[j] * (sys.E[j] * w[j + 1]);
        const Vec3 Sj = (6.0 * r1 - 4.0 * a1 - 2.0 * b1) / (h[j] * h[j]);
        out.F[r] = G - Sj;
        const double size = glm::length(G) + glm::length(Sj);
        const double rel = size > 0.0 ? glm::length(out.F[r]) / size : 0.0;
        if (!(rel <= out.residual)) {
            out.residual = rel;
            out.worst = j;
        }
        out.merit += glm::dot(out.F[r], out.F[r]);
        out.L[r] = (2.0 / h[i]) * sys.Jr[i];
        out.D[r] = (1.0 / h[i]) * (nt.jac * sys.E[i]) + Mat3(4.0 * (1.0 / h[i] + 1.0 / h[j]));
        out.U[r] = (2.0 / h[j]) * sys.E[j];
    }
}

// Newton's step: J·x = −F, x_r the change of row r's knot velocity. An open spline's J is block
// tridiagonal (block Thomas); a loop's is cyclic: L_r multiplies x_{r−1}, U_r x_{r+1} (mod S), solved
// by bordering.
std::vector<Vec3> c2_step(const Curve::Impl& m, const C2Rows& rows) {
    const std::vector<Mat3>&L = rows.L, &D = rows.D, &U = rows.U;
    const std::vector<Vec3>& F = rows.F;
    const std::size_t R = F.size();
    std::vector<Vec3> x(R);
    if (!m.cyclic) {
        const std::size_t n = R;
        std::vector<Mat3> Dinv(n);
        std::vector<Vec3> y(n);
        Dinv[0] = checked_inverse(D[0], m, 1);
        y[0] = -F[0];
        for (std::size_t k = 1; k < n; ++k) {
            const Mat3 f = L[k] * Dinv[k - 1];
            Dinv[k] = checked_inverse(D[k] - f * U[k - 1], m, k + 1);
            y[k] = -F[k] - f * y[k - 1];
        }
        x[n - 1] = Dinv[n - 1] * y[n - 1];
        for (std::size_t k = n - 1; k-- > 0;) x[k] = Dinv[k] * (y[k] - U[k] * x[k + 1]);
        return x;
    }
    if (R == 1) {
        x[0] = checked_inverse(L[0] + D[0] + U[0], m, 0) * -F[0];
        return x;
    }
    const std::size_t n = R - 1;  // rows 0 … S−2, unknowns x_0 … x_{S−2}; x_{S−1} = z
    // Row k's coefficient of z: L[0] in row 0, U[n−1] in row n−1 (both when n = 1).
    std::vector<Mat3> C(n, Mat3(0.0));
    C[0] += L[0];
    C[n - 1] += U[n - 1];
    // Thomas on [−F | −C]: x_k = p_k + P_k·z.
    std::vector<Mat3> Dinv(n), Y(n);
    std::vector<Vec3> y(n);
    Dinv[0] = checked_inverse(D[0], m, 0);
    y[0] = -F[0];
    Y[0] = -C[0];
    for (std::size_t k = 1; k < n; ++k) {
        const Mat3 f = L[k] * Dinv[k - 1];
        Dinv[k] = checked_inverse(D[k] - f * U[k - 1], m, k);
        y[k] = -F[k] - f * y[k - 1];
        Y[k] = -C[k] - f * Y[k - 1];
    }
    std::vector<Vec3> p(n);
    std::vector<Mat3> P(n);
    p[n - 1] = Dinv[n - 1] * y[n - 1];
    P[n - 1] = Dinv[n - 1] * Y[n - 1];
    for (std::size_t k = n - 1; k-- > 0;) {
        p[k] = Dinv[k] * (y[k] - U[k] * p[k + 1]);
        P[k] = Dinv[k] * (Y[k] - U[k] * P[k + 1]);
    }
    // Row S−1: L·x_{S−2} + D·z + U·x_0 = −F.
    const Mat3 A = D[n] + L[n] * P[n - 1] + U[n] * P[0];
    const Vec3 z = checked_inverse(A, m, n) * (-F[n] - L[n] * p[n - 1] - U[n] * p[0]);
    for (std::size_t k = 0; k < n; ++k) x[k] = p[k] + P[k] * z;
    x[n] = z;
    return x;
}

// w + α·x: row r's knot (r + 1 open, r in a loop, whose w_S follows w_0).
std::vector<Vec3> c2_moved(const Curve::Impl& m, const std::vector<Vec3>& w, const std::vector<Vec3>& x, double alpha) {
    std::vector<Vec3> out = w;
    const std::size_t first = m.cyclic ? 0 : 1;
    for (std::size_t r = 0; r < x.size(); ++r) out[first + r] += alpha * x[r];
    if (m.cyclic) out[out.size() - 1] = out[0];
    return out;
}

// Newton's method on the C2 system from w: true when its step falls below 1e-12 of the largest knot
// velocity within `iterations`. Plain (`damped` false): whole steps. Damped: each step halved until
// Σ|F|² falls (Armijo's rule; at most 40 halvings), which keeps a start far from the solution, as
// keys a hundredth of a frame apart beside turns of 100° make it, from cycling or running off.
// Unless it converged, `rows` ends as the system at the last w.
bool c2_newton(const Curve::Impl& m, const C2System& sys, std::vector<Vec3>& w, bool damped, int iterations,
               C2Rows& rows) {
    c2_rows(m, sys, w, rows);
    C2Rows trial;
    for (int iter = 0; iter < iterations; ++iter) {
        double wmax = 0.0;
        for (const Vec3& v : w) wmax = std::fmax(wmax, glm::length(v));
        const std::vector<Vec3> x = c2_step(m, rows);
        double step = 0.0;
        for (const Vec3& v : x) step = std::fmax(step, glm::length(v));
        if (!std::isfinite(step)) return false;
        if (!damped) {
            w = c2_moved(m, w, x, 1.0);
            if (step <= 1e-12 * wmax) return true;
            c2_rows(m, sys, w, rows);
            continue;
        }
        double alpha = 1.0;
        std::vector<Vec3> next = c2_moved(m, w, x, alpha);
        c2_rows(m, sys, next, trial);
        for (int half = 0; !(trial.merit <= (1.0 - 1e-4 * alpha) * rows.merit); ++half) {
            if (half == 40) return false;
            alpha *= 0.5;
            next = c2_moved(m, w, x, alpha);
            c2_rows(m, sys, next, trial);
        }
        w = std::move(next);
        std::swap(rows, trial);
        if (alpha * step <= 1e-12 * wmax) return true;
    }
    return false;
}

// The knot velocities of the spline, then its segments. Newton starts from the chord averages with
// whole steps; where 50 do not converge, it starts again damped (at most 200 steps); where that stalls
// too (at a local minimum of Σ|F|²), the D-term is brought in by shares from 0, the linear system
// (continuation). Each solve must end with its step below 1e-12 of the largest knot velocity or every
// residual below 1e-9 of its terms' size.
void solve_spline(Curve::Impl& m, const C2System& sys) {
    const std::size_t S = m.kr.size();
    const std::vector<double>& h = sys.h;
    std::vector<Vec3> w(S + 1);
    if (m.cyclic) {
        for (std::size_t j = 0; j < S; ++j) {
            const std::size_t i = j == 0 ? S - 1 : j - 1;
            w[j] = (m.kr[i] + m.kr[j]) / (h[i] + h[j]);
        }
        w[S] = w[0];
    } else {
        // ends fixed at the end segments' slerp velocities, interior from the chord average
        w[0] = m.kr[0] / h[0];
        w[S] = m.kr[S - 1] / h[S - 1];
        for (std::size_t j = 1; j < S; ++j) w[j] = (m.kr[j - 1] + m.kr[j]) / (h[j - 1] + h[j]);
    }
    if (m.cyclic || S > 1) {
        const std::vector<Vec3> start = w;
        C2Rows rows;
        bool solved;
        try {
            solved = c2_newton(m, sys, w, false, 50, rows) || rows.residual <= 1e-9;
        } catch (const InvalidArgument&) {  // a singular pivot on the way: the damped steps may avoid it
            solved = false;
        }
        if (!solved) {
            w = start;
            solved = c2_newton(m, sys, w, true, 200, rows) || rows.residual <= 1e-9;
        }
        if (!solved) {
            // Continuation: the D-term brought in by shares, each solve (damped) starting from the
            // last share's solution; a share that fails is approached in smaller steps.
            w = start;
            C2System part = sys;
            double share = 0.0, stride = 0.125;
            for (int stage = 0; stage < 64 && share < 1.0 && stride >= 1.0 / 1024.0; ++stage) {
                part.share = std::fmin(1.0, share + stride);
                std::vector<Vec3> tried = w;
                bool ok;
                try {
                    ok = c2_newton(m, part, tried, true, 50, rows) || rows.residual <= 1e-9;
                } catch (const InvalidArgument&) {
                    ok = false;
                }
                if (ok) {
                    w = std::move(tried);
                    share = part.share;
                    stride = std::fmin(0.5, 2.0 * stride);
                } else {
                    stride *= 0.5;
                }
            }
            solved = share == 1.0;
            if (!solved) {
                part.share = 1.0;
                c2_rows(m, part, w, rows);
                throw InvalidArgument("SPLINE_C2: the C2 solve did not converge (whole, damped and continued "
                                      "Newton steps); the angular acceleration at " + knot_name(m, rows.worst) +
                                      " still jumps by " + three_digits(rows.residual) + " of its size");
            }
        }
    }
    make_spline_segments(m, h, sys.E, w);
}

}  // namespace

void build_spline(Curve::Impl& m) {
    const std::size_t S = m.kr.size();
    for (std::size_t i = 0; i < S; ++i)
        QUATCURVE_EXPECTS(glm::length(m.kr[i]) <= kPi * (1.0 + 1e-9) && m.kt[i + 1] > m.kt[i],
                          "build_spline: knot segments turn at most π, knot times increase");
    C2System sys;
    sys.h.resize(S);
    sys.E.resize(S);
    sys.Jr.resize(S);
    sys.jc.resize(S);
    for (std::size_t i = 0; i < S; ++i) {
        sys.h[i] = m.kt[i + 1] - m.kt[i];
        sys.E[i] = jr_inv_matrix(m.kr[i]);
        sys.Jr[i] = jr_matrix(m.kr[i]);
        sys.jc[i] = jac_coeffs(glm::dot(m.kr[i], m.kr[i]), false);
    }
    solve_spline(m, sys);
}

// Per run of times in one segment, four samples at a time (curve_simd.hpp): v(s) = Q·(0, ρ(s)) by
// Horner, θ² = |v|², q = Q·c + k·v (SplineSeg); the exp series' length chosen once per segment from
// the bound of |ρ| on [0, 1] (exp_terms: 6, 8, 10 or 12 terms). A segment whose bound passes 2π (a cubic
// that may overshoot far beyond its end rotation; rare) takes 12 terms, and a lane whose |ρ| does
// pass 2π takes libm's cos and sin, as exp_coeffs does.
namespace {
QUATCURVE_INLINE void sample_spline_body(const Curve::Impl& m, const double* times, std::size_t n, double* out) {
    const SplineSeg* seg = m.spline.data();
    drive_runs(
        m.kt, times, n,
        [&](std::size_t j, std::size_t i0, std::size_t i1) QUATCURVE_LAMBDA_INLINE {
            const SplineSeg& g = seg[j];
            auto eval = [&](auto terms, auto beyond) QUATCURVE_LAMBDA_INLINE {
                for_groups(times, i0, i1, out, [&](const V4& t, QV& q) QUATCURVE_LAMBDA_INLINE {
                    const V4 s = (t - g.t0) * g.inv_h;
                    const V4 vw = ((g.p3.w * s + g.p2.w) * s + g.p1.w) * s;
                    const V4 vx = ((g.p3.x * s + g.p2.x) * s + g.p1.x) * s;
                    const V4 vy = ((g.p3.y * s + g.p2.y) * s + g.p1.y) * s;
                    const V4 vz = ((g.p3.z * s + g.p2.z) * s + g.p1.z) * s;
                    const V4 th2 = vw * vw + vx * vx + vy * vy + vz * vz;
                    V4 c, k;
                    exp_coeffs4<decltype(terms)::value>(th2, c, k);
                    if constexpr (decltype(beyond)::value) {
                        for (int l = 0; l < 4; ++l) {
                            if (th2[l] > kTwoPi * kTwoPi) {
                                // Through scalars: Clang binds no reference to a vector lane.
                                double cl, kl;
                                exp_coeffs(th2[l], cl, kl);
                                c[l] = cl;
                                k[l] = kl;
                            }
                        }
                    }
                    const Q4& Q = g.Q;
                    q.w = Q.w * c + k * vw;
                    q.x = Q.x * c + k * vx;
                    q.y = Q.y * c + k * vy;
                    q.z = Q.z * c + k * vz;
                });
            };
            using No = std::false_type;
            switch (exp_terms(g.bound2)) {
                case 6: eval(std::integral_constant<int, 6>(), No()); break;
                case 8: eval(std::integral_constant<int, 8>(), No()); break;
                case 10: eval(std::integral_constant<int, 10>(), No()); break;
                case 12: eval(std::integral_constant<int, 12>(), No()); break;
                default: eval(std::integral_constant<int, 12>(), std::true_type()); break;
            }
        },
        [&](std::size_t i, bool before) { store(before ? m.first_q : m.last_q, out + 4 * i); });
}
}  // namespace

QUATCURVE_VERSIONS(sample_spline, (const Curve::Impl& m, const double* times, std::size_t n, double* out),
                   (m, times, n, out))

// ω = R(q_i)·J_l(ρ)·ρ'(s)/h.
void velocity_spline(const Curve::Impl& m, const double* times, std::size_t n, double* out) {
    drive(
        m.kt, times, n,
        [&](std::size_t i, std::size_t j, double t) {
            const SplineSeg& g = m.spline[j];
            const double s = (t - g.t0) * g.inv_h;
            const Vec3 rho = ((g.c3 * s + g.c2) * s + g.c1) * s;
            const Vec3 drho = (3.0 * s * g.c3 + 2.0 * g.c2) * s + g.c1;
            store(rot(to_quat(g.Q), jl_apply(rho, drho * g.inv_h)), out + 3 * i);
        },
        [&](std::size_t i, bool) { store(Vec3(0.0), out + 3 * i); });
}

}  // namespace quatcurve::detail
