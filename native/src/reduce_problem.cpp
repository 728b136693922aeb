// Key reduction, stage 1: admission of the input and the Problem it becomes (reduce_impl.hpp).
// Every argument check of reduce_keys / reduce_keys_euler lives here, each message naming the
// argument and element.
#include <algorithm>
#include <cmath>
#include <string>

#include "curve_math.hpp"
#include "quatcurve/errors.hpp"
#include "quatcurve/euler.hpp"
#include "quatcurve/quat.hpp"
#include "reduce_impl.hpp"

namespace quatcurve::reduce_impl {

namespace {

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

// Rotation angle between the unit quaternions a and b (either sign): angle_between (quat.hpp)
// without its argument checks and normalization, for the per-sample setup loops.
double unit_angle(const Quat& a, const Quat& b) {
    const double x[4] = {a.w, a.x, a.y, a.z}, y[4] = {b.w, b.x, b.y, b.z};
    return detail::angle_between(x, y);
}

// A problem of `kind` over `times` (checked) with `count` rows of `C` channels (`what`: the rows'
// argument and noun for the count message): every per-sample array sized, nothing filled yet.
Problem new_problem(Kind kind, int C, const std::vector<double>& times, std::size_t count, const char* what,
                    const char* noun) {
    check_times(times);
    if (count != times.size())
        throw InvalidArgument(std::string(what) + ": " + std::to_string(count) + " " + noun + " for " +
                              std::to_string(times.size()) + " times");
    Problem p;
    p.kind = kind;
    p.C = C;
    p.n = times.size();
    p.t.resize(p.n);
    p.y.resize(p.n * static_cast<std::size_t>(C));
    p.ref.resize(p.n);
    if (kind != Kind::EULER) {
        p.unit.assign(p.n * static_cast<std::size_t>(C), 0.0);
        p.norm2.assign(p.n, 0.0);
    }
    return p;
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
        } else if (p.kind == Kind::AXIS_ANGLE) {
            // An angle jump (a turn between two samples) or an axis turning over: Blender's lerp of
            // the axis would pass near zero, where the normalized axis swings.
            jump = std::fabs(b[0] - a[0]) > kPi || a[1] * b[1] + a[2] * b[2] + a[3] * b[3] < 0.0;
        } else {
            for (int c = 0; c < 3; ++c) jump = jump || std::fabs(b[c] - a[c]) > kPi;
        }
        p.breaks[k] = p.breaks[k - 1] + (jump ? 1 : 0);
    }
    p.step_tan.assign(p.n, 0.0);
    for (std::size_t k = 0; guard && k + 1 < p.n; ++k)
        p.step_tan[k] = std::tan(0.5 * kBetweenStep * unit_angle(p.ref[k], p.ref[k + 1]));
    if (guard && p.kind != Kind::QUAT && p.n > 1) {
        p.mid_ref.resize(p.n - 1);
        for (std::size_t k = 0; k + 1 < p.n; ++k) {
            double mean[kMaxChannels] = {};
            for (int c = 0; c < p.C; ++c) mean[c] = 0.5 * (p.y[k * p.C + c] + p.y[(k + 1) * p.C + c]);
            p.mid_ref[k] = p.kind == Kind::AXIS_ANGLE ? axis_angle_rotation(mean) : euler_rotation(p, mean);
        }
    }
}

