// Cleaning captured rotations (clean.hpp): flips, the noise estimate, spikes, the smoothing within a
// deviation bound, and clean_rotations. The formulas are stated in clean.hpp and docs/clean.md.
#include "quatcurve/clean.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <queue>
#include <string>
#include <tuple>

#include "curve_math.hpp"
#include "quatcurve/channels.hpp"

namespace quatcurve {

namespace {

using detail::qconj;
using detail::qexp;
using detail::qmul;
using detail::rotvec_principal;

// Median of the chi distribution with 3 degrees of freedom: √(median of χ²₃) (χ²₃ median 2.365974…).
constexpr double kChi3Median = 1.5381722544550522;
// find_spikes' local speed: over the frames kLocalGap … kLocalGap + kLocalSpan − 1 before and after a
// window (beyond the two neighbours on each side that a spike in it moves).
constexpr std::size_t kLocalGap = 3, kLocalSpan = 5;
// A departure below this share of the local speed (angle per frame) is never a spike.
constexpr double kSpeedShare = 1.0;
// The motion's roughness over the whole clip: kRoughFactor times the kRoughQuantile quantile of the
// frames' scaled residuals |r_i|/g_i (for white noise 2 × 1.44σ: above the threshold's 3σ only where
// the motion itself departs from the cubic at more than a tenth of its frames).
constexpr double kRoughQuantile = 0.9, kRoughFactor = 2.0;
// A window of L frames needs 1 + kRunShare·(L − 1) times a single frame's departure: a run predicted
// across a gap is less certain than one frame (a fast stretch of motion departs from the cubic across
// it too).
constexpr double kRunShare = 0.5;
// The prediction's noise gain for one frame inside evenly spaced frames, √(1 + 2·(1/6)² + 2·(2/3)²):
// min_angle applies where the cubic interpolates (two nodes on each side), and grows with the gain
// where it extrapolates near the clip's ends (a spike among the nodes throws it far off there).
const double kInteriorGain = std::sqrt(35.0 / 18.0);
// Rounds of search and pruning in find_spikes at most: a guard against marks and prunes cycling.
constexpr int kPruneRounds = 8;
constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();

std::string num(double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.17g", x);
    return buf;
}

// The checked input: quaternions normalized; times as τ_i, in units of their median spacing from the
// first (so 0, 1, 2, … for one sample a frame, and no spacing overflows or underflows the formulas).
struct Prepared {
    std::vector<Quat> u;
    std::vector<double> tau;
};

// Times finite and strictly increasing, their spacings finite and within kSpacingRatio of the median
// spacing; quaternions finite and nonzero; at least 3 frames.
constexpr double kSpacingRatio = 1e6;

Prepared prepare(const std::vector<double>& times, const std::vector<Quat>& q) {
    if (times.size() != q.size())
        throw InvalidArgument("times: " + std::to_string(times.size()) + " values for " + std::to_string(q.size()) +
                              " quats");
    if (q.size() < 3)
        throw InvalidArgument("quats: " + std::to_string(q.size()) + " frames (at least 3 needed)");
    const std::size_t n = q.size();
    Prepared p;
    p.u.resize(n);
    std::vector<double> h(n - 1);
    for (std::size_t i = 0; i < n; ++i) {
        check_finite(times[i], "times[" + std::to_string(i) + "]");
        if (i > 0 && !(times[i] > times[i - 1]))
            throw InvalidArgument("times[" + std::to_string(i) + "]: " + num(times[i]) + " is not after times[" +
                                  std::to_string(i - 1) + "] = " + num(times[i - 1]) + " (times must increase)");
        if (i > 0) h[i - 1] = times[i] - times[i - 1];
        p.u[i] = normalized_rotation(q[i], "quats", i);
    }
    std::vector<double> sorted = h;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    const double median = sorted[sorted.size() / 2];
    p.tau.resize(n);
    p.tau[0] = 0.0;
    for (std::size_t i = 1; i < n; ++i) {
        const double r = h[i - 1] / median;
        if (!std::isfinite(h[i - 1]) || !(r <= kSpacingRatio && r >= 1.0 / kSpacingRatio))
            throw InvalidArgument("times[" + std::to_string(i) + "]: the spacing " + num(h[i - 1]) + " from times[" +
                                  std::to_string(i - 1) + "] is not within a factor 1e6 of the median spacing " +
                                  num(median));
        p.tau[i] = p.tau[i - 1] + r;
    }
    return p;
}

void check_non_negative(double x, const char* what) {
    if (!std::isfinite(x) || x < 0.0)
        throw InvalidArgument(std::string(what) + ": " + num(x) + " (expected a finite value >= 0)");
}

// Sample indices: increasing, each below n.
void check_indices(const std::vector<std::size_t>& frames, std::size_t n, const char* what) {
    for (std::size_t k = 0; k < frames.size(); ++k) {
        const std::string name = std::string(what) + "[" + std::to_string(k) + "]";
        if (frames[k] >= n)
            throw InvalidArgument(name + ": " + std::to_string(frames[k]) + " is not a frame index (" +
                                  std::to_string(n) + " frames)");
        if (k > 0 && frames[k] <= frames[k - 1])
            throw InvalidArgument(name + ": " + std::to_string(frames[k]) + " is not after " +
                                  std::to_string(frames[k - 1]) + " (indices must increase)");
    }
}

// ---- the prediction of a window from its neighbours ------------------------------------------------------

struct Nodes {
    std::array<std::size_t, 4> index{};
    std::size_t count = 0;
    std::size_t reference = kNone;  // the nearest neighbour
};

// The two nearest unmarked frames on each side of the window first..last, or, where one side has
// fewer, more from the other side (four in all when the clip has them), so that a window at the
// clip's ends is extrapolated by a cubic too. False when the run of marked frames the window would
// join (between the nearest unmarked neighbours) is longer than max_gap, or fewer than two
// neighbours exist.
bool find_nodes(const std::vector<char>& marked, std::size_t first, std::size_t last, std::size_t max_gap,
                Nodes& out) {
    const std::size_t n = marked.size();
    std::size_t left[4], right[4], nl = 0, nr = 0;
    for (std::size_t k = first; k > 0 && nl < 4;)
        if (!marked[--k]) left[nl++] = k;
    for (std::size_t k = last + 1; k < n && nr < 4; ++k)
        if (!marked[k]) right[nr++] = k;
    const std::size_t lo = nl ? left[0] + 1 : 0, hi = nr ? right[0] : n;
    if (hi - lo > max_gap) return false;
    std::size_t use_l = std::min<std::size_t>(2, nl), use_r = std::min<std::size_t>(2, nr);
    if (use_l < 2) use_r = std::min(4 - use_l, nr);
    if (use_r < 2) use_l = std::min(4 - use_r, nl);
    out.count = 0;
    for (std::size_t a = use_l; a-- > 0;) out.index[out.count++] = left[a];
    for (std::size_t a = 0; a < use_r; ++a) out.index[out.count++] = right[a];
    if (out.count < 2) return false;
    out.reference = nl ? left[0] : right[0];
    return true;
}

// The rotation the nodes predict at time t (τ units): the Lagrange polynomial through their rotation vectors
// in the reference's tangent space; gain = √(1 + Σ w_k²).
Quat predict(const std::vector<double>& tau, const std::vector<Quat>& u, const Nodes& nodes, double t,
             double& gain) {
    const Quat& ref = u[nodes.reference];
    Vec3 p(0.0);
    double w2 = 0.0;
    for (std::size_t a = 0; a < nodes.count; ++a) {
        double w = 1.0;
        const double ta = tau[nodes.index[a]];
        for (std::size_t b = 0; b < nodes.count; ++b)
            if (b != a) w *= (t - tau[nodes.index[b]]) / (ta - tau[nodes.index[b]]);
        w2 += w * w;
        if (nodes.index[a] != nodes.reference) p += w * rotvec_principal(qmul(qconj(ref), u[nodes.index[a]]));
    }
    gain = std::sqrt(1.0 + w2);
    return qmul(ref, qexp(p));
}

// ---- the smoother's linear algebra -----------------------------------------------------------------------

// A symmetric positive definite pentadiagonal matrix (diagonal d, first and second off-diagonals e1, e2),
// factored in place as L·D·Lᵀ.
struct Pentadiagonal {
    std::vector<double> d, e1, e2;

