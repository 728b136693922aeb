// The Curve: validation of keys and options, the relative rotation vector of every segment (spins
// from Euler paths included), the split of segments that turn more than π, and dispatch to the
// method families (curve_basic.cpp, curve_squad.cpp, curve_spline.cpp).
#include "quatcurve/curve.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstddef>
#include <cstring>
#include <initializer_list>
#include <utility>
#include <string>

#include "curve_impl.hpp"
#include "quatcurve/errors.hpp"
#include "quatcurve/quat.hpp"

#if QUATCURVE_MULTIVERSION
#include <cpuid.h>
#endif

namespace quatcurve {

using detail::kPi;
using detail::kTwoPi;

// x86-64-v3 needs AVX, AVX2, BMI1, BMI2, F16C, FMA, LZCNT, MOVBE and the SSE3–4.2 and POPCNT of v2,
// and the system's saving of the YMM registers (XCR0 bits 1–2); v4 adds AVX-512 F, BW, CD, DQ and VL
// and the saving of the mask and ZMM registers (XCR0 bits 5–7). Intel's and AMD's CPUID bits.
int cpu_level() {
    int level = 0;
#if QUATCURVE_MULTIVERSION
    unsigned a, b, c, d;
    auto has = [](unsigned reg, std::initializer_list<int> bits) {
        for (int bit : bits)
            if (!(reg >> bit & 1u)) return false;
        return true;
    };
    if (__get_cpuid(1, &a, &b, &c, &d) && has(c, {0, 9, 12, 19, 20, 22, 23, 27, 28, 29})) {
        unsigned xcr0_lo, xcr0_hi;
        __asm__("xgetbv" : "=a"(xcr0_lo), "=d"(xcr0_hi) : "c"(0));
        unsigned b7 = 0, c7 = 0, d7 = 0, ce = 0;
        const bool leaf7 = __get_cpuid_count(7, 0, &a, &b7, &c7, &d7);
        const bool ext = __get_cpuid(0x80000001, &a, &b, &ce, &d);
        if (has(xcr0_lo, {1, 2}) && leaf7 && ext && has(b7, {3, 5, 8}) && has(ce, {5})) {
            level = 3;
            if (has(b7, {16, 17, 28, 30, 31}) && has(xcr0_lo, {5, 6, 7})) level = 4;
        }
    }
#endif
    if (const char* cap = std::getenv("QUATCURVE_CPU_LEVEL")) level = std::min(level, std::atoi(cap));
    return level;
}

namespace {

const std::vector<std::string> kMethodNames = {"EULER", "QUAT_COMPONENTS", "NLERP", "SLERP",
                                               "SQUAD", "CATMULL_ROM",     "TCB",   "SPLINE_C2"};
const std::vector<std::string> kTcbOptions = {"tension", "continuity", "bias", "ease_in", "ease_out"};
const std::vector<std::string> kEaseOptions = {"ease_in", "ease_out"};
// Options of every method, after the method's own.
const std::vector<std::string> kCommonOptions = {"cyclic"};

std::string join(const std::vector<std::string>& names) {
    std::string s;
    for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
    return s;
}

std::vector<double>* tcb_field(CurveOptions& o, const std::string& name) {
    if (name == "tension") return &o.tension;
    if (name == "continuity") return &o.continuity;
    if (name == "bias") return &o.bias;
    if (name == "ease_in") return &o.ease_in;
    if (name == "ease_out") return &o.ease_out;
    if (name == "turns") return &o.turns;
    return nullptr;
}

bool is_default(const std::vector<double>& v) { return v.size() == 1 && v[0] == 0.0; }

bool takes_turns(Method method) { return method != Method::EULER && method != Method::QUAT_COMPONENTS; }

// Turns (curve.hpp, "Turns"): whole numbers within ±kMaxTurns (as Euler segments, 1e4 turns: the
// sub-arcs grow with the turn), one value or one per key.
constexpr double kMaxTurns = 1e4;
// A segment turning by less than this has no axis of its own (float32 noise between equal keys is
// ~1e-7 rad): its turns take a neighbour's axis.
constexpr double kMinAxisTurn = 1e-6;

void check_turns(const std::vector<double>& v, std::size_t keys) {
    if (v.size() != 1 && v.size() != keys)
        throw InvalidArgument("turns: expected one value or one per key (" + std::to_string(keys) + "), got " +
                              std::to_string(v.size()));
    for (std::size_t i = 0; i < v.size(); ++i) {
        const std::string name = "turns[" + std::to_string(i) + "]: ";
        if (!std::isfinite(v[i])) throw InvalidArgument(name + "not a finite number");
        if (v[i] != std::nearbyint(v[i])) throw InvalidArgument(name + std::to_string(v[i]) + " is not a whole number");
        if (std::fabs(v[i]) > kMaxTurns)
            throw InvalidArgument(name + std::to_string(v[i]) + " is beyond the supported ±10000 turns");
    }
}

// The rotation vector each key segment gains from its turns (2π·turns[i] along its axis, curve.hpp
// "Turns"), from the segments' rotation vectors without turns. Throws naming the key of a turned
// segment without an axis of its own or a neighbour's.
// A loop's first and last segments are neighbours across the seam.
std::vector<Vec3> turn_vectors(const std::vector<Vec3>& r, const std::vector<double>& turns, bool cyclic) {
    std::vector<Vec3> extra(r.size(), Vec3(0.0));
    auto axis_of = [&](std::size_t i, Vec3& u) {
        const double n = glm::length(r[i]);
        if (!(n >= kMinAxisTurn)) return false;
        u = r[i] / n;
        return true;
    };
    for (std::size_t i = 0; i < r.size(); ++i) {
        const double n = turns.size() == 1 ? turns[0] : turns[i];
        if (n == 0.0) continue;
        Vec3 u;
        const std::size_t S = r.size();
        const bool prev = i > 0 ? axis_of(i - 1, u) : cyclic && S > 1 && axis_of(S - 1, u);
        if (!axis_of(i, u) && !prev &&
            !(i + 1 < S ? axis_of(i + 1, u) : cyclic && S > 1 && axis_of(0, u)))
            throw InvalidArgument("turns[" + std::to_string(i) + "]: key " + std::to_string(i) + " and key " +
                                  std::to_string(i + 1) +
                                  " are the same rotation and neither neighbouring segment turns: the segment has no "
                                  "axis to turn about");
        extra[i] = (kTwoPi * n) * u;
    }
    return extra;
}

// Each value of a per-key option lies in [lo, hi] and the option has one value or one per key.
void check_per_key(const std::vector<double>& v, const char* name, double lo, double hi, std::size_t keys) {
    if (v.size() != 1 && v.size() != keys)
        throw InvalidArgument(std::string(name) + ": expected one value or one per key (" +
                              std::to_string(keys) + "), got " + std::to_string(v.size()));
    for (std::size_t i = 0; i < v.size(); ++i) {
        if (!std::isfinite(v[i]) || v[i] < lo || v[i] > hi)
            throw InvalidArgument(std::string(name) + "[" + std::to_string(i) + "]: " + std::to_string(v[i]) +
                                  " is outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    }
}

// Key times the engine can follow in double precision (curve.hpp, "Key times"): finite, strictly
// increasing, consecutive keys kMinSpacing..kMaxSpacing frames apart and at least kTimeResolution of
// their magnitude apart (sub-keys and sample parameters stay resolvable: t = 1, 1 + ulp is refused);
// for the methods whose tangents mix neighbouring segments (SQUAD, TCB, CATMULL_ROM, SPLINE_C2) also
// neighbouring spacings within a factor kMaxSpacingRatio (beyond it the short segment's velocity
// stretched over the long one is a rotation of ~1e6 turns, and SPLINE_C2's cubic loses the keys to
// cancellation).
constexpr double kMinSpacing = 1e-9;
constexpr double kMaxSpacing = 1e12;
constexpr double kTimeResolution = 0x1p-32;  // ≈ 2.3e-10
constexpr double kMaxSpacingRatio = 1e6;

// x in the fewest significant digits (up to 17) that read back as x.
std::string num(double x) {
    char buf[32];
    for (int digits = 6; digits <= 17; ++digits) {
        std::snprintf(buf, sizeof buf, "%.*g", digits, x);
        if (std::strtod(buf, nullptr) == x) break;
    }
    return buf;
}

void check_times(const std::vector<double>& t, Method method) {
    if (t.empty()) throw InvalidArgument("times: at least one key is needed");
    const bool tangents = method == Method::SQUAD || method == Method::TCB || method == Method::CATMULL_ROM ||
                          method == Method::SPLINE_C2;
    auto name = [](std::size_t i) { return "times[" + std::to_string(i) + "]"; };
    for (std::size_t i = 0; i < t.size(); ++i) {
        if (!std::isfinite(t[i])) throw InvalidArgument(name(i) + ": not a finite number");
        if (i == 0) continue;
        if (!(t[i] > t[i - 1]))
            throw InvalidArgument(name(i) + ": not increasing (" + num(t[i]) + " after " + num(t[i - 1]) + ")");
        const double h = t[i] - t[i - 1];  // may overflow to inf: refused below
        auto gap = [&] { return name(i) + ": " + num(h) + " frames after " + name(i - 1); };
        if (!(h >= kMinSpacing))
            throw InvalidArgument(gap() + "; consecutive keys must be at least " + num(kMinSpacing) + " frames apart");
        if (!(h <= kMaxSpacing))
            throw InvalidArgument(gap() + "; consecutive keys may be at most " + num(kMaxSpacing) + " frames apart");
        const double mag = std::fmax(std::fabs(t[i]), std::fabs(t[i - 1]));
        if (h < kTimeResolution * mag)
            throw InvalidArgument(gap() + ", below the resolution of times near " + num(mag) +
                                  " (keys must be at least 2^-32 of their magnitude apart)");
        if (tangents && i >= 2) {
            const double h0 = t[i - 1] - t[i - 2];
            if (h > kMaxSpacingRatio * h0 || h0 > kMaxSpacingRatio * h)
                throw InvalidArgument(gap() + " next to a spacing of " + num(h0) + " frames: " +
                                      method_name(method) + " needs neighbouring key spacings within a factor of " +
                                      num(kMaxSpacingRatio));
        }
    }
}

// Euler keys the engine can follow: every angle within ±kMaxEulerAngle (beyond it a double steps
// by more than 1e-9 rad, so the path between keys cannot be followed), and every angle changing
// by at most kMaxEulerTurn per segment (the path's turn is followed step by step: the work and the
// sub-keys grow with it). 1e300 rad is refused rather than reduced to an arbitrary orientation.
constexpr double kMaxEulerAngle = 1e6 * kTwoPi;
constexpr double kMaxEulerTurn = 1e4 * kTwoPi;

void check_euler_keys(const std::vector<Vec3>& angles) {
    for (std::size_t i = 0; i < angles.size(); ++i) {
        const Vec3& a = angles[i];
        if (!std::isfinite(a.x) || !std::isfinite(a.y) || !std::isfinite(a.z))
            check_finite(a, "angles[" + std::to_string(i) + "]");
        for (int k = 0; k < 3; ++k) {
            auto name = [&] { return "angles[" + std::to_string(i) + "][" + std::to_string(k) + "]"; };
            if (std::fabs(a[k]) > kMaxEulerAngle)
                throw InvalidArgument(name() + ": " + num(a[k]) + " rad is beyond the supported ±1e6 turns (" +
                                      num(kMaxEulerAngle) + " rad)");
            if (i > 0 && std::fabs(a[k] - angles[i - 1][k]) > kMaxEulerTurn)
                throw InvalidArgument(name() + ": segment turns " + num(a[k] - angles[i - 1][k]) + " rad from angles[" +
                                      std::to_string(i - 1) + "], more than the supported 10000 turns (" +
                                      num(kMaxEulerTurn) + " rad) per segment");
        }
    }
}

// detail::rotvec_near, except that a rotation within 1e-9 rad of the identity keeps ref's direction:
// there the principal rotation vector's direction is rounding noise (the end of an exact full turn,
// 400° → 760° about one axis), which would turn the whole segment about a random axis.
Vec3 rotvec_near_turn(const Quat& d, const Vec3& ref) {
    const Vec3 chi0 = detail::rotvec_principal(d);
    const double rn = std::sqrt(glm::dot(ref, ref));
    if (std::sqrt(glm::dot(chi0, chi0)) < 1e-9 && rn > 0.0)
        return (std::nearbyint(rn / kTwoPi) * kTwoPi / rn) * ref + chi0;
    return detail::rotvec_near(d, ref);
}

// The relative rotation vector of the axis-angle path (a0, v0) → (a1, v1) — angle and axis linear,
// the axis normalized as Blender does (a zero axis is the identity) — starting at the rotation q0,
// followed continuously in steps of at most 0.25 rad of angle and 1/16 of the axis change (the
// path turns at most |a1 − a0| + 2·∠(v0, v1) ≤ |a1 − a0| + 2π), so whole turns are counted.
Vec3 lift_axis_angle_path(const double* k0, const double* k1, const Quat& q0) {
    const double da = k1[0] - k0[0];
    const std::size_t steps = static_cast<std::size_t>(std::ceil(std::fabs(da) / 0.25)) + 16;
    const Quat c0 = detail::qconj(q0);
    Vec3 r(0.0);
    for (std::size_t k = 1; k <= steps; ++k) {
        const double f = static_cast<double>(k) / static_cast<double>(steps);
        double v[4];
        for (int c = 0; c < 4; ++c) v[c] = k == steps ? k1[c] : k0[c] + f * (k1[c] - k0[c]);
        const Vec3 axis(v[1], v[2], v[3]);
        const Quat q = glm::dot(axis, axis) > 0.0 ? axis_angle_to_quat(axis, v[0]) : Quat(1.0, 0.0, 0.0, 0.0);
        r = rotvec_near_turn(detail::qmul(c0, q), r);
    }
    return r;
}

// Rotation vector of the unit quaternion d on its keyed path: angle 2·atan2(|v|, w) ∈ [0, 2π].
Vec3 rotvec_keyed(const Quat& d, std::size_t i) {
    const Vec3 v(d.x, d.y, d.z);
    const double n = std::sqrt(glm::dot(v, v));
    if (n <= 1e-12 && d.w < 0.0) {
        throw InvalidArgument("quats[" + std::to_string(i) + "], quats[" + std::to_string(i + 1) +
                              "]: opposite keys have no keyed path axis (shortest_path=false)");
    }
    if (n == 0.0) return Vec3(0.0);
    return (2.0 * std::atan2(n, d.w) / n) * v;
}

// The relative rotation vector of the Euler path a0 → a1 (linear in every angle), starting at the
// rotation q0: the rotation vector of conj(q0)·q(a(s)) followed continuously in steps of at most
// 0.5 rad (the Euler path turns at most ‖a1 − a0‖₁ in total), so whole turns are counted.
Vec3 lift_euler_path(const Vec3& a0, const Vec3& a1, EulerOrder order, const Quat& q0) {
    const Vec3 d = a1 - a0;
    const double len = std::fabs(d.x) + std::fabs(d.y) + std::fabs(d.z);
    const std::size_t steps = static_cast<std::size_t>(std::ceil(len / 0.5)) + 1;
    const Quat c0 = detail::qconj(q0);
    Vec3 r(0.0);
    for (std::size_t k = 1; k <= steps; ++k) {
        const Vec3 a = k == steps ? a1 : a0 + d * (static_cast<double>(k) / static_cast<double>(steps));
        r = detail::rotvec_near(detail::qmul(c0, euler_to_quat(a, order)), r);
    }
    return r;
}

// Cumulative turning angle of the Euler path a0 → a1 at n + 1 equally spaced parameters: cum[k] at
// s = k/n. With R = R_last(a_l)·R_mid(a_m)·R_first(a_f) and a(s) = a0 + s·d the speed is
//   |ω(s)|² = d_f² + d_m² + d_l² + 2ε·d_l·d_f·sin(a_m(s)),   ε = e_last·(e_mid × e_first),
// (|ω|² = |R_lastᵀω|², and R_mid leaves e_mid fixed), so it depends on the middle angle only: constant
// when d_m = 0 or d_l·d_f = 0 (n = 1), otherwise Simpson's rule on cells where the middle angle
// moves at most 0.05 rad (relative error below 1e-8). The work grows with the middle angle's turn
// only, which check_euler_keys bounds.
void euler_path_length(const Vec3& a0, const Vec3& a1, EulerOrder order, std::vector<double>& cum) {
    const char* name = euler_order_name(order);
    const int f = name[0] - 'X', m = name[1] - 'X', l = name[2] - 'X';
    Vec3 ef(0.0), em(0.0), el(0.0);
    ef[f] = em[m] = el[l] = 1.0;
    const double eps = glm::dot(el, glm::cross(em, ef));
    const Vec3 d = a1 - a0;
    const double P = glm::dot(d, d), Q = 2.0 * eps * d[l] * d[f];
    const double dm = d[m];
    const std::size_t n = Q == 0.0 || dm == 0.0 ? 1 : static_cast<std::size_t>(std::ceil(std::fabs(dm) / 0.05));
    auto speed = [&](double s) { return std::sqrt(std::fmax(0.0, P + Q * std::sin(a0[m] + s * dm))); };
    cum.assign(n + 1, 0.0);
    const double ds = 1.0 / static_cast<double>(n);
    double v0 = speed(0.0);
    for (std::size_t k = 1; k <= n; ++k) {
        const double s1 = k == n ? 1.0 : static_cast<double>(k) * ds;
        const double v1 = speed(s1), vm = speed(s1 - 0.5 * ds);
        cum[k] = cum[k - 1] + ds * (v0 + 4.0 * vm + v1) / 6.0;
        v0 = v1;
    }
}

// The path parameter s ∈ [0, 1] where the cumulative angle reaches `length` (linear between steps).
double path_parameter(const std::vector<double>& cum, double length) {
    const std::size_t n = cum.size() - 1;
    const std::size_t k = static_cast<std::size_t>(std::lower_bound(cum.begin(), cum.end(), length) - cum.begin());
    if (k == 0) return 0.0;
    if (k > n) return 1.0;
    const double span = cum[k] - cum[k - 1];
    const double f = span > 0.0 ? (length - cum[k - 1]) / span : 0.0;
    return (static_cast<double>(k - 1) + f) / static_cast<double>(n);
}

}  // namespace

Method parse_method(const std::string& name) {
    for (std::size_t i = 0; i < kMethodNames.size(); ++i)
        if (kMethodNames[i] == name) return static_cast<Method>(i);
    throw InvalidArgument("method: unknown method '" + name + "' (valid: " + join(kMethodNames) + ")");
}

const char* method_name(Method method) {
    const auto i = static_cast<std::size_t>(method);
    if (i >= kMethodNames.size()) throw InvalidArgument("method: invalid Method value");
    return kMethodNames[i].c_str();
}

const std::vector<std::string>& method_names() { return kMethodNames; }

std::vector<std::string> option_names(Method method) {
    if (method == Method::TCB) {
        std::vector<std::string> names{"clamped"};
        names.insert(names.end(), kTcbOptions.begin(), kTcbOptions.end());
        names.push_back("turns");
        names.insert(names.end(), kCommonOptions.begin(), kCommonOptions.end());
        return names;
    }
    std::vector<std::string> names;
    if (method == Method::SLERP) names.push_back("shortest_path");
    if (method == Method::SQUAD || method == Method::CATMULL_ROM) names.push_back("clamped");
    names.insert(names.end(), kEaseOptions.begin(), kEaseOptions.end());
    if (takes_turns(method)) names.push_back("turns");
    names.insert(names.end(), kCommonOptions.begin(), kCommonOptions.end());
    return names;
}

void set_option(CurveOptions& options, Method method, const std::string& name,
                const std::vector<double>& values) {
    const bool flag = name == "shortest_path" || name == "clamped" || name == "cyclic";
    const bool known = flag || tcb_field(options, name) != nullptr;
    if (!known)
        throw InvalidArgument(name + ": unknown option (options: ease_in, ease_out, cyclic for every method; turns for every "
                              "method but EULER and QUAT_COMPONENTS; shortest_path for SLERP; clamped for SQUAD, TCB "
                              "and CATMULL_ROM; tension, continuity, bias for TCB)");
    const auto valid = option_names(method);
    if (std::find(valid.begin(), valid.end(), name) == valid.end())
        throw InvalidArgument(name + ": not an option of method " + method_name(method) +
                              (valid.empty() ? std::string(" (it takes none)") : " (it takes " + join(valid) + ")"));
    if (values.empty()) throw InvalidArgument(name + ": no value given");
    for (std::size_t i = 0; i < values.size(); ++i)
        if (!std::isfinite(values[i]))
            throw InvalidArgument(name + "[" + std::to_string(i) + "]: not a finite number");
    if (flag) {
        if (values.size() != 1 || (values[0] != 0.0 && values[0] != 1.0))
            throw InvalidArgument(name + ": expected a bool");
        (name == "clamped" ? options.clamped : name == "cyclic" ? options.cyclic : options.shortest_path) =
            values[0] != 0.0;
        return;
    }
    *tcb_field(options, name) = values;
}

Curve::Curve(Method method, CurveOptions options) : method_(method), options_(std::move(options)) {
    method_name(method);  // validates the enum value
}

Curve::Curve(std::vector<double> times, const std::vector<Quat>& quats, Method method, CurveOptions options)
    : Curve(method, std::move(options)) {
    if (method == Method::EULER)
        throw InvalidArgument("method: EULER interpolates Euler angles; build it with Curve::from_euler");
    check_times(times, method);
    if (quats.size() != times.size())
        throw InvalidArgument("quats: " + std::to_string(quats.size()) + " keys for " +
                              std::to_string(times.size()) + " times");
    times_ = std::move(times);
    raw_ = quats;
    quats_.reserve(quats.size());
    for (std::size_t i = 0; i < quats.size(); ++i) quats_.push_back(normalized_rotation(quats[i], "quats", i));
    build();
}

Curve::Curve(const double* times, const double* wxyz, std::size_t n, Method method, CurveOptions options)
    : Curve(std::vector<double>(times, times + n),
            [&] {
                std::vector<Quat> q(n);
                for (std::size_t i = 0; i < n; ++i) q[i] = from_wxyz(wxyz + 4 * i);
                return q;
            }(),
            method, std::move(options)) {}

Curve Curve::from_euler(std::vector<double> times, const std::vector<Vec3>& angles, EulerOrder order,
                        Method method, CurveOptions options) {
    Curve c(method, std::move(options));
    euler_order_name(order);
    check_times(times, method);
    if (angles.size() != times.size())
        throw InvalidArgument("angles: " + std::to_string(angles.size()) + " keys for " +
                              std::to_string(times.size()) + " times");
    check_euler_keys(angles);
    c.times_ = std::move(times);
    c.angles_ = angles;
    c.order_ = order;
    c.build();
    return c;
}

Curve Curve::from_euler(const double* times, const double* angles, std::size_t n, EulerOrder order,
                        Method method, CurveOptions options) {
    std::vector<Vec3> a(n);
    for (std::size_t i = 0; i < n; ++i) a[i] = Vec3(angles[3 * i], angles[3 * i + 1], angles[3 * i + 2]);
    return from_euler(std::vector<double>(times, times + n), a, order, method, std::move(options));
}

Curve Curve::from_axis_angle(std::vector<double> times, const std::vector<double>& values, Method method,
                             CurveOptions options) {
    if (method == Method::EULER)
        throw InvalidArgument("method: EULER interpolates Euler angles; build it with Curve::from_euler");
    Curve c(method, std::move(options));
    check_times(times, method);
    const std::size_t K = times.size();
    if (values.size() != 4 * K)
        throw InvalidArgument("values: " + std::to_string(values.size() / 4) + " keys for " + std::to_string(K) +
                              " times");
    for (std::size_t i = 0; i < K; ++i) {
        const double* v = &values[4 * i];
        const std::string name = "values[" + std::to_string(i) + "]";
        check_finite(v[0], name + " angle");
        check_finite(Vec3(v[1], v[2], v[3]), name + " axis");
        check_nonzero(Vec3(v[1], v[2], v[3]), name + " axis");
        if (std::fabs(v[0]) > kMaxEulerAngle)
            throw InvalidArgument(name + " angle: " + num(v[0]) + " rad is beyond the supported ±1e6 turns (" +
                                  num(kMaxEulerAngle) + " rad)");
        if (i > 0 && std::fabs(v[0] - values[4 * i - 4]) > kMaxEulerTurn)
            throw InvalidArgument(name + " angle: segment turns " + num(v[0] - values[4 * i - 4]) +
                                  " rad, more than the supported 10000 turns (" + num(kMaxEulerTurn) +
                                  " rad) per segment");
    }
    c.times_ = std::move(times);
    c.quats_.resize(K);
    c.path_rotvecs_.resize(K - 1);
    for (std::size_t i = 0; i < K; ++i) {
        const double* v = &values[4 * i];
        c.quats_[i] = axis_angle_to_quat(Vec3(v[1], v[2], v[3]), v[0]);
        if (i > 0) {
            c.path_rotvecs_[i - 1] = lift_axis_angle_path(&values[4 * i - 4], v, c.quats_[i - 1]);
            // The key's sign on the chain, as for Euler keys (either sign is the same rotation).
            const Quat reached = detail::qmul(c.quats_[i - 1], detail::qexp(c.path_rotvecs_[i - 1]));
            if (detail::qdot(c.quats_[i], reached) < 0.0) c.quats_[i] = -c.quats_[i];
        }
    }
    c.raw_ = c.quats_;
    c.build();
    return c;
}

Curve::~Curve() = default;
Curve::Curve(Curve&&) noexcept = default;
Curve& Curve::operator=(Curve&&) noexcept = default;
Curve::Curve(const Curve& o)
    : method_(o.method_), options_(o.options_), times_(o.times_), quats_(o.quats_), raw_(o.raw_),
      angles_(o.angles_), order_(o.order_), path_rotvecs_(o.path_rotvecs_), rotvecs_(o.rotvecs_),
      impl_(o.impl_ ? std::make_unique<Impl>(*o.impl_) : nullptr) {}
Curve& Curve::operator=(const Curve& o) {
    if (this != &o) *this = Curve(o);
    return *this;
}

namespace {

template <class T>
bool same_bits(const T& a, const T& b) {
    return std::memcmp(&a, &b, sizeof(T)) == 0;
}

// A quadrangle segment's doubles bit for bit, and its flag (the bytes after the flag are padding,
// which two segments built from the same keys need not share).
bool same_bits(const detail::SquadSeg& a, const detail::SquadSeg& b) {
    return std::memcmp(&a, &b, offsetof(detail::SquadSeg, small_log)) == 0 && a.small_log == b.small_log;
}

// Element j of two per-knot-segment arrays, bit for bit (both empty: the family is not in use). The
// segment types hold doubles only (but SquadSeg, above): a padding byte would make equal segments
// differ, which test_bound's refit test (two curves built from the same keys) would catch.
template <class T>
bool same_element(const std::vector<T>& a, std::size_t j, const std::vector<T>& b, std::size_t oj) {
    if (a.empty() && b.empty()) return true;
    return j < a.size() && oj < b.size() && same_bits(a[j], b[oj]);
}

// The knot segments [first, last) of key segment k (kseg is sorted).
std::pair<std::size_t, std::size_t> knot_range(const std::vector<int>& kseg, std::size_t k) {
    const auto range = std::equal_range(kseg.begin(), kseg.end(), static_cast<int>(k));
    return {static_cast<std::size_t>(range.first - kseg.begin()), static_cast<std::size_t>(range.second - kseg.begin())};
}

}  // namespace

bool Curve::same_key_segment(std::size_t k, const Curve& other, std::size_t other_k) const {
    if (k + 1 >= times_.size() || other_k + 1 >= other.times_.size() || !impl_ || !other.impl_) return false;
    const Impl& a = *impl_;
    const Impl& b = *other.impl_;
    if (method_ != other.method_ || times_[k] != other.times_[other_k] || times_[k + 1] != other.times_[other_k + 1] ||
        has_euler_keys() != other.has_euler_keys() || order_ != other.order_)
        return false;
    if (a.cyclic != b.cyclic || a.eased != b.eased) return false;
    if (a.cyclic && !(a.period == b.period && a.period_sign == b.period_sign && same_bits(a.kq.front(), b.kq.front())))
        return false;
    if (a.eased && !(a.ease_a[k] == b.ease_a[other_k] && a.ease_b[k] == b.ease_b[other_k])) return false;
    const auto [first, last] = knot_range(a.kseg, k);
    const auto [ofirst, olast] = knot_range(b.kseg, other_k);
    if (last - first != olast - ofirst || first == last) return false;
    for (std::size_t j = first, oj = ofirst; j < last; ++j, ++oj) {
        if (a.kt[j] != b.kt[oj] || a.kt[j + 1] != b.kt[oj + 1] || !same_bits(a.kq[j], b.kq[oj]) ||
            !same_bits(a.kq[j + 1], b.kq[oj + 1]) || !same_bits(a.kr[j], b.kr[oj]))
            return false;
        if (!same_element(a.lerp, j, b.lerp, oj) || !same_element(a.slerp, j, b.slerp, oj) ||
            !same_element(a.squad, j, b.squad, oj) || !same_element(a.bezier, j, b.bezier, oj) ||
            !same_element(a.spline, j, b.spline, oj) || !same_element(a.euler, j, b.euler, oj) ||
            !same_element(a.kspeed, j, b.kspeed, oj) || !same_element(a.kaccel, j, b.kaccel, oj))
            return false;
    }
    return true;
}

// Validates the options, computes the sign-continuous key rotations and segment rotation vectors,
// splits segments turning more than π into sub-arcs of at most 2π/3, and prepares the method.
void Curve::build() {
    const std::size_t K = times_.size();
    // ---- options
    if (method_ != Method::SLERP && !options_.shortest_path)
        throw InvalidArgument(std::string("shortest_path: not an option of method ") + method_name(method_));
    if (!options_.clamped && method_ != Method::SQUAD && method_ != Method::TCB && method_ != Method::CATMULL_ROM)
        throw InvalidArgument(std::string("clamped: not an option of method ") + method_name(method_));
    check_per_key(options_.ease_in, "ease_in", 0.0, 1.0, K);
    check_per_key(options_.ease_out, "ease_out", 0.0, 1.0, K);
    if (method_ == Method::TCB) {
        check_per_key(options_.tension, "tension", -1.0, 1.0, K);
        check_per_key(options_.continuity, "continuity", -1.0, 1.0, K);
        check_per_key(options_.bias, "bias", -1.0, 1.0, K);
    } else {
        CurveOptions& o = options_;
        for (const auto& name : {"tension", "continuity", "bias"})
            if (!is_default(*tcb_field(o, name)))
                throw InvalidArgument(std::string(name) + ": not an option of method " + method_name(method_));
    }
    if (!takes_turns(method_) && !is_default(options_.turns))
        throw InvalidArgument(std::string("turns: not an option of method ") + method_name(method_));
    check_turns(options_.turns, K);

    // Turns: the knots without them give every segment's own rotation vector (and so its axis, or a
    // neighbour's); the knots are then made again with the turns added.
    build_knots({});
    if (std::any_of(options_.turns.begin(), options_.turns.end(), [](double n) { return n != 0.0; }) && K > 1)
        build_knots(turn_vectors(rotvecs_, options_.turns, options_.cyclic));

    Impl& m = *impl_;
    if (options_.cyclic && K > 1) close_loop();
    const bool lifted = has_euler_keys() || !path_rotvecs_.empty();
    m.first_q = m.kq.front();
    m.last_q = m.kq.back();
    if (K == 1) return;
    detail::set_ease(m, options_, K);

    switch (method_) {
        case Method::EULER: detail::build_euler(m, times_, angles_, order_); break;
        case Method::QUAT_COMPONENTS:
            if (lifted) {
                detail::build_lerp(m, m.kt, m.kq);
            } else {
                detail::build_lerp(m, times_, raw_);
                m.first_q = quats_.front();
                m.last_q = quats_.back();
            }
            break;
        case Method::NLERP:  // the great arc between sign-continuous knots: the path is the arc
            detail::build_lerp(m, m.kt, m.kq);
            m.path_rule_proven = true;
            break;
        case Method::SLERP:
            detail::build_slerp(m);
            m.path_rule_proven = true;
            break;
        case Method::SQUAD:
        case Method::TCB:
        case Method::CATMULL_ROM:
            detail::build_tangent_curve(m, method_, options_);
            m.path_rule_proven = options_.clamped;
            break;
        case Method::SPLINE_C2: detail::build_spline(m); break;
    }
    detail::build_speed_bounds(m);
    if (m.cyclic) {
        // The sign the curve reaches at the end of a period, as the method samples it there.
        const double ends[2] = {times_.front(), times_.back()};
        double q[8];
        m.cyclic = false;
        sample(ends, 2, q);
        m.cyclic = true;
        m.period_sign = q[0] * q[4] + q[1] * q[5] + q[2] * q[6] + q[3] * q[7] < 0.0 ? -1.0 : 1.0;
    }
}

// Loops (curve.hpp "Loops"): refuses a last key that is not the first rotation, snaps the last knot
// onto the first (the same sign as it had; the last knot segment's rotation vector follows, by at
// most kLoopTolerance), and marks the prepared curve as periodic.
void Curve::close_loop() {
    Impl& m = *impl_;
    const std::size_t K = times_.size(), S = m.kr.size();
    // The seam makes the first and last spacings neighbours (check_times, kMaxSpacingRatio).
    const bool tangents = method_ == Method::SQUAD || method_ == Method::TCB || method_ == Method::CATMULL_ROM ||
                          method_ == Method::SPLINE_C2;
    const double h_first = times_[1] - times_[0], h_last = times_[K - 1] - times_[K - 2];
    if (tangents && K >= 3 && (h_first > kMaxSpacingRatio * h_last || h_last > kMaxSpacingRatio * h_first))
        throw InvalidArgument("cyclic: times[1] is " + num(h_first) + " frames after times[0], across the seam from a "
                              "spacing of " + num(h_last) + " frames (times[" + std::to_string(K - 1) + "]): " +
                              method_name(method_) + " needs neighbouring key spacings within a factor of " +
                              num(kMaxSpacingRatio));
    const double angle = angle_between(quats_.front(), quats_.back());
    if (!(angle <= kLoopTolerance)) {
        const double deg = angle * 180.0 / kPi;
        throw InvalidArgument("cyclic: the last key (key " + std::to_string(K - 1) + ", frame " + num(times_.back()) +
                              ") is not the first key's rotation (key 0, frame " + num(times_.front()) +
                              "): they are " + num(std::round(deg * 1e4) / 1e4) +
                              "° apart; key the first pose again at frame " + num(times_.back()));
    }
    const double sign = detail::qdot(m.kq[S], m.kq[0]) < 0.0 ? -1.0 : 1.0;
    const Quat end = sign * m.kq[0];
    const Vec3 before = m.kr[S - 1];
    m.kr[S - 1] = detail::rotvec_near(detail::qmul(detail::qconj(m.kq[S - 1]), end), before);
    rotvecs_.back() += m.kr[S - 1] - before;
    m.kq[S] = end;
    quats_.back() = detail::qdot(quats_.back(), end) < 0.0 ? -end : end;
    const double raw_norm = std::sqrt(glm::dot(raw_.back(), raw_.back()));
    raw_.back() = (detail::qdot(raw_.back(), end) < 0.0 ? -raw_norm : raw_norm) * end;
    m.cyclic = true;
    m.period = times_.back() - times_.front();
}

// The knots (keys and sub-keys) and every segment's rotation vector; extra (empty, or one per
// segment) is added to the rotation vectors of the segments it turns (turns), which are then split
// along their own axis whatever the keys are (quaternion, Euler or axis-angle).
void Curve::build_knots(const std::vector<Vec3>& extra) {
    const std::size_t K = times_.size();
    impl_ = std::make_unique<Impl>();
    Impl& m = *impl_;
    const std::vector<Vec3> own = rotvecs_;  // without turns, when extra is given
    rotvecs_.assign(K - 1, Vec3(0.0));
    auto turned = [&](std::size_t i) { return !extra.empty() && extra[i] != Vec3(0.0); };
    // Knots: the keys plus the sub-keys of segments that turn more than π (none for EULER and for
    // QUAT_COMPONENTS on quaternion keys, which reproduce Blender's own channels).
    auto add_knot = [&](double t, const Quat& q, int key, int seg) {
        m.kt.push_back(t);
        m.kq.push_back(q);
        m.kkey.push_back(key);
        if (seg >= 0) m.kseg.push_back(seg);
    };
    const bool lifted = has_euler_keys() || !path_rotvecs_.empty();
    const bool split = method_ != Method::EULER && !(method_ == Method::QUAT_COMPONENTS && !lifted);
    // Every segment gets its rotation vector r (angle may exceed π) and its end quaternion on the
    // chain q0·exp(r/2); a segment turning more than π is split along r's own axis into ≤ 2π/3
    // sub-arcs, so every method turns the full amount at the constant rate SLERP promises.
    auto add_segment = [&](std::size_t i, const Vec3& r, const Quat& next) {
        const Quat q0 = m.kq.back();
        rotvecs_[i] = r;
        const double theta = glm::length(r);
        // The count of sub-arcs with 1e-6 of slack: a turn of exactly 360° (three sub-arcs) keyed as
        // float32 (360.00001°) must not become four, which shapes the tangent methods differently.
        const std::size_t parts = split && theta > kPi * (1.0 + 1e-12)
                                      ? static_cast<std::size_t>(std::ceil(theta / (kTwoPi / 3.0) - 1e-6))
                                      : 1;
        const double h = times_[i + 1] - times_[i];
        for (std::size_t j = 1; j <= parts; ++j) {
            const double f = static_cast<double>(j) / static_cast<double>(parts);
            m.kr.push_back(r / static_cast<double>(parts));
            if (j == parts)
                add_knot(times_[i + 1], next, static_cast<int>(i + 1), static_cast<int>(i));
            else
                add_knot(times_[i] + f * h, detail::qmul(q0, detail::qexp(f * r)), -1, static_cast<int>(i));
        }
    };
    if (has_euler_keys()) {
        // Each segment turns as its Euler path turns (spins beyond π are kept in every method).
        add_knot(times_[0], euler_to_quat(angles_[0], order_), 0, -1);
        for (std::size_t i = 0; i + 1 < K; ++i) {
            if (turned(i)) {  // the path's turn plus the turns, along the path's net axis
                const Quat q0 = m.kq.back();
                const Vec3 r = own[i] + extra[i];
                Quat next = euler_to_quat(angles_[i + 1], order_);
                if (detail::qdot(next, detail::qmul(q0, detail::qexp(r))) < 0.0) next = -next;
                add_segment(i, r, next);
                continue;
            }
            const Vec3 a0 = angles_[i], da = angles_[i + 1] - angles_[i];
            const double h = times_[i + 1] - times_[i];
            std::vector<double> cum;
            euler_path_length(a0, angles_[i + 1], order_, cum);
            const double L = cum.back();
            if (L < kTwoPi - 0.5) {
                // A path shorter than a turn never comes back near its start's rotation from the
                // far side, so following its rotation vector continuously is unambiguous: r is the
                // side the path goes round (beyond π when it goes the long way), split along r's
                // axis — SLERP keeps a constant speed even on a curved Euler path.
                const Quat q0 = m.kq.back();
                const Vec3 r = lift_euler_path(a0, angles_[i + 1], order_, q0);
                Quat next = euler_to_quat(angles_[i + 1], order_);
                if (detail::qdot(next, detail::qmul(q0, detail::qexp(r))) < 0.0) next = -next;
                add_segment(i, r, next);
                continue;
            }
            // A path of a turn or more (spins): its whole turns are counted by its length and the
            // sub-keys lie on the Euler path itself, so every method turns as the path turns
            // (0 → 720° about Z turns twice, also with a tilt).
            const std::size_t parts = split ? static_cast<std::size_t>(std::ceil(L / (kTwoPi / 3.0))) : 1;
            const Quat q0 = m.kq.back();
            for (std::size_t j = 1; j <= parts; ++j) {
                const double f =
                    j == parts ? 1.0 : path_parameter(cum, L * static_cast<double>(j) / static_cast<double>(parts));
                const Vec3 a = j == parts ? angles_[i + 1] : a0 + f * da;
                const Quat prev = m.kq.back();
                const double fprev = j == 1 ? 0.0 : (m.kt.back() - times_[i]) / h;
                const Vec3 r = lift_euler_path(a0 + fprev * da, a, order_, prev);
                Quat q = euler_to_quat(a, order_);
                if (detail::qdot(q, detail::qmul(prev, detail::qexp(r))) < 0.0) q = -q;
                m.kr.push_back(r);
                add_knot(j == parts ? times_[i + 1] : times_[i] + f * h, q, j == parts ? static_cast<int>(i + 1) : -1,
                         static_cast<int>(i));
            }
            // The segment's net rotation with the whole number of turns nearest the path length.
            const Vec3 net = detail::rotvec_principal(detail::qmul(detail::qconj(q0), m.kq.back()));
            const double t0 = glm::length(net);
            Vec3 u = t0 > 1e-12 ? net / t0 : Vec3(0.0);
            if (t0 <= 1e-12) {
                Vec3 sum(0.0);
                for (std::size_t j = m.kr.size() - parts; j < m.kr.size(); ++j) sum += m.kr[j];
                if (parts == 1) sum = da;  // EULER keeps the keys only: the angles' direction
                u = glm::length(sum) > 0.0 ? glm::normalize(sum) : Vec3(0.0, 0.0, 1.0);
            }
            const double k_pos = std::nearbyint((L - t0) / kTwoPi), k_neg = std::nearbyint((L + t0) / kTwoPi);
            rotvecs_[i] = std::fabs(t0 + kTwoPi * k_pos - L) <= std::fabs(kTwoPi * k_neg - t0 - L)
                              ? (t0 + kTwoPi * k_pos) * u
                              : -(kTwoPi * k_neg - t0) * u;
        }
        quats_.clear();
        for (std::size_t j = 0; j < m.kq.size(); ++j)
            if (m.kkey[j] >= 0) quats_.push_back(m.kq[j]);
        raw_ = quats_;
    } else {
        // Quaternion keys: the shortest rotation after the hemisphere fix, or on the keyed path
        // (QUAT_COMPONENTS, SLERP with shortest_path = false) the arc as stored, up to 2π, split
        // along its own axis when it exceeds π.
        // Axis-angle keys: the segment's lifted path (from_axis_angle; the keys' signs follow it).
        const bool keyed = method_ == Method::QUAT_COMPONENTS || (method_ == Method::SLERP && !options_.shortest_path);
        add_knot(times_[0], quats_[0], 0, -1);
        for (std::size_t i = 0; i + 1 < K; ++i) {
            const Quat q0 = m.kq.back();
            Quat next = quats_[i + 1];
            Vec3 r;
            // The keys as stored (a segment turned an odd number of times before leaves the chain at
            // −quats_[i], which must not change the keyed path of this one).
            const Quat d = detail::qmul(detail::qconj(quats_[i]), next);
            if (turned(i)) {
                r = own[i] + extra[i];
            } else if (!path_rotvecs_.empty()) {
                r = path_rotvecs_[i];
            } else if (!keyed) {
                if (detail::qdot(q0, next) < 0.0) next = -next;
                r = detail::rotvec_principal(d);
            } else if (method_ == Method::QUAT_COMPONENTS && d.w < 0.0 && glm::length(Vec3(d.x, d.y, d.z)) <= 1e-12) {
                r = Vec3(kTwoPi, 0.0, 0.0);  // q, −q: Blender's lerp passes through zero
            } else {
                r = rotvec_keyed(d, i);
            }
            if (!extra.empty() && detail::qdot(next, detail::qmul(q0, detail::qexp(r))) < 0.0) next = -next;
            add_segment(i, r, next);
        }
    }
}

void Curve::sample(const double* times, std::size_t n, double* out) const {
    const Impl& m = *impl_;
    if (times_.size() == 1) {
        for (std::size_t i = 0; i < n; ++i) {
            if (!std::isfinite(times[i])) detail::bad_time(i);
            detail::store(m.first_q, out + 4 * i);
        }
        return;
    }
    std::vector<double> wrapped, periods, warped;
    if (m.cyclic) {  // a loop: every time in the first period, the sign of its own period after
        wrapped.resize(n);
        periods.resize(n);
        for (std::size_t i = 0; i < n; ++i) {
            if (!std::isfinite(times[i])) detail::bad_time(i);
            wrapped[i] = detail::wrap_time(m, times[i], periods[i]);
        }
        times = wrapped.data();
    }
    if (m.eased) {  // ease: the method's path at warped times (curve_ease.cpp)
        warped.resize(n);
        detail::ease_times(m, times_, times, n, warped.data(), nullptr);
        times = warped.data();
    }
    switch (method_) {
        case Method::EULER: detail::sample_euler(m, times, n, out); break;
        case Method::QUAT_COMPONENTS:
        case Method::NLERP: detail::sample_lerp(m, times, n, out); break;
        case Method::SLERP: detail::sample_slerp(m, times, n, out); break;
        case Method::SQUAD:
        case Method::TCB: detail::sample_squad(m, times, n, out); break;
        case Method::CATMULL_ROM: detail::sample_bezier(m, times, n, out); break;
        case Method::SPLINE_C2: detail::sample_spline(m, times, n, out); break;
    }
    if (m.period_sign < 0.0)
        for (std::size_t i = 0; i < periods.size(); ++i)
            if (std::fmod(periods[i], 2.0) != 0.0)
                for (int c = 0; c < 4; ++c) out[4 * i + c] = -out[4 * i + c];
}

void Curve::angular_velocity(const double* times, std::size_t n, double* out) const {
    const Impl& m = *impl_;
    if (times_.size() == 1) {
        for (std::size_t i = 0; i < n; ++i) {
            if (!std::isfinite(times[i])) detail::bad_time(i);
            detail::store(Vec3(0.0), out + 3 * i);
        }
        return;
    }
    std::vector<double> wrapped, warped, rate;
    if (m.cyclic) {
        wrapped.resize(n);
        for (std::size_t i = 0; i < n; ++i) {
            if (!std::isfinite(times[i])) detail::bad_time(i);
            double periods;
            wrapped[i] = detail::wrap_time(m, times[i], periods);
        }
        times = wrapped.data();
    }
    if (m.eased) {
        warped.resize(n);
        rate.resize(n);
        detail::ease_times(m, times_, times, n, warped.data(), rate.data());
        times = warped.data();
    }
    switch (method_) {
        case Method::EULER: detail::velocity_euler(m, times, n, out); break;
        case Method::QUAT_COMPONENTS:
        case Method::NLERP: detail::velocity_lerp(m, times, n, out); break;
        case Method::SLERP: detail::velocity_slerp(m, times, n, out); break;
        case Method::SQUAD:
        case Method::TCB: detail::velocity_squad(m, times, n, out); break;
        case Method::CATMULL_ROM: detail::velocity_bezier(m, times, n, out); break;
        case Method::SPLINE_C2: detail::velocity_spline(m, times, n, out); break;
    }
    for (std::size_t i = 0; i < rate.size(); ++i)  // chain rule: dω/dt = ω(t')·dt'/dt
        for (int c = 0; c < 3; ++c) out[3 * i + c] *= rate[i];
}

std::vector<SegmentPath> Curve::segment_paths(std::size_t samples_per_segment) const {
    if (samples_per_segment < 1) throw InvalidArgument("samples_per_segment: must be at least 1");
    const Impl& m = *impl_;
    std::vector<SegmentPath> paths(rotvecs_.size());
    if (paths.empty()) return paths;
    const std::vector<double> arcs = detail::key_arcs(m);
    for (std::size_t i = 0; i < paths.size(); ++i) paths[i] = {arcs[i], 0.0};
    const std::vector<double>& knots = m.kt;  // keys and sub-keys; m.kseg maps knot segments to keys
    const std::size_t S = knots.size() - 1;
    std::vector<double> t(S * samples_per_segment + 1), q(4 * t.size());
    for (std::size_t j = 0; j < S; ++j)
        for (std::size_t k = 0; k < samples_per_segment; ++k)
            t[j * samples_per_segment + k] =
                knots[j] + (knots[j + 1] - knots[j]) * static_cast<double>(k) / static_cast<double>(samples_per_segment);
    t.back() = knots.back();
    sample(t.data(), t.size(), q.data());
    for (std::size_t j = 0; j < S; ++j) {
        const std::size_t seg = static_cast<std::size_t>(m.kseg[j]);
        for (std::size_t k = j * samples_per_segment; k < (j + 1) * samples_per_segment; ++k)
            paths[seg].length += detail::angle_between(q.data() + 4 * k, q.data() + 4 * k + 4);
    }
    return paths;
}

std::vector<std::pair<std::size_t, SegmentPath>> Curve::path_rule_breaks() const {
    std::vector<std::pair<std::size_t, SegmentPath>> out;
    if (impl_->path_rule_proven) return out;
    const std::vector<SegmentPath> paths = segment_paths();
    for (std::size_t k = 0; k < paths.size(); ++k)
        if (!paths[k].obeys_path_rule()) out.emplace_back(k, paths[k]);
    return out;
}

std::vector<Quat> Curve::sample(const std::vector<double>& times) const {
    std::vector<double> buf(4 * times.size());
    sample(times.data(), times.size(), buf.data());
    std::vector<Quat> q(times.size());
    for (std::size_t i = 0; i < q.size(); ++i) q[i] = from_wxyz(&buf[4 * i]);
    return q;
}

std::vector<Vec3> Curve::angular_velocity(const std::vector<double>& times) const {
    std::vector<double> buf(3 * times.size());
    angular_velocity(times.data(), times.size(), buf.data());
    std::vector<Vec3> w(times.size());
    for (std::size_t i = 0; i < w.size(); ++i) w[i] = Vec3(buf[3 * i], buf[3 * i + 1], buf[3 * i + 2]);
    return w;
}

}  // namespace quatcurve
