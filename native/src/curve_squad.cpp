// SQUAD and TCB: Shoemake's spherical quadrangle through the knots with the knot tangents of
// curve_tangents.cpp (TCB's ease, like every method's, is the time warp of curve_ease.cpp).
#include <cmath>
#include <type_traits>

#include "curve_impl.hpp"
#include "curve_simd.hpp"

namespace quatcurve::detail {

namespace {

// Shoemake's quadrangle at s from A = Q·exp(s r/2) = A·C1 + (Q·(0, r))·K1 and
// B = a·exp(s ψ/2) = a·C2 + (a·(0, ψ))·K2: X = A⁻¹B, q = A·X^g, g = 2s(1−s); log and exp by
// polynomial (curve_math.hpp). The outer slerp takes X as it stands, as Shoemake's formula does:
// choosing X's hemisphere would make the curve jump wherever X.w crosses 0 (large tangents, e.g.
// keys far apart), since X and −X are the same rotation but X^g and (−X)^g are not.
inline Q4 squad_from(const SquadSeg& g, double s, double C1, double K1, double C2, double K2) {
    const Q4 A{g.A.w * C1 + g.BA.w * K1, g.A.x * C1 + g.BA.x * K1, g.A.y * C1 + g.BA.y * K1,
               g.A.z * C1 + g.BA.z * K1};
    const Q4 B{g.a.w * C2 + g.Ba.w * K2, g.a.x * C2 + g.Ba.x * K2, g.a.y * C2 + g.Ba.y * K2,
               g.a.z * C2 + g.Ba.z * K2};
    const Q4 X = cmul(A, B);
    const double n2 = X.x * X.x + X.y * X.y + X.z * X.z;
    const double f = 2.0 * atan2_over_n_any(std::sqrt(n2), X.w);  // χ = f·vec(X)
    const double gf = 2.0 * s * (1.0 - s) * f;
    double c3, k3;
    exp_coeffs(gf * gf * n2, c3, k3);
    k3 *= gf;
    // A·(c3, k3·vec X) = (c3 − k3·X.w)·A + k3·A·X, and A·X = B (A is a unit quaternion).
    const double ca = c3 - k3 * X.w;
    return {ca * A.w + k3 * B.w, ca * A.x + k3 * B.x, ca * A.y + k3 * B.y, ca * A.z + k3 * B.z};
}

// The same construction with jets: exact world angular velocity; s advances at sd per frame.
inline RJet squad_jet(const SquadSeg& g, double s, double sd) {
    const RJet A = jmul(jconst(to_quat(g.A)), jexp({s * g.r, sd * g.r}));
    const RJet B = jmul(jconst(to_quat(g.a)), jexp({s * g.psi, sd * g.psi}));
    const VJet chi = jlog_unflipped(jmul(jinv(A), B));
    return jmul(A, jexp(jscale(2.0 * s * (1.0 - s), (2.0 - 4.0 * s) * sd, chi)));
}

}  // namespace

Q4 squad_at(const SquadSeg& g, double s) {
    double c1, k1, c2, k2;
    exp_coeffs(s * s * g.r2, c1, k1);
    exp_coeffs(s * s * g.psi2, c2, k2);
    return squad_from(g, s, c1, k1 * s, c2, k2 * s);
}

// The quadrangle of knot segment i from its knot tangents (curve_tangents.cpp): control rotations
// a = q_i·exp(α/2), α = (out − r)/2 and b = q_{i+1}·exp(β/2), β = (r − in)/2, which gives
// q'(0) = out and q'(1) = in (per s). At uniform spacing with Kochanek–Bartels' t = c = b = 0 this
// is Shoemake's a_i = q_i·exp(−(log(q_i⁻¹q_{i+1}) + log(q_i⁻¹q_{i−1}))/4).
SquadSeg make_squad_seg(const Curve::Impl& m, std::size_t i, const Vec3& out, const Vec3& in) {
    const Vec3& r = m.kr[i];
    const Vec3 alpha = 0.5 * (out - r);
    const Vec3 beta = 0.5 * (r - in);
    // Every quaternion of the quadrangle is taken on the segment's own chain: the end is
    // q_i·exp(r/2) (= ±q_{i+1}, whatever sign is stored) and the inner slerp a → b runs to b as
    // it stands (plain slerp, as Shoemake's formula). Then X = A⁻¹B is exp(α/2) at s = 0 and
    // exp(β/2) at s = 1, so the outer slerp needs no hemisphere choice and the curve is C1
    // even when stored neighbours sit in opposite hemispheres.
    const Quat a = qmul(m.kq[i], qexp(alpha));
    const Quat b = qmul(qmul(m.kq[i], qexp(r)), qexp(beta));
    const Vec3 psi = rotvec_unflipped(qmul(qconj(a), b));
    SquadSeg g;
    g.t0 = m.kt[i];
    g.inv_h = 1.0 / (m.kt[i + 1] - m.kt[i]);
    g.A = q4(m.kq[i]);
    g.BA = mul(g.A, {0.0, r.x, r.y, r.z});
    g.a = q4(a);
    g.Ba = mul(g.a, {0.0, psi.x, psi.y, psi.z});
    g.r2 = glm::dot(r, r);
    g.psi2 = glm::dot(psi, psi);
    g.r = r;
    g.psi = psi;
    squad_bounds(r, glm::length(alpha), glm::length(beta), psi, g.speed, g.accel);
    g.small_log = glm::length(r) + glm::length(alpha) + glm::length(psi) <= 1.0;
    return g;
}

// Per run of times in one segment, four or eight samples at a time (curve_simd.hpp): squad_from's formula
// lane by lane, A and B by polynomial (series lengths chosen once per segment from |r| ≤ π and
// |ψ| < 2π), X's log by the branch-free atan2_over_n_any4, the outer exp with 10 terms (g ≤ 1/2 and
// |χ| ≤ 2π, so g·|χ| ≤ π; 6 terms for a small log, |χ| ≤ 1).
namespace {

// Times within segment g, four or eight at a time: groups(f) calls f(t, q) for each group of four
// times or pair of groups (for_groups, for_group_pairs or for_groups_columns, curve_simd.hpp).
template <class Groups>
QUATCURVE_INLINE void squad_groups(const SquadSeg& g, Groups&& groups) {
    auto eval = [&](auto terms_a, auto terms_b, auto small_log) QUATCURVE_LAMBDA_INLINE {
        groups([&](const auto& t, auto& q) QUATCURVE_LAMBDA_INLINE {  // V4 or V4x2 times
            using V = std::decay_t<decltype(t)>;
            const V s = (t - g.t0) * g.inv_h;
            const V s2 = s * s;
            V c1, k1, c2, k2;
            exp_coeffs4<decltype(terms_a)::value>(s2 * g.r2, c1, k1);
            exp_coeffs4<decltype(terms_b)::value>(s2 * g.psi2, c2, k2);
            QVOf<V> A, B, X;
            combine(g.A, g.BA, c1, k1 * s, A);
            combine(g.a, g.Ba, c2, k2 * s, B);
            cmul(A, B, X);
            const V xx = X.x * X.x;  // products named in order (curve_simd.hpp: sums of two products)
            const V yy = X.y * X.y;
            const V n2 = xx + yy + X.z * X.z;
            V f;  // χ = f·vec(X)
            if constexpr (decltype(small_log)::value) {
                f = 2.0 * atan2_over_n_small4(sqrt4(n2), X.w);
            } else {
                f = 2.0 * atan2_over_n_any4(sqrt4(n2), X.w);
            }
            const V gf = 2.0 * s * (1.0 - s) * f;
            V c3, k3;
            // g·|χ| ≤ π: θ² ≤ π² < 10; a small log: |χ| ≤ 1, θ² ≤ 1/4
            exp_coeffs4<decltype(small_log)::value ? 6 : 10>(gf * gf * n2, c3, k3);
            k3 *= gf;
            // A·(c3, k3·vec X) = (c3 − k3·X.w)·A + k3·A·X, and A·X = B (A is a unit quaternion).
            const V ca = c3 - k3 * X.w;
            const V aw = ca * A.w, ax = ca * A.x, ay = ca * A.y, az = ca * A.z;
            const V bw = k3 * B.w, bx = k3 * B.x, by = k3 * B.y, bz = k3 * B.z;
            q.w = aw + bw;
            q.x = ax + bx;
            q.y = ay + by;
            q.z = az + bz;
        });
    };
    // A: |r| ≤ π, so 8 or 10 terms; B: |ψ| < 2π, so 8, 10 or 12 (exp_terms). A small log (|r| ≤ 1 and
    // |ψ| ≤ 1) takes 6 or 8 terms for both, as the larger needs.
    using T6 = std::integral_constant<int, 6>;
    using T8 = std::integral_constant<int, 8>;
    using Any = std::false_type;
    auto with_b = [&](auto terms_a) QUATCURVE_LAMBDA_INLINE {
        switch (exp_terms(g.psi2)) {
            case 8: eval(terms_a, T8(), Any()); break;
            case 10: eval(terms_a, std::integral_constant<int, 10>(), Any()); break;
            default: eval(terms_a, std::integral_constant<int, 12>(), Any()); break;
        }
    };
    if (g.small_log) {
        if (exp_terms(std::fmax(g.r2, g.psi2)) == 6) {
            eval(T6(), T6(), std::true_type());
        } else {
            eval(T8(), T8(), std::true_type());
        }
    } else if (exp_terms(g.r2) == 8) {
        with_b(T8());
    } else {
        with_b(std::integral_constant<int, 10>());
    }
}

// Samples i0 … i1 − 1 of `times`, all within segment g, as rows (w, x, y, z) at out + 4·i; with
// Pairs, two groups at a time (for_group_pairs).
template <bool Pairs>
QUATCURVE_INLINE void squad_segment_run(const SquadSeg& g, const double* times, std::size_t i0, std::size_t i1,
                                        double* out) {
    squad_groups(g, [&](auto&& f) QUATCURVE_LAMBDA_INLINE {
        if constexpr (Pairs) {
            for_group_pairs(times, i0, i1, out, f);
        } else {
            for_groups(times, i0, i1, out, f);
        }
    });
}

template <bool Pairs>
QUATCURVE_INLINE void sample_squad_runs(const Curve::Impl& m, const double* times, std::size_t n, double* out) {
    const SquadSeg* seg = m.squad.data();
    drive_runs(
        m.kt, times, n,
        [&](std::size_t j, std::size_t i0, std::size_t i1) QUATCURVE_LAMBDA_INLINE {
            squad_segment_run<Pairs>(seg[j], times, i0, i1, out);
        },
        [&](std::size_t i, bool before) { store(before ? m.first_q : m.last_q, out + 4 * i); });
}

}  // namespace

// Two groups at a time in the x86-64-v3 and v4 versions, whose AVX2 has sixteen 256-bit registers and
// AVX-512 32 (two chains side by side: 1.4–1.5× on this kernel); the baseline's SSE2 code, which
// splits every V4 in two already, would spill them (1.5× slower), so it takes one group at a time.
namespace {
#if QUATCURVE_MULTIVERSION
QUATCURVE_TARGET_V4 void squad_runs_v4(const Curve::Impl& m, const double* times, std::size_t n, double* out) {
    sample_squad_runs<true>(m, times, n, out);
}
QUATCURVE_TARGET_V3 void squad_runs_v3(const Curve::Impl& m, const double* times, std::size_t n, double* out) {
    sample_squad_runs<true>(m, times, n, out);
}
#endif
void squad_runs_v0(const Curve::Impl& m, const double* times, std::size_t n, double* out) {
    sample_squad_runs<false>(m, times, n, out);
}
}  // namespace

void sample_squad(const Curve::Impl& m, const double* times, std::size_t n, double* out) {
#if QUATCURVE_MULTIVERSION
    static const int level = cpu_level();
    if (level >= 4) return squad_runs_v4(m, times, n, out);
    if (level >= 3) return squad_runs_v3(m, times, n, out);
#endif
    squad_runs_v0(m, times, n, out);
}

// The first sample is g.A itself: at s = 0 the formula gives A = Q exactly (c1 = 1, k1·s = 0 and
// g = 0, so the outer exp is (1, ±0·X)), only a zero component's sign may differ, which no chord
// angle sees. The others, s = 1/samples … 1, fill whole groups of four for 16 or 64 samples.
namespace {
QUATCURVE_INLINE void sample_squad_segment_body(const SquadSeg& g, std::size_t samples, double* out) {
    QUATCURVE_EXPECTS(samples >= 4 && samples <= kMaxSegmentSamples, "sample_squad_segment: 4 … 64 samples");
    double times[kMaxSegmentSamples];
    const double h = 1.0 / g.inv_h;
    for (std::size_t k = 1; k <= samples; ++k)
        times[k - 1] = g.t0 + h * (static_cast<double>(k) / static_cast<double>(samples));
    out[0] = g.A.w;
    out[kSegmentColumn] = g.A.x;
    out[2 * kSegmentColumn] = g.A.y;
    out[3 * kSegmentColumn] = g.A.z;
    squad_groups(g, [&](auto&& f) QUATCURVE_LAMBDA_INLINE {
        for_groups_columns(times, samples, kSegmentColumn, out + 1, f);
    });
}
}  // namespace

QUATCURVE_VERSIONS(sample_squad_segment, (const SquadSeg& g, std::size_t samples, double* out), (g, samples, out))

void velocity_squad(const Curve::Impl& m, const double* times, std::size_t n, double* out) {
    drive(
        m.kt, times, n,
        [&](std::size_t i, std::size_t j, double t) {
            const SquadSeg& g = m.squad[j];
            store(squad_jet(g, (t - g.t0) * g.inv_h, g.inv_h).w, out + 3 * i);
        },
        [&](std::size_t i, bool) { store(Vec3(0.0), out + 3 * i); });
}

}  // namespace quatcurve::detail
