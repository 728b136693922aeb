// Key reduction with a guaranteed angular error bound (see reduce.hpp for the contract): the
// orchestration. The stages live in their own files (reduce_impl.hpp lists them):
//
//   reduce_problem.cpp  the samples in channel space (w, x, y, z; X, Y, Z angles; or angle, axis
//                       x, y, z), the reference
//                       rotation of every sample and a second-order error metric (angle² ≈ eᵀ·M·e
//                       for a small channel error e);
//   reduce_fit.cpp      a Fitter fits one segment [i, j] of a set of channels (LINEAR: the chord;
//                       BEZIER: the two inner control values per channel by weighted least squares
//                       in M, then iterative reweighting toward the minimax fit) and tests the exact
//                       rotation error at every sample inside;
//   reduce_select.cpp   select_keys picks keys greedily (farthest feasible end by exponential +
//                       binary search) and then removes keys whose neighbours join; remove_keys
//                       repeats that removal once the other channels are final;
//   reduce_verify.cpp   verify_and_repair evaluates every sample exactly as Blender does
//                       (blender_eval.hpp) and refits or splits failing segments.
#include "quatcurve/reduce.hpp"

#include <algorithm>
#include <utility>

#include "quatcurve/blender_eval.hpp"
#include "reduce_impl.hpp"

namespace quatcurve {

std::size_t ReducedKeys::key_count() const {
    std::size_t total = 0;
    for (const ReducedChannel& ch : channels) total += ch.indices.size();
    return total;
}

using namespace reduce_impl;

namespace reduce_impl {

namespace {

// The verification threshold (a margin below the tolerance for Blender's own float32 rotation
// building) and the fits' target angle below it.
struct Thresholds {
    double verify_angle, fit_angle;
};

Thresholds thresholds(double tolerance) {
    const double verify_angle = tolerance > 2.0 * kVerifyMargin ? tolerance - kVerifyMargin : 0.5 * tolerance;
    return {verify_angle, verify_angle - std::min(kFitMarginAbs, kFitMarginRel * verify_angle)};
}

}  // namespace

ReducedKeys reduce(const Problem& p, double tolerance, KeyInterpolation ipo, bool synchronized,
                   bool free_handle_frames) {
    check_tolerance(tolerance);
    check_float32_storage(p, tolerance);
    const int C = p.C;
    const double fit_angle = thresholds(tolerance).fit_angle;
    const double verify_tan2 = tan2_half(thresholds(tolerance).verify_angle);

    // `beat` (synchronized runs): the run gives up (returns false) as soon as its keys in total
    // cannot come out fewer than `beat` — verification only ever adds keys, and every channel keeps
    // at least the forced samples (the first and last included) — so the result is the one a full
    // run would lose with. (A per-channel run always runs to the end: its removal pass below may
    // still drop keys of the channels chosen first.) `pace` (synchronized runs): select_keys' pace,
    // from the per-channel keys to beat.
    std::size_t forced = 0;
    for (std::size_t k = 0; k < p.n; ++k) forced += p.is_forced(k) ? 1 : 0;
    // `forced_only` (synchronized runs): one segment from each forced key to the next, or none.
    auto run = [&](bool sync, std::size_t beat, ReducedKeys& out, bool forced_only = false,
                   const std::vector<std::size_t>* pace = nullptr) {
        // Nothing to build when the forced keys alone cannot beat the other result.
        if (forced * static_cast<std::size_t>(C) >= beat) return false;
        State s = empty_state(p, !sync);
        Fitter fitter(p, ipo, s, free_handle_frames && tolerance >= kHandleFreeMinTolerance);
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
            // Every channel keeps these keys: fewer than `beat` in total is fewer than this each.
            const std::size_t budget = beat == kNone ? kNone : (beat + C - 1) / C;
            std::vector<std::size_t> keys;
            if (forced_only) {
                keys.push_back(0);
                for (std::size_t k = 1; k < p.n; ++k) {
                    if (!p.is_forced(k)) continue;
                    if (!fitter.fit(keys.back(), k, all.data(), C, tan2_half(fit_angle), false)) return false;
                    keys.push_back(k);
                }
            } else {
                keys = select_keys(p, fitter, all.data(), C, tan2_half(fit_angle), budget, pace);
                if (keys.empty()) return false;
            }
            for (int c = 0; c < C; ++c) s.keys[c] = keys;
        } else {
            // One channel after the other, each fitted against the already fitted ones (the rest
            // still exact) under a growing share of the tolerance; the last gets all of it. The
            // first channel (w for quaternions, the least costly in angle near identity; the angle
            // for axis-angle) goes first.
            static const double kQuatShare[4] = {0.6, 0.75, 0.9, 1.0};
            static const double kEulerShare[3] = {0.7, 0.85, 1.0};
            for (int c = 0; c < C; ++c) {
                groups.push_back({c});
                const double share = C == 4 ? kQuatShare[c] : kEulerShare[c];
                s.keys[c] = select_keys(p, fitter, &c, 1, tan2_half(share * fit_angle));
            }
            // The channels chosen under a share of the tolerance, once more under all of it against
            // the others' final fits: a key whose neighbours one segment now joins is dropped. Every
            // fit tests the rotation of all channels, so each sample stays within the limit whatever
            // is dropped (the last channel was chosen under the whole tolerance already).
            for (int c = 0; c + 1 < C; ++c)
                s.keys[c] = remove_keys(p, fitter, &c, 1, tan2_half(fit_angle), s.keys[c]);
        }
        out.interpolation = ipo;
        out.synchronized = sync;
        out.channels = verify_and_repair(p, s, fitter, ipo, verify_tan2, tan2_half(fit_angle),
                                         groups, out.max_error);
        // A per-channel result's still channels keep one key before it is compared; its key sets may
        // coincide (flatten_channels reports what they are).
        if (!sync) flatten_channels(p, verify_tan2, out);
        return true;
    };

