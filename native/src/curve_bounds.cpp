// Upper bounds of a Curve's angular speed |ω| and of |q̈| (the second derivative of its unit
// quaternion q(t)): what lets a check at finitely many times prove a bound at every time between them
// (bound.hpp). Each knot segment gets one bound of each, from the data its family evaluates — no
// sampling. For a unit quaternion q̇ = ½ω·q and q̈ = ½α·q + ¼ω·ω·q, so |q̈| ≤ ½|α| + ¼|ω|² (α the
// angular acceleration); per unit s below, divided by h and h² for frames.
//   EULER        angles linear: |ω| ≤ w = |Δx| + |Δy| + |Δz| (each axis' rotation adds at most its
//                rate, whatever frame it acts in) and |α| ≤ w² (the axes turn at most at w).
//   NLERP, QUAT_COMPONENTS  p = (1 − s)·a + s·b, q = p/|p|: |ω| = 2·|c|/|p|² (curve_impl.hpp) and
//                |q̈| ≤ 2|p''|/|p| + 5|p'|²/|p|² = 5|b − a|²/|p|², with the exact minimum of the
//                quadratic |p|² on [0, 1]. A segment through zero (QUAT_COMPONENTS across a sign
//                flip) has no bound (+∞).
//   SLERP        constant ω: |q̈| = ¼|ω|².
//   SQUAD, TCB   q = A·P, A = Q·exp(s·r/2), P = exp(g·χ/2), χ = log(Y), Y = A⁻¹B, g = 2s(1 − s)
//                (|g| ≤ ½, |g'| ≤ 2, |g''| = 4), with squad_bound's M ≥ |χ| and W ≥ |ω_Y|
//                (curve_tangents.cpp), κ = κ(M) ≥ ‖J⁻¹(χ)‖ and D ≥ ‖D(J⁻¹)(χ)‖ (the derivative of
//                log's inverse Jacobian; J⁻¹(ρ) = I + ½ρ^ + f(θ)ρ^², f(θ) = (1 − (θ/2)·cot(θ/2))/θ²,
//                whose series has positive coefficients, so f and f' grow with θ and
//                D ≤ ½ + f'(M)·M² + 2f(M)·M):
//                  |ω| ≤ |r| + V,  V = 2M + ½κW ≥ |ω_P| = |J(gχ)·(gχ)'|;
//                  |χ'| ≤ κW, |ω_Y'| ≤ W·|r|, |χ''| ≤ κW·|r| + D·κW²;
//                  |(gχ)''| ≤ 4M + 4κW + ½(κW·|r| + D·κW²);
//                  |α| ≤ V·|r| + ½V² + |(gχ)''|   (‖DJ‖ ≤ ½ for exp's Jacobian).
//   CATMULL_ROM  q = b0·Π exp(βₖ·dₖ/2), β1' = 3(1 − s)², β2' = 6s(1 − s), β3' = 3s² (3× the quadratic
//                Bernstein basis) and |βₖ''| ≤ 6: |ω| ≤ 3·max|dₖ|, |α| ≤ 6·Σ|dₖ| + (3·max|dₖ|)².
//   SPLINE_C2    q = Q·exp(ρ/2): ω = J(ρ)·ρ' with ‖J‖ ≤ 1 and ‖DJ‖ ≤ ½: |ω| ≤ V = |c1| + 2|c2| + 3|c3|,
//                |α| ≤ |ρ''| + ½V² ≤ 2|c2| + 6|c3| + ½V².
// Ease warps time inside each key segment (curve_ease.cpp): q(t) = q_m(w(t)), so |ω| ≤ |ω_m|·w' and
// |q̈| ≤ |q̈_m|·w'² + ½|ω_m|·|w''|, with w' ≤ 2k and |w''| ≤ 2k/(min(a, b)·h), k = 1/(2 − a − b).
// A loop repeats its period: an interval is wrapped into it (the part beyond the last key continues
// from the first), and one at least a period long takes every segment. Its corner times repeat
// every period; where a loop is smooth (SQUAD, TCB, CATMULL_ROM, SPLINE_C2) the seam is a key as
// any other, listed as the keys are, and its bounds hold on both sides.
#include <algorithm>
#include <cmath>

#include "curve_impl.hpp"

