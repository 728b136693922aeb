// Key reduction, stage 4: the result's F-curves, every sample evaluated exactly as Blender does
// (blender_eval.hpp), and the repairs — refit with Blender's own frame→parameter map, then split —
// until every sample passes (reduce_impl.hpp: verify_and_repair).
#include <algorithm>
#include <limits>
#include <memory>

#include "quatcurve/blender_eval.hpp"
#include "reduce_impl.hpp"

namespace quatcurve::reduce_impl {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// One key at sample `index` (frame, value float32) with flat handles a frame to either side: Blender
// plays it at every frame, extrapolation included.
ReducedChannel one_key_channel(std::size_t index, double frame, double value, KeyInterpolation ipo) {
    ReducedChannel ch;
    ch.indices = {index};
    ch.frames = {frame};
    ch.values = {value};
    if (ipo == KeyInterpolation::BEZIER) {
        ch.handle_left = {f32(frame - 1.0), value};
        ch.handle_right = {f32(frame + 1.0), value};
    }
    return ch;
}

ReducedChannel make_channel(const Problem& p, const State& s, int c, KeyInterpolation ipo) {
    const std::vector<std::size_t>& keys = s.keys[c];
    const std::size_t K = keys.size();
    if (K == 1) return one_key_channel(keys[0], p.t[keys[0]], f32(p.y[keys[0] * p.C + c]), ipo);
    ReducedChannel ch;
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
            float hx[2];
            segment_handle_frames(p.t[i], p.t[j], s.a1[i * p.C + c], s.a2[i * p.C + c], hx);
            ch.handle_right[2 * a] = hx[0];
            ch.handle_right[2 * a + 1] = f32(s.h1[i * p.C + c]);
            ch.handle_left[2 * (a + 1)] = hx[1];
            ch.handle_left[2 * (a + 1) + 1] = f32(s.h2[i * p.C + c]);
        }
        // Outer handles mirror the inner ones (they only shape extrapolation, which is constant).
        if (K > 1) {
            ch.handle_left[0] = f32(2.0 * ch.frames[0] - ch.handle_right[0]);
            ch.handle_left[1] = f32(2.0 * ch.values[0] - ch.handle_right[1]);
            const std::size_t L = K - 1;
            ch.handle_right[2 * L] = f32(2.0 * ch.frames[L] - ch.handle_left[2 * L]);
            ch.handle_right[2 * L + 1] = f32(2.0 * ch.values[L] - ch.handle_left[2 * L + 1]);
        }
    }
    return ch;
}

// The error (tan²(θ/2)) at sample k of the channel values f as Blender plays them: its normalize_qt
// turns an exactly zero quaternion into (0, 1, 0, 0) (f is changed so).
double played_error(const Problem& p, std::size_t k, double* f) {
    if (p.kind == Kind::QUAT && f[0] == 0.0 && f[1] == 0.0 && f[2] == 0.0 && f[3] == 0.0) f[1] = 1.0;
    return error_tan2(p, k, f);
}

// The largest angle of the errors err (tan²(θ/2)), from the largest tan²: angle_of_tan2 rises with
// it, so only samples near the largest need the arctangent. Below half of it (at most 1e20, ~1e-10
// rad short of π) the angle is smaller by far more than atan's rounding (< 1 ulp), so none of them
// can come out larger; beyond, and for non-finite errors (π), every sample is converted.
double largest_angle(const std::vector<double>& err) {
    double worst = 0.0;
    for (double e : err) worst = std::max(worst, e < kInf ? e : kInf);
    const double below = worst <= 1e20 ? 0.5 * worst : -1.0;
    double angle = 0.0;
    for (double e : err)
        if (!(e < below)) angle = std::max(angle, angle_of_tan2(e));
    return angle;
}

