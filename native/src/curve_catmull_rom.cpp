// CATMULL_ROM: a spherical cubic Bezier per knot segment in the cumulative form of Kim, Kim & Shin
// ("A general construction scheme for unit quaternion curves with simple high order derivatives",
// SIGGRAPH 1995):
//   q(s) = b0·exp(β1(s)·d01/2)·exp(β2(s)·d12/2)·exp(β3(s)·d23/2),
//   β1 = 1 − (1−s)³, β2 = 3s² − 2s³, β3 = s³ (the cumulative cubic Bernstein basis),
// with control rotations b1 = b0·exp(d01/2), b2 = b1·exp(d12/2), b3 = b2·exp(d23/2) = q_{i+1}.
// Since β1'(0) = 3 and β2'(0) = β3'(0) = 0 (and mirrored at s = 1) the curve leaves b0 along 3·d01
// and reaches b3 along 3·d23: with d01 = out/3 and d23 = in/3 the knot tangents are met exactly,
// so equal tangents on both sides of a knot make the curve C1. Every factor is the exponential of a
// fixed vector, so no logarithm (and no branch choice) is taken at run time: the curve is
// continuous whatever its tangents, and its path is at most |d01| + |d12| + |d23| long (each factor
// turns monotonically, β' ≥ 0).
#include <cmath>

#include "curve_impl.hpp"

namespace quatcurve::detail {

namespace {

// (β1, β2, β3) and their derivatives at s.
struct Basis {
    double b1, b2, b3, d1, d2, d3;
};
inline Basis basis(double s) {
    const double u = 1.0 - s;
    return {1.0 - u * u * u, s * s * (3.0 - 2.0 * s), s * s * s, 3.0 * u * u, 6.0 * s * u, 3.0 * s * s};
}

}  // namespace

// d12 is the branch of log(b1⁻¹·b2) nearest to r − d01 − d23 (what the legs leave of the keyed arc),
// so small tangents give the segment's own arc. If b0·exp(d01)·exp(d12)·exp(d23) lands on −q_{i+1}
// (possible with long legs), b0 of the next segment takes the opposite sign: every segment starts
// where the previous one ended, and the output stays sign-continuous (at a key it may be −key).
BezierSeg make_bezier_seg(const Curve::Impl& m, std::size_t i, const Vec3& out, const Vec3& in) {
    BezierSeg g;
    g.t0 = m.kt[i];
    g.inv_h = 1.0 / (m.kt[i + 1] - m.kt[i]);
    g.d01 = out / 3.0;
    g.d23 = in / 3.0;
    const Quat b1 = qmul(m.kq[i], qexp(g.d01));
    const Quat b2 = qmul(m.kq[i + 1], qexp(-g.d23));
    g.d12 = rotvec_near(qmul(qconj(b1), b2), m.kr[i] - g.d01 - g.d23);
    g.b0 = q4(m.kq[i]);
    return g;
}

Q4 bezier_at(const BezierSeg& g, double s) {
    const Basis b = basis(s);
    return mul(mul(mul(g.b0, exp_half(b.b1 * g.d01)), exp_half(b.b2 * g.d12)), exp_half(b.b3 * g.d23));
}

// The sign of every segment's b0 (see make_bezier_seg) and the rotation after the last knot.
void chain_bezier_signs(Curve::Impl& m) {
    double sign = 1.0;
    for (BezierSeg& g : m.bezier) {
        g.b0 = {sign * g.b0.w, sign * g.b0.x, sign * g.b0.y, sign * g.b0.z};
        const Q4 end = bezier_at(g, 1.0);
        const std::size_t next = static_cast<std::size_t>(&g - m.bezier.data()) + 1;
        const Quat& key = m.kq[next];
        if (end.w * key.w + end.x * key.x + end.y * key.y + end.z * key.z < 0.0) sign = -sign;
    }
    m.last_q = sign * m.kq.back();
}

void sample_bezier(const Curve::Impl& m, const double* times, std::size_t n, double* out) {
    drive(
        m.kt, times, n,
        [&](std::size_t i, std::size_t j, double t) {
            const BezierSeg& g = m.bezier[j];
            store(bezier_at(g, (t - g.t0) * g.inv_h), out + 4 * i);
        },
        [&](std::size_t i, bool before) { store(before ? m.first_q : m.last_q, out + 4 * i); });
}

// ω = R(b0)·[β1'·d01 + R(E1)·(β2'·d12 + R(E2)·β3'·d23)]·ds/dt, E_k the factors above.
void velocity_bezier(const Curve::Impl& m, const double* times, std::size_t n, double* out) {
    drive(
        m.kt, times, n,
        [&](std::size_t i, std::size_t j, double t) {
            const BezierSeg& g = m.bezier[j];
            const Basis b = basis((t - g.t0) * g.inv_h);
            const Quat e1 = qexp(b.b1 * g.d01), e2 = qexp(b.b2 * g.d12);
            const Vec3 inner = b.d2 * g.d12 + rot(e2, b.d3 * g.d23);
            const Vec3 w = rot(to_quat(g.b0), b.d1 * g.d01 + rot(e1, inner));
            store(g.inv_h * w, out + 3 * i);
        },
        [&](std::size_t i, bool) { store(Vec3(0.0), out + 3 * i); });
}

}  // namespace quatcurve::detail
