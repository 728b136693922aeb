// Fitting F-curves through an animator's keys (see fit.hpp for what each function promises).
#include "quatcurve/fit.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "quatcurve/bound.hpp"
#include "quatcurve/errors.hpp"

namespace quatcurve {

constexpr double kTwoPiFit = 6.283185307179586476925286766559;


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

namespace {

// The fit matches the method within this share of the tolerance at its samples: the rest is the
// room the proof between samples needs (bound.hpp), which is what the tolerance promises.
constexpr double kFitShare = 0.9;
// Rounds of "prove, add the times that failed as samples, fit again".
constexpr int kProofRounds = 8;
// The proof halves intervals down to this (frames): a change of Euler branch beside a key at gimbal
// lock spans 0.0105 frame, and its fast channels need steps far below 1/1024 frame to be bounded.
constexpr double kProofMinStep = 1.0 / 65536.0;
// An added sample keeps this far from the samples beside it (beyond Blender's 1e-4 key snap, and
// distinct in float32 up to frame ~3e4).
constexpr double kAddedSampleGap = 1.0 / 1024.0;
// Two Euler rows that agree within this (radians, per angle) are on the same branch: branches differ
// by about π, while near gimbal lock the first and last angles of the same rotation are ill-conditioned
// (a float32 key's 1e-7 rad moves them by 1e-7/cos b); the F-curve bridges what is left, and the
// proof measures it.
constexpr double kSameAngles = 1e-2;
// A change of Euler branch between keys whose path passes no nearer than this to gimbal lock is
// refused (radians: 5°, a visible swing of about 10°).
constexpr double kSwitchRefused = 5.0 * kTwoPiFit / 360.0;
// The sample beside a key at gimbal lock, in min_gaps from it (the nearest a generated key may sit).
constexpr double kBesideLock = 1.05;
// cos(middle angle) below this: the key sits at gimbal lock.
constexpr double kAtLock = 1e-5;

std::size_t middle_axis(EulerOrder order) { return static_cast<std::size_t>(euler_middle_axis(order)); }

bool same_angles(const double* a, const double* b) {
    return std::fabs(a[0] - b[0]) < kSameAngles && std::fabs(a[1] - b[1]) < kSameAngles &&
           std::fabs(a[2] - b[2]) < kSameAngles;
}

// Rows of V (n × 3) shifted by whole turns per channel so that row r comes nearest `target`.
void shift_turns(std::vector<double>& V, std::size_t r, const double* target) {
    for (std::size_t c = 0; c < 3; ++c) {
        const double turns = std::round((target[c] - V[3 * r + c]) / kTwoPiFit);
        if (turns == 0.0) continue;
        for (std::size_t i = c; i < V.size(); i += 3) V[i] += turns * kTwoPiFit;
    }
}

// V (n × 3 Euler rows of one path) as the continuous lift that passes through `target` at row r, if
// one does: the same path on the other branch ((a + π, π − b, c + π), b the middle angle) or whole
// turns away. Returns whether row r then equals target.
bool lift_through(std::vector<double>& V, std::size_t r, const double* target, std::size_t mid) {
    shift_turns(V, r, target);
    if (same_angles(&V[3 * r], target)) return true;
    std::vector<double> W = V;
    for (std::size_t i = 0; i < W.size(); i += 3)
        for (std::size_t c = 0; c < 3; ++c) W[i + c] = c == mid ? kTwoPiFit / 2 - W[i + c] : W[i + c] + kTwoPiFit / 2;
    shift_turns(W, r, target);
    if (!same_angles(&W[3 * r], target)) return false;
    V.swap(W);
    return true;
}

void fit_round(const Curve& curve, const std::vector<double>& key_frames, const std::vector<double>& key_values,
               const RotationMode& mode, double tolerance, double min_gap, KeyFit& fit);

// Euler channel values of one key segment's samples q (its two keys included), joining the keys as
// keyed, `start` and `end`. The path is followed continuously from start (or back from end); when it
// reaches the other key on another Euler branch, the channels change branch once:
// - at a key at gimbal lock, in the sample interval beside it (fit_through_keys puts a sample
//   1.05·min_gap from every such key): at the lock the first and last angles move together without
//   moving the rotation, so the change costs what the path moves off the lock in that interval;
// - otherwise at the sample nearest gimbal lock (switch_at; lock_distance says how near).
// The keys keep their values: the method's curve is made from them, so a refit sees the same path.
std::vector<double> euler_span_values(const std::vector<Quat>& q, const RotationMode& mode, const double* start,
                                      const double* end, std::size_t& switch_at, double& lock_distance) {
    const std::size_t n = q.size(), mid = middle_axis(mode.order);
    switch_at = 0;
    lock_distance = 0.0;
    std::vector<double> V = quats_to_channels(q, mode, start, 1);
    const bool starts = lift_through(V, 0, start, mid);
    if (starts && same_angles(&V[3 * (n - 1)], end)) return V;
    std::vector<double> B = quats_to_channels(q, mode, end, 1);
    const bool ends = lift_through(B, n - 1, end, mid);
    if (ends && same_angles(&B[0], start)) return B;
    std::size_t s;
    if (n > 2 && std::fabs(std::cos(start[mid])) < kAtLock) {
        s = 1;  // leave the lock on the path back from end at once (beside keeps a sample near)
    } else if (n > 2 && std::fabs(std::cos(end[mid])) < kAtLock) {
        s = n - 1;  // arrive at the lock on the path from start
    } else {
        s = 1;
        double nearest = HUGE_VAL;
        for (std::size_t i = 1; i + 1 < n; ++i) {
            const double g = std::fabs(std::cos(V[3 * i + mid]));
            if (g < nearest) {
                nearest = g;
                s = i;
            }
        }
        lock_distance = gimbal_distance(Vec3(V[3 * s], V[3 * s + 1], V[3 * s + 2]), mode.order);
    }
    if (!starts) lift_through(V, 0, start, mid);  // the rows before s: from start whatever it matched
    if (!ends) lift_through(B, n - 1, end, mid);
    std::copy(B.begin() + static_cast<std::ptrdiff_t>(3 * s), B.end(), V.begin() + static_cast<std::ptrdiff_t>(3 * s));
    std::copy(start, start + 3, V.begin());
    std::copy(end, end + 3, V.end() - 3);
    switch_at = s;
    return V;
}

}  // namespace

KeyFit fit_through_keys(const Curve& curve, const std::vector<double>& key_frames,
                        const std::vector<double>& key_values, const RotationMode& mode, int subframes,
                        double tolerance, double min_gap) {
    const std::size_t K = key_frames.size(), C = channel_count(mode);
    if (K < 2) throw InvalidArgument("key_frames: at least two keys to fit through");
    if (key_values.size() != K * C)
        throw InvalidArgument("key_values: " + std::to_string(key_values.size()) + " values for " +
                              std::to_string(K) + " keys of " + std::to_string(C) + " channels");
    if (!(tolerance > 0.0) || !std::isfinite(tolerance)) throw InvalidArgument("tolerance: must be finite and > 0");
    KeyFit fit;
    fit.times = fit_sample_frames(key_frames, subframes);
    if (mode.kind != RotationMode::Kind::quaternion) {
        // An Euler key at gimbal lock: where the path reaches or leaves it on another triple than the
        // keyed one, the channels change branch in the sample interval beside it (euler_span_values).
        // An axis-angle key at the rest pose (angle a multiple of 360°): its axis is any axis, and
        // the path leaves or reaches it along its own. Samples 1.05·min_gap from the key (the nearest
        // a generated key may sit) make that change where the rotation is still within a few
        // hundredths of a degree of the key.
        const bool euler = mode.kind == RotationMode::Kind::euler;
        const std::size_t mid = euler ? middle_axis(mode.order) : 0;
        std::vector<double> extra;
        for (std::size_t k = 0; k < K; ++k) {
            const double singular = euler ? std::fabs(std::cos(key_values[C * k + mid]))
                                          : std::fabs(std::sin(0.5 * key_values[C * k]));
            if (!(singular < kAtLock)) continue;
            if (k + 1 < K && key_frames[k] + kBesideLock * min_gap < key_frames[k + 1] - min_gap)
                extra.push_back(static_cast<float>(key_frames[k] + kBesideLock * min_gap));
            if (k > 0 && key_frames[k] - kBesideLock * min_gap > key_frames[k - 1] + min_gap)
                extra.push_back(static_cast<float>(key_frames[k] - kBesideLock * min_gap));
        }
        if (!extra.empty()) {
            fit.times.insert(fit.times.end(), extra.begin(), extra.end());
            std::sort(fit.times.begin(), fit.times.end());
            fit.times.erase(std::unique(fit.times.begin(), fit.times.end()), fit.times.end());
        }
    }
    const CurveMotion method(curve);
    for (int round = 0;; ++round) {
        fit_round(curve, key_frames, key_values, mode, tolerance * kFitShare, min_gap, fit);
        std::vector<FCurveKeys> channels(fit.keys.channels.begin(), fit.keys.channels.end());
        const PlaybackMotion playback(std::move(channels), fit.keys.interpolation, mode);
        fit.proof = prove_within(playback, method, fit.times, tolerance, kProofMinStep);
        if (fit.proof.proven() || round + 1 >= kProofRounds) break;
        // The times that failed (and the middle of each interval left unproven) become samples.
        std::vector<double> add = fit.proof.violations;
        for (const auto& span : fit.proof.unproven) add.push_back(0.5 * (span.first + span.second));
        std::sort(add.begin(), add.end());
        std::vector<double> merged;
        merged.reserve(fit.times.size() + add.size());
        // A failing time hard by a sample (a Bezier leaving a key bends between that sample and the
        // next) is moved into the interval, an eighth of it from the near end: the next round then
        // holds the bend there, and the rounds after close in on the key.
        std::size_t j = 0, added = 0;
        double below = -HUGE_VAL;  // the sample before the current interval
        for (double t : fit.times) {
            for (; j < add.size() && add[j] < t; ++j) {
                const double before = merged.empty() ? -HUGE_VAL : merged.back();
                const double g = std::isfinite(below) ? std::fmax(kAddedSampleGap, 0.125 * (t - below)) : kAddedSampleGap;
                const double at = std::isfinite(below) ? std::clamp(add[j], below + g, t - g) : add[j];
                if (at - before > kAddedSampleGap && t - at > kAddedSampleGap) {
                    merged.push_back(at);
                    ++added;
                }
            }
            merged.push_back(t);
            below = t;
        }
        if (added == 0) break;
        fit.times.swap(merged);
    }
    return fit;
}

namespace {

// One fit at the samples fit.times (every key among them): the channel values along the curve that
// join the keys as written, then fit_keys with the keys forced.
void fit_round(const Curve& curve, const std::vector<double>& key_frames, const std::vector<double>& key_values,
               const RotationMode& mode, double tolerance, double min_gap, KeyFit& fit) {
    const std::size_t K = key_frames.size(), C = channel_count(mode);
    const std::vector<double>& t = fit.times;
    const std::size_t N = t.size();
    fit.forced.resize(K);
    for (std::size_t k = 0, i = 0; k < K; ++k) {
        while (t[i] != key_frames[k]) ++i;  // every key is a sample
        fit.forced[k] = i;
    }
    const std::vector<std::size_t>& forced = fit.forced;
    fit.switches.clear();
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
        return;
    }
    std::vector<Quat> q(N);
    for (std::size_t i = 0; i < N; ++i) q[i] = from_wxyz(&qd[4 * i]);
    std::vector<double> values(N * C);
    switch (mode.kind) {
        case RotationMode::Kind::euler:
            for (std::size_t k = 0; k + 1 < K; ++k) {
                const std::vector<Quat> span(q.begin() + static_cast<std::ptrdiff_t>(forced[k]),
                                             q.begin() + static_cast<std::ptrdiff_t>(forced[k + 1]) + 1);
                std::size_t switch_at = 0;
                double lock = 0.0;
                const std::vector<double> v = euler_span_values(span, mode, kv + C * k, kv + C * (k + 1), switch_at, lock);
                if (lock > kSwitchRefused) {
                    // Changing branch away from gimbal lock swings the rotation by about twice the
                    // distance from it: no channel path follows the method there. (Nearer the lock
                    // the change is made, the proof bounds what it costs and the result says so.)
                    char text[400];
                    std::snprintf(text, sizeof text,
                                  "keys at frames %g and %g: the method's path reaches the second key on the other "
                                  "Euler branch and passes no nearer than %.2f° to gimbal lock (near frame %.2f), so "
                                  "Euler channels cannot follow it there: convert the target to quaternion first",
                                  key_frames[k], key_frames[k + 1], lock * 360.0 / kTwoPiFit, t[forced[k] + switch_at]);
                    throw InvalidArgument(text);
                }
                if (switch_at > 0) fit.switches.push_back({k, t[forced[k] + switch_at]});
                std::copy(v.begin(), v.end() - 3, values.begin() + static_cast<std::ptrdiff_t>(C * forced[k]));
            }
            break;
        case RotationMode::Kind::axis_angle:
            for (std::size_t k = 0; k + 1 < K; ++k) {
                const std::vector<Quat> span(q.begin() + static_cast<std::ptrdiff_t>(forced[k]),
                                             q.begin() + static_cast<std::ptrdiff_t>(forced[k + 1]) + 1);
                std::size_t split = span.size();
                const std::vector<double> v = axis_angle_span_channels(span, kv + C * k, kv + C * (k + 1), &split);
                if (split < span.size()) {
                    // The channels leave one turn of the angle for another (or flip the axis with the
                    // angle) between samples split-1 and split. That costs nothing only through the
                    // identity, where every axis is the same rotation, and only across one multiple
                    // of 2π: the switch sits at the sample nearest the identity; further from it than
                    // 5°, or with the angle moving by more than π between the two samples (a whole
                    // turn played between them), no channel path follows the method.
                    const double from_identity = 2.0 * std::acos(std::min(1.0, std::fabs(span[split].w)));
                    const double jump = std::fabs(v[4 * split] - v[4 * split - 4]);
                    if (from_identity > kSwitchRefused || jump > 0.5 * kTwoPiFit) {
                        char text[480];
                        std::snprintf(text, sizeof text,
                                      "keys at frames %g and %g: the method's path reaches the second key's axis-angle "
                                      "values only on another turn of the angle, which channels can change only "
                                      "where the rotation passes through the rest pose, and the path passes no "
                                      "nearer than %.2f° to it (near frame %.2f)%s: convert the target to "
                                      "quaternion first",
                                      key_frames[k], key_frames[k + 1], from_identity * 360.0 / kTwoPiFit,
                                      t[forced[k] + split],
                                      jump > 0.5 * kTwoPiFit ? " and would have to make a whole turn there" : "");
                        throw InvalidArgument(text);
                    }
                    fit.switches.push_back({k, t[forced[k] + split]});
                }
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
    for (std::size_t k = 0; k < K; ++k)
        std::copy(kv + C * k, kv + C * (k + 1), values.begin() + static_cast<std::ptrdiff_t>(C * forced[k]));
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
}

}  // namespace

}  // namespace quatcurve
