// Key reduction, stage 2: fitting one segment of some channels (reduce_impl.hpp: Fitter). LINEAR
// takes the chord; BEZIER fits the two inner control values per channel by weighted least squares in
// the rotation metric, then reweights toward the minimax fit; either way the exact rotation error is
// tested at every sample inside (and, for Bezier and Euler fits, midway between samples).
#include <algorithm>
#include <cmath>
#include <limits>

#include "quatcurve/blender_eval.hpp"
#include "reduce_impl.hpp"

namespace quatcurve::reduce_impl {

namespace {

// Solves H·x = g (H symmetric positive definite, dim ≤ 8) by Cholesky; H and g are overwritten.
// A non-positive pivot (degenerate data) is lifted to a tiny positive value, so a solution always
// comes back; the fit's quality is judged by the error test anyway. dim is a template argument and
// the loops are unrolled: a reduction solves some 10⁴ of these small systems per bone, and rolled
// loops of 1 to 7 steps cost three times the arithmetic.
template <int dim>
void solve_spd(double* H, double* g) {
#pragma GCC unroll 8
    for (int j = 0; j < dim; ++j) {
        double d = H[j * dim + j];
#pragma GCC unroll 8
        for (int k = 0; k < j; ++k) d -= H[j * dim + k] * H[j * dim + k];
        if (!(d > 1e-300)) d = 1e-300;
        const double L = std::sqrt(d);
        H[j * dim + j] = L;
#pragma GCC unroll 8
        for (int i = j + 1; i < dim; ++i) {
            double s = H[i * dim + j];
#pragma GCC unroll 8
            for (int k = 0; k < j; ++k) s -= H[i * dim + k] * H[j * dim + k];
            H[i * dim + j] = s / L;
        }
    }
#pragma GCC unroll 8
    for (int i = 0; i < dim; ++i) {
        double s = g[i];
#pragma GCC unroll 8
        for (int k = 0; k < i; ++k) s -= H[i * dim + k] * g[k];
        g[i] = s / H[i * dim + i];
    }
#pragma GCC unroll 8
    for (int i = dim - 1; i >= 0; --i) {
        double s = g[i];
#pragma GCC unroll 8
        for (int k = i + 1; k < dim; ++k) s -= H[k * dim + i] * g[k];
        g[i] = s / H[i * dim + i];
    }
}

// Basis of the cubic Bezier at u.
void bernstein(double u, double b[4]) {
    const double v = 1.0 - u;
    b[0] = v * v * v;
    b[1] = 3.0 * v * v * u;
    b[2] = 3.0 * v * u * u;
    b[3] = u * u * u;
}

// dX/ds of bezier_time_parameter's frame X(s) (below), with b = 1 − a2.
double time_slope(double s, double a1, double b) {
    const double v = 1.0 - s;
    return 3.0 * v * v * a1 + 6.0 * v * s * (b - a1) + 3.0 * s * s * (1.0 - b);
}

// Newton's solve of bezier_time_parameter (below), kept inside a shrinking bracket.
double solve_time_parameter(double tau, double a1, double a2) {
    double lo = 0.0, hi = 1.0, s = tau;
    const double b = 1.0 - a2;
    for (int it = 0; it < 40; ++it) {
        const double v = 1.0 - s;
        const double x = 3.0 * v * v * s * a1 + 3.0 * v * s * s * b + s * s * s - tau;
        if (x < 0.0) lo = s;
        else hi = s;
        const double dx = time_slope(s, a1, b);
        double next = dx > 0.0 ? s - x / dx : 0.5 * (lo + hi);
        if (!(next >= lo && next <= hi)) next = 0.5 * (lo + hi);
        // Newton converges quadratically: a step this small leaves an error far below it.
        if (std::fabs(next - s) <= 1e-14) return next;
        s = next;
    }
    return s;
}

// solve_time_parameter for the pairs of kHandleFractions, from a table: the parameter and its slope
// ds/dτ = 1/X'(s) at kTableSize + 1 evenly spaced frames, joined by cubic Hermite pieces (error below
// 1e-12 in s: the fit is verified against Blender's own float32 parameter anyway). The Newton solve
// per sample and pair was a third of a reduction's time.
constexpr int kTableSize = 1024;
}  // namespace

struct ParameterTable {
    int index;  // in kHandleFractions
    double a1, a2;
    double s[kTableSize + 1], ds[kTableSize + 1];
};

namespace {

const ParameterTable* parameter_table(double a1, double a2) {
    static const std::vector<ParameterTable> tables = [] {
        std::vector<ParameterTable> out(kHandleAlternatives);
        for (int alt = 0; alt < kHandleAlternatives; ++alt) {
            ParameterTable& t = out[alt];
            t.index = alt;
            t.a1 = kHandleFractions[alt][0];
            t.a2 = kHandleFractions[alt][1];
            const double b = 1.0 - t.a2;
            for (int k = 0; k <= kTableSize; ++k) {
                const double s = solve_time_parameter(double(k) / kTableSize, t.a1, t.a2);
                t.s[k] = s;
                t.ds[k] = 1.0 / time_slope(s, t.a1, b);
            }
        }
        return out;
    }();
    for (const ParameterTable& t : tables)
        if (t.a1 == a1 && t.a2 == a2) return &t;
    return nullptr;
}

// The parameter s ∈ [0, 1] of a Bezier segment whose frame runs 0, a1, 1 − a2, 1 (fractions of the
// segment) at which the frame is tau ∈ [0, 1]: X(s) = 3(1−s)²s·a1 + 3(1−s)s²·(1 − a2) + s³ rises
// (a1, a2 ≥ 0, a1 + a2 ≤ 1). `table`: parameter_table(a1, a2), or null to solve (Newton's steps kept
// inside a shrinking bracket).
double bezier_time_parameter(double tau, double a1, double a2, const ParameterTable* table) {
    if (!table) return solve_time_parameter(tau, a1, a2);
    const double x = std::min(std::max(tau, 0.0), 1.0) * kTableSize;
    const int k = std::min(static_cast<int>(x), kTableSize - 1);
    const double h = 1.0 / kTableSize, r = x - k, r2 = r * r, r3 = r2 * r;
    return (2 * r3 - 3 * r2 + 1) * table->s[k] + (r3 - 2 * r2 + r) * h * table->ds[k] +
           (-2 * r3 + 3 * r2) * table->s[k + 1] + (r3 - r2) * h * table->ds[k + 1];
}

// |f|² ≥ (kMinNormRatio)²·norm2: of the quaternion, or of the axis (f[1..3]) for axis-angle.
bool norm_ok(const Problem& p, const double* f, double norm2) {
    const double f2 = (p.kind == Kind::QUAT ? f[0] * f[0] : 0.0) + f[1] * f[1] + f[2] * f[2] + f[3] * f[3];
    return f2 >= kMinNormRatio * kMinNormRatio * norm2;
}

// conj(r)·e_c for the unit quaternion e_c of channel c: r's components, permuted and signed.
void relative_unit(const Quat& r, int c, double d[4]) {
    switch (c) {
    case 0: d[0] = r.w, d[1] = -r.x, d[2] = -r.y, d[3] = -r.z; break;
    case 1: d[0] = r.x, d[1] = r.w, d[2] = -r.z, d[3] = r.y; break;
    case 2: d[0] = r.y, d[1] = r.z, d[2] = r.w, d[3] = -r.x; break;
    default: d[0] = r.z, d[1] = -r.y, d[2] = r.x, d[3] = r.w; break;
    }
}

}  // namespace

State empty_state(const Problem& p, bool one_by_one) {
    State s;
    if (one_by_one) s.F = p.y;
    s.keys.assign(p.C, {});
    s.h1.assign(p.n * p.C, 0.0);
    s.h2.assign(p.n * p.C, 0.0);
    s.a1.assign(p.n * p.C, 1.0 / 3.0);
    s.a2.assign(p.n * p.C, 1.0 / 3.0);
    s.exact_param.assign(p.n * p.C, 0);
    return s;
}

Fitter::Fitter(const Problem& p, KeyInterpolation ipo, State& s, bool free_handle_frames)
    : p_(p), ipo_(ipo), s_(s),
      free_handle_frames_(free_handle_frames && p.kind == Kind::QUAT && ipo == KeyInterpolation::BEZIER) {
    buf_.reset(new double[p.n * p.C]);
    even_from_.resize(p.n);
    for (std::size_t k = 0; k < p.n; ++k)
        even_from_[k] = k >= 2 && p.t[k] - p.t[k - 1] == p.t[k - 1] - p.t[k - 2] ? even_from_[k - 1]
                        : k >= 1                                                  ? k - 1
                                                                                  : 0;
    bern_.reset(new double[p.n * 4]);
    u_.reset(new double[p.n]);
    if (p.kind == Kind::QUAT) {
        terms_.reset(new double[p.n * 5]);
        interval_mid_.reset(new double[p.n]);
        interval_weight_.reset(new double[p.n]);
        interval_stamp_.assign(p.n, 0);
    }
    w_.reset(new double[p.n]);
    err_.reset(new double[p.n]);
    between_limits_.reset(new double[p.n]);
}

bool Fitter::fit(std::size_t i, std::size_t j, const int* chans, int nc, double limit, bool force,
                 bool exact_param) {
    const int C = p_.C;
    if (!force && j - i >= 2 && p_.breaks[j] != p_.breaks[i]) return false;
    const double ti = p_.t[i], tj = p_.t[j], d = tj - ti;
    // A refit with Blender's parameter keeps the segment's committed handle frames.
    double a1 = 1.0 / 3.0, a2 = 1.0 / 3.0;
    if (exact_param && ipo_ == KeyInterpolation::BEZIER) {
        a1 = s_.a1[i * C + chans[0]];
        a2 = s_.a2[i * C + chans[0]];
    }
    set_parameters(i, j, a1, a2, exact_param);
    if (p_.kind == Kind::QUAT && nc == 1) other_channels(i, j, chans[0]);
    double p1[kMaxChannels] = {}, p2[kMaxChannels] = {};
    bool ok;
    if (ipo_ == KeyInterpolation::LINEAR || j - i < 2) {
        for (int a = 0; a < nc; ++a) {
            const int c = chans[a];
            const double yi = p_.y[i * C + c], yj = p_.y[j * C + c];
            p1[a] = yi + (yj - yi) / 3.0;
            p2[a] = yj - (yj - yi) / 3.0;
            if (ipo_ == KeyInterpolation::BEZIER && j - i < 2 && p_.breaks[j] == p_.breaks[i]) {
                // No sample inside: the default (finite-difference) tangents; across a
                // discontinuity the straight line (handles at thirds of the chord).
                p1[a] = yi + p_.slope[i * C + c] * d / 3.0;
                p2[a] = yj - p_.slope[j * C + c] * d / 3.0;
            }
        }
        ok = evaluate(i, j, chans, nc, p1, p2, limit,
                      force ? std::numeric_limits<double>::infinity() : limit) <= limit;
    } else {
        // One quaternion channel among fixed others: a sample that no value of the channel brings
        // within the limit fails the segment at any handle frames, and handle frames at which the
        // samples' intervals cannot all be met fail too (intervals_may_pass): there the thirds keep
        // only their plain fit (its worst decides on the other handle frames below), and other
        // handle frames are not fitted. Neither test rejects a fit that could pass: the keys are
        // those the fits alone would choose (docs/benchmarks.md has the instructions saved).
        const bool intervals = p_.kind == Kind::QUAT && nc == 1 && !force && !exact_param;
        if (intervals && !channel_intervals(i, j, limit)) return false;
        double worst0;
        ok = fit_handles(i, j, chans, nc, limit, force, p1, p2, worst0, kHopeless,
                         intervals && !intervals_may_pass(i, j, chans[0]) ? 0 : -1);
        // Other handle frames, while the thirds came near (kHandleFractions). A forced fit that none
        // of them passes keeps the thirds' fit, refitted (the trials overwrote the samples' values).
        if (!ok && free_handle_frames_ && !exact_param && j - i > kHandleFreeSamples &&
            worst0 <= kHandleFreeHopeless * limit) {
            double q1[kMaxChannels], q2[kMaxChannels], w;
            for (int alt = 0; alt < kHandleAlternatives && !ok; ++alt) {
                set_parameters(i, j, kHandleFractions[alt][0], kHandleFractions[alt][1], false);
                if (intervals && !intervals_may_pass(i, j, chans[0])) continue;
                if (fit_handles(i, j, chans, nc, limit, false, q1, q2, w, kHopelessOtherFrames)) {
                    ok = true;
                    std::copy(q1, q1 + nc, p1);
                    std::copy(q2, q2 + nc, p2);
                }
            }
            if (!ok && force) {
                set_parameters(i, j, 1.0 / 3.0, 1.0 / 3.0, false);
                fit_handles(i, j, chans, nc, limit, true, p1, p2, w);
            }
        }
    }
    if (ok || force) commit(i, j, chans, nc, p1, p2, exact_param);
    return ok;
}

void Fitter::set_parameters(std::size_t i, std::size_t j, double a1, double a2, bool exact_param) {
    const double ti = p_.t[i], tj = p_.t[j], d = tj - ti;
    frac1_ = a1;
    frac2_ = a2;
    const bool thirds = a1 == 1.0 / 3.0 && a2 == 1.0 / 3.0;
    table_ = thirds ? nullptr : parameter_table(a1, a2);
    u_at_ = u_.get();
    bern_at_ = bern_.get();
    first_ = 0;
    // Evenly spaced samples: each one's frame fraction (t_k − t_i)/(t_j − t_i) is (k − i)/(j − i)
    // (float32 frames: the differences are exact), so its parameter and basis are those of every
    // segment of j − i steps at these handle fractions: computed once per thread, and read there.
    const std::size_t m = j - i;
    if (!exact_param && ipo_ == KeyInterpolation::BEZIER && m < kEvenSegmentsKept && even_from_[j] <= i &&
        (thirds || table_)) {
        // Per handle fractions (the thirds last) and step count: the m − 1 parameters, then the bases.
        thread_local std::vector<std::vector<double>> even_segments[kHandleAlternatives + 1];
        std::vector<std::vector<double>>& of_pair = even_segments[thirds ? kHandleAlternatives : table_->index];
        if (of_pair.size() <= m) of_pair.resize(m + 1);
        std::vector<double>& kept = of_pair[m];
        if (kept.empty()) {
            kept.resize(5 * (m - 1));
            for (std::size_t k = 1; k < m; ++k) {
                const double tau = static_cast<double>(k) / static_cast<double>(m);
                kept[k - 1] = thirds ? tau : bezier_time_parameter(tau, a1, a2, table_);
                bernstein(kept[k - 1], &kept[(m - 1) + 4 * (k - 1)]);
            }
        }
        u_at_ = kept.data();
        bern_at_ = kept.data() + (m - 1);
        first_ = i + 1;
        return;
    }
    for (std::size_t k = i + 1; k < j; ++k) {
        const double tau = (p_.t[k] - ti) / d;
        u_[k] = thirds ? tau : bezier_time_parameter(tau, a1, a2, table_);
    }
    if (exact_param && ipo_ == KeyInterpolation::BEZIER) {
        float hx[2];
        segment_handle_frames(ti, tj, a1, a2, hx);
        for (std::size_t k = i + 1; k < j; ++k) {
            const float r = blender_bezier_parameter(float(p_.t[k]), float(ti), hx[0], hx[1],
                                                     float(tj));
            if (r >= 0.0f) u_[k] = r;
        }
    }
    if (ipo_ == KeyInterpolation::BEZIER)
        for (std::size_t k = i + 1; k < j; ++k) bernstein(u_[k], &bern_[k * 4]);
}

bool Fitter::fit_handles(std::size_t i, std::size_t j, const int* chans, int nc, double limit,
                         bool force, double* p1, double* p2, double& worst0, const double* hopeless,
                         int rounds) {
    bool ok = false;
    worst0 = std::numeric_limits<double>::infinity();
    double kappa = 4.0;  // quaternion and axis-angle metric: radial direction free
    for (int attempt = 0; attempt < 2 && !ok; ++attempt) {
        if (attempt == 1) {
            // The norm dipped: refit with radial errors weighted.
            if (p_.kind == Kind::EULER || !between_failed_) break;
            kappa = 4.0 - kRadialWeight;
        }
        for (std::size_t k = i + 1; k < j; ++k) w_[k] = 1.0;
        const int iterations = rounds >= 0              ? rounds
                               : nc != 1                  ? kReweightIterations
                               : p_.kind == Kind::QUAT ? kReweightIterationsQuatChannel
                                                       : kReweightIterationsSingle;
        for (int it = 0; it <= iterations; ++it) {
            solve_handles(i, j, chans, nc, kappa, p1, p2, it > 0);
            // The last round keeps the first round's bound: over the limit it fails anyway,
            // but a norm dip further on is still found (and refitted with radial weights).
            const double give_up = force ? std::numeric_limits<double>::infinity()
                                   : it < iterations ? hopeless[it] * limit
                                                     : hopeless[0] * limit;
            const double worst = evaluate(i, j, chans, nc, p1, p2, limit, give_up);
            if (attempt == 0 && it == 0) worst0 = between_failed_ ? 0.0 : worst;
            if (worst <= limit) {
                ok = true;
                break;
            }
            // Reweighting cannot fix the norm, nor hopeless segments (too far over the limit
            // for the rounds left).
            if (between_failed_ || worst > give_up || it == iterations) break;
            // Lawson-style reweighting toward the minimax fit: w ← w·err, normalized.
            double total = 0.0;
            for (std::size_t k = i + 1; k < j; ++k) {
                w_[k] *= std::sqrt(err_[k]) + 1e-300;  // ≈ θ/2
                total += w_[k];
            }
            const double scale = static_cast<double>(j - i - 1) / total;
            for (std::size_t k = i + 1; k < j; ++k) w_[k] = std::max(w_[k] * scale, 1e-6);
        }
    }
    return ok;
}

// other_'s terms of samples i..j (and of the midpoints after them) for fits of channel `chan`:
// d_o = conj(ref)·q − q_c·d_c from the fitted values q, with the channel's value taken out.
void Fitter::other_channels(std::size_t i, std::size_t j, int chan) {
    constexpr int C = 4;
    if (other_.stamp.empty()) {
        other_.stamp.assign(p_.n, 0);
        other_.terms.reset(new double[p_.n * OtherChannels::kStride]);  // filled before it is read
    }
    if (chan != other_.chan) {
        other_.chan = chan;
        ++other_.epoch;
    }
    for (std::size_t k = i; k <= j; ++k) {
        if (other_.stamp[k] == other_.epoch) continue;
        other_.stamp[k] = other_.epoch;
        double* o = &other_.terms[k * OtherChannels::kStride];
        const double* F = &s_.F[k * C];
        const double* y = &p_.y[k * C];
        const double* u = &p_.unit[k * C];
        relative_rotation(p_.ref[k], F, o);
        relative_unit(p_.ref[k], chan, o + 4);
        double ue = 0.0;
        for (int c = 0; c < C; ++c) {
            o[c] -= F[chan] * o[4 + c];
            ue += u[c] * (F[c] - y[c]);
        }
        o[8] = F[0] * F[0] + F[1] * F[1] + F[2] * F[2] + F[3] * F[3] - F[chan] * F[chan];
        o[9] = ue - u[chan] * (F[chan] - y[chan]);
        // The midpoint terms serve the between-samples guard (BEZIER only for quaternions).
        if (k + 1 == p_.n || ipo_ == KeyInterpolation::LINEAR) continue;
        double q[C], mean[C];
        for (int c = 0; c < C; ++c) {
            q[c] = 0.5 * (F[c] + F[C + c]);
            mean[c] = 0.5 * (y[c] + y[C + c]);
        }
        const Quat ref(mean[0], mean[1], mean[2], mean[3]);
        relative_rotation(ref, q, o + 10);
        relative_unit(ref, chan, o + 14);
        for (int c = 0; c < C; ++c) o[10 + c] -= q[chan] * o[14 + c];
        o[18] = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] - q[chan] * q[chan];
    }
}

