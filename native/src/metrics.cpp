// Metrics over sampled orientation paths (see metrics.hpp for the definitions).
#include "quatcurve/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "quatcurve/errors.hpp"
#include "quatcurve/quat.hpp"

namespace quatcurve {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
// Key times match sample times within this many frames (Blender stores frames as float32; callers
// pass sample grids that contain the key times exactly, so this only absorbs rounding).
constexpr double kTimeMatch = 1e-6;

// x in the fewest significant digits (up to 17) that read back as x.
std::string shortest(double x) {
    char buf[32];
    for (int digits = 6; digits <= 17; ++digits) {
        std::snprintf(buf, sizeof buf, "%.*g", digits, x);
        if (std::strtod(buf, nullptr) == x) break;
    }
    return buf;
}

std::string element(const std::string& name, std::size_t i) {
    return name + "[" + std::to_string(i) + "]";
}

// Every quaternion checked (finite, nonzero) and normalized; messages name "name[i]".
std::vector<Quat> normalized_all(const std::vector<Quat>& quats, const std::string& name) {
    std::vector<Quat> out(quats.size());
    for (std::size_t i = 0; i < quats.size(); ++i) out[i] = normalized_rotation(quats[i], name.c_str(), i);
    return out;
}

void check_count(std::size_t got, std::size_t want, const std::string& name, const std::string& what) {
    if (got != want)
        throw InvalidArgument(name + ": " + std::to_string(got) + " values, expected " +
                              std::to_string(want) + " (one per " + what + ")");
}

// Rotation vector of a unit quaternion d taken in the hemisphere w ≥ 0: axis · angle with
// angle = 2·atan2(|v|, w) in [0, π]. atan2(n, w)/n stays accurate as n → 0 (no Taylor branch needed);
// exactly 0 for the identity.
Vec3 rotation_vector(Quat d) {
    if (d.w < 0.0) d = -d;
    const Vec3 v(d.x, d.y, d.z);
    const double n = std::sqrt(glm::dot(v, v));
    if (n == 0.0) return Vec3(0.0);
    return v * (2.0 * std::atan2(n, d.w) / n);
}

// Fits r(s) = a·s + b·s² (+ c·s³) through m = 1..3 points (s_i ≠ 0, distinct) as the polynomial
// g(s) = r(s)/s of degree m-1 through (s_i, r_i/s_i): a = g(0) and b = g'(0) by Lagrange weights,
// L_i(0) = Π_{j≠i} s_j/(s_j - s_i) and L_i'(0) = L_i(0)·Σ_{j≠i} 1/(0 - s_j). b is NaN for m = 1.
void fit_derivatives(const double* s, const Vec3* r, int m, Vec3& velocity, Vec3& acceleration) {
    velocity = Vec3(0.0);
    Vec3 b(0.0);
    for (int i = 0; i < m; ++i) {
        double l0 = 1.0, dsum = 0.0;
        for (int j = 0; j < m; ++j) {
            if (j == i) continue;
            l0 *= s[j] / (s[j] - s[i]);
            dsum += -1.0 / s[j];
        }
        const Vec3 g = r[i] / s[i];
        velocity += g * l0;
        b += g * (l0 * dsum);
    }
    acceleration = m >= 2 ? 2.0 * b : Vec3(kNaN);
}

// One-sided estimate at the sample `at` from up to three samples stepping by `dir` (±1) while the
// index stays within [lo, hi]. Returns the number of samples used.
int one_sided(const std::vector<double>& times, const std::vector<Quat>& q, std::size_t at, int dir,
              std::size_t lo, std::size_t hi, Vec3& velocity, Vec3& acceleration) {
    double s[3];
    Vec3 r[3];
    int m = 0;
    const Quat inv = conjugate(q[at]);
    for (long idx = static_cast<long>(at) + dir;
         m < 3 && idx >= static_cast<long>(lo) && idx <= static_cast<long>(hi); idx += dir, ++m) {
        s[m] = times[static_cast<std::size_t>(idx)] - times[at];
        r[m] = rotation_vector(multiply(q[static_cast<std::size_t>(idx)], inv));
    }
    if (m == 0) {
        velocity = acceleration = Vec3(kNaN);
        return 0;
    }
    fit_derivatives(s, r, m, velocity, acceleration);
    return m;
}

// Speed at sample i of the segment whose samples are first..last, from the interval speeds
// (speeds[k] belongs to the midpoint of [t_k, t_k+1]) of that segment only: linear interpolation
// between the two neighbouring midpoints inside, linear extrapolation from the segment's first
// (last) two midpoints at its ends, clamped at 0. Both are O(h²) for a smooth speed, whereas the
// interval speeds themselves sit h/2 away from the keys (an O(h) error where the speed has a slope
// there, as normalized lerp's has). Exact for constant speed; a one-interval segment has its one speed.
double speed_at_sample(const std::vector<double>& t, const std::vector<double>& speeds, std::size_t i,
                       std::size_t first, std::size_t last) {
    if (last - first == 1) return speeds[first];
    auto mid = [&](std::size_t k) { return 0.5 * (t[k] + t[k + 1]); };
    std::size_t a, b;  // the two intervals whose midpoints bracket (or are nearest to) t_i
    if (i == first) {
        a = first;
        b = first + 1;
    } else if (i == last) {
        a = last - 2;
        b = last - 1;
    } else {
        a = i - 1;
        b = i;
    }
    const double w = (t[i] - mid(a)) / (mid(b) - mid(a));
    return std::max(0.0, speeds[a] + w * (speeds[b] - speeds[a]));
}

// max/min speed. A minimum below 1e-12 of the maximum is a stop (rounding leaves a residue where
// the true speed is 0, e.g. at a flat Bezier handle): +inf rather than a meaningless 1e15.
double ratio_of(double lo, double hi) {
    if (hi == 0.0) return 1.0;  // no motion at all: constant (zero) speed
    if (lo <= 1e-12 * hi) return kInf;
    return hi / lo;
}

// Largest finite value and the key time where it occurs (first one); 0 and k[0] when none.
void max_at(const std::vector<double>& values, const std::vector<double>& key_times, double& value,
            double& time) {
    value = 0.0;
    time = key_times.empty() ? 0.0 : key_times.front();
    bool found = false;
    for (std::size_t j = 0; j < values.size(); ++j) {
        if (std::isnan(values[j])) continue;
        if (!found || values[j] > value) {
            value = values[j];
            time = key_times[j];
            found = true;
        }
    }
}

}  // namespace