// Slopes for default tangents: central differences inside, one-sided at the ends and next to a
// discontinuity (which no tangent should see). Where the two one-sided slopes differ more than
// kKinkRatio times (a corner: an Euler branch change in a short interval beside a key at gimbal
// lock), the gentler side's: the steep side's slope carried past the corner would bend the next
// segment far off its samples.
constexpr double kKinkRatio = 8.0;
void compute_slopes(Problem& p) {
    p.slope.assign(p.n * p.C, 0.0);
    if (p.n < 2) return;
    for (std::size_t k = 0; k < p.n; ++k) {
        std::size_t a = k > 0 && p.breaks[k] == p.breaks[k - 1] ? k - 1 : k;
        std::size_t b = k + 1 < p.n && p.breaks[k + 1] == p.breaks[k] ? k + 1 : k;
        const double dt = p.t[b] - p.t[a];
        for (int c = 0; c < p.C; ++c) {
            double slope = dt > 0.0 ? (p.y[b * p.C + c] - p.y[a * p.C + c]) / dt : 0.0;
            if (a < k && k < b) {
                const double left = (p.y[k * p.C + c] - p.y[a * p.C + c]) / (p.t[k] - p.t[a]);
                const double right = (p.y[b * p.C + c] - p.y[k * p.C + c]) / (p.t[b] - p.t[k]);
                if (std::fabs(left) > kKinkRatio * std::fabs(right)) slope = right;
                else if (std::fabs(right) > kKinkRatio * std::fabs(left)) slope = left;
            }
            p.slope[k * p.C + c] = slope;
        }
    }
}

}  // namespace

void check_tolerance(double tolerance) {
    if (!std::isfinite(tolerance) || tolerance < 0.0)
        throw InvalidArgument("tolerance: must be finite and >= 0 radians, got " +
                              std::to_string(tolerance));
}