// Errors (tan²(θ/2)) of every sample under Blender's evaluation of the current keys. Consecutive
// channels with the same keys are evaluated in one walk (all of them when synchronized), sharing
// their Bezier parameters.
void emulate_errors(const Problem& p, const std::vector<ReducedChannel>& chans,
                    KeyInterpolation ipo, std::vector<double>& err) {
    const int C = p.C;
    // Every entry is written below (the runs cover all channels): no zero-fill.
    std::unique_ptr<double[]> vals(new double[p.n * C]);
    const FCurveKeys* run[kMaxChannels];
    for (int c = 0; c < C;) {
        int count = 1;
        run[0] = &chans[c];
        while (c + count < C && chans[c + count].indices == chans[c].indices) {
            run[count] = &chans[c + count];
            ++count;
        }
        blender_evaluate_sorted_shared(run, count, ipo, p.t, &vals[c], C);
        c += count;
    }
    err.resize(p.n);
    for (std::size_t k = 0; k < p.n; ++k) err[k] = played_error(p, k, &vals[k * C]);
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

}  // namespace

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
        bool changed = false;
        for (const Fix& f : fixes) {
            const std::vector<int>& grp = groups[f.group];
            std::vector<std::size_t>& keys = s.keys[grp[0]];
            const std::size_t i = keys[f.seg], j = keys[f.seg + 1];
            const int nc = static_cast<int>(grp.size());
            if (ipo == KeyInterpolation::BEZIER && !s.exact_param[i * C + grp[0]]) {
                fitter.fit(i, j, grp.data(), nc, fit_limit, true, true);
                changed = true;
                continue;
            }
            // Split at the worst sample, or the candidate nearest to it (not too close to a forced
            // key); a segment with no candidate inside stays as it is and max_error says so.
            std::size_t m = kNone;
            for (std::size_t d = 0; m == kNone; ++d) {
                const bool below = f.sample >= i + 1 + d, above = f.sample + d < j;
                if (!below && !above) break;
                if (below && p.is_candidate(f.sample - d)) m = f.sample - d;
                else if (above && p.is_candidate(f.sample + d)) m = f.sample + d;
            }
            if (m == kNone) continue;
            changed = true;
            fitter.fit(i, m, grp.data(), nc, fit_limit, true);
            fitter.fit(m, j, grp.data(), nc, fit_limit, true);
            for (int c : grp) {
                std::vector<std::size_t>& kc = s.keys[c];
                kc.insert(std::upper_bound(kc.begin(), kc.end(), i), m);
            }
        }
        if (!changed) break;
    }
    max_error = largest_angle(err);
    return chans;
}

namespace {

void flatten_still(const Problem& p, double verify_tan2, ReducedKeys& keys) {
    const int C = p.C;
    const KeyInterpolation ipo = keys.interpolation;
    std::vector<ReducedChannel>& chans = keys.channels;
    if (!p.single_key || p.n < 2 || static_cast<int>(chans.size()) != C) return;
    for (std::size_t k = 1; k + 1 < p.n; ++k)
        if (p.is_forced(k)) return;
    if (std::none_of(chans.begin(), chans.end(), [](const ReducedChannel& ch) {
            return ch.frames.size() >= 2 && ch.frames.size() <= 3;
        }))
        return;
    // Every channel's playback at every sample, then one column at a time replaced by a constant.
    std::vector<double> vals(p.n * C);
    for (int c = 0; c < C; ++c) {
        const FCurveKeys* ch = &chans[c];
        blender_evaluate_sorted_shared(&ch, 1, ipo, p.t, &vals[c], C);
    }
    auto worst_with = [&](int c, double value) {
        double worst = 0.0;
        for (std::size_t k = 0; k < p.n && worst <= verify_tan2; ++k) {
            double f[kMaxChannels];
            std::copy(&vals[k * C], &vals[k * C] + C, f);
            f[c] = value;
            worst = std::max(worst, played_error(p, k, f));
        }
        return worst;
    };
    bool changed = false;
    for (int c = 0; c < C; ++c) {
        const ReducedChannel& ch = chans[c];
        if (ch.frames.size() < 2 || ch.frames.size() > 3) continue;
        double lo = p.y[c], hi = p.y[c];
        for (std::size_t k = 1; k < p.n; ++k) {
            lo = std::min(lo, p.y[k * C + c]);
            hi = std::max(hi, p.y[k * C + c]);
        }
        const double candidates[] = {ch.values.front(), ch.values.back(), 0.5 * (ch.values.front() + ch.values.back()),
                                     0.5 * (lo + hi)};
        double best = kInf, value = 0.0;
        for (double v : candidates) {
            const double w = worst_with(c, f32(v));
            if (w <= verify_tan2 && w < best) {
                best = w;
                value = f32(v);
            }
        }
        if (!(best <= verify_tan2)) continue;
        chans[c] = one_key_channel(0, ch.frames.front(), value, ipo);
        for (std::size_t k = 0; k < p.n; ++k) vals[k * C + c] = value;
        changed = true;
    }
    if (!changed) return;
    std::vector<double> err(p.n);
    for (std::size_t k = 0; k < p.n; ++k) err[k] = played_error(p, k, &vals[k * C]);
    keys.max_error = largest_angle(err);
}

}  // namespace

bool same_keys(const std::vector<ReducedChannel>& chans) {
    for (const ReducedChannel& ch : chans)
        if (ch.indices != chans.front().indices) return false;
    return true;
}

void flatten_channels(const Problem& p, double verify_tan2, ReducedKeys& keys) {
    flatten_still(p, verify_tan2, keys);
    keys.synchronized = same_keys(keys.channels);
}

}  // namespace quatcurve::reduce_impl
