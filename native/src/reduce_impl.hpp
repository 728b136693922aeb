// Private to the key reducer: the problem in channel space, the tuning constants, and the
// interfaces between its stages. Nothing here is public API; from outside include
// quatcurve/reduce.hpp (the contract is stated there).
//
// The stages, in the order reduce.cpp runs them:
//   reduce_problem.cpp  admit the input (argument checks, float32 storage) and build the Problem:
//                       channel values, reference rotations, error metric, discontinuities, slopes;
//   reduce_fit.cpp      the Fitter: one segment of some channels — the LINEAR chord, or the Bezier
//                       inner control values by weighted least squares and reweighting, at the
//                       handle frames of kHandleFractions — and the exact error test at the samples
//                       (and between them);
//   reduce_select.cpp   key choice: greedy farthest feasible end, then key removal;
//   reduce_verify.cpp   the F-curves of the result, evaluated as Blender does (blender_eval.hpp),
//                       refitted or split until every sample passes.
// The small functions used in inner loops (error_tan2, euler_rotation, axis_angle_rotation) are
// inline here, so every stage computes them identically.
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>
#include <memory>
#include <vector>

#include "numbers.hpp"
#include "quatcurve/euler.hpp"
#include "quatcurve/quat.hpp"
#include "quatcurve/reduce.hpp"

