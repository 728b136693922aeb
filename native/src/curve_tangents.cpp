// Knot tangents of SQUAD, TCB and CATMULL_ROM, and the clamp that keeps them on their keys.
//
// A tangent is a rotation vector per unit segment parameter s in the local frame of its knot (see
// curve_impl.hpp, KnotTangents). A knot's incoming rotation g1 = r[j−1] and outgoing g2 = r[j] are
// the same vectors in the knot's frame (a rotation leaves its own axis fixed), so they combine
// directly. h0, h1: the durations (frames) of the segments before and after knot j.
//
// 1. Base tangents.
//    Kochanek–Bartels with KB's adjustment for unequal spacing (tension t, continuity c, bias b per
//    key; all 0 for SQUAD, for CATMULL_ROM and at sub-keys):
//      out_j = [(1−t)(1+c)(1+b)/2·g1 + (1−t)(1−c)(1−b)/2·g2] · 2h1/(h0+h1)
//      in_j  = [(1−t)(1−c)(1+b)/2·g1 + (1−t)(1+c)(1−b)/2·g2] · 2h0/(h0+h1)
//    With c = 0 both are the knot velocity V_j = (g1 + g2)/(h0 + h1)·(1−t)(…) per frame — time
//    scaled: the mean angular velocity over the two segments, however unequal they are — so the
//    curve is C1. End knots take (1−t)·(their segment's rotation); a loop's end knots are one knot,
//    the seam, whose neighbours are the last knot segment (g1, h0) and the first (g2, h1), so the
//    seam is a knot as any other (the two ends' frames are one rotation: the rotation vectors
//    combine there too), its out tangent leaving knot 0 and its in tangent arriving at the last knot.
//    Unclamped CATMULL_ROM (the textbook non-uniform Catmull–Rom, Barry–Goldman) instead takes the
//    derivative of the parabola through the neighbours, V_j = (h1/h0·g1 + h0/h1·g2)/(h0 + h1), whose
//    weights carry a short segment's speed over a long one (keys at 1, 2, 102: the first frame's
//    speed for 100 frames, several turns).
//
// 2. The clamp (clamped = true, the default): a factor λ_j ∈ [0, 1] per knot scales both of its
//    tangents, so a knot that is C1 stays C1. For each segment k next to knot j, with arc r_k and
//    the knot's tangent T into (or out of) it:
//      - T·r_k ≤ 0 → λ_j = 0: the motion holds (r_k = 0) or turns back, and the key is an extreme,
//        flattened as Blender's Auto Clamped handles flatten a scalar extreme. Two equal keys
//        therefore hold still, and a key next to a hold starts and stops at rest.
//      - |T| ≤ 3·|r_k| (λ_j ≤ 3|r_k|/|T|): Fritsch–Carlson's bound α ≤ 3 on the sphere — a Bezier
//        handle (|T|/3) is no longer than its segment's arc.
//    Then the path rule is enforced: each key segment's path (an upper bound of it; when that is
//    too large, 16 chords per knot segment, which pass within 90% of the limit; else 64 chords)
//    must stay within 0.98·(kPathRuleFactor·arc + kPathRuleSlack) (2% below the rule, for the
//    difference between this sampling and a denser one). A segment beyond it scales the λ of all
//    its knots by the largest factor μ ∈ [0, 1] that passes (bisection, 12 steps on 16 chords per
//    knot segment, then 12 more on the verdict's own measure if that disagrees); neighbours are
//    checked again, up to 20 rounds, then any segment still beyond gets λ = 0 at its knots. With
//    zero tangents SQUAD and CATMULL_ROM run along the segment's own arc (smoothstep in angle), so
//    the rule always holds in the end. With even spacing and arcs within a factor 5 of their
//    neighbours' going the same way, no clamp acts and the curve is the textbook one. A loop's two
//    end knots share one λ (the seam), limited by the segments on both sides and scaled with either.
#include <cmath>
#include <type_traits>

#include "curve_impl.hpp"
#include "curve_simd.hpp"