    void factor() {
        const std::size_t n = d.size();
        for (std::size_t i = 0; i < n; ++i) {
            if (i >= 1) d[i] -= e1[i - 1] * e1[i - 1] * d[i - 1];
            if (i >= 2) d[i] -= e2[i - 2] * e2[i - 2] * d[i - 2];
            if (i + 1 < n) {
                double k = e1[i];
                if (i >= 1) k -= e2[i - 1] * d[i - 1] * e1[i - 1];
                e1[i] = k / d[i];
            }
            if (i + 2 < n) e2[i] /= d[i];
        }
    }
    // The diagonal of the inverse, from the factors (Takahashi's recurrence for a band of two: the
    // inverse Z = L⁻ᵀ·D⁻¹·L⁻¹ within the band, from the last row up).
    std::vector<double> inverse_diagonal() const {
        const std::size_t n = d.size();
        std::vector<double> z(n);
        double z11 = 0.0, z12 = 0.0, z22 = 0.0;  // Z at (i+1, i+1), (i+1, i+2), (i+2, i+2)
        for (std::size_t i = n; i-- > 0;) {
            const double l1 = i + 1 < n ? e1[i] : 0.0, l2 = i + 2 < n ? e2[i] : 0.0;
            const double z01 = -(l1 * z11 + l2 * z12), z02 = -(l1 * z12 + l2 * z22);
            const double z00 = 1.0 / d[i] - (l1 * z01 + l2 * z02);
            z[i] = z00;
            z22 = z11, z12 = z01, z11 = z00;
        }
        return z;
    }
    // Solves in place (x holds the right-hand side), stride 3 (one component of Vec3 rows).
    void solve(double* x, std::size_t stride) const {
        const std::size_t n = d.size();
        for (std::size_t i = 1; i < n; ++i) {
            x[i * stride] -= e1[i - 1] * x[(i - 1) * stride];
            if (i >= 2) x[i * stride] -= e2[i - 2] * x[(i - 2) * stride];
        }
        for (std::size_t i = 0; i < n; ++i) x[i * stride] /= d[i];
        for (std::size_t i = n - 1; i-- > 0;) {
            x[i * stride] -= e1[i] * x[(i + 1) * stride];
            if (i + 2 < n) x[i * stride] -= e2[i] * x[(i + 2) * stride];
        }
    }
};

// The smoothing problem: data q (unit, hemisphere-continuous), the acceleration rows' coefficients.
struct Smoother {
    const std::vector<Quat>& q;
    std::size_t n;
    std::vector<double> cm, c0, cp, mu;  // row i (1 ≤ i ≤ n−2): a_i = cp·ω_i − cm·ω_{i−1}

