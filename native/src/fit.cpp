// Fitting F-curves through an animator's keys (see fit.hpp for what each function promises).
#include "quatcurve/fit.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
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
        // The keys on either side of t: grid points within 1e-6 frames, or on the key's float32
        // frame (Blender's frames; one float32 step is 1/128 frame at frame 65536), give way to it.
        const auto on = [t](double key) { return std::fabs(key - t) < 1e-6 || float(key) == float(t); };
        const bool near = (k < key_frames.size() && on(key_frames[k])) || (k > 0 && on(key_frames[k - 1]));
        // Beyond frame 2^19 a float32 step passes 1/64 frame: grid points sharing one give way too.
        if (!near && (out.empty() || float(out.back()) != float(t))) out.push_back(t);
    }
    while (k < key_frames.size()) out.push_back(key_frames[k++]);
    return out;
}

namespace {

// The fit matches the method within this share of the tolerance at its samples: the rest is the
// room the proof between samples needs (bound.hpp), which is what the tolerance promises.
constexpr double kFitShare = 0.9;
// A key segment the fit leaves unproved is fitted again alone at these shares (fit_span).
constexpr double kRetryShares[] = {0.6, 0.3};
// Rounds of "prove, add the times that failed as samples, fit again".
constexpr int kProofRounds = 8;
// The rounds stop (and the failed segments are tightened) where the samples they would add take the
// count past kMaxSampleGrowth times the samples they started from plus kSampleAllowance per key
// segment.
constexpr std::size_t kMaxSampleGrowth = 2;
constexpr std::size_t kSampleAllowance = 256;
// The proof halves intervals down to this (frames): a change of Euler branch beside a key at gimbal
// lock spans 0.0105 frame, and its fast channels need steps far below 1/1024 frame to be bounded.
constexpr double kProofMinStep = 1.0 / 65536.0;
// The evaluations of one proof that tightens a failed segment's bound (tighten_proof): a segment
// the fit cannot hold is rare, and its bound is worth a few proofs, not an unbounded search.
constexpr std::size_t kTightenEvaluations = 200'000;
// An added sample keeps this far from the samples beside it (beyond Blender's 1e-4 key snap), and
// on another float32 frame than either (beyond frame 32768 a float32 step is above this).
constexpr double kAddedSampleGap = 1.0 / 1024.0;
// Two Euler rows that agree within this (radians, per angle) are on the same branch: branches differ
// by about π, while near gimbal lock the first and last angles of the same rotation are ill-conditioned
// (a float32 key's 1e-7 rad moves them by 1e-7/cos b); the F-curve bridges what is left, and the
// proof measures it.
constexpr double kSameAngles = 1e-2;
// A change of Euler branch between keys whose path passes no nearer than this to gimbal lock is
// refused (radians: 5°, a visible swing of about 10°).
constexpr double kSwitchRefused = 5.0 * kTwoPiFit / 360.0;
// A change of Euler branch whose two rows, joined channel by channel, turn the rotation off the path
// by more than this (radians, 20°: a change within kSwitchRefused of the lock swings about twice
// that) needs a whole turn of an angle, which no place on the path makes free: refused.
constexpr double kSwitchSwingRefused = 4.0 * kSwitchRefused;
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

// How far the rotation leaves the path where Euler rows a and b (samples qa and qb) are joined channel
// by channel, as the F-curves join them across a change of branch: the largest angle, at 32 points
// of the straight channel path, to the nearer of qa and qb, less the path's own step between them.
// At gimbal lock the first and last angles move together without moving the rotation (about the
// step); a whole turn of an angle between the rows sweeps the rotation around (up to 180°).
double switch_swing(const double* a, const double* b, const Quat& qa, const Quat& qb, const RotationMode& mode) {
    double worst = 0.0;
    for (int k = 1; k < 32; ++k) {
        const double u = k / 32.0;
        const double row[3] = {a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1]), a[2] + u * (b[2] - a[2])};
        const Quat q = channels_to_quat(row, mode);
        worst = std::fmax(worst, std::fmin(angle_between(q, qa), angle_between(q, qb)));
    }
    return std::fmax(0.0, worst - angle_between(qa, qb));
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