// The samples strictly inside [i, j] as intervals of the value x of other_'s channel (the others at
// their other_ terms, filled): the rotation error d = d_o + x·d_c is within tan²(θ/2) ≤ limit where
// |vec d|² ≤ limit·(w d)², a quadratic a·x² + b·x + c ≤ 0 — with a > 0 an interval, kept as its
// middle and the inverse of its half-width (interval_mid_, interval_weight_); with a ≤ 0 (the
// channel hardly turns the rotation there) the sample is left to the fit's evaluation (weight 0).
// A sample's interval depends on its other_ terms and the limit alone, so it is computed once for
// every fit of the channel's key choice (interval_stamp_). False where an interval is empty: no value
// of the channel meets that sample.
bool Fitter::channel_intervals(std::size_t i, std::size_t j, double limit) {
    if (other_.epoch != interval_epoch_ || limit != interval_limit_) {
        interval_epoch_ = other_.epoch;
        interval_limit_ = limit;
        ++interval_generation_;
    }
    for (std::size_t k = i + 1; k < j; ++k) {
        if (interval_stamp_[k] != interval_generation_) {
            interval_stamp_[k] = interval_generation_;
            const double* o = &other_.terms[k * OtherChannels::kStride];
            const double a = o[5] * o[5] + o[6] * o[6] + o[7] * o[7] - limit * o[4] * o[4];
            const double b = 2.0 * (o[1] * o[5] + o[2] * o[6] + o[3] * o[7] - limit * o[0] * o[4]);
            const double c = o[1] * o[1] + o[2] * o[2] + o[3] * o[3] - limit * o[0] * o[0];
            const double disc = b * b - 4.0 * a * c;
            interval_mid_[k] = a > 0.0 ? -b / (2.0 * a) : 0.0;
            interval_weight_[k] = !(a > 0.0) ? 0.0 : disc > 0.0 ? 2.0 * a / std::sqrt(disc) : -1.0;
        }
        if (interval_weight_[k] < 0.0) return false;
    }
    return true;
}