    Smoother(const std::vector<double>& tau, const std::vector<Quat>& data) : q(data), n(data.size()) {
        cm.assign(n, 0.0), c0.assign(n, 0.0), cp.assign(n, 0.0), mu.assign(n, 0.0);
        for (std::size_t i = 1; i + 1 < n; ++i) {
            const double h0 = tau[i] - tau[i - 1], h1 = tau[i + 1] - tau[i];
            cm[i] = 2.0 / ((h0 + h1) * h0);
            cp[i] = 2.0 / ((h0 + h1) * h1);
            c0[i] = -(cm[i] + cp[i]);
            mu[i] = 0.5 * (h0 + h1);
        }
    }

    Pentadiagonal matrix(double lambda, const std::vector<double>& w) const {
        Pentadiagonal m;
        m.d = w;
        m.e1.assign(n, 0.0), m.e2.assign(n, 0.0);
        for (std::size_t i = 1; i + 1 < n; ++i) {
            const double s = lambda * mu[i];
            m.d[i - 1] += s * cm[i] * cm[i];
            m.d[i] += s * c0[i] * c0[i];
            m.d[i + 1] += s * cp[i] * cp[i];
            m.e1[i - 1] += s * cm[i] * c0[i];
            m.e1[i] += s * c0[i] * cp[i];
            m.e2[i - 1] += s * cm[i] * cp[i];
        }
        m.factor();
        return m;
    }