// Adds a key segment's proof to the whole range's (fit.proof): the larger bound and where it is
// reached, every violation and unproven interval, the evaluations.
void merge_proof(PlaybackBound& into, const PlaybackBound& part) {
    if (part.bound > into.bound || into.evaluations == 0) {
        into.bound = part.bound;
        into.worst_time = part.worst_time;
    }
    into.max_evaluated = std::fmax(into.max_evaluated, part.max_evaluated);
    into.violations.insert(into.violations.end(), part.violations.begin(), part.violations.end());
    into.unproven.insert(into.unproven.end(), part.unproven.begin(), part.unproven.end());
    into.evaluations += part.evaluations;
}

void sort_proof(PlaybackBound& proof) {
    std::sort(proof.violations.begin(), proof.violations.end());
    proof.violations.erase(std::unique(proof.violations.begin(), proof.violations.end()), proof.violations.end());
    std::sort(proof.unproven.begin(), proof.unproven.end());
}

// prove_within of the playback against the method on each key segment (the samples from its first
// key to its second): fit.segment_proofs, and their union in fit.proof.
void prove_segments(const Motion& playback, const Motion& method, double tolerance, KeyFit& fit) {
    const std::size_t S = fit.forced.size() - 1;
    fit.segment_proofs.assign(S, {});
    fit.proof = {};
    for (std::size_t j = 0; j < S; ++j) {
        const std::vector<double> span(fit.times.begin() + static_cast<std::ptrdiff_t>(fit.forced[j]),
                                       fit.times.begin() + static_cast<std::ptrdiff_t>(fit.forced[j + 1]) + 1);
        fit.segment_proofs[j] = prove_within(playback, method, span, tolerance, kProofMinStep);
        merge_proof(fit.proof, fit.segment_proofs[j]);
    }
    sort_proof(fit.proof);
}

// Every key segment of `fit` that is not proved, made tight (tighten_proof: its bound within a few
// percent of what the playback does there, not the bound of the interval its proof stopped at), and
// their union again.
void tighten_failed_segments(const Motion& playback, const Motion& method, KeyFit& fit) {
    if (fit.proof.proven()) return;
    fit.proof = {};
    for (std::size_t j = 0; j + 1 < fit.forced.size(); ++j) {
        PlaybackBound& proof = fit.segment_proofs[j];
        if (!proof.proven()) {
            const std::vector<double> span(fit.times.begin() + static_cast<std::ptrdiff_t>(fit.forced[j]),
                                           fit.times.begin() + static_cast<std::ptrdiff_t>(fit.forced[j + 1]) + 1);
            tighten_proof(playback, method, span, kProofMinStep, kTightenEvaluations, proof);
        }
        merge_proof(fit.proof, proof);
    }
    sort_proof(fit.proof);
}