Problem make_quat_problem(const std::vector<double>& times, const std::vector<Quat>& quats,
                          bool guard) {
    Problem p = new_problem(Kind::QUAT, 4, times, quats.size(), "quats", "quaternions");
    for (std::size_t k = 0; k < p.n; ++k) {
        const Quat& q = quats[k];
        const double len = norm(q);
        if (!(len >= kMinNorm && len < HUGE_VAL)) {  // NaN too: name what is wrong
            const std::string problem = nonzero_problem(q);
            if (!problem.empty()) throw InvalidArgument("quats[" + std::to_string(k) + "]: " + problem);
        }
        p.t[k] = f32(times[k]);
        const double v[4] = {q.w, q.x, q.y, q.z};
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
    Problem p = new_problem(Kind::EULER, 3, times, angles.size(), "angles", "triples");
    p.order = order;
    const std::string name = euler_order_name(order);  // "XYZ": X applied first
    p.axis_first = name[0] - 'X';
    p.axis_mid = name[1] - 'X';
    p.axis_last = name[2] - 'X';
    // Sign of the triple product e_last · (e_mid × e_first): +1 for cyclic (last, mid, first).
    const int perm = (p.axis_mid - p.axis_last + 3) % 3 == 1 ? 1 : -1;
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
Problem make_axis_angle_problem(const std::vector<double>& times, const std::vector<Vec4>& values) {
    Problem p = new_problem(Kind::AXIS_ANGLE, 4, times, values.size(), "values", "rows");
    p.spin.assign(p.n, 0.0);
    for (std::size_t k = 0; k < p.n; ++k) {
        const Vec4& v = values[k];
        const std::string name = "values[" + std::to_string(k) + "]";
        std::string problem = finite_problem(v[0]);
        if (!problem.empty()) throw InvalidArgument(name + " angle: " + problem);
        const Vec3 axis(v[1], v[2], v[3]);
        problem = finite_problem(axis);
        if (problem.empty()) problem = nonzero_problem(axis, "axis");
        if (!problem.empty()) throw InvalidArgument(name + ": " + problem);
        const double len2 = glm::dot(axis, axis);
        if (!(len2 > 1e-30) || !std::isfinite(len2))
            throw InvalidArgument(name + ": axis length " + std::to_string(std::sqrt(len2)) +
                                  " is outside what Blender normalizes reliably (1e-15 .. 1e154)");
        p.t[k] = f32(times[k]);
        for (int a = 0; a < 4; ++a) p.y[k * 4 + a] = v[a];
        p.ref[k] = axis_angle_to_quat(axis, v[0]);
        const double len = std::sqrt(len2);
        for (int a = 1; a < 4; ++a) p.unit[k * 4 + a] = v[a] / len;
        p.norm2[k] = len2;
        const double s = std::sin(0.5 * v[0]);
        p.spin[k] = 4.0 * s * s;
    }
    compute_breaks(p, true);
    compute_slopes(p);
    return p;
}

// Blender keeps key values as float32: a sample whose float32 form is a different rotation (a
// component beyond ±3.4e38, a quaternion whose components all underflow, an angle too large for
// float32 to resolve) cannot be kept within any bound, so it is refused up front. Allowed: the
// tolerance, and never less than 1e-6 rad (float32 rounding of ordinary values is ~1e-7 rad).
void check_float32_storage(const Problem& p, double tolerance) {
    const double allowed = std::max(tolerance, 1e-6);
    const double allowed_tan = std::tan(0.5 * allowed);
    const char* name = p.kind == Kind::QUAT ? "quats[" : p.kind == Kind::EULER ? "angles[" : "values[";
    for (std::size_t k = 0; k < p.n; ++k) {
        const double* y = p.row(k);
        double v[4] = {0.0, 0.0, 0.0, 0.0};
        for (int c = 0; c < p.C; ++c) {
            v[c] = f32(y[c]);
            if (!std::isfinite(v[c]))
                throw InvalidArgument(name + std::to_string(k) + "]: " + std::to_string(y[c]) +
                                      " is beyond float32 range (Blender stores keys as float32)");
        }
        // float32 components are 0 or at least 1e-45 in size: their squares cannot underflow
        if (p.kind == Kind::QUAT && !(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3] > 0.0))
            throw InvalidArgument(name + std::to_string(k) +
                                  "]: every component underflows float32 (Blender stores keys as float32)");
        if (p.kind == Kind::AXIS_ANGLE && !(f32(v[1] * v[1] + v[2] * v[2] + v[3] * v[3]) > 1e-35))
            throw InvalidArgument(name + std::to_string(k) +
                                  "]: the axis is too short for float32 (Blender would show no rotation)");
        const double tan2 = error_tan2(p, k, v);  // the stored key's rotation against the sample's
        if (!(tan2 <= allowed_tan * allowed_tan))
            throw InvalidArgument(name + std::to_string(k) + "]: storing it as float32 (as Blender does) turns it by " +
                                  std::to_string(angle_of_tan2(tan2)) + " rad, more than the tolerance allows");
    }
}

void set_forced_keys(Problem& p, const std::vector<std::size_t>& forced, double min_gap) {
    if (!(min_gap >= 0.0) || !std::isfinite(min_gap))
        throw InvalidArgument("min_gap: must be finite and >= 0 frames");
    p.forced.assign(p.n, 0);
    p.candidate.assign(p.n, 1);
    for (std::size_t a = 0; a < forced.size(); ++a) {
        const std::size_t k = forced[a];
        if (k >= p.n)
            throw InvalidArgument("forced[" + std::to_string(a) + "]: sample " + std::to_string(k) +
                                  " does not exist (" + std::to_string(p.n) + " samples)");
        if (a > 0 && !(k > forced[a - 1]))
            throw InvalidArgument("forced[" + std::to_string(a) + "]: not increasing (" + std::to_string(k) +
                                  " after " + std::to_string(forced[a - 1]) + ")");
        p.forced[k] = 1;
    }
    // Candidates: samples at least min_gap frames from every forced key (two-pointer sweep).
    if (min_gap > 0.0 && !forced.empty()) {
        std::size_t a = 0;
        for (std::size_t k = 0; k < p.n; ++k) {
            while (a + 1 < forced.size() && p.t[forced[a + 1]] <= p.t[k]) ++a;
            double gap = std::fabs(p.t[k] - p.t[forced[a]]);
            if (a + 1 < forced.size()) gap = std::fmin(gap, std::fabs(p.t[forced[a + 1]] - p.t[k]));
            if (gap < min_gap && !p.forced[k]) p.candidate[k] = 0;
        }
    }
}

}  // namespace quatcurve::reduce_impl
