// Key reduction with a guaranteed angular error bound (see reduce.hpp for the contract).
//
// Structure: a Problem holds the samples in channel space (w, x, y, z or X, Y, Z angles), the
// reference rotation of every sample and a second-order error metric (angle² ≈ eᵀ·M·e for a small
// channel error e). A Fitter fits one segment [i, j] of a set of channels (LINEAR: the chord;
// BEZIER: the two inner control values per channel by weighted least squares in M, then iterative
// reweighting toward the minimax fit) and tests the exact rotation error at every sample inside.
// select_keys picks keys greedily (farthest feasible end by exponential + binary search) and then
// removes keys whose neighbours join. Finally verify_and_repair evaluates every sample exactly as
// Blender does (blender_eval.hpp) and refits or splits failing segments.
#include "quatcurve/reduce.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include "quatcurve/errors.hpp"
#include "quatcurve/euler.hpp"
#include "quatcurve/quat.hpp"

namespace quatcurve {

std::size_t ReducedKeys::key_count() const {
    std::size_t total = 0;
    for (const ReducedChannel& ch : channels) total += ch.indices.size();
    return total;
}

namespace {

constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
constexpr int kMaxChannels = 4;
// Margin between the verified error and the tolerance: Blender's own float32 arithmetic may differ
// from our emulation (operation order, fused multiply-adds on some builds: its Bezier value is a
// float power-basis cubic whose rounding reaches ~6e-7 per channel), and its normalization and
// matrix building add ~1e-7 rad.
constexpr double kVerifyMargin = 2e-6;
// Fitting aims this far below the verification threshold (float32 rounding of handle values and
// of handle frames), so that repairs are rare.
constexpr double kFitMarginRel = 2e-3;
constexpr double kFitMarginAbs = 5e-6;
// Reweighting rounds for fits of all channels together, and for one channel among fitted others
// (per-channel mode fits four times as many segments; two rounds keep it within the speed target
// at a cost of ~1 % more keys).
constexpr int kReweightIterations = 4;
constexpr int kReweightIterationsSingle = 2;
// A fit whose worst sample is above this multiple of the limit (in tan²(θ/2), i.e. twice the angle)
// is rejected without reweighting.
constexpr double kHopeless = 4.0;
constexpr double kPi = 3.14159265358979323846;
// The rotation ignores a quaternion's scale, so the fit may let the 4-vector's norm drift — a cubic
// with varying norm bends the normalized path more freely, which saves many keys. It is kept free
// unless the norm would fall below kMinNormRatio of the sample's (checked at the samples and
// midway between them: near zero the direction swings between frames); such fits are redone with
// radial errors weighted kRadialWeight (tangential errors weigh 4).
constexpr double kRadialWeight = 0.25;
constexpr double kMinNormRatio = 0.5;
constexpr double kBetweenFactor = 2.0;
constexpr double kBetweenStep = 0.25;

double f32(double x) { return static_cast<double>(static_cast<float>(x)); }

// ---- the problem ---------------------------------------------------------------------------------

enum class Kind { QUAT, EULER };

struct Problem {
    Kind kind = Kind::QUAT;
    int C = 4;                    // channels
    EulerOrder order = EulerOrder::XYZ;
    std::size_t n = 0;
    std::vector<double> t;        // float32 frames (as Blender keys and evaluates them)
    std::vector<double> y;        // n·C channel values as given
    std::vector<Quat> ref;        // reference rotation of each sample (unit)
    // The error metric M_k (angle² ≈ eᵀ·M_k·e for a small channel error e), computed on the fly:
    //   quaternions: M = (4·I − κ·ûûᵀ)/|q|² with û = q/|q|; κ = 4 projects out the radial direction
    //                (the rotation ignores scale), κ = 4 − kRadialWeight keeps a little of it;
    //   Euler:       M = Gram matrix of the three rotation axes = I except M[first][last] =
    //                M[last][first] = gimbal[k] = ±sin(middle angle).
    std::vector<double> unit;     // quaternions: n·4, û
    std::vector<double> norm2;    // quaternions: |q|² per sample
    std::vector<double> gimbal;   // Euler: the off-diagonal term per sample
    std::vector<double> slope;    // n·C: finite-difference slope (default Bezier tangents)
    // breaks[k]: number of discontinuities between samples 0..k (a quaternion sign flip, an Euler
    // angle jump above π). A segment may not span one: between the two samples Blender would pass
    // through a near-zero quaternion or spin, and a Bezier fit could hide that at the samples.
    std::vector<std::size_t> breaks;
    // step_tan[k] = tan(kBetweenStep/2 × the rotation angle between samples k and k+1), for the
    // between-samples guard.
    std::vector<double> step_tan;
    // Euler: the order's axes (first applied, middle, last) as indices into (X, Y, Z).
    int axis_first = 0, axis_mid = 1, axis_last = 2;