// Whether some inner control values (p1, p2) at the current handle fractions may put channel
// `chan` inside every sample's interval (channel_intervals): its value at sample k is b0·y_i + b1·p1
// + b2·p2 + b3·y_j (b: the Bezier basis there), a weighted Chebyshev problem (chebyshev_may_meet)
// whose rows are the samples. The exchange starts from the last reference of the same segment and
// channel (the handle fractions tried one after the other share most of it: 29 % fewer exchanges
// on the clips).
bool Fitter::intervals_may_pass(std::size_t i, std::size_t j, int chan) {
    constexpr int C = 4;
    const double yi = p_.y[i * C + chan], yj = p_.y[j * C + chan];
    const double* m = interval_mid_.get();
    const double* w = interval_weight_.get();
    if (exchange_.i != i || exchange_.j != j || exchange_.chan != chan) {
        exchange_.i = i;
        exchange_.j = j;
        exchange_.chan = chan;
        exchange_.ref[0] = 0;
        exchange_.ref[1] = (j - i - 2) / 2;
        exchange_.ref[2] = j - i - 2;
    }
    return chebyshev_may_meet(
        j - i - 1,
        [&](std::size_t r, ChebyshevRow& row) {
            const std::size_t k = i + 1 + r;
            const double* b = basis(k);
            row = {b[1], b[2], m[k] - b[0] * yi - b[3] * yj, w[k]};
        },
        exchange_.ref, 1.0 + kIntervalSlack);
}