    // Gauss–Newton from p to the smoother's fixed point for λ and the weights w.
    void solve(double lambda, const std::vector<double>& w, std::vector<Quat>& p) const {
        solve(matrix(lambda, w), lambda, w, p);
    }
    // The same with the factored matrix of λ and w given.
    void solve(const Pentadiagonal& m, double lambda, const std::vector<double>& w, std::vector<Quat>& p) const {
        std::vector<Vec3> omega(n - 1), rhs(n);
        std::vector<double> x(3 * n);  // the three components' right-hand sides, then δ, row by row
        for (int iteration = 0; iteration < 60; ++iteration) {
            for (std::size_t i = 0; i + 1 < n; ++i) omega[i] = rotvec_principal(qmul(qconj(p[i]), p[i + 1]));
            for (std::size_t i = 0; i < n; ++i) rhs[i] = w[i] * rotvec_principal(qmul(qconj(p[i]), q[i]));
            for (std::size_t i = 1; i + 1 < n; ++i) {
                const Vec3 s = lambda * mu[i] * (cp[i] * omega[i] - cm[i] * omega[i - 1]);
                rhs[i - 1] -= cm[i] * s;
                rhs[i] -= c0[i] * s;
                rhs[i + 1] -= cp[i] * s;
            }
            for (std::size_t i = 0; i < n; ++i) x[3 * i] = rhs[i].x, x[3 * i + 1] = rhs[i].y, x[3 * i + 2] = rhs[i].z;
            for (std::size_t c = 0; c < 3; ++c) m.solve(x.data() + c, 3);
            double largest = 0.0;
            for (std::size_t i = 0; i < n; ++i) {
                const Vec3 delta(x[3 * i], x[3 * i + 1], x[3 * i + 2]);
                p[i] = glm::normalize(qmul(p[i], qexp(delta)));
                largest = std::max(largest, glm::length(delta));
            }
            if (largest < 1e-10) break;
        }
    }

    // tr(S) of the linearized smoother S = (W + λ·AᵀMA)⁻¹·W (m: its factored matrix): its degrees of
    // freedom.
    double degrees_of_freedom(const Pentadiagonal& m, const std::vector<double>& w) const {
        const std::vector<double> z = m.inverse_diagonal();
        double df = 0.0;
        for (std::size_t i = 0; i < n; ++i) df += z[i] * w[i];
        return df;
    }