// ---- validation -----------------------------------------------------------------------------------

void check_increasing(const std::vector<double>& times, const std::string& name) {
    for (std::size_t i = 0; i < times.size(); ++i) {
        if (!std::isfinite(times[i])) throw InvalidArgument(element(name, i) + ": not finite");
        if (i > 0 && !(times[i] > times[i - 1]))
            throw InvalidArgument(element(name, i) + ": not increasing");
    }
}

// Binary search for each key among the sorted sample times, accepting |t - k| ≤ kTimeMatch.
std::vector<std::size_t> key_sample_indices(const std::vector<double>& times,
                                            const std::vector<double>& key_times) {
    check_increasing(key_times, "key_times");
    std::vector<std::size_t> idx(key_times.size());
    for (std::size_t j = 0; j < key_times.size(); ++j) {
        const double k = key_times[j];
        auto it = std::lower_bound(times.begin(), times.end(), k - kTimeMatch);
        if (it == times.end() || std::abs(*it - k) > kTimeMatch)
            throw InvalidArgument(element("key_times", j) + ": not a sample time (" + std::to_string(k) + ")");
        idx[j] = static_cast<std::size_t>(it - times.begin());
        if (j > 0 && idx[j] == idx[j - 1])
            throw InvalidArgument(element("key_times", j) + ": matches the same sample as key_times[" +
                                  std::to_string(j - 1) + "]");
    }
    return idx;
}

// ---- deviation ------------------------------------------------------------------------------------

std::vector<double> angular_deviation(const std::vector<Quat>& path, const std::vector<Quat>& reference) {
    check_count(reference.size(), path.size(), "reference", "path sample");
    const std::vector<Quat> a = normalized_all(path, "quats");
    const std::vector<Quat> b = normalized_all(reference, "reference");
    std::vector<double> out(a.size());
    for (std::size_t i = 0; i < a.size(); ++i) out[i] = angle_between(a[i], b[i]);
    return out;
}

// ---- speed ----------------------------------------------------------------------------------------

