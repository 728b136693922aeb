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

#include "reduce_impl.hpp"

namespace quatcurve {

std::size_t ReducedKeys::key_count() const {
    std::size_t total = 0;
    for (const ReducedChannel& ch : channels) total += ch.indices.size();
    return total;
}

using namespace reduce_impl;

namespace reduce_impl {

ReducedKeys reduce(const Problem& p, double tolerance, KeyInterpolation ipo, bool synchronized,
                   bool free_handle_frames) {
    check_tolerance(tolerance);
    check_float32_storage(p, tolerance);
    const int C = p.C;
    // Verification threshold (margin for Blender's own float32 rotation building) and fit target.
    const double verify_angle =
        tolerance > 2.0 * kVerifyMargin ? tolerance - kVerifyMargin : 0.5 * tolerance;
    const double fit_angle =
        verify_angle - std::min(kFitMarginAbs, kFitMarginRel * verify_angle);
    const double verify_tan2 = tan2_half(verify_angle);

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
        // After a per-channel run the key sets may coincide; report what they are.
        if (!sync) {
            bool same = true;
            for (int c = 1; c < C; ++c) same = same && s.keys[c] == s.keys[0];
            out.synchronized = same;
        }
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
    if (forced_only && best.key_count() <= least) return best;
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
    if (per_channel.key_count() < best.key_count() &&
        per_channel.max_error <= std::max(tolerance, best.max_error))
        best = std::move(per_channel);
    return best;
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