    double mean_square_deviation(const std::vector<Quat>& p, const std::vector<char>& bound) const {
        double sum = 0.0;
        std::size_t count = 0;
        for (std::size_t i = 0; i < n; ++i)
            if (bound[i]) {
                const double a = angle_between(p[i], q[i]);
                sum += a * a;
                ++count;
            }
        return count ? sum / static_cast<double>(count) : 0.0;
    }
};

}  // namespace

// ---- 1. flips ----------------------------------------------------------------------------------------------

std::size_t remove_quat_flips(Quat* q, std::size_t n) {
    // hemisphere_continuous's rule on the normalized rotations, so that no dot of huge or tiny
    // components overflows or underflows; the signs found are applied to q as given.
    std::vector<Quat> u(n);
    for (std::size_t i = 0; i < n; ++i) u[i] = normalized_rotation(q[i], "quats", i);
    std::size_t flips = 0;
    for (std::size_t i = 1; i < n; ++i)
        if (glm::dot(u[i], u[i - 1]) < 0.0) ++flips;
    const std::vector<Quat> before = u;
    hemisphere_continuous(u.data(), n);
    for (std::size_t i = 0; i < n; ++i)
        if (u[i] != before[i]) q[i] = -q[i];
    return flips;
}

std::size_t remove_euler_flips(Vec3* angles, std::size_t n, EulerOrder order) {
    for (std::size_t i = 0; i < n; ++i) check_finite(angles[i], "angles[" + std::to_string(i) + "]");
    const std::vector<Vec3> before(angles, angles + n);
    euler_filter(angles, n, order);
    // A repaired pair: the shift applied to a row differs from the one applied to the row before.
    std::size_t flips = 0;
    for (std::size_t i = 1; i < n; ++i) {
        const Vec3 change = (angles[i] - before[i]) - (angles[i - 1] - before[i - 1]);
        const double scale = 1.0 + std::max(glm::length(before[i]), glm::length(before[i - 1]));
        if (glm::length(change) > 1e-9 * scale) ++flips;
    }
    return flips;
}

// ---- 2. noise ------------------------------------------------------------------------------------------------

namespace {

// |r_i|/g_i of every inner frame i (index i − 1): its departure from the cubic through its neighbours,
// over the prediction's noise gain (see estimate_rotation_noise).
std::vector<double> scaled_residuals(const Prepared& in) {
    const std::vector<Quat>& u = in.u;
    const std::vector<char> none(u.size(), 0);
    std::vector<double> r(u.size() - 2);
    for (std::size_t i = 1; i + 1 < u.size(); ++i) {
        Nodes nodes;
        find_nodes(none, i, i, 1, nodes);  // always found: i has a neighbour on each side
        double gain;
        const Quat p = predict(in.tau, u, nodes, in.tau[i], gain);
        r[i - 1] = glm::length(rotvec_principal(qmul(qconj(p), u[i]))) / gain;
    }
    return r;
}

// The median of r; 0 for none.
double median_of(std::vector<double> r) {
    if (r.empty()) return 0.0;
    const auto mid = r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2);
    std::nth_element(r.begin(), mid, r.end());
    double median = *mid;
    if (r.size() % 2 == 0) median = 0.5 * (median + *std::max_element(r.begin(), mid));
    return median;
}

// σ from scaled residuals (estimate_rotation_noise): √3·median/m₃; 0 for none.
double noise_of(std::vector<double> r) { return std::sqrt(3.0) * median_of(std::move(r)) / kChi3Median; }

}  // namespace

double estimate_rotation_noise(const std::vector<double>& times, const std::vector<Quat>& q) {
    return noise_of(scaled_residuals(prepare(times, q)));
}

// ---- 3. spikes -------------------------------------------------------------------------------------------------