std::vector<double> interval_speeds(const std::vector<double>& times, const std::vector<Quat>& quats) {
    check_increasing(times, "times");
    check_count(quats.size(), times.size(), "quats", "sample time");
    if (times.size() < 2) throw InvalidArgument("times: at least 2 samples needed for speeds, got " +
                                                std::to_string(times.size()));
    const std::vector<Quat> q = normalized_all(quats, "quats");
    std::vector<double> out(q.size() - 1);
    for (std::size_t i = 0; i + 1 < q.size(); ++i) {
        // An interval too short for its angle (subnormal spacing) has a speed beyond double range:
        // refused rather than reported as inf. An interval whose length overflows gives 0.
        const double angle = angle_between(q[i], q[i + 1]);
        out[i] = angle / (times[i + 1] - times[i]);
        if (!std::isfinite(out[i]))
            throw InvalidArgument(element("times", i + 1) + ": speed over the interval from " + element("times", i) +
                                  " overflows (" + shortest(angle) + " rad in " +
                                  shortest(times[i + 1] - times[i]) + " frames)");
    }
    return out;
}

// Key samples p_j split the intervals: interval i lies in segment j when p_j ≤ i < p_{j+1}.
std::vector<double> segment_speed_ratios(const std::vector<double>& times, const std::vector<Quat>& quats,
                                         const std::vector<double>& key_times) {
    const std::vector<double> speeds = interval_speeds(times, quats);
    const std::vector<std::size_t> p = key_sample_indices(times, key_times);
    std::vector<double> out;
    for (std::size_t j = 0; j + 1 < p.size(); ++j) {
        double lo = kInf, hi = 0.0;
        for (std::size_t i = p[j]; i <= p[j + 1]; ++i) {
            const double s = speed_at_sample(times, speeds, i, p[j], p[j + 1]);
            lo = std::min(lo, s);
            hi = std::max(hi, s);
        }
        out.push_back(ratio_of(lo, hi));
    }
    return out;
}

std::vector<double> segment_speed_ratios_from_velocity(const std::vector<double>& times,
                                                       const std::vector<Vec3>& velocities,
                                                       const std::vector<double>& key_times) {
    check_increasing(times, "times");
    check_count(velocities.size(), times.size(), "velocities", "sample time");
    for (std::size_t i = 0; i < velocities.size(); ++i) check_finite(velocities[i], element("velocities", i));
    const std::vector<std::size_t> p = key_sample_indices(times, key_times);
    std::vector<double> out;
    for (std::size_t j = 0; j + 1 < p.size(); ++j) {
        if (p[j + 1] - p[j] < 2) {
            out.push_back(kNaN);
            continue;
        }
        double lo = kInf, hi = 0.0;
        for (std::size_t i = p[j] + 1; i < p[j + 1]; ++i) {
            const double s = glm::length(velocities[i]);
            lo = std::min(lo, s);
            hi = std::max(hi, s);
        }
        out.push_back(ratio_of(lo, hi));
    }
    return out;
}

// ---- length ---------------------------------------------------------------------------------------

double path_length(const std::vector<Quat>& quats) {
    const std::vector<Quat> q = normalized_all(quats, "quats");
    double sum = 0.0;
    for (std::size_t i = 0; i + 1 < q.size(); ++i) sum += angle_between(q[i], q[i + 1]);
    return sum;
}

// ---- continuity at keys ---------------------------------------------------------------------------

// Left samples stop at the previous key's sample, right samples at the next key's sample.
KeyJumps key_jumps(const std::vector<double>& times, const std::vector<Quat>& quats,
                   const std::vector<double>& key_times) {
    check_increasing(times, "times");
    check_count(quats.size(), times.size(), "quats", "sample time");
    const std::vector<Quat> q = normalized_all(quats, "quats");
    const std::vector<std::size_t> p = key_sample_indices(times, key_times);
    KeyJumps out;
    out.velocity.assign(p.size(), kNaN);
    out.acceleration.assign(p.size(), kNaN);
    for (std::size_t j = 1; j + 1 < p.size(); ++j) {
        Vec3 wl, al, wr, ar;
        const int ml = one_sided(times, q, p[j], -1, p[j - 1], p[j], wl, al);
        const int mr = one_sided(times, q, p[j], +1, p[j], p[j + 1], wr, ar);
        if (ml >= 1 && mr >= 1) out.velocity[j] = glm::length(wr - wl);
        if (ml >= 2 && mr >= 2) out.acceleration[j] = glm::length(ar - al);
    }
    return out;
}