// The fit of the keys (all of fit_through_keys' keys, or a run of them) without reuse, matching the
// method within `share` of the tolerance at the samples: rounds of fit_round and the proof of every
// key segment (tightened where it fails).
KeyFit fit_rounds(const Curve& curve, const std::vector<double>& key_frames, const std::vector<double>& key_values,
                  const RotationMode& mode, int subframes, double tolerance, double min_gap, double share) {
    const std::size_t K = key_frames.size(), C = channel_count(mode);
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
    const CurveMotion curve_motion(curve);
    const KeptBreaks method(curve_motion);
    const std::size_t sample_budget = kMaxSampleGrowth * fit.times.size() + kSampleAllowance * (K - 1);
    for (int round = 0;; ++round) {
        fit_round(curve, key_frames, key_values, mode, tolerance * share, min_gap, fit);
        std::vector<FCurveKeys> channels(fit.keys.channels.begin(), fit.keys.channels.end());
        const PlaybackMotion playback(std::move(channels), fit.keys.interpolation, mode);
        const KeptBreaks kept(playback);
        prove_segments(kept, method, tolerance, fit);
        if (fit.proof.proven()) break;
        if (round + 1 >= kProofRounds) {
            tighten_failed_segments(kept, method, fit);
            break;
        }
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
                if (at - before > kAddedSampleGap && t - at > kAddedSampleGap &&
                    float(at) != float(before) && float(at) != float(t)) {
                    merged.push_back(at);
                    ++added;
                }
            }
            merged.push_back(t);
            below = t;
        }
        if (added == 0 || fit.times.size() + added > sample_budget) {
            tighten_failed_segments(kept, method, fit);
            break;
        }
        fit.times.swap(merged);
    }
    fit.refitted = K - 1;
    return fit;
}

// Whether a fit made with these settings can lend its key segments to this one. The tolerance may
// differ by float32 rounding (a setting stored in a Blender property); a reused segment then still
// needs a proved bound within the new tolerance (fit_through_keys).
bool reusable(const KeyFit& previous, const RotationMode& mode, int subframes, double tolerance, double min_gap) {
    return previous.curve && previous.mode.kind == mode.kind &&
           (mode.kind != RotationMode::Kind::euler || previous.mode.order == mode.order) &&
           previous.subframes == subframes && std::fabs(previous.tolerance - tolerance) <= 1e-6 * tolerance &&
           previous.min_gap == min_gap &&
           previous.segment_proofs.size() + 1 == previous.key_frames.size() &&
           previous.forced.size() == previous.key_frames.size();
}

// Where key segment k comes from in the assembled fit: segment `segment` of `fit`.
struct Source {
    const KeyFit* fit;
    std::size_t segment;
};

