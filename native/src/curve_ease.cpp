// Ease in / ease out per key, for every method: 3ds Max's Ease To / Ease From as a time warp.
//
// Within key segment k (keys k and k+1, duration h) the curve is sampled at t0 + e(u)·h instead of
// t0 + u·h, u = (t − t0)/h, with the ease curve e of a = ease_out(key k), b = ease_in(key k+1):
//   e(u) = k/a·u²                      on [0, a]        (zero slope at u = 0 when a > 0)
//        = k·(2u − a)                  on [a, 1 − b]
//        = 1 − k/b·(1 − u)²            on [1 − b, 1]    (zero slope at u = 1 when b > 0)
//   k = 1/(2 − a − b); a + b > 1 is scaled down to 1.
// e is monotone from [0, 1] onto itself, so the path is the method's path exactly; only the speed
// along it changes: the angular velocity is the method's at the warped time times e'(u), zero at a
// key with full ease (1). Keys are still hit at their own frames.
#include <cmath>

#include "curve_impl.hpp"

namespace quatcurve::detail {

namespace {

void ease(double u, double a, double b, double& e, double& de) {
    const double sum = a + b;
    if (sum <= 0.0) {
        e = u;
        de = 1.0;
        return;
    }
    if (sum > 1.0) {
        a /= sum;
        b /= sum;
    }
    const double k = 1.0 / (2.0 - a - b);
    if (u < a) {
        e = k / a * u * u;
        de = 2.0 * k / a * u;
    } else if (u < 1.0 - b || b == 0.0) {
        e = k * (2.0 * u - a);
        de = 2.0 * k;
    } else {
        const double v = 1.0 - u;
        e = 1.0 - k / b * v * v;
        de = 2.0 * k / b * v;
    }
}

}  // namespace

void set_ease(Curve::Impl& m, const CurveOptions& options, std::size_t keys) {
    m.eased = false;
    m.ease_a.assign(keys > 0 ? keys - 1 : 0, 0.0);
    m.ease_b.assign(m.ease_a.size(), 0.0);
    for (std::size_t k = 0; k + 1 < keys; ++k) {
        m.ease_a[k] = per_key(options.ease_out, static_cast<int>(k));
        m.ease_b[k] = per_key(options.ease_in, static_cast<int>(k + 1));
        if (m.ease_a[k] > 0.0 || m.ease_b[k] > 0.0) m.eased = true;
    }
}

void ease_times(const Curve::Impl& m, const std::vector<double>& key_times, const double* times, std::size_t n,
                double* warped, double* rate) {
    drive(
        key_times, times, n,
        [&](std::size_t i, std::size_t k, double t) {
            const double t0 = key_times[k], t1 = key_times[k + 1], h = t1 - t0;
            double e, de;
            ease((t - t0) / h, m.ease_a[k], m.ease_b[k], e, de);
            warped[i] = std::fmin(t0 + e * h, t1);
            if (rate) rate[i] = de;
        },
        [&](std::size_t i, bool) {
            warped[i] = times[i];
            if (rate) rate[i] = 0.0;
        });
}

}  // namespace quatcurve::detail