namespace quatcurve {

namespace detail {

namespace {

// f(θ) of J⁻¹ and its derivative (series near 0, where the closed form cancels).
void inverse_jacobian_f(double t, double& f, double& df) {
    if (t < 1e-2) {
        f = 1.0 / 12.0 + t * t / 720.0;
        df = t / 360.0;
        return;
    }
    const double x = 0.5 * t, cot = std::cos(x) / std::sin(x);
    const double g = 1.0 - x * cot;                              // 1 − x·cot x
    const double dg = -cot + x / (std::sin(x) * std::sin(x));  // d/dx
    f = g / (t * t);
    df = (0.5 * dg * t * t - 2.0 * t * g) / (t * t * t * t);
}

}  // namespace

void squad_bounds(const Vec3& r, double alpha, double beta, const Vec3& psi, double& speed, double& accel) {
    const double rr = glm::length(r), pp = glm::length(psi), d = glm::length(psi - r);
    const double M = std::fmin(std::fmax(alpha, beta) + d, 0.5 * (alpha + beta + d));
    if (M >= 0.99 * kTwoPi) {
        speed = accel = HUGE_VAL;
        return;
    }
    const double sin_half = std::sin(0.5 * std::fmin(M, kPi));
    const double W = std::fmin(rr + pp, d + 2.0 * sin_half * rr);
    const double kappa = M > 1e-8 ? 0.5 * M / (M <= kPi ? sin_half : std::sin(0.5 * M)) : 1.0;
    double f, df;
    inverse_jacobian_f(M, f, df);
    const double D = 0.5 + df * M * M + 2.0 * f * M;
    const double V = 2.0 * M + 0.5 * kappa * W;
    speed = rr + V;
    const double gchi2 = 4.0 * M + 4.0 * kappa * W + 0.5 * (kappa * W * rr + D * kappa * W * W);
    const double a = V * rr + 0.5 * V * V + gchi2;
    accel = 0.5 * a + 0.25 * speed * speed;
}

namespace {

double dot4(const Q4& a, const Q4& b) { return a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z; }

// The smallest |p|² on the segment, ≤ 0 when p may pass through zero.
double lerp_min_norm2(const LerpSeg& g) {
    const double A = dot4(g.a, g.a), B = dot4(g.a, g.b), C = dot4(g.b, g.b);
    const double q2 = A - 2.0 * B + C;  // |a − b|² ≥ 0
    double lo = std::fmin(A, C);
    if (q2 > 0.0) {
        const double s = std::clamp((A - B) / q2, 0.0, 1.0);
        lo = std::fmin(lo, A - 2.0 * (A - B) * s + q2 * s * s);
    }
    return lo;
}

}  // namespace

void build_speed_bounds(Curve::Impl& m) {
    const std::size_t S = m.kt.size() > 0 ? m.kt.size() - 1 : 0;
    m.kspeed.assign(S, 0.0);
    m.kaccel.assign(S, 0.0);
    for (std::size_t i = 0; i < S; ++i) {
        double v = 0.0, a = 0.0, inv_h = 1.0 / (m.kt[i + 1] - m.kt[i]);
        if (!m.euler.empty()) {  // per unit s
            const EulerSeg& g = m.euler[i];
            v = std::fabs(g.da.x) + std::fabs(g.da.y) + std::fabs(g.da.z);
            a = 0.75 * v * v;
        } else if (!m.lerp.empty()) {
            const LerpSeg& g = m.lerp[i];
            const double lo = lerp_min_norm2(g);
            const Q4 d{g.b.w - g.a.w, g.b.x - g.a.x, g.b.y - g.a.y, g.b.z - g.a.z};
            v = lo > 0.0 ? 2.0 * glm::length(g.c) / lo : HUGE_VAL;
            a = lo > 0.0 ? 5.0 * dot4(d, d) / lo : HUGE_VAL;
        } else if (!m.slerp.empty()) {
            v = glm::length(m.slerp[i].omega) / inv_h;
            a = 0.25 * v * v;
        } else if (!m.squad.empty()) {
            v = m.squad[i].speed;
            a = m.squad[i].accel;
        } else if (!m.bezier.empty()) {
            const BezierSeg& g = m.bezier[i];
            const double l1 = glm::length(g.d01), l2 = glm::length(g.d12), l3 = glm::length(g.d23);
            v = 3.0 * std::fmax(l1, std::fmax(l2, l3));
            a = 0.5 * (6.0 * (l1 + l2 + l3) + v * v) + 0.25 * v * v;
        } else if (!m.spline.empty()) {
            const SplineSeg& g = m.spline[i];
            const double c2 = glm::length(g.c2), c3 = glm::length(g.c3);
            v = glm::length(g.c1) + 2.0 * c2 + 3.0 * c3;
            a = 0.5 * (2.0 * c2 + 6.0 * c3 + 0.5 * v * v) + 0.25 * v * v;
        }
        m.kspeed[i] = v * inv_h;
        m.kaccel[i] = a * inv_h * inv_h;
    }
}

namespace {

// The largest kspeed and kaccel over the knot segments that meet [t0, t1] (inside the knots).
void knot_bounds(const Curve::Impl& m, double t0, double t1, double& speed, double& accel) {
    const std::size_t S = m.kspeed.size();
    std::size_t j = static_cast<std::size_t>(std::upper_bound(m.kt.begin(), m.kt.end(), t0) - m.kt.begin());
    j = j == 0 ? 0 : std::min(j - 1, S - 1);
    speed = accel = 0.0;
    for (; j < S && m.kt[j] <= t1; ++j) {
        speed = std::fmax(speed, m.kspeed[j]);
        accel = std::fmax(accel, m.kaccel[j]);
    }
}

}  // namespace

}  // namespace detail

void Curve::motion_bounds(double t0, double t1, double& speed, double& accel) const {
    if (!(t0 <= t1)) throw InvalidArgument("motion_bounds: t0 must not be after t1");
    speed = accel = 0.0;
    const std::size_t K = times_.size();
    if (K < 2) return;
    const Impl& m = *impl_;
    if (m.cyclic) {
        const double first = times_.front(), last = times_.back();
        if (!(t1 - t0 < m.period)) {
            bounds_within(first, last, speed, accel);
            return;
        }
        double periods;
        const double w0 = detail::wrap_time(m, t0, periods), w1 = w0 + (t1 - t0);
        if (w1 <= last) {
            bounds_within(w0, w1, speed, accel);
            return;
        }
        double v, a;
        bounds_within(w0, last, speed, accel);
        bounds_within(first, std::fmin(last, first + (w1 - last)), v, a);
        speed = std::fmax(speed, v);
        accel = std::fmax(accel, a);
        return;
    }
    bounds_within(t0, t1, speed, accel);
}

// motion_bounds on the keys' range as it stands (constant outside it).
void Curve::bounds_within(double t0, double t1, double& speed, double& accel) const {
    speed = accel = 0.0;
    const std::size_t K = times_.size();
    const double lo = std::fmax(t0, times_.front()), hi = std::fmin(t1, times_.back());
    if (lo > hi) return;  // outside the keys the curve is constant
    const Impl& m = *impl_;
    if (!m.eased) {
        detail::knot_bounds(m, lo, hi, speed, accel);
        return;
    }
    // Key segment by key segment: the warped sub-interval's bounds through the warp's rates.
    std::size_t k = static_cast<std::size_t>(std::upper_bound(times_.begin(), times_.end(), lo) - times_.begin());
    k = k == 0 ? 0 : std::min(k - 1, K - 2);
    for (; k + 1 < K && times_[k] <= hi; ++k) {
        const double ends[2] = {std::fmax(lo, times_[k]), std::fmin(hi, times_[k + 1])};
        double warped[2];
        detail::ease_times(m, times_, ends, 2, warped, nullptr);
        double ea = m.ease_a[k], eb = m.ease_b[k];
        if (ea + eb > 1.0) {
            const double sum = ea + eb;
            ea /= sum;
            eb /= sum;
        }
        const double kk = 1.0 / (2.0 - ea - eb), rate = 2.0 * kk;
        double curve = 0.0;  // |w''|·h: 2k/a on the ease-out part, 2k/b on the ease-in part
        if (ea > 0.0) curve = std::fmax(curve, 2.0 * kk / ea);
        if (eb > 0.0) curve = std::fmax(curve, 2.0 * kk / eb);
        const double w2 = curve / (times_[k + 1] - times_[k]);
        double v, a;
        detail::knot_bounds(m, std::fmin(warped[0], warped[1]), std::fmax(warped[0], warped[1]), v, a);
        speed = std::fmax(speed, rate * v);
        accel = std::fmax(accel, a * rate * rate + 0.5 * v * w2);
    }
}

std::vector<double> Curve::corner_times() const {
    std::vector<double> out = times_;
    if (times_.size() < 2) return out;
    const Impl& m = *impl_;
    for (std::size_t j = 0; j < m.kkey.size(); ++j) {
        if (m.kkey[j] >= 0) continue;  // a key: already in
        const double tau = m.kt[j];
        if (!m.eased) {
            out.push_back(tau);
            continue;
        }
        // The time t whose warped time is tau: the warp is monotone within the key segment.
        const std::size_t k = static_cast<std::size_t>(m.kseg[j]);
        double lo = times_[k], hi = times_[k + 1];
        for (int it = 0; it < 80 && hi - lo > 0.0; ++it) {
            const double mid = 0.5 * (lo + hi);
            double w;
            detail::ease_times(m, times_, &mid, 1, &w, nullptr);
            (w < tau ? lo : hi) = mid;
        }
        out.push_back(lo);
        out.push_back(hi);
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

std::vector<double> Curve::corner_times(double t0, double t1) const {
    if (!(t0 <= t1)) throw InvalidArgument("corner_times: t0 must not be after t1");
    const std::vector<double> period = corner_times();
    std::vector<double> out;
    if (!impl_ || !impl_->cyclic) {
        for (double t : period)
            if (t >= t0 && t <= t1) out.push_back(t);
        return out;
    }
    // Every period k meeting [t0, t1]: its corner times shifted by k·P (the last is the next's first).
    const Impl& m = *impl_;
    const double first = times_.front(), P = m.period;
    const double k0 = std::floor((t0 - first) / P) - 1.0, k1 = std::floor((t1 - first) / P) + 1.0;
    if (!(k1 - k0 <= 1e7)) throw InvalidArgument("corner_times: [t0, t1] spans more than 1e7 periods of the loop");
    for (double k = k0; k <= k1; k += 1.0)
        for (std::size_t i = 0; i + 1 < period.size(); ++i) {
            const double t = period[i] + k * P;
            if (t >= t0 && t <= t1) out.push_back(t);
        }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

double Curve::speed_bound(double t0, double t1) const {
    double speed, accel;
    motion_bounds(t0, t1, speed, accel);
    return speed;
}

}  // namespace quatcurve