    const double* row(std::size_t k) const { return &y[k * C]; }
};

// Rotation of Euler angles a (about X, Y, Z) for the problem's order: q_last·q_mid·q_first — the
// same product as euler_to_quat (euler.hpp), without its argument checks, for the inner loops.
Quat euler_rotation(const Problem& p, const double* a) {
    auto axis_quat = [](int axis, double angle) {
        const double s = std::sin(0.5 * angle), c = std::cos(0.5 * angle);
        Quat q(c, 0.0, 0.0, 0.0);
        (axis == 0 ? q.x : axis == 1 ? q.y : q.z) = s;
        return q;
    };
    return multiply(multiply(axis_quat(p.axis_last, a[p.axis_last]),
                             axis_quat(p.axis_mid, a[p.axis_mid])),
                    axis_quat(p.axis_first, a[p.axis_first]));
}

// tan²(θ/2) of the rotation angle θ between the rotation r (any nonzero scale) and the channel
// values f (quaternion: f unnormalized, sign-invariant; Euler: the rotation of angles f). +inf when
// f is a zero quaternion or the rotations are 180° apart.
double error_tan2(const Problem& p, const Quat& r, const double* f) {
    Quat q;
    if (p.kind == Kind::QUAT) {
        q = Quat(f[0], f[1], f[2], f[3]);
    } else {
        q = euler_rotation(p, f);
    }
    // d = conj(r)·q: tan(θ/2) = |vec d| / |w d|.
    const double dw = r.w * q.w + r.x * q.x + r.y * q.y + r.z * q.z;
    const double dx = r.w * q.x - r.x * q.w - r.y * q.z + r.z * q.y;
    const double dy = r.w * q.y + r.x * q.z - r.y * q.w - r.z * q.x;
    const double dz = r.w * q.z - r.x * q.y + r.y * q.x - r.z * q.w;
    const double v2 = dx * dx + dy * dy + dz * dz;
    const double w2 = dw * dw;
    if (w2 == 0.0) return std::numeric_limits<double>::infinity();
    return v2 / w2;
}

// The same against the reference rotation of sample k.
double error_tan2(const Problem& p, std::size_t k, const double* f) {
    return error_tan2(p, p.ref[k], f);
}

// The rotation angle (radians, [0, π]) for an error_tan2 value.
double angle_of_tan2(double tan2) {
    if (!(tan2 < std::numeric_limits<double>::infinity())) return kPi;
    return 2.0 * std::atan(std::sqrt(tan2));
}

// ---- validation and setup -------------------------------------------------------------------------

void check_times(const std::vector<double>& times) {
    if (times.empty()) throw InvalidArgument("times: at least one sample is required");
    for (std::size_t k = 0; k < times.size(); ++k) {
        if (!std::isfinite(times[k]))
            throw InvalidArgument("times[" + std::to_string(k) + "]: non-finite value");
        if (k > 0 && !(times[k] > times[k - 1]))
            throw InvalidArgument("times[" + std::to_string(k) + "]: not increasing");
        // Blender stores frames as float32: two samples on one float32 frame cannot both be keys.
        if (k > 0 && !(f32(times[k]) > f32(times[k - 1])))
            throw InvalidArgument("times[" + std::to_string(k) + "]: same float32 frame as times[" +
                                  std::to_string(k - 1) + "] (Blender stores frames as float32)");
        if (!std::isfinite(f32(times[k])))
            throw InvalidArgument("times[" + std::to_string(k) + "]: beyond float32 range");
    }
}

void check_tolerance(double tolerance) {
    if (!std::isfinite(tolerance) || tolerance < 0.0)
        throw InvalidArgument("tolerance: must be finite and >= 0 radians, got " +
                              std::to_string(tolerance));
}

// Discontinuities between consecutive samples (see Problem::breaks) and, when the between-samples
// guard will run (`guard`), the step tangents.
void compute_breaks(Problem& p, bool guard) {
    p.breaks.assign(p.n, 0);
    for (std::size_t k = 1; k < p.n; ++k) {
        const double* a = p.row(k - 1);
        const double* b = p.row(k);
        bool jump = false;
        if (p.kind == Kind::QUAT) {
            jump = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] < 0.0;
        } else {
            for (int c = 0; c < 3; ++c) jump = jump || std::fabs(b[c] - a[c]) > kPi;
        }
        p.breaks[k] = p.breaks[k - 1] + (jump ? 1 : 0);
    }
    p.step_tan.assign(p.n, 0.0);
    for (std::size_t k = 0; guard && k + 1 < p.n; ++k)
        p.step_tan[k] = std::tan(0.5 * kBetweenStep * angle_between(p.ref[k], p.ref[k + 1]));
}

// Slopes for default tangents: central differences inside, one-sided at the ends and next to a
// discontinuity (which no tangent should see).
void compute_slopes(Problem& p) {
    p.slope.assign(p.n * p.C, 0.0);
    if (p.n < 2) return;
    for (std::size_t k = 0; k < p.n; ++k) {
        std::size_t a = k > 0 && p.breaks[k] == p.breaks[k - 1] ? k - 1 : k;
        std::size_t b = k + 1 < p.n && p.breaks[k + 1] == p.breaks[k] ? k + 1 : k;
        const double dt = p.t[b] - p.t[a];
        for (int c = 0; c < p.C; ++c)
            p.slope[k * p.C + c] = dt > 0.0 ? (p.y[b * p.C + c] - p.y[a * p.C + c]) / dt : 0.0;
    }
}

// guard: the between-samples guard will run (BEZIER), so compute what it needs.
Problem make_quat_problem(const std::vector<double>& times, const std::vector<Quat>& quats,
                          bool guard) {
    check_times(times);
    if (quats.size() != times.size())
        throw InvalidArgument("quats: " + std::to_string(quats.size()) +
                              " quaternions for " + std::to_string(times.size()) + " times");
    Problem p;
    p.kind = Kind::QUAT;
    p.C = 4;
    p.n = times.size();
    p.t.resize(p.n);
    p.y.resize(p.n * 4);
    p.ref.resize(p.n);
    p.unit.assign(p.n * 4, 0.0);
    p.norm2.assign(p.n, 0.0);
    for (std::size_t k = 0; k < p.n; ++k) {
        const std::string problem = nonzero_problem(quats[k]);
        if (!problem.empty())
            throw InvalidArgument("quats[" + std::to_string(k) + "]: " + problem);
        p.t[k] = f32(times[k]);
        const Quat& q = quats[k];
        const double v[4] = {q.w, q.x, q.y, q.z};
        const double len = norm(q);
        p.ref[k] = Quat(q.w / len, q.x / len, q.y / len, q.z / len);
        const double u[4] = {v[0] / len, v[1] / len, v[2] / len, v[3] / len};
        p.norm2[k] = len * len;
        for (int a = 0; a < 4; ++a) {
            p.y[k * 4 + a] = v[a];
            p.unit[k * 4 + a] = u[a];
        }
    }
    compute_breaks(p, guard);
    compute_slopes(p);
    return p;
}

Problem make_euler_problem(const std::vector<double>& times, const std::vector<Vec3>& angles,
                           EulerOrder order) {  // Euler fits are always guarded
    check_times(times);
    if (angles.size() != times.size())
        throw InvalidArgument("angles: " + std::to_string(angles.size()) + " triples for " +
                              std::to_string(times.size()) + " times");
    Problem p;
    p.kind = Kind::EULER;
    p.C = 3;
    p.order = order;
    const std::string name = euler_order_name(order);  // "XYZ": X applied first
    p.axis_first = name[0] - 'X';
    p.axis_mid = name[1] - 'X';
    p.axis_last = name[2] - 'X';
    // Sign of the triple product e_last · (e_mid × e_first): +1 for cyclic (last, mid, first).
    const int perm = (p.axis_mid - p.axis_last + 3) % 3 == 1 ? 1 : -1;
    p.n = times.size();
    p.t.resize(p.n);
    p.y.resize(p.n * 3);
    p.ref.resize(p.n);
    p.gimbal.assign(p.n, 0.0);
    for (std::size_t k = 0; k < p.n; ++k) {
        const std::string problem = finite_problem(angles[k]);
        if (!problem.empty())
            throw InvalidArgument("angles[" + std::to_string(k) + "]: " + problem);
        p.t[k] = f32(times[k]);
        for (int a = 0; a < 3; ++a) p.y[k * 3 + a] = angles[k][a];
        p.ref[k] = euler_to_quat(angles[k], order);
        // The rotation error of small angle errors δ is Σ δ_a·u_a with unit world axes u_a; their
        // Gram matrix is the identity except u_first·u_last = ±sin(middle angle).
        p.gimbal[k] = perm * std::sin(angles[k][p.axis_mid]);
    }
    compute_breaks(p, true);
    compute_slopes(p);
    return p;
}

// ---- small dense SPD solve ------------------------------------------------------------------------

// Solves H·x = g (H symmetric positive definite, dim ≤ 8) by Cholesky; H and g are overwritten.
// A non-positive pivot (degenerate data) is lifted to a tiny positive value, so a solution always
// comes back; the fit's quality is judged by the error test anyway.
void solve_spd(double* H, double* g, int dim) {
    for (int j = 0; j < dim; ++j) {
        double d = H[j * dim + j];
        for (int k = 0; k < j; ++k) d -= H[j * dim + k] * H[j * dim + k];
        if (!(d > 1e-300)) d = 1e-300;
        const double L = std::sqrt(d);
        H[j * dim + j] = L;
        for (int i = j + 1; i < dim; ++i) {
            double s = H[i * dim + j];
            for (int k = 0; k < j; ++k) s -= H[i * dim + k] * H[j * dim + k];
            H[i * dim + j] = s / L;
        }
    }
    for (int i = 0; i < dim; ++i) {
        double s = g[i];
        for (int k = 0; k < i; ++k) s -= H[i * dim + k] * g[k];
        g[i] = s / H[i * dim + i];
    }
    for (int i = dim - 1; i >= 0; --i) {
        double s = g[i];
        for (int k = i + 1; k < dim; ++k) s -= H[k * dim + i] * g[k];
        g[i] = s / H[i * dim + i];
    }
}

// ---- segment fitting -----------------------------------------------------------------------------

// The state of a reduction in progress: per channel its keys, the fitted values at every sample
// (F, used as the "other channels" when channels are fitted one by one) and, per segment start, the
// two inner Bezier control values.
struct State {
    std::vector<double> F;                           // n·C fitted values
    std::vector<std::vector<std::size_t>> keys;      // per channel
    std::vector<double> h1, h2;                      // n·C: control values of the segment starting at i
    std::vector<unsigned char> exact_param;          // n·C: segment refitted with Blender's parameter
};

class Fitter {
public:
    Fitter(const Problem& p, KeyInterpolation ipo, State& s) : p_(p), ipo_(ipo), s_(s) {
        buf_.resize(p.n * p.C);
        u_.resize(p.n);
        w_.resize(p.n);
        err_.resize(p.n);
    }