// Weighted least squares for the inner control values: minimize
//   Σ_k w_k·e_kᵀ M_k e_k + λ·|p − p_default|²,  e_k = fitted − data at sample k
// over p = (p1, p2) of the fitted channels (others fixed at F). λ is tiny: it only settles the
// directions the data leave free (few samples; the radial direction of quaternions).
void Fitter::solve_handles(std::size_t i, std::size_t j, const int* chans, int nc, double kappa,
                           double* p1, double* p2, bool reweighted) {
    if (p_.kind == Kind::QUAT && nc == 1)
        return solve_quat_channel(i, j, chans[0], kappa, p1, p2, reweighted);
    if (p_.C == 4 && nc == 4) return solve_handles_t<4, 4>(i, j, chans, kappa, p1, p2);
    if (p_.C == 4 && nc == 1) return solve_handles_t<4, 1>(i, j, chans, kappa, p1, p2);
    if (p_.C == 3 && nc == 3) return solve_handles_t<3, 3>(i, j, chans, kappa, p1, p2);
    return solve_handles_t<3, 1>(i, j, chans, kappa, p1, p2);
}

// Euler metric M_k (see Problem): row `row` times e, and the entry M_k[row][col].
double Fitter::euler_metric_times(std::size_t k, int row, const double* e) const {
    if (row == p_.axis_first) return e[row] + p_.gimbal[k] * e[p_.axis_last];
    if (row == p_.axis_last) return e[row] + p_.gimbal[k] * e[p_.axis_first];
    return e[row];
}
double Fitter::euler_metric_entry(std::size_t k, int row, int col) const {
    if (row == col) return 1.0;
    if ((row == p_.axis_first && col == p_.axis_last) ||
        (row == p_.axis_last && col == p_.axis_first))
        return p_.gimbal[k];
    return 0.0;
}