// The fit of key segments from their sources (a reused segment of the previous fit, or a segment of
// a run fitted now), joined at the keys: each segment's samples, keys and handles as its source has
// them; a key between two segments takes its left handle from the segment before it. Consecutive
// segments of one source are copied as one block (a refit's sources are a few such runs).
void assemble(const std::vector<Source>& sources, std::size_t C, KeyFit& out) {
    const std::size_t S = sources.size();
    struct Block {
        std::size_t k0, k1;    // key segments [k0, k1) of the result
        std::size_t lo, hi;    // their samples [lo, hi] in the source (hi: the block's last key)
        std::vector<std::pair<std::size_t, std::size_t>> keys;  // per channel, [first, end) of its keys
    };
    std::vector<Block> blocks;
    std::size_t samples = 1;
    std::vector<std::size_t> keys(C, 0);
    for (std::size_t k0 = 0; k0 < S;) {
        const KeyFit& f = *sources[k0].fit;
        const std::size_t s0 = sources[k0].segment;
        std::size_t k1 = k0 + 1;
        while (k1 < S && sources[k1].fit == &f && sources[k1].segment == s0 + (k1 - k0)) ++k1;
        Block b{k0, k1, f.forced[s0], f.forced[s0 + (k1 - k0)], {}};
        samples += b.hi - b.lo;
        b.keys.resize(C);
        for (std::size_t c = 0; c < C; ++c) {
            const std::vector<std::size_t>& idx = f.keys.channels[c].indices;
            const auto first = std::lower_bound(idx.begin(), idx.end(), b.lo);
            const auto end = std::upper_bound(first, idx.end(), k1 == S ? b.hi : b.hi - 1);
            b.keys[c] = {static_cast<std::size_t>(first - idx.begin()), static_cast<std::size_t>(end - idx.begin())};
            keys[c] += b.keys[c].second - b.keys[c].first;
        }
        blocks.push_back(std::move(b));
        k0 = k1;
    }
    out.times.clear();
    out.times.reserve(samples);
    out.forced.assign(S + 1, 0);
    out.switches.clear();
    out.segment_proofs.assign(S, {});
    out.proof = {};
    out.keys = ReducedKeys{};
    out.keys.interpolation = KeyInterpolation::BEZIER;
    out.keys.synchronized = true;
    out.keys.channels.assign(C, {});
    for (std::size_t c = 0; c < C; ++c) {
        ReducedChannel& to = out.keys.channels[c];
        to.indices.reserve(keys[c]);
        to.frames.reserve(keys[c]);
        to.values.reserve(keys[c]);
        to.handle_left.reserve(2 * keys[c]);
        to.handle_right.reserve(2 * keys[c]);
    }
    const auto at = [](const auto& v, std::size_t i) { return v.begin() + static_cast<std::ptrdiff_t>(i); };
    for (const Block& b : blocks) {
        const KeyFit& f = *sources[b.k0].fit;
        const std::size_t s0 = sources[b.k0].segment, offset = out.times.size();
        const bool last = b.k1 == S;
        out.times.insert(out.times.end(), at(f.times, b.lo), at(f.times, last ? b.hi + 1 : b.hi));
        for (std::size_t k = b.k0; k < b.k1; ++k) {
            const std::size_t s = s0 + (k - b.k0);
            out.forced[k] = offset + (f.forced[s] - b.lo);
            out.segment_proofs[k] = f.segment_proofs[s];
            merge_proof(out.proof, f.segment_proofs[s]);
        }
        if (last) out.forced[S] = out.times.size() - 1;
        for (const EulerSwitch& w : f.switches)
            if (w.segment >= s0 && w.segment < s0 + (b.k1 - b.k0))
                out.switches.push_back({b.k0 + (w.segment - s0), w.frame});
        out.keys.max_error = std::fmax(out.keys.max_error, f.keys.max_error);
        out.keys.synchronized = out.keys.synchronized && f.keys.synchronized;
        for (std::size_t c = 0; c < C; ++c) {
            const ReducedChannel& from = f.keys.channels[c];
            ReducedChannel& to = out.keys.channels[c];
            const auto [first, end] = b.keys[c];
            for (std::size_t i = first; i < end; ++i) to.indices.push_back(offset + (from.indices[i] - b.lo));
            to.frames.insert(to.frames.end(), at(from.frames, first), at(from.frames, end));
            to.values.insert(to.values.end(), at(from.values, first), at(from.values, end));
            // A key joining this block to the one before takes its left handle from that one.
            const std::size_t left = first < end && b.k0 > 0 ? first + 1 : first;
            to.handle_left.insert(to.handle_left.end(), at(from.handle_left, 2 * left), at(from.handle_left, 2 * end));
            to.handle_right.insert(to.handle_right.end(), at(from.handle_right, 2 * first),
                                   at(from.handle_right, 2 * end));
            if (!last)  // the left handle of the key that ends this block (the next key in its source)
                to.handle_left.insert(to.handle_left.end(), at(from.handle_left, 2 * end),
                                      at(from.handle_left, 2 * end + 2));
        }
    }
    sort_proof(out.proof);
}