namespace quatcurve::detail {

namespace {

KnotTangents base_tangents(const Curve::Impl& m, Method method, const CurveOptions& o) {
    const std::size_t S = m.kr.size();
    KnotTangents T{std::vector<Vec3>(S + 1, Vec3(0.0)), std::vector<Vec3>(S + 1, Vec3(0.0))};
    const bool tcb = method == Method::TCB;
    for (std::size_t j = 0; j <= S; ++j) {
        double t = 0.0, c = 0.0, b = 0.0;
        const int key = m.cyclic && j == S ? 0 : m.kkey[j];  // the seam takes the first key's
        if (tcb && key >= 0) {
            t = per_key(o.tension, key);
            c = per_key(o.continuity, key);
            b = per_key(o.bias, key);
        }
        if (m.cyclic && j == S) {  // the seam: the same tangents as knot 0
            T.in[S] = T.in[0];
            continue;
        }
        if (!m.cyclic && (j == 0 || j == S)) {
            if (j == 0) T.out[0] = (1.0 - t) * m.kr[0];
            if (j == S) T.in[S] = (1.0 - t) * m.kr[S - 1];
            continue;
        }
        const std::size_t before = j == 0 ? S - 1 : j - 1;  // across the seam for a loop's knot 0
        const Vec3& g1 = m.kr[before];
        const Vec3& g2 = m.kr[j];
        const double h0 = m.kt[before + 1] - m.kt[before], h1 = m.kt[j + 1] - m.kt[j];
        if (method == Method::CATMULL_ROM && !o.clamped) {
            const Vec3 V = (h1 / h0 * g1 + h0 / h1 * g2) / (h0 + h1);
            T.out[j] = h1 * V;
            T.in[j] = h0 * V;
            continue;
        }
        const Vec3 td = 0.5 * (1.0 - t) * ((1.0 + c) * (1.0 + b) * g1 + (1.0 - c) * (1.0 - b) * g2);
        const Vec3 ts = 0.5 * (1.0 - t) * ((1.0 - c) * (1.0 + b) * g1 + (1.0 + c) * (1.0 - b) * g2);
        T.out[j] = td * (2.0 * h1 / (h0 + h1));
        T.in[j] = ts * (2.0 * h0 / (h0 + h1));
    }
    return T;
}

// The Fritsch–Carlson / Auto Clamped factor of knot j (step 2, first part).
double fc_factor(const Curve::Impl& m, const KnotTangents& T, std::size_t j) {
    double lambda = 1.0;
    auto limit = [&](const Vec3& tangent, const Vec3& r) {
        const double along = glm::dot(tangent, r);
        if (!(along > 0.0)) {
            lambda = 0.0;
            return;
        }
        const double n = glm::length(tangent), cap = 3.0 * glm::length(r);
        if (n > cap) lambda = std::fmin(lambda, cap / n);
    };
    const std::size_t S = m.kr.size();
    if (m.cyclic && (j == 0 || j == S)) {  // the seam: both sides
        limit(T.out[0], m.kr[0]);
        limit(T.in[S], m.kr[S - 1]);
        return lambda;
    }
    if (j < S) limit(T.out[j], m.kr[j]);
    if (j > 0) limit(T.in[j], m.kr[j - 1]);
    return lambda;
}

// angle_between for neighbouring samples of a path: 4·atan(x), x = |a − b|/|a + b| (b in a's
// hemisphere), atan by its series while x < 1/8 (relative error below 1e-10), else std::atan2.
inline double chord_angle(const double* a, const double* b) {
    double d2, s2;
    chord_squares(a, b, d2, s2);
    if (!(d2 * 64.0 < s2)) return 4.0 * std::atan2(std::sqrt(d2), std::sqrt(s2));
    const double x2 = d2 / s2;
    return 4.0 * std::sqrt(x2) * (1.0 - x2 * (1.0 / 3 - x2 * (1.0 / 5 - x2 * (1.0 / 7 - x2 / 9))));
}

// chord_angle of four pairs of quaternions, lane by lane: the same operations in the same order,
// so the same bits as four calls (with no FMA contraction in either, see squad_chord_angles).
// a, b: four w, then x, y, z at a + stride, … (columns of sample_squad_segment).
QUATCURVE_INLINE void chord_angles4(const double* a, const double* b, std::size_t stride, double* out) {
#if defined(__clang__)
#pragma clang fp contract(off)
#endif
    const QV p{load4(a), load4(a + stride), load4(a + 2 * stride), load4(a + 3 * stride)};
    const QV q{load4(b), load4(b + stride), load4(b + 2 * stride), load4(b + 3 * stride)};
    const V4 dot = p.w * q.w + p.x * q.x + p.y * q.y + p.z * q.z;
    const V4 sign = select(dot < splat(0.0), splat(-1.0), splat(1.0));
    V4 d2 = splat(0.0), s2 = splat(0.0);
    auto add = [&](const V4& u, const V4& v) QUATCURVE_LAMBDA_INLINE {
        const V4 d = u - sign * v, s = u + sign * v;
        d2 += d * d;
        s2 += s * s;
    };
    add(p.w, q.w);
    add(p.x, q.x);
    add(p.y, q.y);
    add(p.z, q.z);
    const V4 x2 = d2 / s2;
    const V4 r = 4.0 * sqrt4(x2) * (1.0 - x2 * (1.0 / 3 - x2 * (1.0 / 5 - x2 * (1.0 / 7 - x2 / 9.0))));
    std::memcpy(out, &r, sizeof r);
    const M4 series = d2 * 64.0 < s2;
    for (int k = 0; k < 4; ++k)
        if (!series[k]) out[k] = 4.0 * std::atan2(std::sqrt(d2[k]), std::sqrt(s2[k]));
}

// chords[k] = chord_angle of samples k and k + 1 of sample_squad_segment's columns q, k < samples
// (a multiple of 4). Four at a time, in the x86-64-v3 and v4 versions too, unfused (GCC's
// fp-contract=off here, clang's fp contract(off) in chord_angles4): each lane's bits are those of the
// scalar chord_angle in baseline code.
namespace {
QUATCURVE_INLINE void squad_chord_angles_body(const double* q, int samples, double* chords) {
    for (int k = 0; k < samples; k += 4) chord_angles4(q + k, q + k + 1, kSegmentColumn, chords + k);
}
}  // namespace

#if defined(__clang__)
QUATCURVE_VERSIONS(squad_chord_angles, (const double* q, int samples, double* chords), (q, samples, chords))
#else
QUATCURVE_VERSIONS_WITH(__attribute__((optimize("fp-contract=off"))), squad_chord_angles,
                        (const double* q, int samples, double* chords), (q, samples, chords))
#endif

// Path length of segment g by `samples` chords: kSearchSamples first and while the bisection
// searches, kSamples where that leaves the verdict close (a chord sum converges as 1/n²: 16 chords
// of a smooth segment that turns 180° miss about 0.3°).
constexpr int kSamples = 64;
constexpr int kSearchSamples = 16;
constexpr double kCoarseShare = 0.9;
// SQUAD segments are sampled in one batch by the sampler's own four-wide kernel.
template <class Seg, class At>
double sampled_path(const Seg& g, At&& at, int samples = kSamples) {
    static_assert(kSamples <= static_cast<int>(kMaxSegmentSamples));
    double len = 0.0;
    if constexpr (std::is_same_v<Seg, SquadSeg>) {
        static_assert(kSearchSamples % 4 == 0 && kSamples % 4 == 0);
        double q[4 * kSegmentColumn], chords[kMaxSegmentSamples];
        sample_squad_segment(g, static_cast<std::size_t>(samples), q);
        squad_chord_angles(q, samples, chords);
        for (int k = 0; k < samples; ++k) len += chords[k];  // in order, as the rows' sum was
        return len;
    }
    double prev[4], cur[4];
    store(at(g, 0.0), prev);
    for (int k = 1; k <= samples; ++k) {
        store(at(g, static_cast<double>(k) / samples), cur);
        len += chord_angle(prev, cur);
        std::copy(cur, cur + 4, prev);
    }
    return len;
}

// Step 2: the λ of every knot, and segs[i] = make(…) of every knot segment i with its knots' final
// λ. A segment's path is first bounded from above cheaply (`bound`, see path_bound below); only a
// key segment whose bounds exceed its limit is sampled, so dense keys (motion capture: small arcs,
// similar neighbours) cost no sampling at all. segs[i] always holds knot segment i made with the
// current λ: bounding, sampling and the result share one make per change of λ.
template <class Seg, class Make, class At, class Bound>
void clamp_factors(const Curve::Impl& m, const KnotTangents& T, const std::vector<double>& key_arcs,
                   std::vector<Seg>& segs, Make&& make, At&& at, Bound&& bound) {
    const std::size_t S = m.kr.size();
    std::vector<double> lambda(S + 1);
    for (std::size_t j = 0; j <= S; ++j) lambda[j] = fc_factor(m, T, j);
    segs.resize(S);
    auto remake = [&](std::size_t i) {
        segs[i] = make(m, i, lambda[i] * T.out[i], lambda[i + 1] * T.in[i + 1]);
    };

    // Knot segments [first[k], first[k+1]) belong to key segment k.
    std::vector<std::size_t> first{0};
    for (std::size_t j = 1; j < S; ++j)
        if (m.kseg[j] != m.kseg[j - 1]) first.push_back(j);
    first.push_back(S);
    const std::size_t K = first.size() - 1;

    // len[i]: the measure of knot segment i so far: an upper bound (sampled[i] = 0), or its path
    // by kSearchSamples (sampled[i] = kSearchSamples) or kSamples chords.
    std::vector<double> len(S);
    std::vector<int> sampled(S);
    auto measure = [&](std::size_t i) {  // an upper bound, refined by sampling on demand
        remake(i);
        len[i] = bound(m, i, lambda[i] * T.out[i], lambda[i + 1] * T.in[i + 1], segs[i]);
        sampled[i] = 0;
    };
    for (std::size_t i = 0; i < S; ++i) measure(i);
    auto limit = [&](std::size_t k) { return 0.98 * (kPathRuleFactor * key_arcs[k] + kPathRuleSlack); };
    // The sum of key segment k's measures after refining each to at least `samples` chords (kept).
    auto refined = [&](std::size_t k, int samples) {
        double L = 0.0;
        for (std::size_t i = first[k]; i < first[k + 1]; ++i) {
            if (sampled[i] < samples) {
                len[i] = sampled_path(segs[i], at, samples);
                sampled[i] = samples;
            }
            L += len[i];
        }
        return L;
    };
    // The verdict on key segment k: its bound within the limit, or its path by kSearchSamples chords
    // within kCoarseShare of it (16 more chords add far less: a chord sum converges as 1/n²), or by
    // kSamples chords within it. search: the bisection's measure, kSearchSamples chords, not kept.
    auto passes = [&](std::size_t k, bool search = false) {
        double L = 0.0;
        for (std::size_t i = first[k]; i < first[k + 1]; ++i) L += len[i];
        if (L <= limit(k)) return true;
        if (search) {
            L = 0.0;
            for (std::size_t i = first[k]; i < first[k + 1]; ++i)
                L += sampled[i] ? len[i] : sampled_path(segs[i], at, kSearchSamples);
            return L <= limit(k);
        }
        if (refined(k, kSearchSamples) <= kCoarseShare * limit(k)) return true;
        return refined(k, kSamples) <= limit(k);
    };
    // Scales the knots of key segment k by mu (relative to `saved`) and re-measures what they touch:
    // its own knot segments, and with `neighbours` the two next to it (the bisection's steps look at
    // k's own only, so its neighbours are measured once, at the λ it settles on).
    std::vector<double> saved;
    // A loop's seam: knots 0 and S are one knot with one λ; the knot segments on the other side of
    // the seam are touched by k's end knots too (seam_neighbours).
    const bool loop = m.cyclic;
    auto link_seam = [&](std::size_t k) {
        if (!loop) return;
        if (first[k] == 0) lambda[S] = lambda[0];
        if (first[k + 1] == S) lambda[0] = lambda[S];
    };
    auto seam_neighbours = [&](std::size_t k, auto&& touch) {
        if (!loop) return;
        if (first[k] == 0 && first[k + 1] != S) touch(S - 1);
        if (first[k + 1] == S && first[k] != 0) touch(0);
    };
    auto scale = [&](std::size_t k, double mu, bool neighbours) {
        for (std::size_t j = first[k]; j <= first[k + 1]; ++j) lambda[j] = saved[j - first[k]] * mu;
        link_seam(k);
        const std::size_t i0 = neighbours && first[k] > 0 ? first[k] - 1 : first[k];
        const std::size_t i1 = neighbours ? std::min(S, first[k + 1] + 1) : first[k + 1];
        for (std::size_t i = i0; i < i1; ++i) measure(i);
        if (neighbours) seam_neighbours(k, measure);
        else if (loop && (first[k] == 0 || first[k + 1] == S)) seam_neighbours(k, remake);
    };

    for (int round = 0; round < 20; ++round) {
        bool beyond = false;
        for (std::size_t k = 0; k < K; ++k) {
            if (passes(k)) continue;
            beyond = true;
            saved.assign(lambda.begin() + static_cast<std::ptrdiff_t>(first[k]),
                         lambda.begin() + static_cast<std::ptrdiff_t>(first[k + 1]) + 1);
            // Bisection on the coarse measure; where that was too generous (the verdict at kSamples
            // fails), it goes on below with the verdict's own measure.
            double lo = 0.0, hi = 1.0;
            auto bisect = [&](bool search) {
                for (int it = 0; it < 12; ++it) {
                    const double mid = 0.5 * (lo + hi);
                    scale(k, mid, false);
                    (passes(k, search) ? lo : hi) = mid;
                }
                scale(k, lo, true);
            };
            bisect(true);
            if (!passes(k)) {
                hi = lo;
                lo = 0.0;
                bisect(false);
            }
        }
        if (!beyond) return;
    }
    // The segments touched are made again (the later verdicts sample them at the new λ), their
    // measures left as they were.
    for (std::size_t k = 0; k < K; ++k) {
        if (passes(k)) continue;
        for (std::size_t j = first[k]; j <= first[k + 1]; ++j) lambda[j] = 0.0;
        link_seam(k);
        for (std::size_t i = first[k] > 0 ? first[k] - 1 : 0; i < std::min(S, first[k + 1] + 1); ++i) remake(i);
        seam_neighbours(k, remake);
    }
}

// Upper bounds of a segment's path length (angle integrated over s).
// CATMULL_ROM (cumulative Bezier): each factor exp(β_k·d/2) turns monotonically, so the path is at
// most |d01| + |d12| + |d23|.
double bezier_bound(const Curve::Impl&, std::size_t, const Vec3&, const Vec3&, const BezierSeg& g) {
    return glm::length(g.d01) + glm::length(g.d12) + glm::length(g.d23);
}
// SQUAD: q = A·exp(g(s)·χ(s)/2), A = q_i·exp(s·r/2), χ = log(Y), Y = A⁻¹B = exp(−s·r/2)·exp(α/2)·exp(s·ψ/2),
// g = 2s(1−s). Its speed is at most |r| + |g'|·|χ| + g·κ(|χ|)·|ω_Y| (exp is 1-Lipschitz within
// the injectivity ball; κ(θ) = (θ/2)/sin(θ/2) bounds the inverse Jacobian of log).
// - |χ|: a rotation's angle is invariant under conjugation and subadditive, and exp is 1-Lipschitz,
//   so |χ(s)| ≤ |α| + s·|ψ − r| (from s = 0) and ≤ |β| + (1 − s)·|ψ − r| (from s = 1, as A and B
//   also run back from their ends): |χ| ≤ M = min(max(|α|, |β|) + |ψ − r|, (|α| + |β| + |ψ − r|)/2).
// - ω_Y = ψ − R(Y)ᵀr in Y's frame: |ω_Y| ≤ W = min(|r| + |ψ|, |ψ − r| + 2·sin(min(M, π)/2)·|r|).
// With ∫|g'| = 1 and ∫g = 1/3 the path is at most |r| + M + W·κ(M)/3 (no bound, +∞, once M
// reaches 2π). Keys that turn alike (r ≈ ψ, small α and β) get a bound close to their arc.
double squad_bound(const Curve::Impl& m, std::size_t i, const Vec3& out, const Vec3& in, const SquadSeg& g) {
    const Vec3& r = m.kr[i];
    const double a = 0.5 * glm::length(out - r), b = 0.5 * glm::length(r - in);
    const double rr = glm::length(r), pp = std::sqrt(g.psi2), d = glm::length(g.psi - r);
    const double M = std::fmin(std::fmax(a, b) + d, 0.5 * (a + b + d));
    if (M >= 0.99 * kTwoPi) return HUGE_VAL;
    const double sin_half = std::sin(0.5 * std::fmin(M, kPi));  // for M ≤ π also κ's sin(M/2)
    const double W = std::fmin(rr + pp, d + 2.0 * sin_half * rr);
    const double kappa = M > 1e-8 ? 0.5 * M / (M <= kPi ? sin_half : std::sin(0.5 * M)) : 1.0;
    return rr + M + W * kappa / 3.0;
}

template <class Seg, class Make, class At, class Bound>
void build_segments(Curve::Impl& m, const KnotTangents& T, bool clamped, const std::vector<double>& key_arcs,
                    std::vector<Seg>& segs, Make&& make, At&& at, Bound&& bound) {
    if (clamped) {
        clamp_factors(m, T, key_arcs, segs, make, at, bound);
        return;
    }
    segs.resize(m.kr.size());
    for (std::size_t i = 0; i < segs.size(); ++i) segs[i] = make(m, i, T.out[i], T.in[i + 1]);
}

}  // namespace

void build_tangent_curve(Curve::Impl& m, Method method, const CurveOptions& options) {
    const KnotTangents T = base_tangents(m, method, options);
    const std::vector<double> arcs = key_arcs(m);
    if (method == Method::CATMULL_ROM) {
        build_segments(m, T, options.clamped, arcs, m.bezier, make_bezier_seg, bezier_at, bezier_bound);
        chain_bezier_signs(m);
        return;
    }
    build_segments(m, T, options.clamped, arcs, m.squad, make_squad_seg, squad_at, squad_bound);
}

}  // namespace quatcurve::detail