// solve_handles for C channels of which NC are fitted (NC == C: all, in order).
template <int C, int NC>
void Fitter::solve_handles_t(std::size_t i, std::size_t j, const int* chans, double kappa,
                             double* p1, double* p2) {
    int ch[NC];
    double yi[NC], yj[NC];
    for (int a = 0; a < NC; ++a) {
        ch[a] = NC == C ? a : chans[a];
        yi[a] = p_.y[i * C + ch[a]];
        yj[a] = p_.y[j * C + ch[a]];
    }
    // Blocks of the normal matrix: Σ w·b1²·M_SS, Σ w·b1·b2·M_SS, Σ w·b2²·M_SS (lower triangles).
    double A[3][NC][NC] = {};
    double g[2][NC] = {};
    for (std::size_t k = i + 1; k < j; ++k) {
        const double* b = basis(k);
        const double* yk = &p_.y[k * C];
        double e0[C];
        if (NC == C) {
            for (int c = 0; c < C; ++c) e0[c] = b[0] * yi[c] + b[3] * yj[c] - yk[c];
        } else {
            for (int c = 0; c < C; ++c) e0[c] = s_.F[k * C + c] - yk[c];
            for (int a = 0; a < NC; ++a) e0[ch[a]] = b[0] * yi[a] + b[3] * yj[a] - yk[ch[a]];
        }
        const double w1 = w_[k] * b[1], w2 = w_[k] * b[2];
        const double s11 = w1 * b[1], s12 = w1 * b[2], s22 = w2 * b[2];
        if constexpr (C == 4) {
            if (p_.kind == Kind::AXIS_ANGLE) {
                // Block-diagonal (Problem): angle 1; axis σ·(I − v̂v̂ᵀ) + ρ·v̂v̂ᵀ with σ = spin/|v|² and
                // ρ = (4 − κ)/|v|² (0 on the first attempt: the axis length is free).
                const double* u = &p_.unit[k * 4];
                const double inv = 1.0 / p_.norm2[k];
                const double sigma = p_.spin[k] * inv, rho = (4.0 - kappa) * inv;
                const double ue = u[1] * e0[1] + u[2] * e0[2] + u[3] * e0[3];
                for (int a = 0; a < NC; ++a) {
                    const int ca = ch[a];
                    const double Me = ca == 0 ? e0[0] : sigma * e0[ca] + (rho - sigma) * u[ca] * ue;
                    g[0][a] -= w1 * Me;
                    g[1][a] -= w2 * Me;
                    for (int bb = 0; bb <= a; ++bb) {
                        const int cb = ch[bb];
                        double m;
                        if (ca == 0 || cb == 0) m = ca == cb ? 1.0 : 0.0;
                        else m = (ca == cb ? sigma : 0.0) + (rho - sigma) * u[ca] * u[cb];
                        A[0][a][bb] += s11 * m;
                        A[1][a][bb] += s12 * m;
                        A[2][a][bb] += s22 * m;
                    }
                }
            } else {
                // M = (4·I − κ·ûûᵀ)/|q|², with û·e and 1/|q|² computed once per sample.
                const double* u = &p_.unit[k * 4];
                const double inv = 1.0 / p_.norm2[k];
                const double ue = u[0] * e0[0] + u[1] * e0[1] + u[2] * e0[2] + u[3] * e0[3];
                double ku[NC];
                for (int a = 0; a < NC; ++a) ku[a] = kappa * u[ch[a]];
                // Unrolled (GCC leaves these short loops rolled): the hottest lines of a reduction.
#pragma GCC unroll 4
                for (int a = 0; a < NC; ++a) {
                    const double Me = inv * (4.0 * e0[ch[a]] - ku[a] * ue);
                    g[0][a] -= w1 * Me;
                    g[1][a] -= w2 * Me;
#pragma GCC unroll 4
                    for (int bb = 0; bb <= a; ++bb) {
                        const double m = inv * ((a == bb ? 4.0 : 0.0) - ku[a] * u[ch[bb]]);
                        A[0][a][bb] += s11 * m;
                        A[1][a][bb] += s12 * m;
                        A[2][a][bb] += s22 * m;
                    }
                }
            }
        } else {
            for (int a = 0; a < NC; ++a) {
                const double Me = euler_metric_times(k, ch[a], e0);
                g[0][a] -= w1 * Me;
                g[1][a] -= w2 * Me;
                for (int bb = 0; bb <= a; ++bb) {
                    const double m = euler_metric_entry(k, ch[a], ch[bb]);
                    A[0][a][bb] += s11 * m;
                    A[1][a][bb] += s12 * m;
                    A[2][a][bb] += s22 * m;
                }
            }
        }
    }
    constexpr int dim = 2 * NC;
    double H[dim * dim], rhs[dim];
    for (int a = 0; a < NC; ++a) {
        for (int bb = 0; bb < NC; ++bb) {
            const int hi = a > bb ? a : bb, lo = a > bb ? bb : a;
            H[a * dim + bb] = A[0][hi][lo];
            H[(NC + a) * dim + (NC + bb)] = A[2][hi][lo];
            H[(NC + a) * dim + bb] = A[1][hi][lo];
            H[a * dim + (NC + bb)] = A[1][hi][lo];
        }
        rhs[a] = g[0][a];
        rhs[NC + a] = g[1][a];
    }
    const double d = p_.t[j] - p_.t[i];
    const double lambda = 1e-7;
    for (int a = 0; a < NC; ++a) {
        const double d1 = yi[a] + p_.slope[i * C + ch[a]] * d / 3.0;
        const double d2 = yj[a] - p_.slope[j * C + ch[a]] * d / 3.0;
        H[a * dim + a] += lambda;
        H[(NC + a) * dim + (NC + a)] += lambda;
        rhs[a] += lambda * d1;
        rhs[NC + a] += lambda * d2;
    }
    solve_spd<dim>(H, rhs);
    for (int a = 0; a < NC; ++a) {
        p1[a] = rhs[a];
        p2[a] = rhs[NC + a];
    }
}