    // Synchronized with the forced keys alone cannot be beaten: tried first (one fit per range
    // between forced keys; motionless bones pass), and when it passes it is the synchronized
    // result even where verification adds keys. Otherwise per channel (on motion capture it has the
    // fewer keys on most bones), then synchronized, which gives up as soon as it cannot come out
    // with as few keys in total (it wins ties: glTF export and hand editing want shared keys). A
    // per-channel result that misses the tolerance (a segment that no candidate sample can split:
    // forced keys closer than min_gap to the failing sample) is kept only with fewer keys than a
    // synchronized one that misses no more. After a per-channel result that meets it, the
    // synchronized run also gives up once it falls behind that result's pace (select_keys).
    ReducedKeys best;
    if (synchronized || p.n <= 2 || tolerance == 0.0) {
        run(true, kNone, best);
        return best;
    }
    const std::size_t least = forced * static_cast<std::size_t>(C);
    const bool forced_only = run(true, kNone, best, true);
    if (forced_only && best.key_count() <= least) {
        flatten_channels(p, verify_tan2, best);
        return best;
    }
    ReducedKeys per_channel;
    run(false, kNone, per_channel);
    const bool meets = per_channel.max_error <= tolerance;
    std::vector<std::size_t> pace;  // the per-channel keys at samples 0..k, all channels together
    if (meets) {
        pace.assign(p.n, 0);
        for (const ReducedChannel& ch : per_channel.channels)
            for (std::size_t k : ch.indices) ++pace[k];
        for (std::size_t k = 1; k < p.n; ++k) pace[k] += pace[k - 1];
    }
    if (!forced_only && !run(true, meets ? per_channel.key_count() + 1 : kNone, best, false,
                             meets ? &pace : nullptr))
        return per_channel;
    // (The per-channel result is flattened already, in run().)
    if (per_channel.key_count() < best.key_count() &&
        per_channel.max_error <= std::max(tolerance, best.max_error))
        return per_channel;
    flatten_channels(p, verify_tan2, best);
    return best;
}

ReducedKeys repair(const Problem& p, double tolerance, KeyInterpolation ipo, const ReducedKeys& previous,
                   const std::vector<std::size_t>& index, bool free_handle_frames) {
    check_tolerance(tolerance);
    const int C = p.C;
    ReducedKeys out;
    out.interpolation = ipo;
    if (previous.channels.size() != static_cast<std::size_t>(C) || previous.interpolation != ipo) return out;
    State s = empty_state(p, !previous.synchronized);
    for (int c = 0; c < C; ++c) {
        const ReducedChannel& ch = previous.channels[c];
        std::vector<std::size_t>& keys = s.keys[c];
        for (std::size_t k : ch.indices) keys.push_back(index.at(k));
        // (A channel of one key — flatten_channels — has no segment to repair: reduced afresh.)
        if (keys.empty() || keys.front() != 0 || keys.back() != p.n - 1 || keys.size() < 2) return out;
        if (ipo != KeyInterpolation::BEZIER) continue;
        for (std::size_t a = 0; a + 1 < keys.size(); ++a) {
            const std::size_t i = keys[a], j = keys[a + 1], at = i * C + c;
            // The handle frames' fractions: the pair whose frames, placed as reduce() places them,
            // are those stored.
            const float stored[2] = {static_cast<float>(ch.handle_right[2 * a]),
                                     static_cast<float>(ch.handle_left[2 * (a + 1)])};
            bool found = false;
            for (int m = -1; m < kHandleAlternatives && !found; ++m) {
                const double a1 = m < 0 ? 1.0 / 3.0 : kHandleFractions[m][0];
                const double a2 = m < 0 ? 1.0 / 3.0 : kHandleFractions[m][1];
                float hx[2];
                segment_handle_frames(p.t[i], p.t[j], a1, a2, hx);
                if (hx[0] != stored[0] || hx[1] != stored[1]) continue;
                s.a1[at] = a1;
                s.a2[at] = a2;
                found = true;
            }
            if (!found) return out;
            s.h1[at] = ch.handle_right[2 * a + 1];
            s.h2[at] = ch.handle_left[2 * (a + 1) + 1];
        }
    }
    if (!previous.synchronized) {
        // The channels' values at every sample, as the fits of the others read them: Blender's
        // playback of each channel (at keys, the samples themselves).
        for (int c = 0; c < C; ++c) {
            const FCurveKeys* ch = &previous.channels[c];
            blender_evaluate_sorted_shared(&ch, 1, ipo, p.t, &s.F[c], C);
            for (std::size_t k : s.keys[c]) s.F[k * C + c] = p.y[k * C + c];
        }
    }
    std::vector<std::vector<int>> groups;
    if (previous.synchronized) {
        groups.emplace_back();
        for (int c = 0; c < C; ++c) groups.back().push_back(c);
    } else {
        for (int c = 0; c < C; ++c) groups.push_back({c});
    }
    const Thresholds at = thresholds(tolerance);
    Fitter fitter(p, ipo, s, free_handle_frames && tolerance >= kHandleFreeMinTolerance);
    out.channels = verify_and_repair(p, s, fitter, ipo, tan2_half(at.verify_angle), tan2_half(at.fit_angle), groups,
                                     out.max_error);
    // Splits may leave keys a segment now joins (a split's two fits see the added samples where the
    // earlier segments did not): one removal pass, as reduce() makes, and verification again.
    if (out.key_count() > previous.key_count()) {
        for (const std::vector<int>& g : groups)
            s.keys[g[0]] = remove_keys(p, fitter, g.data(), static_cast<int>(g.size()), tan2_half(at.fit_angle), s.keys[g[0]]);
        for (const std::vector<int>& g : groups)
            for (int c : g) s.keys[c] = s.keys[g[0]];
        out.channels = verify_and_repair(p, s, fitter, ipo, tan2_half(at.verify_angle), tan2_half(at.fit_angle), groups,
                                         out.max_error);
    }
    flatten_channels(p, tan2_half(at.verify_angle), out);
    return out;
}

}  // namespace reduce_impl