// ---- gimbal lock ----------------------------------------------------------------------------------

std::vector<double> gimbal_distances(const std::vector<Vec3>& angles, EulerOrder order) {
    std::vector<double> out(angles.size());
    for (std::size_t i = 0; i < angles.size(); ++i) {
        check_finite(angles[i], element("angles", i));
        out[i] = gimbal_distance(angles[i], order);
    }
    return out;
}

std::vector<double> gimbal_distances(const std::vector<Quat>& quats, EulerOrder order) {
    const std::vector<Quat> q = normalized_all(quats, "quats");
    std::vector<double> out(q.size());
    for (std::size_t i = 0; i < q.size(); ++i) out[i] = gimbal_distance(quat_to_euler(q[i], order), order);
    return out;
}

GimbalApproach closest_gimbal_approach(const std::vector<double>& times,
                                       const std::vector<double>& distances, double tolerance) {
    check_count(distances.size(), times.size(), "distances", "sample time");
    if (times.empty()) throw InvalidArgument("times: at least 1 sample needed, got 0");
    if (!(tolerance >= 0.0) || !std::isfinite(tolerance))
        throw InvalidArgument("tolerance: must be finite and >= 0, got " + std::to_string(tolerance));
    for (std::size_t i = 0; i < times.size(); ++i) {
        check_finite(times[i], element("times", i));
        check_finite(distances[i], element("distances", i));
        if (distances[i] < 0.0) throw InvalidArgument(element("distances", i) + ": negative");
    }
    GimbalApproach out;
    out.distance = *std::min_element(distances.begin(), distances.end());
    for (std::size_t i = 0; i < times.size(); ++i)
        if (distances[i] <= out.distance + tolerance) out.times.push_back(times[i]);
    return out;
}

// ---- everything for one path ----------------------------------------------------------------------

PathMetrics path_metrics(const std::vector<double>& times, const std::vector<Quat>& quats,
                         const std::vector<double>& key_times, const std::vector<Quat>& reference,
                         const std::vector<Quat>& key_quats) {
    check_increasing(times, "times");
    check_count(quats.size(), times.size(), "quats", "sample time");
    const std::vector<std::size_t> p = key_sample_indices(times, key_times);
    if (!key_quats.empty()) check_count(key_quats.size(), key_times.size(), "key_quats", "key time");

    PathMetrics m;
    m.deviation = angular_deviation(quats, reference);
    double sum = 0.0;
    for (std::size_t i = 0; i < m.deviation.size(); ++i) {
        sum += m.deviation[i];
        if (i == 0 || m.deviation[i] > m.max_deviation) {
            m.max_deviation = m.deviation[i];
            m.max_deviation_time = times[i];
        }
    }
    m.mean_deviation = m.deviation.empty() ? 0.0 : sum / static_cast<double>(m.deviation.size());

    m.speeds = interval_speeds(times, quats);
    m.segment_speed_ratios = segment_speed_ratios(times, quats, key_times);
    m.speed_ratio = 1.0;
    for (double r : m.segment_speed_ratios) m.speed_ratio = std::max(m.speed_ratio, r);

    m.path_length = path_length(quats);
    std::vector<Quat> keys = key_quats;
    if (keys.empty())
        for (std::size_t j : p) keys.push_back(quats[j]);
    m.key_path_length = path_length(keys);
    // Keys that coincide (a whole turn, or no motion) have no meaningful ratio: inf if the path moves.
    constexpr double kStill = 1e-9;
    m.path_length_ratio = m.key_path_length > kStill ? m.path_length / m.key_path_length
                          : (m.path_length > kStill ? kInf : 1.0);

    m.key_jumps = key_jumps(times, quats, key_times);
    max_at(m.key_jumps.velocity, key_times, m.max_velocity_jump, m.max_velocity_jump_time);
    max_at(m.key_jumps.acceleration, key_times, m.max_acceleration_jump, m.max_acceleration_jump_time);
    return m;
}

}  // namespace quatcurve