Spikes find_spikes(const std::vector<double>& times, const std::vector<Quat>& q, double noise,
                   const SpikeOptions& options) {
    const Prepared in = prepare(times, q);
    const std::vector<Quat>& u = in.u;
    check_non_negative(noise, "noise");
    check_non_negative(options.threshold, "threshold");
    check_non_negative(options.min_angle, "min_angle");
    if (options.max_run < 1) throw InvalidArgument("max_run: 0 (expected at least 1)");
    const std::size_t n = u.size(), runs = std::min(options.max_run, n - 2);
    std::vector<char> marked(n, 0);
    // The clip's roughness (kRoughQuantile of the frames' scaled residuals): where the captured motion
    // itself departs from the cubic at many frames, it raises the limit.
    const std::vector<double> residuals = scaled_residuals(in);
    double rough = 0.0;
    {
        std::vector<double> r = residuals;
        const auto at = r.begin() + static_cast<std::ptrdiff_t>(kRoughQuantile * static_cast<double>(r.size() - 1));
        std::nth_element(r.begin(), at, r.end());
        rough = kRoughFactor * *at;
    }
    // The motion's own speed around a window: the median angle between consecutive frames there; a
    // departure below kSpeedShare of it is the motion turning, not a spike.
    auto local_speed = [&](std::size_t first, std::size_t last) {
        std::vector<double> steps;
        for (std::size_t k = 0; k < kLocalSpan; ++k) {
            const std::size_t before = kLocalGap + k, after = last + kLocalGap + k;
            if (first >= before + 1) steps.push_back(angle_between(u[first - before - 1], u[first - before]));
            if (after + 1 < n) steps.push_back(angle_between(u[after], u[after + 1]));
        }
        return median_of(std::move(steps));
    };

    // The window's score: the smallest over its frames of departure / max((1 + kRunShare·(L − 1))·
    // max(threshold·σ·g, roughness·g, local speed), min_angle (× g/g₀ where the cubic extrapolates)),
    // L the window's length; negative when the window cannot be marked.
    auto score = [&](std::size_t first, std::size_t length) {
        const std::size_t last = first + length - 1;
        for (std::size_t i = first; i <= last; ++i)
            if (marked[i]) return -1.0;
        Nodes nodes;
        if (!find_nodes(marked, first, last, runs, nodes)) return -1.0;
        const double speed = local_speed(first, last);
        const double run = 1.0 + kRunShare * static_cast<double>(length - 1);
        // Two nodes on each side: the cubic interpolates (else it extrapolates, at the clip's ends).
        const bool inside = nodes.count == 4 && nodes.index[1] < first && nodes.index[2] > last;
        double s = std::numeric_limits<double>::infinity();
        for (std::size_t i = first; i <= last; ++i) {
            double gain;
            const Quat p = predict(in.tau, u, nodes, in.tau[i], gain);
            const double limit = std::max(
                {run * std::max({options.threshold * noise * gain, rough * gain, kSpeedShare * speed}),
                 options.min_angle * (inside ? 1.0 : std::max(1.0, gain / kInteriorGain)), 1e-300});
            s = std::min(s, angle_between(p, u[i]) / limit);
        }
        return s;
    };

    // Best window first; a popped entry counts only if its window was not scored again since.
    using Entry = std::tuple<double, std::size_t, std::size_t, unsigned>;  // score, first, length, stamp
    std::priority_queue<Entry> queue;
    std::vector<unsigned> stamp(n * runs, 0);
    auto rescore = [&](std::size_t first, std::size_t length) {
        if (first + length > n) return;
        const unsigned s = ++stamp[first * runs + length - 1];
        const double value = score(first, length);
        if (value > 1.0) queue.emplace(value, first, length, s);
    };
    auto search = [&] {
        for (std::size_t first = 0; first < n; ++first)
            for (std::size_t length = 1; length <= runs; ++length) rescore(first, length);
        while (!queue.empty()) {
            const Entry top = queue.top();
            queue.pop();
            const std::size_t first = std::get<1>(top), length = std::get<2>(top);
            if (stamp[first * runs + length - 1] != std::get<3>(top)) continue;
            const std::size_t last = first + length - 1;
            for (std::size_t i = first; i <= last; ++i) marked[i] = 1;
            // Windows whose neighbours or run may include the marked frames: from max_run before the
            // third unmarked frame on the left to the third unmarked frame on the right.
            std::size_t lo = first, hi = last, seen = 0;
            while (lo > 0 && seen < 3)
                if (!marked[--lo]) ++seen;
            seen = 0;
            while (hi + 1 < n && seen < 3)
                if (!marked[++hi]) ++seen;
            lo = lo >= runs ? lo - runs : 0;
            for (std::size_t a = lo; a <= hi; ++a)
                for (std::size_t len = 1; len <= runs; ++len) rescore(a, len);
        }
    };
    // A frame marked while a spike not yet marked spoiled its prediction (an extrapolation at the
    // clip's ends through a spike, say) is no spike once that one is marked: each marked frame is
    // scored again alone with every other mark in place and unmarked below the limit; the search then
    // runs again on what is left, until nothing changes (or after kPruneRounds rounds).
    for (int round = 0; round < kPruneRounds; ++round) {
        search();
        bool pruned = false;
        for (std::size_t i = 0; i < n; ++i) {
            if (!marked[i]) continue;
            marked[i] = 0;
            if (score(i, 1) > 1.0) {
                marked[i] = 1;
            } else {
                pruned = true;
            }
        }
        if (!pruned) break;
    }

    Spikes out;
    for (std::size_t i = 0; i < n; ++i)
        if (marked[i]) out.frames.push_back(i);
    const std::vector<Quat> replaced = replace_spikes(times, u, out.frames);
    for (std::size_t i : out.frames) out.departures.push_back(angle_between(replaced[i], u[i]));
    return out;
}

