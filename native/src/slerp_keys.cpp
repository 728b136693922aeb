// reduce_slerp and gltf_slerp (slerp_keys.hpp).
#include "quatcurve/slerp_keys.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "quatcurve/curve.hpp"
#include "quatcurve/errors.hpp"
#include "quatcurve/quat.hpp"

namespace quatcurve {

namespace {

double length(const Quat& q) { return std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z); }

// gltf_slerp on unit inputs (no checks: the loops below call it millions of times).
Quat slerp_unit(const Quat& a, const Quat& b, double t) {
    const double dot = a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z;
    const double s = dot < 0.0 ? -1.0 : 1.0;
    const Quat c = b * s;
    const double angle = 2.0 * std::atan2(length(a - c), length(a + c));
    Quat out;
    if (angle < 1e-7) {
        out = a * (1.0 - t) + c * t;
    } else {
        const double sa = std::sin(angle);
        out = a * (std::sin(angle * (1.0 - t)) / sa) + c * (std::sin(angle * t) / sa);
    }
    return out * (1.0 / length(out));
}

// Angle between unit quaternions, sign-invariant: 4·atan2(|a − s·b|, |a + s·b|) (quat.hpp).
double angle_unit(const Quat& a, const Quat& b) {
    const double dot = a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z;
    const Quat c = dot < 0.0 ? -b : b;
    return 4.0 * std::atan2(length(a - c), length(a + c));
}

// Largest error of the slerp from sample i to sample j over the samples strictly between them;
// returns early once above `limit`.
double segment_error(const std::vector<double>& t, const std::vector<Quat>& q, std::size_t i, std::size_t j,
                     double limit) {
    double worst = 0.0;
    const double span = t[j] - t[i];
    for (std::size_t k = i + 1; k < j; ++k) {
        const double e = angle_unit(slerp_unit(q[i], q[j], (t[k] - t[i]) / span), q[k]);
        if (e > worst) {
            worst = e;
            if (worst > limit) break;
        }
    }
    return worst;
}

}  // namespace

Quat gltf_slerp(const Quat& a, const Quat& b, double t) {
    check_finite(t, "t");
    return slerp_unit(normalized_rotation(a, "a"), normalized_rotation(b, "b"), t);
}

std::vector<Quat> play_slerp_keys(const std::vector<double>& key_times, const std::vector<Quat>& keys,
                                  const std::vector<double>& at, bool cyclic) {
    const std::size_t n = key_times.size();
    if (keys.size() != n)
        throw InvalidArgument("keys: " + std::to_string(keys.size()) + " rotations for " + std::to_string(n) + " times");
    if (n == 0) throw InvalidArgument("key_times: no keys");
    std::vector<Quat> stored(n);
    for (std::size_t k = 0; k < n; ++k) {
        if (!std::isfinite(key_times[k]) || (k && !(key_times[k] > key_times[k - 1])))
            throw InvalidArgument("key_times[" + std::to_string(k) + "]: not finite and increasing");
        const Quat& q = keys[k];
        const Quat f(static_cast<float>(q.w), static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z));
        stored[k] = normalized_rotation(f, "keys", k);
    }
    const double first = key_times.front(), period = key_times.back() - first;
    std::vector<Quat> out(at.size());
    for (std::size_t i = 0; i < at.size(); ++i) {
        check_finite(at[i], "at");
        double t = at[i];
        if (cyclic && period > 0.0) t = first + (t - first) - std::floor((t - first) / period) * period;
        const std::size_t j = static_cast<std::size_t>(
            std::upper_bound(key_times.begin(), key_times.end(), t) - key_times.begin());
        if (j == 0) out[i] = stored.front();
        else if (j == n) out[i] = stored.back();
        else out[i] = slerp_unit(stored[j - 1], stored[j], (t - key_times[j - 1]) / (key_times[j] - key_times[j - 1]));
    }
    return out;
}

SlerpKeys reduce_slerp(const std::vector<double>& times, const std::vector<Quat>& quats, double tolerance,
                       bool cyclic) {
    const std::size_t n = times.size();
    if (quats.size() != n)
        throw InvalidArgument("quats: " + std::to_string(quats.size()) + " rows for " + std::to_string(n) + " times");
    if (!std::isfinite(tolerance) || tolerance < 0.0) throw InvalidArgument("tolerance: must be finite and >= 0");
    if (n == 0) throw InvalidArgument("times: no samples");
    std::vector<Quat> q(n);
    for (std::size_t k = 0; k < n; ++k) {
        if (!std::isfinite(times[k]))
            throw InvalidArgument("times[" + std::to_string(k) + "]: not finite");
        if (k && !(times[k] > times[k - 1]))
            throw InvalidArgument("times[" + std::to_string(k) + "]: not increasing");
        q[k] = normalized_rotation(quats[k], "quats", k);
    }
    if (cyclic && n >= 2) {  // a loop: the last sample is the first rotation, snapped onto it
        const double angle = angle_unit(q[0], q[n - 1]);
        if (!(angle <= kLoopTolerance)) {
            char deg[32], t0[32], t1[32];
            std::snprintf(deg, sizeof deg, "%.4f", angle * 57.29577951308232);
            std::snprintf(t0, sizeof t0, "%.9g", times[0]);
            std::snprintf(t1, sizeof t1, "%.9g", times[n - 1]);
            throw InvalidArgument("cyclic: the last sample (sample " + std::to_string(n - 1) + ", time " + t1 +
                                  ") is not the first sample's rotation (sample 0, time " + t0 + "): they are " +
                                  deg + "° apart; key the first pose again at time " + t1);
        }
        q[n - 1] = glm::dot(q[n - 1], q[0]) < 0.0 ? -q[0] : q[0];
    }

    SlerpKeys out;
    out.indices.push_back(0);
    std::size_t i = 0;
    while (i + 1 < n) {
        // Doubling: the last end known to pass (i + 1 always does: no sample between) and the first
        // known to fail.
        std::size_t good = i + 1, bad = n;
        for (std::size_t step = 2; i + step < n; step *= 2) {
            if (segment_error(times, q, i, i + step, tolerance) <= tolerance) {
                good = i + step;
            } else {
                bad = i + step;
                break;
            }
        }
        if (bad == n && good != n - 1) {
            if (segment_error(times, q, i, n - 1, tolerance) <= tolerance) good = n - 1;
            else bad = n - 1;
        }
        while (bad - good > 1) {
            const std::size_t mid = good + (bad - good) / 2;
            if (segment_error(times, q, i, mid, tolerance) <= tolerance) good = mid;
            else bad = mid;
        }
        out.indices.push_back(good);
        i = good;
    }

    // The keys in one hemisphere chain, and the error over every sample.
    out.quats.reserve(out.indices.size());
    for (std::size_t a = 0; a < out.indices.size(); ++a) {
        Quat k = q[out.indices[a]];
        if (a && glm::dot(k, out.quats.back()) < 0.0) k = -k;
        out.quats.push_back(k);
    }
    for (std::size_t a = 0; a + 1 < out.indices.size(); ++a) {
        const double e = segment_error(times, q, out.indices[a], out.indices[a + 1], INFINITY);
        if (e > out.max_error) out.max_error = e;
    }
    return out;
}

}  // namespace quatcurve
