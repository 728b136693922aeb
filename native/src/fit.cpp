// Fitting F-curves through an animator's keys (see fit.hpp for what each function promises).
#include "quatcurve/fit.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "quatcurve/errors.hpp"

namespace quatcurve {

std::vector<double> fit_sample_frames(const std::vector<double>& key_frames, int subframes) {
    if (subframes < 1) throw InvalidArgument("subframes: must be at least 1");
    if (key_frames.empty()) return {};
    for (std::size_t k = 0; k < key_frames.size(); ++k) {
        if (!std::isfinite(key_frames[k]))
            throw InvalidArgument("key_frames[" + std::to_string(k) + "]: non-finite");
        if (k > 0 && !(key_frames[k] > key_frames[k - 1]))
            throw InvalidArgument("key_frames[" + std::to_string(k) + "]: not increasing");
    }
    const double sub = subframes;
    const double first = std::ceil(key_frames.front() * sub - 1e-9);
    const double last = std::floor(key_frames.back() * sub + 1e-9);
    if (!(last - first < 1e8)) throw InvalidArgument("key_frames: more than 100000000 samples");
    std::vector<double> out;
    out.reserve(static_cast<std::size_t>(std::max(0.0, last - first + 1)) + key_frames.size());
    std::size_t k = 0;  // the first key not yet merged
    for (double m = first; m <= last; m += 1.0) {
        const double t = m / sub;
        while (k < key_frames.size() && key_frames[k] < t) out.push_back(key_frames[k++]);
        // The keys on either side of t: grid points within 1e-6 frames give way to the key.
        const bool near = (k < key_frames.size() && key_frames[k] - t < 1e-6) ||
                          (k > 0 && t - key_frames[k - 1] < 1e-6);
        if (!near) out.push_back(t);
    }
    while (k < key_frames.size()) out.push_back(key_frames[k++]);
    return out;
}

KeyFit fit_through_keys(const Curve& curve, const std::vector<double>& key_frames,
                        const std::vector<double>& key_values, const RotationMode& mode, int subframes,
                        double tolerance, double min_gap) {
    const std::size_t K = key_frames.size(), C = channel_count(mode);
    if (K < 2) throw InvalidArgument("key_frames: at least two keys to fit through");
    if (key_values.size() != K * C)
        throw InvalidArgument("key_values: " + std::to_string(key_values.size()) + " values for " +
                              std::to_string(K) + " keys of " + std::to_string(C) + " channels");
    KeyFit fit;
    fit.times = fit_sample_frames(key_frames, subframes);
    const std::vector<double>& t = fit.times;
    const std::size_t N = t.size();
    fit.forced.resize(K);
    for (std::size_t k = 0, i = 0; k < K; ++k) {
        while (t[i] != key_frames[k]) ++i;  // every key is a sample (fit_sample_frames)
        fit.forced[k] = i;
    }
    const std::vector<std::size_t>& forced = fit.forced;
    // The curve at every sample (Curve::sample writes all of it: no zero-fill first).
    std::unique_ptr<double[]> qd(new double[4 * N]);
    curve.sample(t.data(), N, qd.get());
    // u along each key segment (samples of key segment k: forced[k] … forced[k+1])
    auto u_of = [&](std::size_t i, std::size_t k) {
        return (t[i] - key_frames[k]) / (key_frames[k + 1] - key_frames[k]);
    };
    const double* kv = key_values.data();
    if (mode.kind == RotationMode::Kind::quaternion) {
        // Straight into the reducer's input, sample after sample: the keys as given, between them
        // the curve scaled by the keys' norms (interpolated) in the sign of the segment's first key.
        std::vector<Quat> a;
        a.reserve(N);
        for (std::size_t k = 0; k + 1 < K; ++k) {
            const double* ka = kv + 4 * k;
            const double* kb = kv + 4 * (k + 1);
            const double* r = &qd[4 * forced[k]];
            const double sign = r[0] * ka[0] + r[1] * ka[1] + r[2] * ka[2] + r[3] * ka[3] < 0.0 ? -1.0 : 1.0;
            const double n0 = std::sqrt(ka[0] * ka[0] + ka[1] * ka[1] + ka[2] * ka[2] + ka[3] * ka[3]);
            const double n1 = std::sqrt(kb[0] * kb[0] + kb[1] * kb[1] + kb[2] * kb[2] + kb[3] * kb[3]);
            a.push_back(from_wxyz(ka));
            for (std::size_t i = forced[k] + 1; i < forced[k + 1]; ++i) {
                const double u = u_of(i, k), s = sign * ((1 - u) * n0 + u * n1);
                const double* q = &qd[4 * i];
                a.push_back(Quat(q[0] * s, q[1] * s, q[2] * s, q[3] * s));
            }
        }
        a.push_back(from_wxyz(kv + 4 * (K - 1)));
        fit.keys = fit_keys(t, a, forced, tolerance, KeyInterpolation::BEZIER, false, min_gap);
        return fit;
    }
    std::vector<Quat> q(N);
    for (std::size_t i = 0; i < N; ++i) q[i] = from_wxyz(&qd[4 * i]);
    std::vector<double> values(N * C);
    switch (mode.kind) {
        case RotationMode::Kind::euler:
            for (std::size_t k = 0; k + 1 < K; ++k) {
                const std::vector<Quat> span(q.begin() + static_cast<std::ptrdiff_t>(forced[k]),
                                             q.begin() + static_cast<std::ptrdiff_t>(forced[k + 1]));
                const std::vector<double> v = quats_to_channels(span, mode, kv + C * k, 1);
                std::copy(v.begin(), v.end(), values.begin() + static_cast<std::ptrdiff_t>(C * forced[k]));
            }
            break;
        case RotationMode::Kind::axis_angle:
            for (std::size_t k = 0; k + 1 < K; ++k) {
                const std::vector<Quat> span(q.begin() + static_cast<std::ptrdiff_t>(forced[k]),
                                             q.begin() + static_cast<std::ptrdiff_t>(forced[k + 1]) + 1);
                const std::vector<double> v = axis_angle_span_channels(span, kv + C * k, kv + C * (k + 1));
                std::copy(v.begin(), v.end(), values.begin() + static_cast<std::ptrdiff_t>(C * forced[k]));
                const double n0 = std::sqrt(kv[C * k + 1] * kv[C * k + 1] + kv[C * k + 2] * kv[C * k + 2] +
                                            kv[C * k + 3] * kv[C * k + 3]);
                const double n1 = std::sqrt(kv[C * k + 5] * kv[C * k + 5] + kv[C * k + 6] * kv[C * k + 6] +
                                            kv[C * k + 7] * kv[C * k + 7]);
                for (std::size_t i = forced[k]; i < forced[k + 1]; ++i) {
                    const double u = u_of(i, k), scale = (1 - u) * n0 + u * n1;
                    for (std::size_t c = 1; c < 4; ++c) values[C * i + c] *= scale;
                }
            }
            break;
        case RotationMode::Kind::quaternion:
            break;  // above
    }
    for (std::size_t k = 0; k < K; ++k) std::copy(kv + C * k, kv + C * (k + 1), values.begin() + static_cast<std::ptrdiff_t>(C * forced[k]));
    switch (mode.kind) {
        case RotationMode::Kind::euler: {
            std::vector<Vec3> a(N);
            for (std::size_t i = 0; i < N; ++i) a[i] = Vec3(values[3 * i], values[3 * i + 1], values[3 * i + 2]);
            fit.keys = fit_keys_euler(t, a, mode.order, forced, tolerance, KeyInterpolation::BEZIER, false, min_gap);
            break;
        }
        case RotationMode::Kind::axis_angle: {
            std::vector<Vec4> a(N);
            for (std::size_t i = 0; i < N; ++i)
                a[i] = Vec4(values[4 * i], values[4 * i + 1], values[4 * i + 2], values[4 * i + 3]);
            fit.keys = fit_keys_axis_angle(t, a, forced, tolerance, KeyInterpolation::BEZIER, false, min_gap);
            break;
        }
        case RotationMode::Kind::quaternion:
            break;  // above
    }
    return fit;
}

}  // namespace quatcurve