ReducedKeys reduce_keys(const std::vector<double>& times, const std::vector<Quat>& quats,
                        double tolerance, KeyInterpolation interpolation, bool synchronized) {
    return fit_keys(times, quats, {}, tolerance, interpolation, synchronized, 0.0);
}

ReducedKeys reduce_keys_euler(const std::vector<double>& times, const std::vector<Vec3>& angles,
                              EulerOrder order, double tolerance, KeyInterpolation interpolation,
                              bool synchronized) {
    return fit_keys_euler(times, angles, order, {}, tolerance, interpolation, synchronized, 0.0);
}

ReducedKeys reduce_keys_axis_angle(const std::vector<double>& times, const std::vector<Vec4>& values,
                                   double tolerance, KeyInterpolation interpolation, bool synchronized) {
    return fit_keys_axis_angle(times, values, {}, tolerance, interpolation, synchronized, 0.0);
}

ReducedKeys fit_keys(const std::vector<double>& times, const std::vector<Quat>& quats,
                     const std::vector<std::size_t>& forced, double tolerance, KeyInterpolation interpolation,
                     bool synchronized, double min_gap) {
    check_tolerance(tolerance);
    Problem p = make_quat_problem(times, quats, interpolation == KeyInterpolation::BEZIER);
    set_forced_keys(p, forced, min_gap);
    return reduce(p, tolerance, interpolation, synchronized);
}

ReducedKeys fit_keys_euler(const std::vector<double>& times, const std::vector<Vec3>& angles, EulerOrder order,
                           const std::vector<std::size_t>& forced, double tolerance,
                           KeyInterpolation interpolation, bool synchronized, double min_gap) {
    check_tolerance(tolerance);
    Problem p = make_euler_problem(times, angles, order);
    set_forced_keys(p, forced, min_gap);
    return reduce(p, tolerance, interpolation, synchronized);
}

ReducedKeys fit_keys_axis_angle(const std::vector<double>& times, const std::vector<Vec4>& values,
                                const std::vector<std::size_t>& forced, double tolerance,
                                KeyInterpolation interpolation, bool synchronized, double min_gap) {
    check_tolerance(tolerance);
    Problem p = make_axis_angle_problem(times, values);
    set_forced_keys(p, forced, min_gap);
    return reduce(p, tolerance, interpolation, synchronized);
}

}  // namespace quatcurve