namespace quatcurve::reduce_impl {

// ---- tuning constants ------------------------------------------------------------------------------

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
// (per-channel mode fits four times as many segments): three for a quaternion channel — on the
// motion-capture clips at 0.1° (reduce_keys_proved) 1.1 % and 0.9 % fewer keys than two for 8 %
// and 5 % more instructions; four gave 0.3 % and 0.1 % fewer again for 3 % and 1 % more — and two
// for an Euler or axis-angle channel (a third let Euler channels keyed apart near gimbal lock swing
// between samples further than fit_through_keys' proof allows: FitProof.EulerKeyAtGimbalLock…).
constexpr int kReweightIterations = 4;
constexpr int kReweightIterationsSingle = 2;
constexpr int kReweightIterationsQuatChannel = 3;
// A fit whose worst sample after reweighting round r (0: the plain least-squares fit) is above
// kHopeless[r] × the limit (in tan²(θ/2); 4 is twice the angle) is rejected without further rounds.
// Each round lowers the worst sample by less than the one before, and half of all rounds went to
// fits that failed in the end. Of the fits that passed after reweighting on the 100-bone SQUAD
// benchmark (synchronized), the worst after rounds 0 to 3 had reached 4.0, 2.2, 1.9, 1.2 × the
// limit: these bounds give up one of ~47,000 such fits (the greedy search then takes another end;
// the key counts of that benchmark and of the motion-capture clips stayed the same).
constexpr double kHopeless[kReweightIterations] = {4.0, 2.5, 1.75, 1.4};
using numbers::kPi;
// A synchronized key choice racing a per-channel result (reduce, select_keys' pace) gives up once its
// keys up to a sample outnumber kPaceSlack × the per-channel keys there per channel, plus
// kPaceExtra. On the motion-capture clips at 0.1° (reduce_keys_proved) no synchronized run beat the
// per-channel keys, and the synchronized runs took 17 % of the reduction's time; with the pace, the
// same keys in 10 % less time. On the 100-bone benchmark (bench_speed.py,
// proved) 1,921,997 → 1,908,926 keys in 16 % less time; a slack of 1.25 + 2 keys gave the keys
// of no pace.
constexpr double kPaceSlack = 1.1;
constexpr double kPaceExtra = 1.0;
// The rotation ignores a quaternion's scale (and an axis-angle axis's length), so the fit may let the
// 4-vector's (the axis's) norm drift — a cubic
// with varying norm bends the normalized path more freely, which saves many keys. It is kept free
// unless the norm would fall below kMinNormRatio of the sample's (checked at the samples and
// midway between them: near zero the direction swings between frames); such fits are redone with
// radial errors weighted kRadialWeight (tangential errors weigh 4).
constexpr double kRadialWeight = 0.25;
constexpr double kMinNormRatio = 0.5;
// The between-samples guard (Fitter::evaluate): midway between two samples the fit may depart from
// the dense input's own LINEAR evaluation by kBetweenFactor × the fit's angle + kBetweenStep × the
// rotation step between the two samples.
constexpr double kBetweenFactor = 2.0;
constexpr double kBetweenStep = 0.25;
// BEZIER handle frames, as fractions of the segment from its left key (a1) and from its right key
// (a2): first 1/3 and 1/3, where the frame is linear in the curve's parameter. A quaternion segment of
// more than kHandleFreeSamples samples inside that fails there is fitted again with each pair of
// kHandleFractions, in order, and the first that passes is kept: a short handle on one side lets the
// curve change speed near that key, as captured motion does where it starts or stops. a1 + a2 ≤ 1
// keeps the segment's frame monotone in its parameter, so Blender plays the handles as stored (no
// correction). A pair is tried only while the thirds' first fit is within kHandleFreeHopeless × the
// limit (tan²): on the motion-capture clips at 0.1° (reduce_keys_proved) 4 gave 13 % fewer keys, 16
// no more for 1.7× the time, 2 and 1.5 only 9 % and 5 %. (0.6, 0.4) and (0.4, 0.6) put both handles
// at one frame, the frame advancing 1.8 and 1.2 times its mean rate at the keys: with them there
// 4,073 → 3,991 keys for 6 % more time; (0.7, 0.3) and (0.3, 0.7) as well gave 3,960 for 15 % more
// again; (0.2, 0.2), (0.2, 1/3), (1/3, 0.2) (passing in 6 % of the cases) gave 1 % fewer for 11 %
// more, beside the five others alone. Those are not tried. Not for Euler and axis-angle channels (a live refit of Euler keys, SPLINE_C2 in
// tests/blender/test_everywhere.py, then ended at 0.065° on a 0.05° tolerance), nor below
// kHandleFreeMinTolerance (a mocap hip reduced at 0.001°, tests/blender/test_reduce.py, then stayed
// at 0.0011° after all the proof's rounds; with the thirds, whose frame→parameter map is linear, it
// is proved).
constexpr int kHandleFreeSamples = 3;
constexpr double kHandleFreeHopeless = 4.0;
// kHopeless for the fits at a pair of kHandleFractions: of those on the motion-capture clips at 0.1°
// (reduce_keys_proved), 1.7 % of the ones that passed had a plain fit above 1.5 × the limit, and six
// in seven failed; these bounds keep the same keys there for 9 % less time than kHopeless' (1.5 in
// every round: 6 keys more). On the 100-bone benchmark (bench_speed.py) 0.14 % more keys for 11 %
// less time.
constexpr double kHopelessOtherFrames[kReweightIterations] = {2.0, 1.75, 1.5, 1.3};
// intervals_may_pass: a segment fails once the Remez exchange's lower bound of the samples' relative
// distance outside their intervals exceeds 1 + kIntervalSlack (rounding of the intervals; the fit's
// own evaluation decides every segment that passes).
constexpr double kIntervalSlack = 1e-6;
constexpr double kHandleFreeMinTolerance = 0.01 * kPi / 180.0;
constexpr double kHandleFractions[][2] = {{0.5, 0.5}, {0.6, 0.4}, {0.4, 0.6}, {0.2, 0.5},
                                          {0.5, 0.2}, {1.0 / 3.0, 0.5}, {0.5, 1.0 / 3.0}};
constexpr int kHandleAlternatives = sizeof(kHandleFractions) / sizeof(kHandleFractions[0]);

// A handle's frame offset from its key in a segment of d frames, for the fraction a (the thirds
// divided, as Blender's own thirds are).
inline double handle_offset(double d, double a) { return a == 1.0 / 3.0 ? d / 3.0 : d * a; }

// The inner handle frames of a segment from frame ti to tj for the fractions a1, a2, as Blender stores
// them (float32). Where a1 + a2 = 1 both sit at one frame, and rounding must not cross them (Blender
// would then shorten both handles).
inline void segment_handle_frames(double ti, double tj, double a1, double a2, float hx[2]) {
    const double d = tj - ti;
    hx[0] = static_cast<float>(ti + handle_offset(d, a1));
    hx[1] = static_cast<float>(tj - handle_offset(d, a2));
    if (hx[0] > hx[1]) hx[1] = hx[0];
}

// x rounded to float32, as Blender stores it.
inline double f32(double x) { return static_cast<double>(static_cast<float>(x)); }

inline double tan2_half(double angle) {
    const double t = std::tan(0.5 * angle);
    return t * t;
}

// ---- the problem -----------------------------------------------------------------------------------

enum class Kind { QUAT, EULER, AXIS_ANGLE };

struct Problem {
    Kind kind = Kind::QUAT;
    int C = 4;                    // channels: w, x, y, z; X, Y, Z angles; or angle, axis x, y, z
    EulerOrder order = EulerOrder::XYZ;
    std::size_t n = 0;
    std::vector<double> t;        // float32 frames (as Blender keys and evaluates them)
    std::vector<double> y;        // n·C channel values as given
    std::vector<Quat> ref;        // reference rotation of each sample (unit)
    // The error metric M_k (angle² ≈ eᵀ·M_k·e for a small channel error e), computed on the fly:
    //   quaternions: M = (4·I − κ·ûûᵀ)/|q|² with û = q/|q|; κ = 4 projects out the radial direction
    //                (the rotation ignores scale), κ = 4 − kRadialWeight keeps a little of it;
    //   Euler:       M = Gram matrix of the three rotation axes = I except M[first][last] =
    //                M[last][first] = gimbal[k] = ±sin(middle angle);
    //   axis-angle:  block-diagonal, angle weight 1 and for the axis v (Blender normalizes it)
    //                (spin[k]/|v|²)·(I − v̂v̂ᵀ) + ρ·v̂v̂ᵀ with spin[k] = 4·sin²(a/2): for unit
    //                q = (cos a/2, sin(a/2)·v̂), ∂q/∂a = ½(−sin a/2, cos(a/2)·v̂) has length ½ and
    //                ∂q/∂v·δ = (0, sin(a/2)·(I − v̂v̂ᵀ)δ/|v|) is orthogonal to it (v̂ ⊥ (I − v̂v̂ᵀ)δ),
    //                and a rotation's angle is twice its unit quaternion's tangent length. The
    //                radial direction is free (ρ = 0) unless the norm dipped (ρ = kRadialWeight/|v|²);
    //                at a = 0 (mod 2π) the axis is free altogether.
    std::vector<double> unit;     // quaternions: n·4, û; axis-angle: n·4, (0, v̂)
    std::vector<double> norm2;    // quaternions: |q|² per sample; axis-angle: |v|²
    std::vector<double> spin;     // axis-angle: 4·sin²(a/2) per sample
    std::vector<double> gimbal;   // Euler: the off-diagonal term per sample
    std::vector<double> slope;    // n·C: finite-difference slope (default Bezier tangents)
    // breaks[k]: number of discontinuities between samples 0..k (a quaternion sign flip, an Euler
    // or axis-angle angle jump above π, an axis-angle axis turning by more than 90°). A segment may not span one: between the two samples Blender would pass
    // through a near-zero quaternion or spin, and a Bezier fit could hide that at the samples.
    std::vector<std::size_t> breaks;
    // step_tan[k] = tan(kBetweenStep/2 × the rotation angle between samples k and k+1), for the
    // between-samples guard.
    std::vector<double> step_tan;
    // Euler and axis-angle: mid_ref[k] = the rotation of the mean of samples k and k+1, the
    // between-samples guard's reference there (n − 1 entries; built once: every fit that passes
    // its samples evaluates it again, and it costs three sines and cosines). Quaternions take the
    // mean itself (no entries).
    std::vector<Quat> mid_ref;
    // Euler: the order's axes (first applied, middle, last) as indices into (X, Y, Z).
    int axis_first = 0, axis_mid = 1, axis_last = 2;
    // Key choice (fit_keys): forced[k] — sample k must be a key of every channel (the first and the
    // last always are); candidate[k] — sample k may become an inserted key (not within min_gap
    // frames of a forced key, where Blender would merge the two). Both empty: every sample is a
    // candidate and only the ends are forced.
    std::vector<unsigned char> forced, candidate;
    // A per-channel result may keep one key on a channel that one value meets at every sample
    // (flatten_channels): set where the keys are the whole result (not a piece joined to others)
    // and no sample but the ends is forced.
    bool single_key = false;

