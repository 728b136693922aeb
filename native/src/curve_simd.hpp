// Private: four samples at a time for the per-segment sampling loops (curve_basic.cpp,
// curve_squad.cpp, curve_spline.cpp). V4 holds one double per sample (lane k = sample i + k), so
// the formulas read as their scalar versions in curve_math.hpp; a quaternion of four samples is four
// V4s (QV, one per component) and is stored as four (w, x, y, z) rows by a 4×4 transpose. GCC and
// Clang vector extensions: one 256-bit register per V4 in the x86-64-v4 and x86-64-v3 versions of a
// hot sampler (QUATCURVE_VERSIONS, curve_impl.hpp), two SSE2 registers in the baseline one. Every
// helper is always inlined into its sampler, so no V4 crosses a call (whose ABI would differ between
// the versions; hence -Wpsabi is silenced here).
//
// The formulas are templates over V4 and V4x2 (eight samples as two V4s, for SQUAD's long chain of
// dependent operations). The polynomial kernels take the term count as a parameter, chosen once per
// segment from a bound of the segment's angles: lanes never depend on their neighbours, so a time
// gives the same bits alone or in a batch, in a V4 or a V4x2 (test_curve.cpp checks it bit for bit).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstring>

#include "curve_impl.hpp"
#include "curve_math.hpp"

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wpsabi"  // for the including sampler file too: its V4 code is inlined
#endif