// The fit of the keys (all of fit_through_keys' keys, or a run of them) without reuse: fit_rounds at
// kFitShare; a key segment it leaves unproved is fitted again alone (key segments are independent:
// the fitted keys' handles are broken at the animator's keys) at the smaller shares of kRetryShares,
// which leave the proof more room between the samples — where Blender's snap to a key on a fast
// channel adds a step, or the error between samples runs high —, and keeps the better of its fits
// (proved, or with the lower bound). Segments proved the first time are as they were.
KeyFit fit_span(const Curve& curve, const std::vector<double>& key_frames, const std::vector<double>& key_values,
                const RotationMode& mode, int subframes, double tolerance, double min_gap) {
    KeyFit fit = fit_rounds(curve, key_frames, key_values, mode, subframes, tolerance, min_gap, kFitShare);
    if (fit.proof.proven()) return fit;
    const std::size_t S = key_frames.size() - 1, C = channel_count(mode);
    std::deque<KeyFit> retries;  // sources point into it: a deque's elements stay put as it grows
    std::vector<Source> sources(S);
    bool replaced = false;
    for (std::size_t j = 0; j < S; ++j) {
        sources[j] = {&fit, j};
        if (fit.segment_proofs[j].proven()) continue;
        const std::vector<double> frames(key_frames.begin() + static_cast<std::ptrdiff_t>(j),
                                         key_frames.begin() + static_cast<std::ptrdiff_t>(j) + 2);
        const std::vector<double> values(key_values.begin() + static_cast<std::ptrdiff_t>(C * j),
                                         key_values.begin() + static_cast<std::ptrdiff_t>(C * (j + 2)));
        for (double share : kRetryShares) {
            KeyFit again = fit_rounds(curve, frames, values, mode, subframes, tolerance, min_gap, share);
            const PlaybackBound& best = sources[j].fit->segment_proofs[sources[j].segment];
            if (again.proof.proven() || again.proof.bound < best.bound) {
                retries.push_back(std::move(again));
                sources[j] = {&retries.back(), 0};
                replaced = true;
            }
            if (sources[j].fit->segment_proofs[sources[j].segment].proven()) break;
        }
    }
    if (!replaced) return fit;
    KeyFit out;
    assemble(sources, C, out);
    out.refitted = S;
    return out;
}

}  // namespace

KeyFit fit_through_keys(const Curve& curve, const std::vector<double>& key_frames,
                        const std::vector<double>& key_values, const RotationMode& mode, int subframes,
                        double tolerance, double min_gap, const KeyFit* previous) {
    const std::size_t K = key_frames.size(), C = channel_count(mode);
    if (K < 2) throw InvalidArgument("key_frames: at least two keys to fit through");
    if (key_values.size() != K * C)
        throw InvalidArgument("key_values: " + std::to_string(key_values.size()) + " values for " +
                              std::to_string(K) + " keys of " + std::to_string(C) + " channels");
    if (!(tolerance > 0.0) || !std::isfinite(tolerance)) throw InvalidArgument("tolerance: must be finite and > 0");
    // The previous fit's key segment that each key segment can keep (none: −1).
    const std::size_t S = K - 1;
    std::vector<std::ptrdiff_t> kept(S, -1);
    std::size_t kept_count = 0;
    if (previous != nullptr && reusable(*previous, mode, subframes, tolerance, min_gap)) {
        const std::vector<double>& pf = previous->key_frames;
        const double* pv = previous->key_values.data();
        for (std::size_t k = 0; k < S; ++k) {
            const auto at = std::lower_bound(pf.begin(), pf.end(), key_frames[k]);
            if (at == pf.end() || *at != key_frames[k] || at + 1 == pf.end() || at[1] != key_frames[k + 1]) continue;
            const std::size_t o = static_cast<std::size_t>(at - pf.begin());
            if (!std::equal(key_values.begin() + static_cast<std::ptrdiff_t>(C * k),
                            key_values.begin() + static_cast<std::ptrdiff_t>(C * (k + 2)), pv + C * o))
                continue;
            if (!curve.same_key_segment(k, *previous->curve, o)) continue;
            // Proved within this tolerance, or as far above it as a fit could be (the same tolerance).
            const PlaybackBound& proof = previous->segment_proofs[o];
            if (previous->tolerance != tolerance && !(proof.proven() && proof.bound <= tolerance)) continue;
            kept[k] = static_cast<std::ptrdiff_t>(o);
            ++kept_count;
        }
    }
    KeyFit fit;
    if (kept_count == 0) {
        fit = fit_span(curve, key_frames, key_values, mode, subframes, tolerance, min_gap);
    } else {
        // Runs of segments that changed, each fitted and proved on its own keys.
        std::vector<KeyFit> runs;
        runs.reserve(S - kept_count);
        std::vector<Source> sources(S);
        for (std::size_t k = 0; k < S;) {
            if (kept[k] >= 0) {
                sources[k] = {previous, static_cast<std::size_t>(kept[k])};
                ++k;
                continue;
            }
            std::size_t end = k + 1;
            while (end < S && kept[end] < 0) ++end;
            const std::vector<double> frames(key_frames.begin() + static_cast<std::ptrdiff_t>(k),
                                             key_frames.begin() + static_cast<std::ptrdiff_t>(end) + 1);
            const std::vector<double> values(key_values.begin() + static_cast<std::ptrdiff_t>(C * k),
                                             key_values.begin() + static_cast<std::ptrdiff_t>(C * (end + 1)));
            runs.push_back(fit_span(curve, frames, values, mode, subframes, tolerance, min_gap));
            for (std::size_t j = k; j < end; ++j) sources[j] = {&runs.back(), j - k};
            k = end;
        }
        assemble(sources, C, fit);
        fit.refitted = S - kept_count;
    }
    fit.curve = std::make_shared<const Curve>(curve);
    fit.key_frames = key_frames;
    fit.key_values = key_values;
    fit.mode = mode;
    fit.subframes = subframes;
    fit.tolerance = tolerance;
    fit.min_gap = min_gap;
    return fit;
}