    // Fits channels `chans` (count nc) on [i, j] with the other channels at their current F and tests
    // every sample strictly inside against tan²(θ/2) ≤ limit. On success (or when `force`) the fit is
    // committed: F, h1/h2 of segment i. exact_param: use Blender's frame→parameter map for the
    // float32 handle frames instead of the ideal linear one. Returns whether the test passed.
    bool fit(std::size_t i, std::size_t j, const int* chans, int nc, double limit, bool force,
             bool exact_param = false) {
        const int C = p_.C;
        if (!force && j - i >= 2 && p_.breaks[j] != p_.breaks[i]) return false;
        const double ti = p_.t[i], tj = p_.t[j], d = tj - ti;
        // Parameters of the interior samples.
        for (std::size_t k = i + 1; k < j; ++k) u_[k] = (p_.t[k] - ti) / d;
        if (exact_param && ipo_ == KeyInterpolation::BEZIER) {
            float hx[2];
            handle_frames(i, j, hx);
            for (std::size_t k = i + 1; k < j; ++k) {
                const float r = blender_bezier_parameter(float(p_.t[k]), float(ti), hx[0], hx[1],
                                                         float(tj));
                if (r >= 0.0f) u_[k] = r;
            }
        }
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
            ok = false;
            double kappa = 4.0;  // quaternion metric: radial direction free
            for (int attempt = 0; attempt < 2 && !ok; ++attempt) {
                if (attempt == 1) {
                    // The norm dipped: refit with radial errors weighted.
                    if (p_.kind != Kind::QUAT || !between_failed_) break;
                    kappa = 4.0 - kRadialWeight;
                }
                for (std::size_t k = i + 1; k < j; ++k) w_[k] = 1.0;
                const int iterations = nc == 1 ? kReweightIterationsSingle : kReweightIterations;
                for (int it = 0; it <= iterations; ++it) {
                    solve_handles(i, j, chans, nc, kappa, p1, p2);
                    const double worst = evaluate(
                        i, j, chans, nc, p1, p2, limit,
                        force ? std::numeric_limits<double>::infinity() : kHopeless * limit);
                    if (worst <= limit) {
                        ok = true;
                        break;
                    }
                    // Reweighting cannot fix the norm, nor hopeless segments (far over the limit).
                    if (between_failed_ || (!force && worst > kHopeless * limit)) break;
                    if (it == iterations) break;
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
        }
        if (ok || force) commit(i, j, chans, nc, p1, p2, exact_param);
        return ok;
    }

    // Handle frames of segment [i, j] as Blender stores them (float32), at 1/3 and 2/3.
    void handle_frames(std::size_t i, std::size_t j, float hx[2]) const {
        const double ti = p_.t[i], tj = p_.t[j], d = tj - ti;
        hx[0] = float(ti + d / 3.0);
        hx[1] = float(tj - d / 3.0);
    }

private:
    // Basis of the cubic Bezier at u.
    static void bernstein(double u, double b[4]) {
        const double v = 1.0 - u;
        b[0] = v * v * v;
        b[1] = 3.0 * v * v * u;
        b[2] = 3.0 * v * u * u;
        b[3] = u * u * u;
    }

    // Weighted least squares for the inner control values: minimize
    //   Σ_k w_k·e_kᵀ M_k e_k + λ·|p − p_default|²,  e_k = fitted − data at sample k
    // over p = (p1, p2) of the fitted channels (others fixed at F). λ is tiny: it only settles the
    // directions the data leave free (few samples; the radial direction of quaternions).
    void solve_handles(std::size_t i, std::size_t j, const int* chans, int nc, double kappa,
                       double* p1, double* p2) {
        if (p_.C == 4 && nc == 4) return solve_handles_t<4, 4>(i, j, chans, kappa, p1, p2);
        if (p_.C == 4 && nc == 1) return solve_handles_t<4, 1>(i, j, chans, kappa, p1, p2);
        if (p_.C == 3 && nc == 3) return solve_handles_t<3, 3>(i, j, chans, kappa, p1, p2);
        return solve_handles_t<3, 1>(i, j, chans, kappa, p1, p2);
    }

    // Euler metric M_k (see Problem): row `row` times e, and the entry M_k[row][col].
    double euler_metric_times(std::size_t k, int row, const double* e) const {
        if (row == p_.axis_first) return e[row] + p_.gimbal[k] * e[p_.axis_last];
        if (row == p_.axis_last) return e[row] + p_.gimbal[k] * e[p_.axis_first];
        return e[row];
    }
    double euler_metric_entry(std::size_t k, int row, int col) const {
        if (row == col) return 1.0;
        if ((row == p_.axis_first && col == p_.axis_last) ||
            (row == p_.axis_last && col == p_.axis_first))
            return p_.gimbal[k];
        return 0.0;
    }

    // solve_handles for C channels of which NC are fitted (NC == C: all, in order).
    template <int C, int NC>
    void solve_handles_t(std::size_t i, std::size_t j, const int* chans, double kappa,
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
            double b[4];
            bernstein(u_[k], b);
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
                // M = (4·I − κ·ûûᵀ)/|q|², with û·e and 1/|q|² computed once per sample.
                const double* u = &p_.unit[k * 4];
                const double inv = 1.0 / p_.norm2[k];
                const double ue = u[0] * e0[0] + u[1] * e0[1] + u[2] * e0[2] + u[3] * e0[3];
                for (int a = 0; a < NC; ++a) {
                    const double ua = u[ch[a]];
                    const double Me = inv * (4.0 * e0[ch[a]] - kappa * ua * ue);
                    g[0][a] -= w1 * Me;
                    g[1][a] -= w2 * Me;
                    for (int bb = 0; bb <= a; ++bb) {
                        const double m = inv * ((a == bb ? 4.0 : 0.0) - kappa * ua * u[ch[bb]]);
                        A[0][a][bb] += s11 * m;
                        A[1][a][bb] += s12 * m;
                        A[2][a][bb] += s22 * m;
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
        solve_spd(H, rhs, dim);
        for (int a = 0; a < NC; ++a) {
            p1[a] = rhs[a];
            p2[a] = rhs[NC + a];
        }
    }

    // Fitted values of the channels at the interior samples (into buf_), their tan²(θ/2) errors (into
    // err_) and the largest.
    // Between samples the fit is guarded too (quaternion BEZIER and every Euler fit): midway
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
    double evaluate(std::size_t i, std::size_t j, const int* chans, int nc, const double* p1,
                    const double* p2, double limit,
                    double give_up = std::numeric_limits<double>::infinity()) {
        const int C = p_.C;
        const bool quat_bezier = p_.kind == Kind::QUAT && ipo_ == KeyInterpolation::BEZIER;
        const bool guard = quat_bezier || p_.kind == Kind::EULER;
        between_failed_ = false;
        double worst = 0.0;
        for (std::size_t k = i + 1; k < j; ++k) {
            double* f = &buf_[k * C];
            for (int c = 0; c < C; ++c) f[c] = s_.F[k * C + c];
            if (ipo_ == KeyInterpolation::LINEAR) {
                const double u = u_[k];
                for (int a = 0; a < nc; ++a) {
                    const int c = chans[a];
                    f[c] = p_.y[i * C + c] + (p_.y[j * C + c] - p_.y[i * C + c]) * u;
                }
            } else {
                bezier_values(i, j, chans, nc, p1, p2, u_[k], f);
            }
            const double e = error_tan2(p_, k, f);
            err_[k] = e;
            worst = std::max(worst, e);
            if (worst > give_up) return worst;  // the caller rejects the fit without looking further
            if (quat_bezier && !norm_ok(f, p_.norm2[k])) {
                between_failed_ = true;
                return std::numeric_limits<double>::infinity();
            }
        }
        if (guard && (worst <= limit || give_up == std::numeric_limits<double>::infinity())) {
            // tan of half the allowed angle: tan(a + b) = (tan a + tan b)/(1 − tan a·tan b).
            const double tan_fit = std::tan(kBetweenFactor * std::atan(std::sqrt(limit)));
            double prev_u = 0.0;
            for (std::size_t k = i; k < j; ++k) {
                const double next_u = k + 1 == j ? 1.0 : u_[k + 1];
                const double u = 0.5 * (prev_u + next_u);
                prev_u = next_u;
                double f[kMaxChannels], mean[kMaxChannels];
                for (int c = 0; c < C; ++c) {
                    f[c] = 0.5 * (s_.F[k * C + c] + s_.F[(k + 1) * C + c]);
                    mean[c] = 0.5 * (p_.y[k * C + c] + p_.y[(k + 1) * C + c]);
                }
                if (ipo_ == KeyInterpolation::LINEAR) {
                    for (int a = 0; a < nc; ++a) {
                        const int c = chans[a];
                        f[c] = p_.y[i * C + c] + (p_.y[j * C + c] - p_.y[i * C + c]) * u;
                    }
                } else {
                    bezier_values(i, j, chans, nc, p1, p2, u, f);
                }
                if (quat_bezier && !norm_ok(f, std::min(p_.norm2[k], p_.norm2[k + 1]))) {
                    between_failed_ = true;
                    return std::numeric_limits<double>::infinity();
                }
                const Quat ref = p_.kind == Kind::QUAT ? Quat(mean[0], mean[1], mean[2], mean[3])
                                                       : euler_rotation(p_, mean);
                const double denom = 1.0 - tan_fit * p_.step_tan[k];
                const double t = (tan_fit + p_.step_tan[k]) / denom;
                const double between_limit =
                    denom > 0.0 ? t * t : std::numeric_limits<double>::infinity();
                if (!(error_tan2(p_, ref, f) <= between_limit)) {
                    between_failed_ = true;
                    return std::numeric_limits<double>::infinity();
                }
            }
        }
        return worst;
    }

    // The fitted channels' Bezier values at parameter u, written into f.
    void bezier_values(std::size_t i, std::size_t j, const int* chans, int nc, const double* p1,
                       const double* p2, double u, double* f) const {
        const int C = p_.C;
        double b[4];
        bernstein(u, b);
        for (int a = 0; a < nc; ++a) {
            const int c = chans[a];
            f[c] = b[0] * p_.y[i * C + c] + b[1] * p1[a] + b[2] * p2[a] + b[3] * p_.y[j * C + c];
        }
    }

    // |f|² ≥ (kMinNormRatio)²·norm2.
    static bool norm_ok(const double* f, double norm2) {
        const double f2 = f[0] * f[0] + f[1] * f[1] + f[2] * f[2] + f[3] * f[3];
        return f2 >= kMinNormRatio * kMinNormRatio * norm2;
    }

    void commit(std::size_t i, std::size_t j, const int* chans, int nc, const double* p1,
                const double* p2, bool exact_param) {
        const int C = p_.C;
        for (int a = 0; a < nc; ++a) {
            const int c = chans[a];
            for (std::size_t k = i + 1; k < j; ++k) s_.F[k * C + c] = buf_[k * C + c];
            s_.F[i * C + c] = p_.y[i * C + c];
            s_.F[j * C + c] = p_.y[j * C + c];
            s_.h1[i * C + c] = p1[a];
            s_.h2[i * C + c] = p2[a];
            s_.exact_param[i * C + c] = exact_param ? 1 : 0;
        }
    }

    const Problem& p_;
    KeyInterpolation ipo_;
    State& s_;
    std::vector<double> buf_, u_, w_, err_;
    bool between_failed_ = false;  // the last evaluate() failed a between-samples guard
};

// ---- key selection ---------------------------------------------------------------------------------

// Keys for the channels `chans` (shared), fitted against the other channels' current F, every sample
// within tan²(θ/2) ≤ limit. Greedy: from key i the farthest feasible end, bracketed around the
// previous segment's length (growing or shrinking by doubling steps) and then pinned down by binary
// search; then one pass that drops a key wherever the segment joining its neighbours passes. A probe
// that passes commits its fit, and the ends only grow, so the chosen segment's fit is the one held.
std::vector<std::size_t> select_keys(const Problem& p, Fitter& fitter, const int* chans, int nc,
                                     double limit) {
    const std::size_t n = p.n;
    std::vector<std::size_t> keys{0};
    if (n == 1) return keys;
    auto probe = [&](std::size_t i, std::size_t j) {
        return fitter.fit(i, j, chans, nc, limit, false);
    };
    std::size_t i = 0, last_len = 2;
    while (i < n - 1) {
        std::size_t good = i + 1, bad = kNone;  // good: feasible (committed unless i + 1)
        const std::size_t guess = i + std::min(std::max<std::size_t>(last_len, 2), n - 1 - i);
        std::size_t step = std::max<std::size_t>(1, last_len / 4);
        if (guess > i + 1) {
            if (probe(i, guess)) {
                good = guess;
                while (good < n - 1) {
                    const std::size_t j = std::min(good + step, n - 1);
                    if (!probe(i, j)) {
                        bad = j;
                        break;
                    }
                    good = j;
                    step *= 2;
                }
            } else {
                bad = guess;
                while (bad > i + 2) {
                    const std::size_t j = bad > i + 1 + step ? bad - step : i + 1;
                    if (j == i + 1) break;
                    if (probe(i, j)) {
                        good = j;
                        break;
                    }
                    bad = j;
                    step *= 2;
                }
            }
            if (bad != kNone) {
                while (bad - good > 1) {
                    const std::size_t mid = good + (bad - good) / 2;
                    if (probe(i, mid)) {
                        good = mid;
                    } else {
                        bad = mid;
                    }
                }
            }
        }
        if (good == i + 1) fitter.fit(i, good, chans, nc, limit, true);
        keys.push_back(good);
        last_len = good - i;
        i = good;
    }
    // Removal pass: join neighbours where one segment suffices. A failed probe changes nothing, so
    // the fits already committed stay valid.
    std::vector<std::size_t> kept{keys[0]};
    for (std::size_t a = 1; a + 1 < keys.size(); ++a) {
        if (probe(kept.back(), keys[a + 1])) continue;
        kept.push_back(keys[a]);
    }
    kept.push_back(keys.back());
    return kept;
}

// ---- result assembly, verification and repair ----------------------------------------------------

ReducedChannel make_channel(const Problem& p, const State& s, int c, KeyInterpolation ipo) {
    ReducedChannel ch;
    const std::vector<std::size_t>& keys = s.keys[c];
    const std::size_t K = keys.size();
    ch.indices = keys;
    ch.frames.resize(K);
    ch.values.resize(K);
    for (std::size_t a = 0; a < K; ++a) {
        ch.frames[a] = p.t[keys[a]];
        ch.values[a] = f32(p.y[keys[a] * p.C + c]);
    }
    if (ipo == KeyInterpolation::BEZIER) {
        ch.handle_left.assign(2 * K, 0.0);
        ch.handle_right.assign(2 * K, 0.0);
        for (std::size_t a = 0; a + 1 < K; ++a) {
            const std::size_t i = keys[a], j = keys[a + 1];
            const double d = p.t[j] - p.t[i];
            ch.handle_right[2 * a] = f32(p.t[i] + d / 3.0);
            ch.handle_right[2 * a + 1] = f32(s.h1[i * p.C + c]);
            ch.handle_left[2 * (a + 1)] = f32(p.t[j] - d / 3.0);
            ch.handle_left[2 * (a + 1) + 1] = f32(s.h2[i * p.C + c]);
        }
        // Outer handles mirror the inner ones (they only shape extrapolation, which is constant).
        if (K == 1) {
            ch.handle_left[0] = f32(ch.frames[0] - 1.0);
            ch.handle_left[1] = ch.values[0];
            ch.handle_right[0] = f32(ch.frames[0] + 1.0);
            ch.handle_right[1] = ch.values[0];
        } else {
            ch.handle_left[0] = f32(2.0 * ch.frames[0] - ch.handle_right[0]);
            ch.handle_left[1] = f32(2.0 * ch.values[0] - ch.handle_right[1]);
            const std::size_t L = K - 1;
            ch.handle_right[2 * L] = f32(2.0 * ch.frames[L] - ch.handle_left[2 * L]);
            ch.handle_right[2 * L + 1] = f32(2.0 * ch.values[L] - ch.handle_left[2 * L + 1]);
        }
    }
    return ch;
}

// Errors (tan²(θ/2)) of every sample under Blender's evaluation of the current keys. Channels with
// the same keys as the previous one share its Bezier parameters.
void emulate_errors(const Problem& p, const std::vector<ReducedChannel>& chans,
                    KeyInterpolation ipo, std::vector<double>& err) {
    const int C = p.C;
    std::vector<double> vals(p.n * C), col;
    std::vector<float> params;
    for (int c = 0; c < C; ++c) {
        const bool reuse = c > 0 && chans[c].indices == chans[c - 1].indices;
        blender_evaluate_sorted(chans[c], ipo, p.t, col, &params, reuse);
        for (std::size_t k = 0; k < p.n; ++k) vals[k * C + c] = col[k];
    }
    err.resize(p.n);
    for (std::size_t k = 0; k < p.n; ++k) {
        double* f = &vals[k * C];
        // Blender's normalize_qt turns an exactly zero quaternion into (0, 1, 0, 0).
        if (p.kind == Kind::QUAT && f[0] == 0.0 && f[1] == 0.0 && f[2] == 0.0 && f[3] == 0.0)
            f[1] = 1.0;
        err[k] = error_tan2(p, k, f);
    }
}

// Index a with keys[a] < k < keys[a+1], or kNone when k is a key.
std::size_t segment_of(const std::vector<std::size_t>& keys, std::size_t k) {
    const auto it = std::upper_bound(keys.begin(), keys.end(), k);
    const std::size_t b = static_cast<std::size_t>(it - keys.begin());
    if (b == 0 || b == keys.size()) return kNone;
    if (keys[b - 1] == k) return kNone;
    return b - 1;
}

// Single-channel contribution at sample k: the error if only channel c took its evaluated value.
double channel_contribution(const Problem& p, std::size_t k, int c, double value) {
    double f[kMaxChannels];
    for (int a = 0; a < p.C; ++a) f[a] = p.y[k * p.C + a];
    f[c] = value;
    return error_tan2(p, k, f);
}

// Evaluates every sample as Blender would; each segment holding a failing sample is first refitted
// with Blender's exact frame→parameter map (BEZIER), then split at its worst failing sample, until
// every sample passes or every failing sample sits on a key of every channel (float32 floor).
// `groups` lists the channel sets that share keys (one group of all channels when synchronized).
std::vector<ReducedChannel> verify_and_repair(const Problem& p, State& s, Fitter& fitter,
                                              KeyInterpolation ipo, double verify_tan2,
                                              double fit_limit,
                                              const std::vector<std::vector<int>>& groups,
                                              double& max_error) {
    const int C = p.C;
    std::vector<ReducedChannel> chans(C);
    std::vector<double> err;
    for (;;) {
        for (int c = 0; c < C; ++c) chans[c] = make_channel(p, s, c, ipo);
        emulate_errors(p, chans, ipo, err);
        // Worst failing sample per (group, segment).
        struct Fix {
            std::size_t group, seg, sample;
            double err;
        };
        std::vector<Fix> fixes;
        for (std::size_t k = 0; k < p.n; ++k) {
            if (!(err[k] > verify_tan2)) continue;
            // The group to repair: the one whose evaluated channels contribute most at k.
            std::size_t best_group = kNone, best_seg = kNone;
            double best = -1.0;
            for (std::size_t g = 0; g < groups.size(); ++g) {
                const int c0 = groups[g][0];
                const std::size_t seg = segment_of(s.keys[c0], k);
                if (seg == kNone) continue;
                double contrib;
                if (groups[g].size() == static_cast<std::size_t>(C)) {
                    contrib = err[k];
                } else {
                    contrib = channel_contribution(
                        p, k, c0, blender_evaluate(chans[c0], ipo, float(p.t[k])));
                }
                if (contrib > best) {
                    best = contrib;
                    best_group = g;
                    best_seg = seg;
                }
            }
            if (best_group == kNone) continue;  // on a key everywhere: nothing left to do
            bool merged = false;
            for (Fix& f : fixes) {
                if (f.group == best_group && f.seg == best_seg) {
                    if (err[k] > f.err) {
                        f.err = err[k];
                        f.sample = k;
                    }
                    merged = true;
                    break;
                }
            }
            if (!merged) fixes.push_back({best_group, best_seg, k, err[k]});
        }
        if (fixes.empty()) break;
        // Splits change key lists: apply per group from the last segment backwards.
        std::sort(fixes.begin(), fixes.end(), [](const Fix& a, const Fix& b) {
            return a.group != b.group ? a.group < b.group : a.seg > b.seg;
        });
        for (const Fix& f : fixes) {
            const std::vector<int>& grp = groups[f.group];
            std::vector<std::size_t>& keys = s.keys[grp[0]];
            const std::size_t i = keys[f.seg], j = keys[f.seg + 1];
            const int nc = static_cast<int>(grp.size());
            if (ipo == KeyInterpolation::BEZIER && !s.exact_param[i * C + grp[0]]) {
                fitter.fit(i, j, grp.data(), nc, fit_limit, true, true);
                continue;
            }
            const std::size_t m = f.sample;
            fitter.fit(i, m, grp.data(), nc, fit_limit, true);
            fitter.fit(m, j, grp.data(), nc, fit_limit, true);
            for (int c : grp) {
                std::vector<std::size_t>& kc = s.keys[c];
                kc.insert(std::upper_bound(kc.begin(), kc.end(), i), m);
            }
        }
    }
    max_error = 0.0;
    for (std::size_t k = 0; k < p.n; ++k) max_error = std::max(max_error, angle_of_tan2(err[k]));
    return chans;
}

State empty_state(const Problem& p) {
    State s;
    s.F = p.y;
    s.keys.assign(p.C, {});
    s.h1.assign(p.n * p.C, 0.0);
    s.h2.assign(p.n * p.C, 0.0);
    s.exact_param.assign(p.n * p.C, 0);
    return s;
}

double tan2_half(double angle) {
    const double t = std::tan(0.5 * angle);
    return t * t;
}

// Blender keeps key values as float32: a sample whose float32 form is a different rotation (a
// component beyond ±3.4e38, a quaternion whose components all underflow, an angle too large for
// float32 to resolve) cannot be kept within any bound, so it is refused up front. Allowed: the
// tolerance, and never less than 1e-6 rad (float32 rounding of ordinary values is ~1e-7 rad).
void check_float32_storage(const Problem& p, double tolerance) {
    const double allowed = std::max(tolerance, 1e-6);
    const char* name = p.kind == Kind::QUAT ? "quats[" : "angles[";
    for (std::size_t k = 0; k < p.n; ++k) {
        const double* y = p.row(k);
        double v[4] = {0.0, 0.0, 0.0, 0.0};
        for (int c = 0; c < p.C; ++c) {
            v[c] = f32(y[c]);
            if (!std::isfinite(v[c]))
                throw InvalidArgument(name + std::to_string(k) + "]: " + std::to_string(y[c]) +
                                      " is beyond float32 range (Blender stores keys as float32)");
        }
        Quat stored;
        if (p.kind == Kind::QUAT) {
            stored = Quat(v[0], v[1], v[2], v[3]);
            if (!nonzero_problem(stored).empty())
                throw InvalidArgument(name + std::to_string(k) +
                                      "]: every component underflows float32 (Blender stores keys as float32)");
        } else {
            stored = euler_to_quat(Vec3(v[0], v[1], v[2]), p.order);
        }
        const double moved = angle_between(p.ref[k], stored);
        if (moved > allowed)
            throw InvalidArgument(name + std::to_string(k) + "]: storing it as float32 (as Blender does) turns it by " +
                                  std::to_string(moved) + " rad, more than the tolerance allows");
    }
}

ReducedKeys reduce(const Problem& p, double tolerance, KeyInterpolation ipo, bool synchronized) {
    check_tolerance(tolerance);
    check_float32_storage(p, tolerance);
    const int C = p.C;
    // Verification threshold (margin for Blender's own float32 rotation building) and fit target.
    const double verify_angle =
        tolerance > 2.0 * kVerifyMargin ? tolerance - kVerifyMargin : 0.5 * tolerance;
    const double fit_angle =
        verify_angle - std::min(kFitMarginAbs, kFitMarginRel * verify_angle);
    const double verify_tan2 = tan2_half(verify_angle);

    auto run = [&](bool sync) {
        State s = empty_state(p);
        Fitter fitter(p, ipo, s);
        std::vector<std::vector<int>> groups;
        if (tolerance == 0.0 || p.n <= 2) {
            // Every sample is a key (tolerance 0, or nothing to remove).
            std::vector<int> all(C);
            for (int c = 0; c < C; ++c) all[c] = c;
            groups.push_back(all);
            std::vector<std::size_t> keys(p.n);
            for (std::size_t k = 0; k < p.n; ++k) keys[k] = k;
            for (std::size_t a = 0; a + 1 < keys.size(); ++a)
                fitter.fit(keys[a], keys[a + 1], all.data(), C, 0.0, true);
            for (int c = 0; c < C; ++c) s.keys[c] = keys;
        } else if (sync) {
            std::vector<int> all(C);
            for (int c = 0; c < C; ++c) all[c] = c;
            groups.push_back(all);
            const std::vector<std::size_t> keys =
                select_keys(p, fitter, all.data(), C, tan2_half(fit_angle));
            for (int c = 0; c < C; ++c) s.keys[c] = keys;
        } else {
            // One channel after the other, each fitted against the already fitted ones (the rest
            // still exact) under a growing share of the tolerance; the last gets all of it. The
            // first channel (w for quaternions, the least costly in angle near identity) goes first.
            static const double kQuatShare[4] = {0.6, 0.75, 0.9, 1.0};
            static const double kEulerShare[3] = {0.7, 0.85, 1.0};
            for (int c = 0; c < C; ++c) {
                groups.push_back({c});
                const double share = C == 4 ? kQuatShare[c] : kEulerShare[c];
                s.keys[c] = select_keys(p, fitter, &c, 1, tan2_half(share * fit_angle));
            }
        }
        ReducedKeys out;
        out.interpolation = ipo;
        out.synchronized = sync;
        out.channels = verify_and_repair(p, s, fitter, ipo, verify_tan2, tan2_half(fit_angle),
                                         groups, out.max_error);
        // After a per-channel run the key sets may coincide; report what they are.
        if (!sync) {
            bool same = true;
            for (int c = 1; c < C; ++c) same = same && s.keys[c] == s.keys[0];
            out.synchronized = same;
        }
        return out;
    };

    ReducedKeys best = run(true);
    if (!synchronized && p.n > 2 && tolerance > 0.0) {
        ReducedKeys per_channel = run(false);
        if (per_channel.key_count() < best.key_count()) best = std::move(per_channel);
    }
    return best;
}

}  // namespace

ReducedKeys reduce_keys(const std::vector<double>& times, const std::vector<Quat>& quats,
                        double tolerance, KeyInterpolation interpolation, bool synchronized) {
    check_tolerance(tolerance);
    return reduce(make_quat_problem(times, quats, interpolation == KeyInterpolation::BEZIER),
                  tolerance, interpolation, synchronized);
}

ReducedKeys reduce_keys_euler(const std::vector<double>& times, const std::vector<Vec3>& angles,
                              EulerOrder order, double tolerance, KeyInterpolation interpolation,
                              bool synchronized) {
    check_tolerance(tolerance);
    return reduce(make_euler_problem(times, angles, order), tolerance, interpolation, synchronized);
}

}  // namespace quatcurve