namespace quatcurve::detail {

typedef double V4 __attribute__((vector_size(32)));
using M4 = decltype(V4{} < V4{});  // lane masks of comparisons: all ones or 0
template <class V>
using MaskOf = decltype(V{} < V{});

#if defined(__clang__)
#define QUATCURVE_SHUFFLE(a, b, i, j, k, l) __builtin_shufflevector(a, b, i, j, k, l)
#else
#define QUATCURVE_SHUFFLE(a, b, i, j, k, l) __builtin_shuffle(a, b, M4{i, j, k, l})
#endif

template <class V>
struct QVOf {
    V w, x, y, z;
};
using QV = QVOf<V4>;

QUATCURVE_INLINE V4 splat(double x) { return V4{x, x, x, x}; }
QUATCURVE_INLINE V4 load4(const double* p) {
    V4 v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
template <class V>
QUATCURVE_INLINE V sqrt4(const V& x) {
    V r;
    for (int i = 0; i < static_cast<int>(sizeof(V) / sizeof(double)); ++i) r[i] = std::sqrt(x[i]);
    return r;
}
// m ? a : b, lane by lane
template <class V>
QUATCURVE_INLINE V select(const MaskOf<V>& m, const V& a, const V& b) {
    return reinterpret_cast<V>((reinterpret_cast<MaskOf<V>>(a) & m) | (reinterpret_cast<MaskOf<V>>(b) & ~m));
}

// Eight samples as two V4s (V4x2: each operation on both halves, one after the other), for the
// samplers whose chain of dependent operations is long (SQUAD's: two exp series, a log with three
// divisions, a third exp): two independent chains side by side keep the units busy where one group
// waits on its own results. Every lane gets the V4 operations, so the same bits as in a V4 group.
// Not a V8 vector: GCC lowers 512-bit comparison masks lane by lane in target clones.
struct V4x2 {
    V4 lo, hi;
};
struct M4x2 {
    M4 lo, hi;
};
#define QUATCURVE_V4X2_ARITHMETIC(op)                                                                  \
    QUATCURVE_INLINE V4x2 operator op(const V4x2& a, const V4x2& b) { return {a.lo op b.lo, a.hi op b.hi}; } \
    QUATCURVE_INLINE V4x2 operator op(const V4x2& a, double b) { return {a.lo op b, a.hi op b}; }             \
    QUATCURVE_INLINE V4x2 operator op(double a, const V4x2& b) { return {a op b.lo, a op b.hi}; }             \
    QUATCURVE_INLINE V4x2& operator op##=(V4x2& a, const V4x2& b) {                                    \
        a.lo op##= b.lo;                                                                             \
        a.hi op##= b.hi;                                                                             \
        return a;                                                                                     \
    }
QUATCURVE_V4X2_ARITHMETIC(+)
QUATCURVE_V4X2_ARITHMETIC(-)
QUATCURVE_V4X2_ARITHMETIC(*)
QUATCURVE_V4X2_ARITHMETIC(/)
#undef QUATCURVE_V4X2_ARITHMETIC
#define QUATCURVE_V4X2_COMPARE(op) \
    QUATCURVE_INLINE M4x2 operator op(const V4x2& a, const V4x2& b) { return {a.lo op b.lo, a.hi op b.hi}; }
QUATCURVE_V4X2_COMPARE(<)
QUATCURVE_V4X2_COMPARE(<=)
QUATCURVE_V4X2_COMPARE(>=)
QUATCURVE_V4X2_COMPARE(==)
#undef QUATCURVE_V4X2_COMPARE
QUATCURVE_INLINE V4x2 operator-(const V4x2& a) { return {-a.lo, -a.hi}; }
QUATCURVE_INLINE M4x2 operator&(const M4x2& a, const M4x2& b) { return {a.lo & b.lo, a.hi & b.hi}; }
QUATCURVE_INLINE M4x2 operator~(const M4x2& a) { return {~a.lo, ~a.hi}; }
QUATCURVE_INLINE V4x2 sqrt4(const V4x2& x) { return {sqrt4(x.lo), sqrt4(x.hi)}; }
QUATCURVE_INLINE V4x2 select(const M4x2& m, const V4x2& a, const V4x2& b) {
    return {select(m.lo, a.lo, b.lo), select(m.hi, a.hi, b.hi)};
}

// The quaternions of four samples as rows (w, x, y, z) at out[0..15].
QUATCURVE_INLINE void store_rows(const QV& q, double* out) {
    const V4 a = QUATCURVE_SHUFFLE(q.w, q.x, 0, 4, 2, 6);  // w0 x0 w2 x2
    const V4 b = QUATCURVE_SHUFFLE(q.w, q.x, 1, 5, 3, 7);  // w1 x1 w3 x3
    const V4 c = QUATCURVE_SHUFFLE(q.y, q.z, 0, 4, 2, 6);  // y0 z0 y2 z2
    const V4 d = QUATCURVE_SHUFFLE(q.y, q.z, 1, 5, 3, 7);  // y1 z1 y3 z3
    const V4 r0 = QUATCURVE_SHUFFLE(a, c, 0, 1, 4, 5), r1 = QUATCURVE_SHUFFLE(b, d, 0, 1, 4, 5);
    const V4 r2 = QUATCURVE_SHUFFLE(a, c, 2, 3, 6, 7), r3 = QUATCURVE_SHUFFLE(b, d, 2, 3, 6, 7);
    std::memcpy(out, &r0, sizeof r0);
    std::memcpy(out + 4, &r1, sizeof r1);
    std::memcpy(out + 8, &r2, sizeof r2);
    std::memcpy(out + 12, &r3, sizeof r3);
}

// Where a sum takes two products, GCC contracts the product computed first into an FMA whose addend
// is the other. So products are named, in order, before they are summed (here and in the samplers):
// a V4x2's operator calls would compute the right one first, and its lanes would not get a V4's bits.
// a0·b0 ± a1·b1 ± a2·b2 ± a3·b3, left to right (s1, s2, s3: the signs).
template <class V>
QUATCURVE_INLINE V signed_sum4(const V& a0, const V& b0, double s1, const V& a1, const V& b1, double s2, const V& a2,
                               const V& b2, double s3, const V& a3, const V& b3) {
    const V p0 = a0 * b0;
    const V p1 = a1 * b1;
    V r = s1 > 0 ? p0 + p1 : p0 - p1;
    const V p2 = a2 * b2;
    r = s2 > 0 ? r + p2 : r - p2;
    const V p3 = a3 * b3;
    return s3 > 0 ? r + p3 : r - p3;
}
// Hamilton products a·b and conj(a)·b of four (or eight) pairs.
template <class V>
QUATCURVE_INLINE void mul(const QVOf<V>& a, const QVOf<V>& b, QVOf<V>& r) {
    r.w = signed_sum4(a.w, b.w, -1, a.x, b.x, -1, a.y, b.y, -1, a.z, b.z);
    r.x = signed_sum4(a.w, b.x, +1, a.x, b.w, +1, a.y, b.z, -1, a.z, b.y);
    r.y = signed_sum4(a.w, b.y, -1, a.x, b.z, +1, a.y, b.w, +1, a.z, b.x);
    r.z = signed_sum4(a.w, b.z, +1, a.x, b.y, -1, a.y, b.x, +1, a.z, b.w);
}
template <class V>
QUATCURVE_INLINE void cmul(const QVOf<V>& a, const QVOf<V>& b, QVOf<V>& r) {
    r.w = signed_sum4(a.w, b.w, +1, a.x, b.x, +1, a.y, b.y, +1, a.z, b.z);
    r.x = signed_sum4(a.w, b.x, -1, a.x, b.w, -1, a.y, b.z, +1, a.z, b.y);
    r.y = signed_sum4(a.w, b.y, +1, a.x, b.z, -1, a.y, b.w, -1, a.z, b.x);
    r.z = signed_sum4(a.w, b.z, -1, a.x, b.y, +1, a.y, b.x, -1, a.z, b.w);
}
// a·c + b·k for constant quaternions a, b (a slerp's A·cos φ + B·sin φ/θ).
template <class V>
QUATCURVE_INLINE void combine(const Q4& a, const Q4& b, const V& c, const V& k, QVOf<V>& r) {
    const V w = a.w * c, x = a.x * c, y = a.y * c, z = a.z * c;
    const V bw = b.w * k, bx = b.x * k, by = b.y * k, bz = b.z * k;
    r.w = w + bw;
    r.x = x + bx;
    r.y = y + by;
    r.z = z + bz;
}

// exp_coeffs (curve_math.hpp) with N = 6, 8, 10 or 12 series terms for every lane: c = cos(θ/2),
// k = sin(θ/2)/θ from θ², the series of the quarter angle x = θ/4 in x² summed by Estrin's scheme
// (pairs, then pairs of pairs: a quarter of Horner's dependency chain, so the groups of a short run
// overlap in the pipeline). Preconditions: θ² ≤ (2π)² in every lane (N = 12; below 1e-19), ≤ 10
// for N = 10 (θ ≤ 3.16, x ≤ 0.79: below 4e-21), ≤ 2.56 for N = 8 (below 3e-20), ≤ 0.25 for N = 6
// (θ ≤ 0.5, x ≤ 0.125: below 4e-20).
// Σ c[i]·y^i, i < N, by Estrin's scheme (y2 = y², y4 = y⁴, y8 = y⁸).
template <int N, class V>
QUATCURVE_INLINE void estrin(const double* c, const V& y, const V& y2, const V& y4, const V& y8, V& r) {
    if constexpr (N == 6) {
        r = (c[0] + c[1] * y) + y2 * (c[2] + c[3] * y) + y4 * (c[4] + c[5] * y);
        return;
    }
    r = (c[0] + c[1] * y) + y2 * (c[2] + c[3] * y) + y4 * ((c[4] + c[5] * y) + y2 * (c[6] + c[7] * y));
    if constexpr (N == 10) r += y8 * (c[8] + c[9] * y);
    if constexpr (N == 12) r += y8 * ((c[8] + c[9] * y) + y2 * (c[10] + c[11] * y));
}
// kTaylorSinc/4: the series of sin x/θ = (sin x/x)/4 (θ = 4x). A power of two scales every rounding
// of the sum alike, so this gives the bits of summing kTaylorSinc and multiplying by 0.25.
inline constexpr double kTaylorSincQuarter[12] = {
    kTaylorSinc[0] / 4, kTaylorSinc[1] / 4, kTaylorSinc[2] / 4, kTaylorSinc[3] / 4,
    kTaylorSinc[4] / 4, kTaylorSinc[5] / 4, kTaylorSinc[6] / 4, kTaylorSinc[7] / 4,
    kTaylorSinc[8] / 4, kTaylorSinc[9] / 4, kTaylorSinc[10] / 4, kTaylorSinc[11] / 4};
template <int N, class V>
QUATCURVE_INLINE void exp_coeffs4(const V& theta2, V& c, V& k) {
    static_assert(N == 6 || N == 8 || N == 10 || N == 12, "exp_coeffs4: 6, 8, 10 or 12 terms");
    const V y = theta2 * (1.0 / 16.0);
    const V y2 = y * y, y4 = y2 * y2, y8 = y4 * y4;
    V cq, sq;
    estrin<N>(kTaylorCos, y, y2, y4, y8, cq);          // cos x
    estrin<N>(kTaylorSincQuarter, y, y2, y4, y8, sq);  // sin x/θ
    const V cc = cq * cq;
    const V ss = theta2 * sq * sq;
    c = cc - ss;
    k = 2.0 * cq * sq;
}
// The term count exp_coeffs4 needs for angles up to √bound2; 0 beyond 2π (no polynomial).
QUATCURVE_INLINE int exp_terms(double bound2) {
    return bound2 <= 0.25 ? 6 : bound2 <= 2.56 ? 8 : bound2 <= 10.0 ? 10 : bound2 <= kTwoPi * kTwoPi ? 12 : 0;
}

// atan_over_x_small (curve_math.hpp) lane by lane: atan(x)/x for 0 ≤ x ≤ 0.66.
template <class V>
QUATCURVE_INLINE V atan_over_x_small4(const V& x) {
    const V z = x * x;
    const V p = (((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z - 7.500855792314704667340e1) * z -
                  1.228866684490136173410e2) * z - 6.485021904942025371773e1;
    const V q = ((((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z + 4.328810604912902668951e2) * z +
                  4.853903996359136964868e2) * z + 1.945506571482613964425e2;
    return 1.0 + z * p / q;
}

// atan2_over_n (curve_math.hpp) on its small-angle range alone, lane by lane: φ/n = atan(n/w)/n for
// n ≤ 0.66·w, w > 0 in every lane (the same bits as atan2_over_n_any4 gives such lanes).
template <class V>
QUATCURVE_INLINE V atan2_over_n_small4(const V& n, const V& w) { return atan_over_x_small4(n / w) / w; }

// atan2_over_n_any (curve_math.hpp) lane by lane, without branches: each lane takes the same one of
// the three atan ranges as the scalar version, the selects pick its argument and offset.
// Preconditions: n ≥ 0, n² + w² ≈ 1.
template <class V>
QUATCURVE_INLINE V atan2_over_n_any4(const V& n, const V& w) {
    using M = MaskOf<V>;
    const V zero = V{} + 0.0;
    const V aw = select(w < zero, -w, w);
    const M small = n <= 0.66 * aw, big = aw <= 0.66 * n, pos = w >= zero;
    const V num = select(small, n, select(big, aw, n - aw));
    const V den = select(small, aw, select(big, n, n + aw));
    const V x = num / den;
    const V ratio = atan_over_x_small4(x);  // atan(x)/x
    const V at = x * ratio;
    const V phi = select(small, at, select(big, 0.5 * kPi - at, 0.25 * kPi + at));  // atan2(n, |w|)
    // w ≥ 0: φ/n (on the small range P/|w|, finite at n = 0); w < 0: (π − φ)/n, 0 at n = 0 (q = −1).
    const M by_w = small & pos;
    const V r = select(by_w, ratio, select(pos, phi, kPi - phi)) / select(by_w, aw, n);
    return select(~pos & (n == zero), zero, r);
}

// Calls run(j, i0, i1) for every run of consecutive times [i0, i1) that lie in one knot segment j
// (knots[j] ≤ t < knots[j+1], the last segment up to knots.back() inclusive) and outside(i, before)
// for the times outside [knots.front(), knots.back()]; non-finite times throw. Sorted times give one
// run per segment (one locate each); a run's loop needs no per-sample checks. A run's end is found
// four times at a time, then time by time within the first four that leave it.
template <class Run, class Outside>
QUATCURVE_INLINE void drive_runs(const std::vector<double>& knots, const double* times, std::size_t n, Run&& run,
                                 Outside&& outside) {
    const std::size_t segments = knots.size() - 1;
    const double first = knots.front(), last = knots.back();
    std::size_t hint = 0;
    for (std::size_t i = 0; i < n;) {
        const double t = times[i];
        if (t >= first && t <= last) {
            const std::size_t j = locate(knots.data(), segments, t, hint);
            const double lo = knots[j], hi = knots[j + 1];
            std::size_t end = i + 1;
            if (j + 1 < segments) {  // NaN ends a run
                for (; end + 4 <= n; end += 4) {
                    const V4 v = load4(times + end);
                    const M4 in = (v >= lo) & (v < hi);
                    if (!(in[0] & in[1] & in[2] & in[3])) break;
                }
                while (end < n && times[end] >= lo && times[end] < hi) ++end;
            } else {
                while (end < n && times[end] >= lo && times[end] <= hi) ++end;
            }
            run(j, i, end);
            i = end;
        } else {
            if (!std::isfinite(t)) bad_time(i);
            outside(i, t < first);
            ++i;
        }
    }
}

// Calls f(t, q) for the times [0, n), n ≥ 4, four at a time and stores q by component: w at out[i],
// x at out[stride + i], y at out[2·stride + i], z at out[3·stride + i]. When n is not a multiple of
// four the last group overlaps the one before (the rows written twice get the same values).
template <class F>
QUATCURVE_INLINE void for_groups_columns(const double* times, std::size_t n, std::size_t stride, double* out,
                                         F&& f) {
    QUATCURVE_EXPECTS(n >= 4, "for_groups_columns: four times or more");
    QV q;
    for (std::size_t i = 0;; i += 4) {
        if (i + 4 > n) i = n - 4;
        f(load4(times + i), q);
        std::memcpy(out + i, &q.w, sizeof q.w);
        std::memcpy(out + stride + i, &q.x, sizeof q.x);
        std::memcpy(out + 2 * stride + i, &q.y, sizeof q.y);
        std::memcpy(out + 3 * stride + i, &q.z, sizeof q.z);
        if (i + 4 >= n) return;
    }
}

// A run of fewer than four times [i0, i1): one group padded with its last time, only the run's own
// rows stored at out + 4·i.
template <class F>
QUATCURVE_INLINE void short_run(const double* times, std::size_t i0, std::size_t i1, double* out, F&& f) {
    QV q;
    double t[4], rows[16];
    for (std::size_t k = 0; k < 4; ++k) t[k] = times[i0 + k < i1 ? i0 + k : i1 - 1];
    f(load4(t), q);
    store_rows(q, rows);
    for (std::size_t k = 0; i0 + k < i1; ++k) std::memcpy(out + 4 * (i0 + k), rows + 4 * k, 4 * sizeof(double));
}

// Calls f(t, q) for the times [i0, i1) four at a time (q: the four samples' quaternions) and stores
// q at out + 4·i. A run of four or more ends with a group that overlaps the one before (lanes are
// independent, so the rows written twice get the same values); a shorter run is padded with its last
// time and only its own rows are stored.
template <class F>
QUATCURVE_INLINE void for_groups(const double* times, std::size_t i0, std::size_t i1, double* out, F&& f) {
    QV q;
    if (i1 - i0 >= 4) {
        std::size_t i = i0;
        for (; i + 4 <= i1; i += 4) {
            f(load4(times + i), q);
            store_rows(q, out + 4 * i);
        }
        if (i < i1) {
            f(load4(times + i1 - 4), q);
            store_rows(q, out + 4 * (i1 - 4));
        }
        return;
    }
    short_run(times, i0, i1, out, f);
}

// for_groups (above) with the groups of a run taken two at a time (V4x2) where it has two: f(t, q)
// is called with V4x2 times (groups starting at i and j) or V4 times (a run's lone last group, a
// run shorter than four padded with its last time), and q's rows are stored at out + 4·(start). The
// groups are for_groups': a run's starts are i0, i0 + 4, … and, where four do not divide it, i1 − 4.
// One call site of f per width, so one copy of its code each.
template <class F>
QUATCURVE_INLINE void for_group_pairs(const double* times, std::size_t i0, std::size_t i1, double* out, F&& f) {
    std::size_t i = i0;
    while (i1 - i > 4) {  // two groups: at i and at i + 4, or at i1 − 4 when that is the run's last
        const std::size_t j = i1 - i >= 8 ? i + 4 : i1 - 4;
        QVOf<V4x2> q;
        f(V4x2{load4(times + i), load4(times + j)}, q);
        store_rows(QV{q.w.lo, q.x.lo, q.y.lo, q.z.lo}, out + 4 * i);
        store_rows(QV{q.w.hi, q.x.hi, q.y.hi, q.z.hi}, out + 4 * j);
        i = j + 4;
    }
    if (i == i1) return;
    if (i1 - i0 >= 4) {  // the last group, overlapping the one before where four do not divide the run
        QV q;
        f(load4(times + i1 - 4), q);
        store_rows(q, out + 4 * (i1 - 4));
        return;
    }
    short_run(times, i0, i1, out, f);
}

}  // namespace quatcurve::detail