KeyFit fit_channels(const std::vector<double>& key_frames, const std::vector<double>& key_values,
                    const RotationMode& mode, Method method, const CurveOptions& options, int subframes,
                    double tolerance, double min_gap, const KeyFit* previous) {
    const Curve curve = curve_from_channels(key_frames, key_values, mode, method, options);
    if (mode.kind != RotationMode::Kind::quaternion)
        return fit_through_keys(curve, key_frames, key_values, mode, subframes, tolerance, min_gap, previous);
    // Each quaternion key in the sign the curve reaches it with (the curve's output is sign-continuous).
    const std::size_t K = key_frames.size();
    std::vector<double> at(4 * K), signed_values(key_values);
    curve.sample(key_frames.data(), K, at.data());
    for (std::size_t k = 0; k < K; ++k) {
        const double* q = &at[4 * k];
        double* v = &signed_values[4 * k];
        if (q[0] * v[0] + q[1] * v[1] + q[2] * v[2] + q[3] * v[3] < 0.0)
            for (int c = 0; c < 4; ++c) v[c] = -v[c];
    }
    return fit_through_keys(curve, key_frames, signed_values, mode, subframes, tolerance, min_gap, previous);
}

FitQueue::FitQueue(std::size_t threads, std::size_t window)
    : queue_([](const FitJob& j) {
                 return fit_channels(j.key_frames, j.key_values, j.mode, j.method, j.options, j.subframes, j.tolerance,
                                     j.min_gap, j.previous);
             },
             threads, window) {}

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
                if (switch_at > 0) {
                    const std::size_t s = switch_at;
                    const double swing = switch_swing(&v[3 * (s - 1)], &v[3 * s], span[s - 1], span[s], mode);
                    if (swing > kSwitchSwingRefused) {
                        char text[480];
                        std::snprintf(text, sizeof text,
                                      "keys at frames %g and %g: the method's path reaches the second key on the "
                                      "other Euler branch, and the channels can change branch (near frame %.3f) "
                                      "only with a whole turn of an angle, which swings the rotation by up to "
                                      "%.0f° there: key the second key's angles on the path's own turn, or convert "
                                      "the target to quaternion first",
                                      key_frames[k], key_frames[k + 1], t[forced[k] + s], swing * 360.0 / kTwoPiFit);
                        throw InvalidArgument(text);
                    }
                    fit.switches.push_back({k, t[forced[k] + s]});
                }
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