// solve_handles for one quaternion channel, the others fixed (their terms from other_): the same
// normal equations as solve_handles_t<4, 1>, a 2×2 system.
void Fitter::solve_quat_channel(std::size_t i, std::size_t j, int chan, double kappa, double* p1,
                                double* p2, bool reweighted) {
    constexpr int C = 4;
    const double yi = p_.y[i * C + chan], yj = p_.y[j * C + chan];
    double A0 = 0.0, A1 = 0.0, A2 = 0.0, g0 = 0.0, g1 = 0.0;
    if (!reweighted) {
        // The first round (every weight 1): each sample's terms, kept for the rounds after it.
        for (std::size_t k = i + 1; k < j; ++k) {
            const double* b = basis(k);
            const double e0 = b[0] * yi + b[3] * yj - p_.y[k * C + chan];
            const double uc = p_.unit[k * C + chan];
            const double ue = other_.terms[k * OtherChannels::kStride + 9] + uc * e0;
            const double inv = 1.0 / p_.norm2[k];
            const double ku = kappa * uc;
            const double Me = inv * (4.0 * e0 - ku * ue);
            const double m = inv * (4.0 - ku * uc);
            double* t = &terms_[k * 5];
            t[0] = b[1] * b[1] * m;
            t[1] = b[1] * b[2] * m;
            t[2] = b[2] * b[2] * m;
            t[3] = b[1] * Me;
            t[4] = b[2] * Me;
            A0 += t[0];
            A1 += t[1];
            A2 += t[2];
            g0 -= t[3];
            g1 -= t[4];
        }
    } else {
        for (std::size_t k = i + 1; k < j; ++k) {
            const double* t = &terms_[k * 5];
            const double w = w_[k];
            A0 += w * t[0];
            A1 += w * t[1];
            A2 += w * t[2];
            g0 -= w * t[3];
            g1 -= w * t[4];
        }
    }
    const double d = p_.t[j] - p_.t[i];
    const double lambda = 1e-7;
    double H[4] = {A0 + lambda, A1, A1, A2 + lambda};
    double rhs[2] = {g0 + lambda * (yi + p_.slope[i * C + chan] * d / 3.0),
                     g1 + lambda * (yj - p_.slope[j * C + chan] * d / 3.0)};
    solve_spd<2>(H, rhs);
    p1[0] = rhs[0];
    p2[0] = rhs[1];
}