std::vector<Quat> replace_spikes(const std::vector<double>& times, const std::vector<Quat>& q,
                                 const std::vector<std::size_t>& frames) {
    const Prepared in = prepare(times, q);
    const std::vector<Quat>& u = in.u;
    check_indices(frames, u.size(), "frames");
    std::vector<char> marked(u.size(), 0);
    for (std::size_t i : frames) marked[i] = 1;
    std::vector<Quat> out = u;
    for (std::size_t k = 0; k < frames.size();) {
        std::size_t end = k;
        while (end + 1 < frames.size() && frames[end + 1] == frames[end] + 1) ++end;
        Nodes nodes;
        if (!find_nodes(marked, frames[k], frames[end], kNone, nodes))
            throw InvalidArgument("frames[" + std::to_string(k) + "]: the run of frames " +
                                  std::to_string(frames[k]) + ".." + std::to_string(frames[end]) +
                                  " has fewer than two other frames to predict it");
        for (std::size_t i = frames[k]; i <= frames[end]; ++i) {
            double gain;
            out[i] = predict(in.tau, u, nodes, in.tau[i], gain);
        }
        k = end + 1;
    }
    hemisphere_continuous(out.data(), out.size());
    return out;
}

// ---- 4. smoothing -------------------------------------------------------------------------------------------