    const double* row(std::size_t k) const { return &y[k * C]; }
    bool is_forced(std::size_t k) const { return k == 0 || k + 1 == n || (!forced.empty() && forced[k]); }
    bool is_candidate(std::size_t k) const { return candidate.empty() || candidate[k]; }
};

// Rotation of Euler angles a (about X, Y, Z) for the problem's order: q_last·q_mid·q_first — the
// same product as euler_to_quat (euler.hpp), without its argument checks, for the inner loops.
inline Quat euler_rotation(const Problem& p, const double* a) {
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

// Rotation of axis-angle channels f = (angle, x, y, z) as Blender builds it (axis_angle_to_mat3):
// the axis normalized; an axis whose squared length is not above 1e-35 (normalize_v3_v3's float
// threshold) gives the identity.
inline Quat axis_angle_rotation(const double* f) {
    const double len2 = f[1] * f[1] + f[2] * f[2] + f[3] * f[3];
    if (!(len2 > 1e-35)) return Quat(1.0, 0.0, 0.0, 0.0);
    const double s = std::sin(0.5 * f[0]) / std::sqrt(len2);
    return Quat(std::cos(0.5 * f[0]), s * f[1], s * f[2], s * f[3]);
}

// d = conj(r)·q for the quaternion q = (w, x, y, z): the rotation from r to q, scaled by |r|·|q|.
// Linear in q, so the part of fixed channels can be kept and the rest added (Fitter::OtherChannels).
inline void relative_rotation(const Quat& r, const double* q, double d[4]) {
    d[0] = r.w * q[0] + r.x * q[1] + r.y * q[2] + r.z * q[3];
    d[1] = r.w * q[1] - r.x * q[0] - r.y * q[3] + r.z * q[2];
    d[2] = r.w * q[2] + r.x * q[3] - r.y * q[0] - r.z * q[1];
    d[3] = r.w * q[3] - r.x * q[2] + r.y * q[1] - r.z * q[0];
}

// tan²(θ/2) of the rotation angle θ of a relative rotation d (relative_rotation): |vec d|² / w d²;
// +inf when w d = 0 (180°, or a zero quaternion).
inline double tan2_of_relative(const double d[4]) {
    const double v2 = d[1] * d[1] + d[2] * d[2] + d[3] * d[3];
    const double w2 = d[0] * d[0];
    if (w2 == 0.0) return std::numeric_limits<double>::infinity();
    return v2 / w2;
}

// tan²(θ/2) of the rotation angle θ between the rotation r (any nonzero scale) and the channel
// values f (quaternion: f unnormalized, sign-invariant; Euler: the rotation of angles f; axis-angle:
// axis_angle_rotation). +inf when f is a zero quaternion or the rotations are 180° apart.
inline double error_tan2(const Problem& p, const Quat& r, const double* f) {
    Quat q;
    if (p.kind == Kind::QUAT) {
        q = Quat(f[0], f[1], f[2], f[3]);
    } else if (p.kind == Kind::AXIS_ANGLE) {
        q = axis_angle_rotation(f);
    } else {
        q = euler_rotation(p, f);
    }
    // d = conj(r)·q: tan(θ/2) = |vec d| / |w d|.
    const double qa[4] = {q.w, q.x, q.y, q.z};
    double d[4];
    relative_rotation(r, qa, d);
    return tan2_of_relative(d);
}

// The same against the reference rotation of sample k.
inline double error_tan2(const Problem& p, std::size_t k, const double* f) {
    return error_tan2(p, p.ref[k], f);
}

// The rotation angle (radians, [0, π]) for an error_tan2 value.
inline double angle_of_tan2(double tan2) {
    if (!(tan2 < std::numeric_limits<double>::infinity())) return kPi;
    return 2.0 * std::atan(std::sqrt(tan2));
}

// ---- minimax of two unknowns -----------------------------------------------------------------------

// Row r of a weighted Chebyshev problem in two unknowns (p1, p2): its residual is w·(g1·p1 + g2·p2 − t).
struct ChebyshevRow {
    double g1, g2, t, w;
};

// Whether the weighted Chebyshev problem of rows 0..n−1 (row(r, out) fills row r, in increasing order
// of a parameter u in (0, 1) with g1, g2 = 3u(1 − u)², 3u²(1 − u)) may have a solution whose largest
// |residual| is within cap. The rows' functions span u(1 − u)·(a line), a Haar system on (0, 1), so
// the discrete Remez exchange applies: the fit levelled on a reference of three rows (residuals
// σ·h, σ = +1, −1, +1) has |h| at most the optimum (de la Vallée Poussin), so false as soon as one
// reference's |h| exceeds cap; true once the levelled fit's largest residual is within cap, and
// wherever the exchange cannot decide (a reference row of weight 0, a singular or non-finite
// reference, a residual's largest at the reference already (rounding), kExchangeRounds reached).
// `ref`: the starting reference (row indices, increasing; any other start: true), left at the last one.
template <class Row>
bool chebyshev_may_meet(std::size_t n, const Row& row, std::size_t ref[3], double cap) {
    constexpr int kExchangeRounds = 16;
    if (!(ref[0] < ref[1] && ref[1] < ref[2] && ref[2] < n)) return true;
    for (int round = 0; round < kExchangeRounds; ++round) {
        // The reference's levelled fit: g·p − σ·h/w = t at its three rows.
        double M[3][4];
        for (int a = 0; a < 3; ++a) {
            ChebyshevRow r;
            row(ref[a], r);
            if (r.w == 0.0) return true;
            M[a][0] = r.g1;
            M[a][1] = r.g2;
            M[a][2] = (a == 1 ? 1.0 : -1.0) / r.w;
            M[a][3] = r.t;
        }
        // Cramer's rule: the determinant of columns (c0, c1, c2) of M.
        auto det = [&M](int c0, int c1, int c2) {
            return M[0][c0] * (M[1][c1] * M[2][c2] - M[2][c1] * M[1][c2]) -
                   M[1][c0] * (M[0][c1] * M[2][c2] - M[2][c1] * M[0][c2]) +
                   M[2][c0] * (M[0][c1] * M[1][c2] - M[1][c1] * M[0][c2]);
        };
        const double d = det(0, 1, 2);
        if (!(std::fabs(d) > 0.0) || !std::isfinite(d)) return true;
        const double p1 = det(3, 1, 2) / d, p2 = det(0, 3, 2) / d, h = det(0, 1, 3) / d;
        if (!std::isfinite(h)) return true;
        if (std::fabs(h) > cap) return false;
        // The row of the largest weighted residual.
        double worst = -1.0, signed_worst = 0.0;
        std::size_t kw = 0;
        for (std::size_t k = 0; k < n; ++k) {
            ChebyshevRow r;
            row(k, r);
            const double e = (r.g1 * p1 + r.g2 * p2 - r.t) * r.w;
            if (std::fabs(e) > worst) {
                worst = std::fabs(e);
                signed_worst = e;
                kw = k;
            }
        }
        if (worst <= cap) return true;
        if (kw == ref[0] || kw == ref[1] || kw == ref[2]) return true;
        // Exchange kw in, the signs still alternating (σ·h at the reference): among the four rows
        // in order, kw replaces a neighbour of its own sign, or else the reference's far end goes.
        std::size_t rows[4];
        bool up[4];
        int at = 0;
        while (at < 3 && ref[at] < kw) ++at;
        for (int a = 0, b = 0; a < 4; ++a) {
            if (a == at) {
                rows[a] = kw;
                up[a] = signed_worst > 0.0;
            } else {
                rows[a] = ref[b];
                up[a] = (b == 1 ? -h : h) > 0.0;
                ++b;
            }
        }
        const int drop = at > 0 && up[at - 1] == up[at]   ? at - 1
                         : at < 3 && up[at + 1] == up[at] ? at + 1
                         : at == 0                        ? 3
                                                          : 0;
        for (int a = 0, b = 0; a < 4; ++a)
            if (a != drop) ref[b++] = rows[a];
    }
    return true;
}

// ---- stage 1: admission and setup (reduce_problem.cpp) ---------------------------------------------

// "tolerance: must be finite and >= 0 radians" unless it is.
void check_tolerance(double tolerance);

// The Problem of quaternion samples; throws InvalidArgument naming times[k] / quats[k]. guard: the
// between-samples guard will run (BEZIER), so compute what it needs.
Problem make_quat_problem(const std::vector<double>& times, const std::vector<Quat>& quats,
                          bool guard);

// The Problem of Euler samples (always guarded); throws InvalidArgument naming times[k] / angles[k].
Problem make_euler_problem(const std::vector<double>& times, const std::vector<Vec3>& angles,
                           EulerOrder order);

// The Problem of axis-angle samples (angle, x, y, z; always guarded); throws InvalidArgument naming
// times[k] / values[k] (non-finite, zero-length axis).
Problem make_axis_angle_problem(const std::vector<double>& times, const std::vector<Vec4>& values);

// Refuses samples whose float32 form (as Blender stores keys) is another rotation.
void check_float32_storage(const Problem& p, double tolerance);

// Sets p.forced and p.candidate from the forced sample indices (increasing, within the samples;
// throws InvalidArgument naming forced[a] otherwise) and the minimum gap (frames, ≥ 0) between an
// inserted key and a forced one.
void set_forced_keys(Problem& p, const std::vector<std::size_t>& forced, double min_gap);

// ---- stage 2: fitting one segment (reduce_fit.cpp) -------------------------------------------------

// The state of a reduction in progress: per channel its keys, the fitted values at every sample
// (F, used as the "other channels" when channels are fitted one by one) and, per segment start, the
// two inner Bezier control values. F is read only by fits of fewer than all channels, and a run
// never mixes those with fits of all channels: a synchronized run keeps no F (it stays empty).
struct State {
    std::vector<double> F;                           // n·C fitted values (one-by-one runs)
    std::vector<std::vector<std::size_t>> keys;      // per channel
    std::vector<double> h1, h2;                      // n·C: control values of the segment starting at i
    std::vector<double> a1, a2;                      // n·C: its handle frames' fractions (kHandleFractions)
    std::vector<unsigned char> exact_param;          // n·C: segment refitted with Blender's parameter
};

// A State with no keys; for a run that fits channels one by one (one_by_one), F at the samples.
State empty_state(const Problem& p, bool one_by_one);

struct ParameterTable;  // reduce_fit.cpp

class Fitter {
public:
    // free_handle_frames: try kHandleFractions where the thirds fail (quaternion BEZIER only).
    Fitter(const Problem& p, KeyInterpolation ipo, State& s, bool free_handle_frames = false);

    // Fits channels `chans` (count nc) on [i, j] with the other channels at their current F and tests
    // every sample strictly inside against tan²(θ/2) ≤ limit. On success (or when `force`) the fit is
    // committed: F, h1/h2 of segment i. exact_param: use Blender's frame→parameter map for the
    // float32 handle frames instead of the ideal linear one. Returns whether the test passed.
    bool fit(std::size_t i, std::size_t j, const int* chans, int nc, double limit, bool force,
             bool exact_param = false);

private:
    // reweighted: a round after the first of the same segment, parameters and κ (solve_quat_channel
    // then reuses the first round's terms).
    void solve_handles(std::size_t i, std::size_t j, const int* chans, int nc, double kappa,
                       double* p1, double* p2, bool reweighted = false);
    template <int C, int NC>
    void solve_handles_t(std::size_t i, std::size_t j, const int* chans, double kappa, double* p1,
                         double* p2);
    double euler_metric_times(std::size_t k, int row, const double* e) const;
    double euler_metric_entry(std::size_t k, int row, int col) const;
    double evaluate(std::size_t i, std::size_t j, const int* chans, int nc, const double* p1,
                    const double* p2, double limit,
                    double give_up = std::numeric_limits<double>::infinity());
    template <int C, int NC>
    double evaluate_t(std::size_t i, std::size_t j, const int* chans, const double* p1,
                      const double* p2, double limit, double give_up);
    const double* between_limits(double limit);
    void commit(std::size_t i, std::size_t j, const int* chans, int nc, const double* p1,
                const double* p2, bool exact_param);
    // u_ (and the Bezier basis) of the samples inside [i, j] for the handle fractions a1, a2.
    void set_parameters(std::size_t i, std::size_t j, double a1, double a2, bool exact_param);
    // The fit of one parameterization (fit's reweighting rounds); worst0: the plain fit's worst.
    // hopeless: kHopeless, or kHopelessOtherFrames.
    // rounds: reweighting rounds (−1: the default for the channels; 0: the plain fit only).
    bool fit_handles(std::size_t i, std::size_t j, const int* chans, int nc, double limit, bool force,
                     double* p1, double* p2, double& worst0, const double* hopeless = kHopeless,
                     int rounds = -1);

    // Quaternion fits of one channel among fixed others (per-channel key choice): per sample, what
    // the other channels contribute to the error terms, so that a fit computes only its channel's
    // part. The others stay fixed while one channel's keys are chosen; entries are filled when a fit
    // first needs them (stamp == epoch), and a fit of another channel, or a commit to other
    // channels, starts a new epoch.
    struct OtherChannels {
        // Per sample k, at k·kStride: d_o = conj(ref_k)·q_o with q_o the fitted values with the
        // channel set to 0, and d_c = conj(ref_k)·e_c (the fit's value x gives d = d_o + x·d_c);
        // |q_o|²; û_k·(q_o − the sample with the channel set to 0) (the metric's radial term). Then the
        // same midway to sample k + 1 against the mean of the two samples (the between-samples guard),
        // without the radial term.
        static constexpr int kStride = 20;
        int chan = -1;
        std::size_t epoch = 1;
        std::vector<std::size_t> stamp;
        std::unique_ptr<double[]> terms;
    };
    void other_channels(std::size_t i, std::size_t j, int chan);
    // Where a quaternion channel among fixed others meets the limit at each sample (an interval of its
    // value), and whether a fit at the current handle fractions may meet them all (a Remez
    // exchange, a lower bound): segments that cannot are rejected without reweighting.
    bool channel_intervals(std::size_t i, std::size_t j, double limit);
    bool intervals_may_pass(std::size_t i, std::size_t j, int chan);
    // Per sample (channel_intervals; weight −1: empty), valid where interval_stamp_ is the generation
    // of other_'s epoch and the limit they were computed for.
    std::unique_ptr<double[]> interval_mid_, interval_weight_;
    std::vector<std::size_t> interval_stamp_;
    std::size_t interval_generation_ = 1, interval_epoch_ = 0;
    double interval_limit_ = -1.0;
    struct Exchange {  // intervals_may_pass' last reference, and its segment and channel
        std::size_t ref[3] = {0, 0, 0};
        std::size_t i = kNone, j = kNone;
        int chan = -1;
    } exchange_;
    void solve_quat_channel(std::size_t i, std::size_t j, int chan, double kappa, double* p1,
                            double* p2, bool reweighted);

    const Problem& p_;
    KeyInterpolation ipo_;
    State& s_;
    OtherChannels other_;
    // Per-sample scratch of the segment being fitted, each entry written by fit() or evaluate() before
    // it is read (so allocated without zeroing: a fit through keys makes two Fitters of n samples for a
    // few hundred short fits, and zero-filling them was ~9% of its instructions): fitted values (n·C),
    // parameters, weights, errors (n each).
    std::unique_ptr<double[]> buf_, u_, w_, err_;
    // The end of buf_'s samples the last evaluate() wrote (it stops early at a fit it rejects, or
    // where the norm dips): commit() computes the rest of a forced fit's values there.
    std::size_t buf_end_ = 0;
    // BEZIER: the cubic's basis at each interior sample of the segment being fitted (n·4), computed
    // once per fit for all its solves and evaluations.
    std::unique_ptr<double[]> bern_;
    // Quaternion channel fits (solve_quat_channel): each interior sample's five terms of the normal
    // equations without its weight (n·5), from a segment's first round for the rounds after it.
    std::unique_ptr<double[]> terms_;
    // between_limits' last limit and its limits (n − 1 entries; many fits in a row share a limit).
    double between_limit_ = -1.0;
    std::unique_ptr<double[]> between_limits_;
    bool between_failed_ = false;  // the last evaluate() failed a between-samples guard
    // The handle fractions of the parameterization in u_ (1/3, 1/3: u is linear in the frame).
    double frac1_ = 1.0 / 3.0, frac2_ = 1.0 / 3.0;
    const ParameterTable* table_ = nullptr;  // their parameter table (reduce_fit.cpp), if any
    // The parameter and Bezier basis of interior sample k of the segment being fitted: param(k),
    // basis(k) (4 values), from u_ and bern_ or, for evenly spaced samples, from a table per step
    // count and handle fractions (set_parameters; computed per fit, they took 8 % of a reduction's
    // instructions; the tables of the step counts met, below kEvenSegmentsKept, stay with the thread:
    // 10 MB at most). even_from_[k]: the first sample of the evenly spaced run ending at sample k.
    static constexpr std::size_t kEvenSegmentsKept = 256;
    const double* u_at_ = nullptr;
    const double* bern_at_ = nullptr;
    std::size_t first_ = 0;
    double param(std::size_t k) const { return u_at_[k - first_]; }
    const double* basis(std::size_t k) const { return bern_at_ + (k - first_) * 4; }
    std::vector<std::size_t> even_from_;

    bool free_handle_frames_;
};

// ---- stage 3: key selection (reduce_select.cpp) ----------------------------------------------------

// Keys for the channels `chans` (shared), every sample within tan²(θ/2) ≤ limit where it can be:
// every forced sample, plus inserted keys at candidate samples; the chosen segments' fits are
// committed in the Fitter's State. Empty (given up) as soon as the keys cannot come out fewer than
// `budget`, or (with `pace`: n counts of another result's keys at samples 0..k, all its channels
// together) once the keys kept up to a sample k outnumber kPaceSlack × pace[k] / nc + kPaceExtra.
std::vector<std::size_t> select_keys(const Problem& p, Fitter& fitter, const int* chans, int nc,
                                     double limit, std::size_t budget = kNone,
                                     const std::vector<std::size_t>* pace = nullptr);

// Drops the inserted keys of `keys` (the channels' current keys, their fits committed) whose
// neighbours one segment within `limit` joins; returns the keys kept, their fits committed.
std::vector<std::size_t> remove_keys(const Problem& p, Fitter& fitter, const int* chans, int nc,
                                     double limit, const std::vector<std::size_t>& keys);

// ---- stage 4: verification and repair (reduce_verify.cpp) ------------------------------------------

// The F-curves of the State's keys, every sample evaluated as Blender does, failing segments refitted
// or split until all pass (or sit on keys: the float32 floor). `groups`: the channel sets that share
// keys. max_error: the largest emulated error (radians).
std::vector<ReducedChannel> verify_and_repair(const Problem& p, State& s, Fitter& fitter,
                                              KeyInterpolation ipo, double verify_tan2,
                                              double fit_limit,
                                              const std::vector<std::vector<int>>& groups,
                                              double& max_error);

// A channel of keys (a result on p's samples) that a constant meets at every sample — every sample's
// error within verify_tan2 with the other channels as they play — becomes one key at the first
// sample holding that value (flat handles: Blender plays it at every frame, extrapolation included),
// channel by channel in order, the value with the least largest error of a few candidates (the
// channel's first and last key values, their mean, the middle of its samples' range; float32). Only
// channels of two or three keys are tried, and only with p.single_key; max_error is updated, and
// synchronized set to whether every channel has the same keys (same_keys).
void flatten_channels(const Problem& p, double verify_tan2, ReducedKeys& keys);
// Whether every channel has the same keys.
bool same_keys(const std::vector<ReducedChannel>& chans);

// ---- the whole reduction (reduce.cpp) --------------------------------------------------------------

// The keys of Problem p (its forced and candidate samples as set) within `tolerance`: the stages
// above, synchronized and (unless `synchronized`) per channel, the fewer keys kept. fit_keys* call it;
// so does reduce_proved.cpp, whose samples added by the proof are candidates of no key.
// free_handle_frames: quaternion BEZIER segments may take the handle frames of kHandleFractions (from
// kHandleFreeMinTolerance); false keeps every segment's at the thirds.
ReducedKeys reduce(const Problem& p, double tolerance, KeyInterpolation ipo, bool synchronized,
                   bool free_handle_frames = true);

// The keys of an earlier reduction (`previous`, its indices mapped to p's samples by `index`: the
// samples it was made on, each found again among p's) made to meet `tolerance` on p, which holds
// more samples: every segment keeps its keys, handles and handle frames, and only the segments where
// a sample fails are refitted or split (verify_and_repair; where that adds keys, one removal pass
// and verification again). Far cheaper than reduce() when few
// samples were added (reduce_proved.cpp's rounds after the first). Empty channels when the earlier
// keys are not its own kind of result (handle frames off the pairs reduce() places, another channel
// count or interpolation): the caller then reduces afresh.
ReducedKeys repair(const Problem& p, double tolerance, KeyInterpolation ipo, const ReducedKeys& previous,
                   const std::vector<std::size_t>& index, bool free_handle_frames = true);

}  // namespace quatcurve::reduce_impl