// Fitted values of the channels at the interior samples (into buf_, when fewer than all channels are
// fitted: see State), their tan²(θ/2) errors (into err_) and the largest.
// Between samples the fit is guarded too (quaternion BEZIER, every Euler and axis-angle fit): midway
// between consecutive samples (keys included) the fitted rotation must lie within
// kBetweenFactor × the fit's angle + kBetweenStep × the step between the two samples of what
// the dense input shows there (its own LINEAR evaluation: the normalized mean of the
// quaternions, the rotation of the mean angles; a smooth curve rightly departs from that chord
// where the motion is fast, hence the step term), and a
// quaternion's norm must stay above kMinNormRatio of the samples' (also checked at the samples).
// Without it a fit may pass every sample yet swing between them — a quaternion curve through
// near zero, or Euler channels keyed at different frames near gimbal lock, where two angles must
// cancel. Midpoints are checked only when the samples pass (or the fit is forced). Channels not
// fitted here take the mean of their neighbouring fitted values midway.
double Fitter::evaluate(std::size_t i, std::size_t j, const int* chans, int nc, const double* p1,
                        const double* p2, double limit, double give_up) {
    if (p_.C == 4 && nc == 4) return evaluate_t<4, 4>(i, j, chans, p1, p2, limit, give_up);
    if (p_.C == 4 && nc == 1) return evaluate_t<4, 1>(i, j, chans, p1, p2, limit, give_up);
    if (p_.C == 3 && nc == 3) return evaluate_t<3, 3>(i, j, chans, p1, p2, limit, give_up);
    return evaluate_t<3, 1>(i, j, chans, p1, p2, limit, give_up);
}

// The between-samples guard's limits (tan²(θ/2)) midway between samples k and k + 1 for the fit's
// limit: kBetweenFactor × its angle plus kBetweenStep × the step between the samples (step_tan), by
// tan(a + b) = (tan a + tan b)/(1 − tan a·tan b); +∞ from 180° on. Every fit of a key choice shares
// its limit, so they are computed once per limit (n − 1 of them), not per fit and midpoint.
const double* Fitter::between_limits(double limit) {
    if (limit != between_limit_) {
        between_limit_ = limit;
        const double tan_fit = std::tan(kBetweenFactor * std::atan(std::sqrt(limit)));
        for (std::size_t k = 0; k + 1 < p_.n; ++k) {
            const double denom = 1.0 - tan_fit * p_.step_tan[k];
            const double t = (tan_fit + p_.step_tan[k]) / denom;
            between_limits_[k] = denom > 0.0 ? t * t : std::numeric_limits<double>::infinity();
        }
    }
    return between_limits_.get();
}