Smoothed smooth_rotations(const std::vector<double>& times, const std::vector<Quat>& q, double deviation,
                          const SmoothOptions& options) {
    Prepared in = prepare(times, q);
    std::vector<Quat>& u = in.u;
    hemisphere_continuous(u.data(), u.size());
    check_non_negative(deviation, "deviation");
    if (options.noise) check_non_negative(*options.noise, "noise");
    if (options.smoothness && !(std::isfinite(*options.smoothness) && *options.smoothness > 0.0))
        throw InvalidArgument("smoothness: " + num(*options.smoothness) + " (expected a finite value > 0)");
    check_indices(options.free_frames, u.size(), "free_frames");
    const std::size_t n = u.size();
    std::vector<char> bound(n, 1);
    std::vector<double> w(n, 1.0);
    for (std::size_t i : options.free_frames) bound[i] = 0, w[i] = 1e-8;

    Smoothed out;
    out.q = u;
    if (deviation == 0.0) return out;

    const Smoother smoother(in.tau, u);
    std::vector<Quat> p = u;
    if (options.smoothness) {
        out.smoothness = *options.smoothness;
    } else {
        // Stein's unbiased risk estimate of the mean squared angle to the truth over the bound frames,
        // for white noise of RMS angle σ: (Σ dev² + 2·σ²·tr(S))/m − σ², minimized over log λ (a grid
        // of decades over [10⁻³, 10¹⁰], then golden section around the best to 0.01).
        const double noise = options.noise ? *options.noise : estimate_rotation_noise(times, u);
        const double sigma2 = noise * noise;
        const double m = std::max(1.0, static_cast<double>(std::count(bound.begin(), bound.end(), 1)));
        auto risk = [&](double log_lambda) {
            const double lambda = std::pow(10.0, log_lambda);
            const Pentadiagonal matrix = smoother.matrix(lambda, w);
            smoother.solve(matrix, lambda, w, p);
            return smoother.mean_square_deviation(p, bound) + 2.0 * sigma2 * smoother.degrees_of_freedom(matrix, w) / m;
        };
        double best = 10.0, best_risk = std::numeric_limits<double>::infinity();
        for (double x = 10.0; x >= -3.0; x -= 1.0) {
            const double r = risk(x);
            if (r < best_risk) best_risk = r, best = x;
        }
        const double golden = 0.5 * (std::sqrt(5.0) - 1.0);
        double a = std::max(-3.0, best - 1.0), b = std::min(10.0, best + 1.0);
        double c = b - golden * (b - a), d = a + golden * (b - a);
        double rc = risk(c), rd = risk(d);
        while (b - a > 0.01) {
            if (rc < rd) {
                b = d, d = c, rd = rc, c = b - golden * (b - a), rc = risk(c);
            } else {
                a = c, c = d, rc = rd, d = a + golden * (b - a), rd = risk(d);
            }
        }
        const double x = 0.5 * (a + b);
        out.smoothness = std::pow(10.0, risk(x) <= best_risk ? x : best);
    }

    // The bound: raise the weights of the frames beyond 0.98·deviation until every bound frame is
    // within deviation.
    const double inner = 0.98 * deviation;
    std::vector<char> pulled(n, 0);
    for (int round = 0; round < 30; ++round) {
        smoother.solve(out.smoothness, w, p);
        bool beyond = false;
        for (std::size_t i = 0; i < n; ++i)
            if (bound[i] && angle_between(p[i], u[i]) > deviation) beyond = true;
        if (!beyond) break;
        for (std::size_t i = 0; i < n; ++i) {
            if (!bound[i]) continue;
            const double d = angle_between(p[i], u[i]);
            if (d <= inner) continue;
            w[i] = std::min(1e12, w[i] * std::max(4.0, 2.0 * (d / inner) * (d / inner)));
            pulled[i] = 1;
        }
    }
    for (std::size_t i = 0; i < n; ++i) {
        if (!bound[i]) continue;
        if (angle_between(p[i], u[i]) > deviation) p[i] = u[i], ++out.kept;
        out.max_deviation = std::max(out.max_deviation, angle_between(p[i], u[i]));
        out.pulled += pulled[i];
    }
    hemisphere_continuous(p.data(), n);
    out.q = std::move(p);
    return out;
}

// ---- 5. everything ---------------------------------------------------------------------------------------------

CleanResult clean_rotations(const std::vector<double>& times, const std::vector<Quat>& q,
                            const CleanOptions& options) {
    std::vector<Quat> u = prepare(times, q).u;
    CleanResult out;
    out.flips = remove_quat_flips(u.data(), u.size());
    if (options.noise) check_non_negative(*options.noise, "noise");
    check_non_negative(options.deviation_factor, "deviation_factor");
    if (options.deviation) check_non_negative(*options.deviation, "deviation");
    out.noise = options.noise ? *options.noise : estimate_rotation_noise(times, u);
    out.deviation = options.deviation ? *options.deviation : options.deviation_factor * out.noise;

    std::vector<Quat> base = u;
    if (options.spikes) {
        Spikes spikes = find_spikes(times, u, out.noise, options.spike);
        base = replace_spikes(times, u, spikes.frames);
        out.spike_frames = std::move(spikes.frames);
        out.spike_departures = std::move(spikes.departures);
    }
    if (options.smooth) {
        SmoothOptions smooth;
        smooth.smoothness = options.smoothness;
        smooth.noise = out.noise;
        smooth.free_frames = out.spike_frames;
        Smoothed s = smooth_rotations(times, base, out.deviation, smooth);
        out.q = std::move(s.q);
        out.smoothness = s.smoothness;
        out.max_deviation = s.max_deviation;
        out.pulled = s.pulled;
    } else {
        out.q = std::move(base);
    }
    return out;
}

}  // namespace quatcurve