// evaluate for C channels of which NC are fitted (NC == C: all, in order; the others keep F).
template <int C, int NC>
double Fitter::evaluate_t(std::size_t i, std::size_t j, const int* chans, const double* p1,
                          const double* p2, double limit, double give_up) {
    const bool linear = ipo_ == KeyInterpolation::LINEAR;
    const bool quat_bezier = p_.kind == Kind::QUAT && !linear;
    // The norm check: a quaternion's (BEZIER: LINEAR cannot dip without a sign flip, a break) or
    // an axis-angle axis's (any interpolation: two axes 90° apart lerp through 0.71 of their length).
    const bool norm_check = C == 4 && (quat_bezier || p_.kind == Kind::AXIS_ANGLE);
    const bool guard = quat_bezier || p_.kind != Kind::QUAT;
    // One quaternion channel: the others' part of the error from other_ (filled by fit).
    const bool other = C == 4 && NC == 1 && p_.kind == Kind::QUAT;
    int ch[NC];
    double yi[NC], yj[NC], c1[NC], c2[NC];  // local copies: the stores below may not alias them
    for (int a = 0; a < NC; ++a) {
        ch[a] = NC == C ? a : chans[a];
        yi[a] = p_.y[i * C + ch[a]];
        yj[a] = p_.y[j * C + ch[a]];
        c1[a] = p1[a];
        c2[a] = p2[a];
    }
    // The fitted channels at parameter u (b: the Bezier basis there) into f.
    auto fitted = [&](double u, const double* b, double* f) {
        for (int a = 0; a < NC; ++a) {
            f[ch[a]] = linear ? yi[a] + (yj[a] - yi[a]) * u
                              : b[0] * yi[a] + b[1] * c1[a] + b[2] * c2[a] + b[3] * yj[a];
        }
    };
    between_failed_ = false;
    double worst = 0.0;
    for (std::size_t k = i + 1; k < j; ++k) {
        double f[kMaxChannels] = {};
        if (NC < C && !other)
            for (int c = 0; c < C; ++c) f[c] = s_.F[k * C + c];
        fitted(param(k), basis(k), f);
        if (NC < C)  // kept for commit (F); fits of all channels keep no F (State)
            for (int a = 0; a < NC; ++a) buf_[k * C + ch[a]] = f[ch[a]];
        double e;
        bool norm_failed;
        if (other) {
            const double* o = &other_.terms[k * OtherChannels::kStride];
            const double x = f[ch[0]];
            const double d[4] = {o[0] + x * o[4], o[1] + x * o[5], o[2] + x * o[6], o[3] + x * o[7]};
            e = tan2_of_relative(d);
            norm_failed = norm_check &&
                          !(o[8] + x * x >= kMinNormRatio * kMinNormRatio * p_.norm2[k]);
        } else {
            e = error_tan2(p_, k, f);
            norm_failed = norm_check && !norm_ok(p_, f, p_.norm2[k]);
        }
        err_[k] = e;
        worst = std::max(worst, e);
        if (worst > give_up) {  // the caller rejects the fit without looking further
            buf_end_ = k + 1;
            return worst;
        }
        if (norm_failed) {
            buf_end_ = k + 1;
            between_failed_ = true;
            return std::numeric_limits<double>::infinity();
        }
    }
    buf_end_ = j;
    if (guard && (worst <= limit || give_up == std::numeric_limits<double>::infinity())) {
        // tan of half the allowed angle: tan(a + b) = (tan a + tan b)/(1 − tan a·tan b).
        const double* between_limits = this->between_limits(limit);
        const bool thirds = linear || (frac1_ == 1.0 / 3.0 && frac2_ == 1.0 / 3.0);
        double prev_u = 0.0;
        for (std::size_t k = i; k < j; ++k) {
            const double next_u = k + 1 == j ? 1.0 : param(k + 1);
            // Midway in frames: halfway in the parameter where it is linear in the frame.
            const double u = thirds ? 0.5 * (prev_u + next_u)
                                    : bezier_time_parameter(
                                          (0.5 * (p_.t[k] + p_.t[k + 1]) - p_.t[i]) / (p_.t[j] - p_.t[i]),
                                          frac1_, frac2_, table_);
            prev_u = next_u;
            double f[kMaxChannels] = {}, b[4];
            if (NC < C && !other)
                for (int c = 0; c < C; ++c) f[c] = 0.5 * (s_.F[k * C + c] + s_.F[(k + 1) * C + c]);
            if (!linear) bernstein(u, b);
            fitted(u, b, f);
            const double norm2 = norm_check ? std::min(p_.norm2[k], p_.norm2[k + 1]) : 0.0;
            double e;
            if (other) {
                const double* o = &other_.terms[k * OtherChannels::kStride + 10];
                const double x = f[ch[0]];
                if (norm_check && !(o[8] + x * x >= kMinNormRatio * kMinNormRatio * norm2)) {
                    between_failed_ = true;
                    return std::numeric_limits<double>::infinity();
                }
                const double d[4] = {o[0] + x * o[4], o[1] + x * o[5], o[2] + x * o[6],
                                     o[3] + x * o[7]};
                e = tan2_of_relative(d);
            } else {
                if (norm_check && !norm_ok(p_, f, norm2)) {
                    between_failed_ = true;
                    return std::numeric_limits<double>::infinity();
                }
                Quat ref;
                if (C == 4 && p_.kind == Kind::QUAT) {
                    const double* a = &p_.y[k * C];
                    const double* b = &p_.y[(k + 1) * C];
                    ref = Quat(0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2]),
                               0.5 * (a[3] + b[3]));
                } else {
                    ref = p_.mid_ref[k];  // the rotation of the mean (Problem)
                }
                e = error_tan2(p_, ref, f);
            }
            if (!(e <= between_limits[k])) {
                between_failed_ = true;
                return std::numeric_limits<double>::infinity();
            }
        }
    }
    return worst;
}

void Fitter::commit(std::size_t i, std::size_t j, const int* chans, int nc, const double* p1,
                    const double* p2, bool exact_param) {
    const int C = p_.C;
    if (nc != 1 || chans[0] != other_.chan) ++other_.epoch;  // other_'s fixed channels change
    for (int a = 0; a < nc; ++a) {
        const int c = chans[a];
        if (nc < C) {  // F: only fits of fewer than all channels read it (State)
            // A forced fit whose evaluation stopped early (the norm dipped): the values it left out.
            for (std::size_t k = std::max(buf_end_, i + 1); k < j; ++k) {
                const double yi = p_.y[i * C + c], yj = p_.y[j * C + c];
                const double* b = basis(k);
                buf_[k * C + c] = ipo_ == KeyInterpolation::LINEAR ? yi + (yj - yi) * param(k)
                                                                   : b[0] * yi + b[1] * p1[a] + b[2] * p2[a] + b[3] * yj;
            }
            for (std::size_t k = i + 1; k < j; ++k) s_.F[k * C + c] = buf_[k * C + c];
            s_.F[i * C + c] = p_.y[i * C + c];
            s_.F[j * C + c] = p_.y[j * C + c];
        }
        s_.h1[i * C + c] = p1[a];
        s_.h2[i * C + c] = p2[a];
        s_.a1[i * C + c] = frac1_;
        s_.a2[i * C + c] = frac2_;
        s_.exact_param[i * C + c] = exact_param ? 1 : 0;
    }
}

}  // namespace quatcurve::reduce_impl
