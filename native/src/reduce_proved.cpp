// Key reduction proved at every instant (reduce.hpp, "a reduction proved at every instant"): the
// reducer at 93% of the tolerance, prove_within (bound.hpp) of its playback against a reference, and
// the times that fail added as samples, round after round.
#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>

#include "quatcurve/channels.hpp"
#include "quatcurve/errors.hpp"
#include "quatcurve/euler.hpp"
#include "quatcurve/reduce.hpp"
#include "reduce_impl.hpp"

namespace quatcurve {

namespace {

// The reducer matches the samples within this share of the tolerance: the rest is the room the proof
// between samples needs. A larger share keeps a few keys fewer for more rounds and time, a smaller
// one more keys (docs/benchmarks.md has the figures). Below kTightTolerance the share is
// kReduceShareTight: there the proof's fixed allowances (kArithmeticSlack, 2e-6 rad, and the
// flat-segment steps) need the tenth of the tolerance (at 0.001°, 1.7e-6 rad: with 93 % bones of
// both clips stay unproved after every round).
constexpr double kReduceShare = 0.93;
constexpr double kReduceShareTight = 0.9;
constexpr double kTightTolerance = reduce_impl::kHandleFreeMinTolerance;  // 0.01°

double reduce_share(double tolerance) { return tolerance >= kTightTolerance ? kReduceShare : kReduceShareTight; }
// Rounds at most: the first reduction, then one round per set of added samples (its keys repaired or
// reduced afresh, reduce_again).
constexpr int kProofRounds = 8;
// The round after a pass's first reduction repairs its keys (reduce_again) where the proof added at
// most this share of its samples, and keeps the repair with up to kRepairSlack of its keys (and one
// key per channel more).
constexpr double kRepairAdded = 0.5;
constexpr double kRepairSlack = 1.1;
// An added sample keeps this far from the samples beside it (beyond Blender's 1e-4 key snap).
constexpr double kAddedSampleGap = 1.0 / 1024.0;
// A sample interval where the proof fails, and the one on either side of it, get samples at their
// quarters too (add_samples).
constexpr int kQuarters = 4;
// prove_within halves an interval down to this (frames): 16 times finer than prove_playback's default
// 1/1024, since a reduction at 93% of the tolerance may run close to it between samples where both
// playbacks turn fast (the fit goes down to 1/65536, fit.cpp's kProofMinStep).
constexpr double kMinStep = 1.0 / 16384.0;
// Evaluations the proof of a piece may spend per sample (and at least kMinEvaluations): a cap that only
// a proof stuck at min_step everywhere reaches (what is left then counts as unproven).
constexpr std::size_t kEvaluationsPerSample = 4096;
constexpr std::size_t kMinEvaluations = 65536;

// The reference's channel values at t, continuous with `before` (the sample before t).
using ValuesAt = std::function<void(double t, const double* before, double* out)>;
// Makes the samples' rows one continuous lift again after samples were added between them (empty:
// the rows are the reference's own channel values, kept as they are).
using Relift = std::function<void(std::vector<double>& rows)>;

// The samples of a reduction: the given ones (candidates for keys) and those added (checked, and keys
// only where open_candidates opens them: a reduction keeps keys on the frames it was given).
struct Samples {
    std::vector<double> times;
    std::vector<double> values;            // rows of channel_count(mode)
    std::vector<unsigned char> given;      // 1: a given sample, 0: added (midpoints, the proof's)
    std::vector<unsigned char> candidate;  // 1: may become a key (the given ones; added ones opened)
    std::vector<unsigned char> forced;     // 1: a key in every reduction (given samples only; empty: none)
    bool single_key = false;               // a channel may keep one key (reduce_impl::flatten_channels)
};

// The reducer's Problem of the samples (its checks name times[k], quats[k], angles[k], values[k]).
reduce_impl::Problem make_problem(const Samples& s, const RotationMode& mode, KeyInterpolation ipo) {
    using namespace reduce_impl;
    const std::size_t n = s.times.size();
    switch (mode.kind) {
        case RotationMode::Kind::quaternion: {
            std::vector<Quat> q(n);
            for (std::size_t i = 0; i < n; ++i) q[i] = from_wxyz(&s.values[4 * i]);
            return make_quat_problem(s.times, q, ipo == KeyInterpolation::BEZIER);
        }
        case RotationMode::Kind::euler: {
            std::vector<Vec3> a(n);
            for (std::size_t i = 0; i < n; ++i) a[i] = Vec3(s.values[3 * i], s.values[3 * i + 1], s.values[3 * i + 2]);
            return make_euler_problem(s.times, a, mode.order);
        }
        case RotationMode::Kind::axis_angle: break;
    }
    std::vector<Vec4> a(n);
    for (std::size_t i = 0; i < n; ++i) a[i] = Vec4(s.values[4 * i], s.values[4 * i + 1], s.values[4 * i + 2], s.values[4 * i + 3]);
    return make_axis_angle_problem(s.times, a);
}

// The reducer's Problem of the samples: their forced keys (no other key within min_gap of one) and
// candidates set.
reduce_impl::Problem sample_problem(const Samples& s, const RotationMode& mode, KeyInterpolation ipo,
                                    double min_gap) {
    reduce_impl::Problem p = make_problem(s, mode, ipo);
    p.single_key = s.single_key;
    std::vector<std::size_t> forced;
    for (std::size_t k = 0; k < s.forced.size(); ++k)
        if (s.forced[k]) forced.push_back(k);
    reduce_impl::set_forced_keys(p, forced, forced.empty() ? 0.0 : min_gap);
    for (std::size_t k = 0; k < p.n; ++k) p.candidate[k] = p.candidate[k] && s.candidate[k];
    return p;
}

ReducedKeys reduce_samples(const Samples& s, const RotationMode& mode, double tolerance, KeyInterpolation ipo,
                           bool synchronized, double min_gap, bool free_handle_frames = true) {
    return reduce_impl::reduce(sample_problem(s, mode, ipo, min_gap), tolerance, ipo, synchronized,
                               free_handle_frames);
}

// The keys of the last round (`previous`, on the samples `before`) repaired on the samples of this
// one (reduce_impl::repair: only the segments where an added sample fails change), or the samples
// reduced afresh where the proof added more than kRepairAdded of them, or the repair does not meet the
// tolerance or keeps more than kRepairSlack of the keys and one per channel: where the added samples
// fail all over, splitting segment after segment keeps far more keys than a new choice (random keys
// at uneven spacing: up to +26 %; the 100-bone rig's random arcs, whose first proofs add 2.3 samples
// for each: +46 %).
ReducedKeys reduce_again(const Samples& s, const std::vector<double>& before, const ReducedKeys& previous,
                         const RotationMode& mode, double tolerance, KeyInterpolation ipo, bool synchronized,
                         double min_gap, bool free_handle_frames) {
    if (double(s.times.size() - before.size()) > kRepairAdded * double(before.size()))
        return reduce_samples(s, mode, tolerance, ipo, synchronized, min_gap, free_handle_frames);
    std::vector<std::size_t> index(before.size());
    for (std::size_t k = 0; k < before.size(); ++k)
        index[k] = static_cast<std::size_t>(std::lower_bound(s.times.begin(), s.times.end(), before[k]) - s.times.begin());
    ReducedKeys repaired = reduce_impl::repair(sample_problem(s, mode, ipo, min_gap), tolerance, ipo,
                                               previous, index, free_handle_frames);
    const double most = kRepairSlack * double(previous.key_count()) + double(previous.channels.size());
    if (!repaired.channels.empty() && repaired.max_error <= tolerance && double(repaired.key_count()) <= most)
        return repaired;
    return reduce_samples(s, mode, tolerance, ipo, synchronized, min_gap, free_handle_frames);
}

// Quaternion rows in place: each row negated where it disagrees in sign with the one before.
void make_continuous(std::vector<double>& values) {
    for (std::size_t i = 1; 4 * i < values.size(); ++i) {
        const double* a = &values[4 * (i - 1)];
        double* b = &values[4 * i];
        if (a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] < 0.0)
            for (int c = 0; c < 4; ++c) b[c] = -b[c];
    }
}

void merge_into(PlaybackBound& all, const PlaybackBound& part) {
    if (part.bound > all.bound || all.evaluations == 0) {
        all.bound = std::fmax(all.bound, part.bound);
        all.worst_time = part.worst_time;
    }
    all.max_evaluated = std::fmax(all.max_evaluated, part.max_evaluated);
    all.violations.insert(all.violations.end(), part.violations.begin(), part.violations.end());
    all.unproven.insert(all.unproven.end(), part.unproven.begin(), part.unproven.end());
    all.evaluations += part.evaluations;
}

// `all` with its violations sorted and unique and its unproven intervals sorted.
PlaybackBound merged(PlaybackBound all) {
    std::sort(all.violations.begin(), all.violations.end());
    all.violations.erase(std::unique(all.violations.begin(), all.violations.end()), all.violations.end());
    std::sort(all.unproven.begin(), all.unproven.end());
    return all;
}

// ---- the proof, piece by piece ---------------------------------------------------------------------
// The range is cut at every kPiece-th given sample into pieces, each
// proved on its own with the keys that shape Blender's playback there: a piece whose keys did not
// change since the last reduction keeps its proof (the playback there is the same, whatever samples
// were added), so the rounds after the first prove only where the keys moved, and every evaluation
// searches a few keys rather than all of them.

constexpr std::size_t kPiece = 32;

// The keys of `ch` that shape Blender's evaluation on [t0, t1]: from the one before the last key at or
// before t0 to the one after the first key at or after t1 (a frame within 1e-4 of a key takes its
// value, and keys are farther apart than that), as their own F-curve.
FCurveKeys slice_keys(const FCurveKeys& ch, double t0, double t1) {
    const std::size_t n = ch.frames.size();
    if (n == 0) return ch;
    const auto first = std::upper_bound(ch.frames.begin(), ch.frames.end(), t0);
    const auto last = std::lower_bound(ch.frames.begin(), ch.frames.end(), t1);
    std::size_t i0 = static_cast<std::size_t>(first - ch.frames.begin()), i1 = static_cast<std::size_t>(last - ch.frames.begin());
    i0 = i0 >= 2 ? i0 - 2 : 0;
    i1 = std::min(n - 1, i1 + 1);
    FCurveKeys out;
    out.frames.assign(ch.frames.begin() + static_cast<std::ptrdiff_t>(i0), ch.frames.begin() + static_cast<std::ptrdiff_t>(i1) + 1);
    out.values.assign(ch.values.begin() + static_cast<std::ptrdiff_t>(i0), ch.values.begin() + static_cast<std::ptrdiff_t>(i1) + 1);
    if (ch.handle_left.size() == 2 * n && ch.handle_right.size() == 2 * n) {
        out.handle_left.assign(ch.handle_left.begin() + static_cast<std::ptrdiff_t>(2 * i0),
                               ch.handle_left.begin() + static_cast<std::ptrdiff_t>(2 * i1) + 2);
        out.handle_right.assign(ch.handle_right.begin() + static_cast<std::ptrdiff_t>(2 * i0),
                                ch.handle_right.begin() + static_cast<std::ptrdiff_t>(2 * i1) + 2);
    }
    return out;
}

// The reference on one piece: the original keys sliced to it (a PlaybackMotion of a few keys), or the
// whole reference (a curve).
using ReferenceOn = std::function<std::unique_ptr<Motion>(double t0, double t1)>;

struct Piece {
    double t0 = 0.0, t1 = 0.0;          // given samples (float32 frames)
    std::unique_ptr<Motion> reference;  // null: the whole reference
    std::vector<FCurveKeys> keys;       // the reduced keys last proved here (sliced)
    PlaybackBound proof;
    bool proved = false;
};

bool same_keys(const std::vector<FCurveKeys>& a, const std::vector<FCurveKeys>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t c = 0; c < a.size(); ++c)
        if (a[c].frames != b[c].frames || a[c].values != b[c].values || a[c].handle_left != b[c].handle_left ||
            a[c].handle_right != b[c].handle_right)
            return false;
    return true;
}

// The pieces of the given samples `times`: cut at every kPiece-th sample, neighbours sharing their ends.
std::vector<Piece> make_pieces(const std::vector<double>& times, const ReferenceOn& reference_on) {
    std::vector<Piece> pieces;
    const std::size_t last = times.size() - 1;
    for (std::size_t a = 0;; a += kPiece) {
        const std::size_t b = std::min(a + kPiece, last);
        Piece piece;
        piece.t0 = static_cast<float>(times[a]);
        piece.t1 = static_cast<float>(times[b]);
        piece.reference = reference_on(piece.t0, piece.t1);
        pieces.push_back(std::move(piece));
        if (b == last) break;
    }
    return pieces;
}

// The samples of a piece: those whose float32 frames lie within its ends (float32 frames). A sample
// time that is not a float32 frame (3.3 + 40 × 0.25 in doubles) rounds to the frame Blender shows
// there, which may be a piece's end: compared as doubles it fell outside, and the interval between
// it and the piece's last sample inside was proved by neither piece.
std::vector<double> piece_span(const std::vector<double>& samples, const Piece& piece) {
    const auto from = std::lower_bound(samples.begin(), samples.end(), piece.t0,
                                       [](double s, double t0) { return static_cast<float>(s) < t0; });
    const auto to = std::upper_bound(samples.begin(), samples.end(), piece.t1,
                                     [](double t1, double s) { return t1 < static_cast<float>(s); });
    return std::vector<double>(from, to);
}

// The reduced keys' playback against the reference over every piece (`samples`: the samples of the
// reduction, whose times inside a piece are the proof's evaluated times there); pieces whose keys
// are those proved last keep their proof.
PlaybackBound prove_pieces(const ReducedKeys& keys, const RotationMode& mode, const Motion& whole_reference,
                           const std::vector<double>& samples, double tolerance, std::vector<Piece>& pieces) {
    PlaybackBound all;
    for (Piece& piece : pieces) {
        std::vector<FCurveKeys> sliced;
        for (const ReducedChannel& ch : keys.channels) sliced.push_back(slice_keys(ch, piece.t0, piece.t1));
        if (!piece.proved || !same_keys(sliced, piece.keys)) {
            const std::vector<double> span = piece_span(samples, piece);
            const std::size_t cap = std::max(kMinEvaluations, kEvaluationsPerSample * span.size());
            const PlaybackMotion reduced(sliced, keys.interpolation, mode);
            const Motion& reference = piece.reference ? *piece.reference : whole_reference;
            piece.proof = prove_within(reduced, reference, span, tolerance, kMinStep, cap);
            piece.keys = std::move(sliced);
            piece.proved = true;
        }
        merge_into(all, piece.proof);
    }
    return merged(std::move(all));
}

// After the last round, each piece whose proof still fails is made tight (tighten_proof, as the
// fit's key segments are): where the keys cannot follow the reference the bound is then within a
// few percent of what the playback does there, not the bound of the interval the proof stopped at.
// The verdict (violations, unproven intervals) stays the one at the tolerance.
PlaybackBound tighten_pieces(const ReducedKeys& keys, const RotationMode& mode, const Motion& whole_reference,
                             const std::vector<double>& samples, std::vector<Piece>& pieces) {
    PlaybackBound all;
    for (Piece& piece : pieces) {
        PlaybackBound& proof = piece.proof;
        if (!proof.proven()) {
            const std::vector<double> span = piece_span(samples, piece);
            const std::size_t cap = std::max(kMinEvaluations, kEvaluationsPerSample * span.size());
            const PlaybackMotion reduced(piece.keys, keys.interpolation, mode);
            tighten_proof(reduced, piece.reference ? *piece.reference : whole_reference, span, kMinStep, cap, proof);
        }
        merge_into(all, proof);
    }
    return merged(std::move(all));
}

// The times to add after a failed proof: every violation and the middle of every unproven interval,
// and with each the quarters of the sample interval it falls in and of the one on either side (where
// the reference turns between two samples in a way the reduction missed, one new sample rarely
// shows the reducer its shape there, and the next reduction moves its keys: on random BEZIER
// channels whose handles swing between frames this took 3-6 reductions where the failing times
// alone took 5-8 or more), as float32 frames, each kAddedSampleGap clear of the samples and of each
// other. Inserts them (with the reference's values) into
// times/values; returns how many.
std::size_t add_samples(const PlaybackBound& proof, const ValuesAt& values_at, std::size_t C, Samples& s) {
    const std::vector<double>& times = s.times;
    std::vector<double> failed = proof.violations;
    for (const auto& span : proof.unproven) failed.push_back(0.5 * (span.first + span.second));
    std::vector<double> add;
    for (double t : failed) {
        add.push_back(t);
        const std::size_t i = static_cast<std::size_t>(std::upper_bound(times.begin(), times.end(), t) - times.begin());
        if (i == 0 || i >= times.size()) continue;
        for (std::size_t j = i >= 2 ? i - 2 : 0; j < std::min(times.size() - 1, i + 1); ++j) {
            const double a = times[j], b = times[j + 1];
            for (int q = 1; q < kQuarters; ++q) add.push_back(a + (b - a) * q / kQuarters);
        }
    }
    for (double& t : add) t = static_cast<float>(t);
    std::sort(add.begin(), add.end());
    Samples out;
    out.single_key = s.single_key;
    out.times.reserve(times.size() + add.size());
    out.values.reserve(s.values.size() + C * add.size());
    out.given.reserve(times.size() + add.size());
    std::size_t j = 0, added = 0;
    for (std::size_t i = 0; i < times.size(); ++i) {
        for (; j < add.size() && add[j] < times[i]; ++j) {
            const double before = out.times.empty() ? -HUGE_VAL : out.times.back();
            if (out.times.empty() || !(add[j] - before > kAddedSampleGap) || !(times[i] - add[j] > kAddedSampleGap))
                continue;
            // Distinct from both neighbours as float32 (Blender's frames).
            if (!(static_cast<float>(add[j]) > static_cast<float>(before)) ||
                !(static_cast<float>(add[j]) < static_cast<float>(times[i])))
                continue;
            out.times.push_back(add[j]);
            const std::size_t row = out.values.size();
            out.values.resize(row + C);
            values_at(add[j], &out.values[row - C], &out.values[row]);
            out.given.push_back(0);
            out.candidate.push_back(0);
            if (!s.forced.empty()) out.forced.push_back(0);
            ++added;
        }
        out.times.push_back(times[i]);
        out.values.insert(out.values.end(), s.values.begin() + static_cast<std::ptrdiff_t>(C * i),
                          s.values.begin() + static_cast<std::ptrdiff_t>(C * (i + 1)));
        out.given.push_back(s.given[i]);
        out.candidate.push_back(s.candidate[i]);
        if (!s.forced.empty()) out.forced.push_back(s.forced[i]);
    }
    if (added) s = std::move(out);
    return added;
}

// The first reduction's samples: the given ones and, as added samples (checked, not keys), the
// reference midway between each two of them. The reducer's own
// between-samples guard measures its fit midway against the samples' LINEAR mean, loosely (reduce_fit.cpp);
// the reference's own value there lets the first reduction pass the proof far more often (the 19
// joints of mocapbank.bvh keyed at every frame, BEZIER and LINEAR: 25 of 38 proved after the first
// reduction instead of 8, in half the time).
void add_midpoints(const ValuesAt& values_at, std::size_t C, Samples& s) {
    Samples out;
    out.single_key = s.single_key;
    out.times.reserve(2 * s.times.size());
    out.values.reserve(2 * s.values.size());
    out.given.reserve(2 * s.times.size());
    for (std::size_t i = 0; i < s.times.size(); ++i) {
        if (i > 0) {
            const double a = s.times[i - 1], b = s.times[i], t = static_cast<float>(0.5 * (a + b));
            if (t - a > kAddedSampleGap && b - t > kAddedSampleGap) {
                out.times.push_back(t);
                const std::size_t row = out.values.size();
                out.values.resize(row + C);
                values_at(t, &out.values[row - C], &out.values[row]);
                out.given.push_back(0);
                out.candidate.push_back(0);
                if (!s.forced.empty()) out.forced.push_back(0);
            }
        }
        out.times.push_back(s.times[i]);
        out.values.insert(out.values.end(), s.values.begin() + static_cast<std::ptrdiff_t>(C * i),
                          s.values.begin() + static_cast<std::ptrdiff_t>(C * (i + 1)));
        out.given.push_back(s.given[i]);
        out.candidate.push_back(s.candidate[i]);
        if (!s.forced.empty()) out.forced.push_back(s.forced[i]);
    }
    s = std::move(out);
}

// Where keys on the given samples cannot meet an added sample (a Euler path sweeping through
// gimbal lock within a frame, a fast turn between two frames), the added samples between the two
// given ones around it become candidates for keys too: a key between frames where nothing else
// follows the reference. Returns whether any did.
bool open_candidates(const ReducedKeys& keys, const RotationMode& mode, double target, Samples& s) {
    std::vector<FCurveKeys> channels(keys.channels.begin(), keys.channels.end());
    const PlaybackMotion reduced(std::move(channels), keys.interpolation, mode);
    const std::size_t C = channel_count(mode), n = s.times.size();
    bool opened = false;
    std::size_t done = 0;  // samples before this are decided
    for (std::size_t i = 0; i < n; ++i) {
        if (s.given[i] || i < done) continue;
        const Quat want = channels_to_quat(&s.values[C * i], mode);
        if (!(angle_between(reduced.at(s.times[i]), want) > target)) continue;
        std::size_t a = i, b = i;
        while (a > 0 && !s.given[a]) --a;
        while (b + 1 < n && !s.given[b]) ++b;
        for (std::size_t k = a + 1; k < b; ++k) {
            opened = opened || !s.candidate[k];
            s.candidate[k] = 1;
        }
        done = b;
    }
    return opened;
}

// A quaternion row negated where it lies in the other hemisphere from `before` (other modes: as is).
void continue_sign(const RotationMode& mode, const double* before, double* out) {
    if (mode.kind == RotationMode::Kind::quaternion &&
        before[0] * out[0] + before[1] * out[1] + before[2] * out[2] + before[3] * out[3] < 0.0)
        for (int c = 0; c < 4; ++c) out[c] = -out[c];
}

// The channel values of `mode` at t of a reference given as rotations (`rotation_at`), continuous
// with the sample before.
ValuesAt rotation_values(std::function<Quat(double)> rotation_at, const RotationMode& mode) {
    return [rotation_at = std::move(rotation_at), mode](double at, const double* before, double* out) {
        const std::vector<double> v = quats_to_channels({rotation_at(at)}, mode, before, 1);
        std::copy(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(channel_count(mode)), out);
        continue_sign(mode, before, out);
    };
}

// The original keys (of `mode`) sliced to each piece, a PlaybackMotion of a few keys.
ReferenceOn sliced_reference(const std::vector<FCurveKeys>& original, KeyInterpolation interpolation,
                             const RotationMode& mode) {
    return [&original, interpolation, mode](double t0, double t1) -> std::unique_ptr<Motion> {
        std::vector<FCurveKeys> sliced;
        for (const FCurveKeys& ch : original) sliced.push_back(slice_keys(ch, t0, t1));
        return std::make_unique<PlaybackMotion>(std::move(sliced), interpolation, mode);
    };
}

// Euler rows made one compatible chain again after every insertion of samples (euler_filter_from_anchor:
// the row farthest from gimbal lock keeps its values); empty for other modes. The given rows' branches
// were chosen between samples a frame or a quarter frame apart; where the path passes near gimbal
// lock its channels swing fast and the branch nearest the row before may be the other one, so a
// sample added before such a row, continuous with the row before it, would leave a change of branch
// between two neighbouring samples, which Blender interpolates channel by channel, off the rotation
// (a quaternion path 1.5° from XYZ's lock: 1.55° between two samples 1/512 frame apart; SQUAD and
// SLERP bakes reduced to XYZ or ZXY through random keys: 34 of 240 above 0.05° after 8 rounds, up to
// 11.7°). Re-chained, the rows follow the path as densely as it is sampled.
Relift euler_relift(const RotationMode& mode) {
    if (mode.kind != RotationMode::Kind::euler) return {};
    return [order = mode.order](std::vector<double>& r) {
        const std::size_t n = r.size() / 3;
        std::vector<Vec3> a(n);
        for (std::size_t i = 0; i < n; ++i) a[i] = Vec3(r[3 * i], r[3 * i + 1], r[3 * i + 2]);
        euler_filter_from_anchor(a.data(), n, order);
        for (std::size_t i = 0; i < n; ++i)
            for (int c = 0; c < 3; ++c) r[3 * i + c] = a[i][c];
    };
}

// forced: flags of the given samples that are keys in every reduction (empty: none), no other key
// within min_gap frames of them. single_key: the keys are the whole result (not a piece joined to
// copied keys), so a channel one value meets may keep one key (reduce_impl::flatten_channels).
ProvedKeys reduce_proved(const Motion& reference, const ReferenceOn& reference_on, const ValuesAt& values_at,
                         const RotationMode& mode, const std::vector<double>& times, std::vector<double> values,
                         double tolerance, KeyInterpolation ipo, bool synchronized,
                         std::vector<unsigned char> forced = {}, double min_gap = 0.0, const Relift& relift = {},
                         bool single_key = false) {
    ProvedKeys out;
    const std::size_t C = channel_count(mode);
    Samples s{times, std::move(values), std::vector<unsigned char>(times.size(), 1),
              std::vector<unsigned char>(times.size(), 1), std::move(forced), single_key};
    // The given samples checked as the reducer checks them, before any is added (errors name them).
    reduce_impl::check_float32_storage(make_problem(s, mode, ipo), tolerance);
    if (tolerance == 0.0) {
        // Every sample kept; between them nothing can be promised at 0.
        out.keys = reduce_samples(s, mode, 0.0, ipo, synchronized, min_gap);
        out.rounds = 1;
        out.proof.bound = HUGE_VAL;
        out.proof.worst_time = times.front();
        if (times.size() > 1) out.proof.unproven.emplace_back(times.front(), times.back());
        out.times = std::move(s.times);
        return out;
    }
    std::vector<Piece> pieces = make_pieces(times, reference_on);
    add_midpoints(values_at, C, s);
    if (relift) relift(s.values);
    // Rounds with the handle frames free (reduce_impl.hpp, kHandleFractions); should they end unproved,
    // the rounds again with every handle frame at the thirds, on the samples added so far (random
    // quaternion keys at uneven spacing: 2 of 40 ended unproved with the frames free, none with the
    // thirds).
    const double share = reduce_share(tolerance) * tolerance;
    for (bool free_frames : {true, false}) {
        const int first_round = out.rounds + 1;
        std::vector<double> before;  // the samples of the last round, when its keys are to be repaired
        for (int round = first_round;; ++round) {
            if (before.empty()) {
                out.keys = reduce_samples(s, mode, share, ipo, synchronized, min_gap, free_frames);
            } else {
                out.keys = reduce_again(s, before, out.keys, mode, share, ipo, synchronized, min_gap, free_frames);
            }
            if (out.keys.max_error > share && open_candidates(out.keys, mode, share, s))
                out.keys = reduce_samples(s, mode, share, ipo, synchronized, min_gap, free_frames);
            out.rounds = round;
            out.proof = prove_pieces(out.keys, mode, reference, s.times, tolerance, pieces);
            if (out.proof.proven() || round - first_round + 1 >= kProofRounds) break;
            // The second round repairs the first one's keys where the added samples fail: every
            // sample stays one (add_samples only adds), at the same values unless relifted. Later
            // rounds reduce afresh: where repaired keys still fail, they fail in new places, and
            // repairing them again splits ever more segments (random keys at uneven spacing: more
            // left unproved after 8 rounds than with every round reduced afresh).
            if (!relift && round == first_round) {
                before = s.times;
            } else {
                before.clear();
            }
            if (add_samples(out.proof, values_at, C, s) == 0) break;
            if (relift) relift(s.values);
        }
        const bool could_be_free = mode.kind == RotationMode::Kind::quaternion && ipo == KeyInterpolation::BEZIER &&
                                   share >= reduce_impl::kHandleFreeMinTolerance;
        if (out.proof.proven() || !could_be_free) break;
    }
    if (!out.proof.proven()) out.proof = tighten_pieces(out.keys, mode, reference, s.times, pieces);
    out.times = std::move(s.times);
    return out;
}

// Checks what the reducer does not see before it runs: the values count, the tolerance.
void check_rows(const std::vector<double>& times, const std::vector<double>& values, const RotationMode& mode,
                double tolerance) {
    const std::size_t C = channel_count(mode);
    if (values.size() != C * times.size())
        throw InvalidArgument("values: " + std::to_string(values.size()) + " numbers for " +
                              std::to_string(times.size()) + " times of " + std::to_string(C) + " channels");
    if (times.empty()) throw InvalidArgument("times: at least one sample");
    if (!(tolerance >= 0.0) || !std::isfinite(tolerance)) throw InvalidArgument("tolerance: must be finite and >= 0");
    for (std::size_t i = 0; i < times.size(); ++i)
        if (!std::isfinite(times[i])) throw InvalidArgument("times[" + std::to_string(i) + "]: not finite");
}

// ---- the original's own sign flips, copied -----------------------------------------------------------
// Where the original's stored quaternions lie in opposite hemispheres at two neighbouring samples,
// Blender interpolates the four channels through near zero: a turn of up to 360° inside one
// interval that no hemisphere-continuous reduction follows. The keys that shape that playback are
// copied instead, bit for bit (reduce.hpp), and the pieces between them reduced on their own.

// Quaternion rows in place: each with the sign of the original's playback at its time (the caller's
// values are Blender's evaluation, possibly of either sign).
void stored_signs(const PlaybackMotion& playback, const std::vector<double>& times, std::vector<double>& rows) {
    for (std::size_t i = 0; i < times.size(); ++i) {
        double p[4];
        playback.values(times[i], p);
        double* r = &rows[4 * i];
        if (r[0] * p[0] + r[1] * p[1] + r[2] * p[2] + r[3] * p[3] < 0.0)
            for (int c = 0; c < 4; ++c) r[c] = -r[c];
    }
}

// A channel of one key or none is constant: keyed, in effect, at every frame.
bool constant_channel(const FCurveKeys& ch) { return ch.frames.size() <= 1; }

// Whether every channel with more than one key has a key at `frame` (float32): `all`; or any: !all.
bool keyed_at(const std::vector<FCurveKeys>& original, float frame, bool all) {
    bool any = false;
    for (const FCurveKeys& ch : original) {
        if (constant_channel(ch)) continue;
        const bool has = std::binary_search(ch.frames.begin(), ch.frames.end(), static_cast<double>(frame));
        if (all && !has) return false;
        any = any || has;
    }
    return all || any;
}

// The sample span [s0, s1] widened to the last sample at or before s0 and the first at or after s1
// where every channel has a key (keyed_at; the range's first or last sample where there is none).
void widen_to_common_keys(const std::vector<FCurveKeys>& original, const std::vector<double>& times, std::size_t& s0,
                          std::size_t& s1) {
    while (s0 > 0 && !keyed_at(original, static_cast<float>(times[s0]), true)) --s0;
    while (s1 + 1 < times.size() && !keyed_at(original, static_cast<float>(times[s1]), true)) ++s1;
}

// Merges sample spans (overlapping or touching) in place, sorted.
void merge_spans(std::vector<std::pair<std::size_t, std::size_t>>& spans) {
    std::sort(spans.begin(), spans.end());
    std::vector<std::pair<std::size_t, std::size_t>> out;
    for (const auto& s : spans) {
        if (!out.empty() && s.first <= out.back().second) {
            out.back().second = std::max(out.back().second, s.second);
        } else {
            out.push_back(s);
        }
    }
    spans = std::move(out);
}

// The sample spans [S0, S1] (indices into times) whose keys are copied. Blender leaves the
// hemisphere-continuous path where two neighbouring samples lie in opposite hemispheres, and across
// every segment between two neighbouring key frames (of any channel) whose ends do — there every
// channel interpolates between two keys of its own, toward the far side of the origin, whether or not
// a sample lands on either side of where it passes it. Each such interval is widened to the last
// sample before it where every channel has a key (keyed_at) and the first one after it — the range's
// first or last sample where there is none — and the spans merged where they overlap or touch.
std::vector<std::pair<std::size_t, std::size_t>> flip_spans(const std::vector<FCurveKeys>& original,
                                                            const std::vector<double>& times,
                                                            const std::vector<double>& rows) {
    const std::size_t n = times.size();
    std::vector<unsigned char> keyed(n);
    for (std::size_t i = 0; i < n; ++i) keyed[i] = keyed_at(original, static_cast<float>(times[i]), false);
    const auto opposite = [&](std::size_t i, std::size_t j) {
        const double* a = &rows[4 * i];
        const double* b = &rows[4 * j];
        return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] < 0.0;
    };
    std::vector<std::pair<std::size_t, std::size_t>> spans;
    std::size_t last_key = keyed[0] ? 0 : n;  // the last keyed sample so far (n: none)
    for (std::size_t i = 1; i < n; ++i) {
        std::size_t s0 = n;
        if (opposite(i - 1, i)) s0 = i - 1;
        if (keyed[i] && last_key < n && opposite(last_key, i)) s0 = std::min(s0, last_key);
        if (keyed[i]) last_key = i;
        if (s0 == n) continue;
        std::size_t s1 = i;
        widen_to_common_keys(original, times, s0, s1);
        spans.emplace_back(s0, s1);
    }
    merge_spans(spans);
    return spans;
}

// One key of an assembled channel; a side without handles gets straight ones (segment_handles).
struct KeyRow {
    double frame = 0.0, value = 0.0;
    double left[2] = {0.0, 0.0}, right[2] = {0.0, 0.0};
    bool has_left = false, has_right = false;
};

// The keys of `ch` that shape Blender's playback on [f0, f1], f0 and f1 keys of it or the ends of its
// keyed range: those with frames in [f0, f1], handles as stored. A constant channel: two keys holding
// its value at f0 and f1 with flat handles (Blender plays both exactly as the value: a LINEAR change of
// 0, a BEZIER segment of four equal values).
std::vector<KeyRow> copy_keys(const FCurveKeys& ch, double f0, double f1) {
    std::vector<KeyRow> out;
    if (constant_channel(ch)) {
        const double v = ch.frames.empty() ? 0.0 : ch.values[0];
        const double third = static_cast<float>((f1 - f0) / 3.0);
        for (double f : {f0, f1}) {
            KeyRow k;
            k.frame = f;
            k.value = v;
            k.left[0] = static_cast<float>(f - third);
            k.right[0] = static_cast<float>(f + third);
            k.left[1] = k.right[1] = v;
            k.has_left = k.has_right = true;
            out.push_back(k);
        }
        return out;
    }
    const bool handles = ch.handle_left.size() == 2 * ch.frames.size() && ch.handle_right.size() == 2 * ch.frames.size();
    for (std::size_t k = 0; k < ch.frames.size(); ++k) {
        if (ch.frames[k] < f0 || ch.frames[k] > f1) continue;
        KeyRow r;
        r.frame = ch.frames[k];
        r.value = ch.values[k];
        if (handles) {
            std::copy(&ch.handle_left[2 * k], &ch.handle_left[2 * k] + 2, r.left);
            std::copy(&ch.handle_right[2 * k], &ch.handle_right[2 * k] + 2, r.right);
            r.has_left = r.has_right = true;
        }
        out.push_back(r);
    }
    return out;
}

std::vector<KeyRow> reduced_rows(const ReducedChannel& ch) {
    std::vector<KeyRow> out(ch.frames.size());
    const bool handles = ch.handle_left.size() == 2 * ch.frames.size();
    for (std::size_t k = 0; k < out.size(); ++k) {
        out[k].frame = ch.frames[k];
        out[k].value = ch.values[k];
        if (handles) {
            std::copy(&ch.handle_left[2 * k], &ch.handle_left[2 * k] + 2, out[k].left);
            std::copy(&ch.handle_right[2 * k], &ch.handle_right[2 * k] + 2, out[k].right);
            out[k].has_left = out[k].has_right = true;
        }
    }
    return out;
}

// Appends `part` to `out`; a key on both (the joint of a piece and a copied span) keeps the value of
// `copied` side's key (the original's, which the piece's end key equals), the left handle of the part
// before and the right handle of the part after.
void append_rows(std::vector<KeyRow>& out, const std::vector<KeyRow>& part, bool part_copied) {
    std::size_t from = 0;
    if (!out.empty() && !part.empty() && part.front().frame == out.back().frame) {
        KeyRow& k = out.back();
        if (part_copied) k.value = part.front().value;
        std::copy(part.front().right, part.front().right + 2, k.right);
        k.has_right = part.front().has_right;
        from = 1;
    }
    out.insert(out.end(), part.begin() + static_cast<std::ptrdiff_t>(from), part.end());
}

// The reduced pieces (pieces[p] reduced the samples piece_of[p]) and the copied spans, joined into one
// ProvedKeys over `times`: per channel the pieces' keys and the original's keys of each span in frame
// order; handles where the output or the copied keys are BEZIER (a side that has none straight);
// the proofs of the pieces merged (a copied span's playback is the original's); the samples of every
// piece, the given ones inside the spans and the copied key frames.
ProvedKeys join_pieces(const std::vector<FCurveKeys>& original, KeyInterpolation original_interpolation,
                       const std::vector<double>& times, const std::vector<std::pair<std::size_t, std::size_t>>& spans,
                       const std::vector<ProvedKeys>& pieces,
                       const std::vector<std::pair<std::size_t, std::size_t>>& piece_of, double tolerance,
                       KeyInterpolation ipo) {
    ProvedKeys out;
    out.copied_interpolation = original_interpolation;
    for (const auto& span : spans) out.copied.emplace_back(static_cast<float>(times[span.first]), static_cast<float>(times[span.second]));
    out.keys.interpolation = ipo;
    out.proof.worst_time = static_cast<float>(times.front());
    out.rounds = 1;
    for (const ProvedKeys& piece : pieces) {
        merge_into(out.proof, piece.proof);
        out.keys.max_error = std::fmax(out.keys.max_error, piece.keys.max_error);
        out.rounds = std::max(out.rounds, piece.rounds);
        out.times.insert(out.times.end(), piece.times.begin(), piece.times.end());
    }
    std::sort(out.proof.violations.begin(), out.proof.violations.end());
    std::sort(out.proof.unproven.begin(), out.proof.unproven.end());
    if (tolerance == 0.0) {  // every sample kept; nothing promised between them at 0
        out.proof = PlaybackBound();
        out.proof.bound = HUGE_VAL;
        out.proof.worst_time = times.front();
        out.proof.unproven.emplace_back(times.front(), times.back());
    }
    for (const auto& span : spans)
        out.times.insert(out.times.end(), times.begin() + static_cast<std::ptrdiff_t>(span.first),
                         times.begin() + static_cast<std::ptrdiff_t>(span.second) + 1);
    const bool handles = ipo == KeyInterpolation::BEZIER || original_interpolation == KeyInterpolation::BEZIER;
    std::vector<std::vector<KeyRow>> channels(original.size());
    for (std::size_t c = 0; c < original.size(); ++c) {
        std::size_t p = 0;
        for (std::size_t s = 0; s <= spans.size(); ++s) {
            const std::size_t before = s < spans.size() ? spans[s].first : times.size();
            for (; p < pieces.size() && piece_of[p].first < before; ++p)
                append_rows(channels[c], reduced_rows(pieces[p].keys.channels[c]), false);
            if (s == spans.size()) break;
            const std::vector<KeyRow> copied =
                copy_keys(original[c], out.copied[s].first, out.copied[s].second);
            append_rows(channels[c], copied, true);
            for (const KeyRow& k : copied) out.times.push_back(k.frame);
        }
    }
    // The samples, increasing: a copied key on a sample's float32 frame is that sample.
    std::sort(out.times.begin(), out.times.end());
    std::vector<double> unique;
    for (double t : out.times)
        if (unique.empty() || static_cast<float>(t) != static_cast<float>(unique.back())) unique.push_back(t);
    out.times = std::move(unique);
    std::vector<float> frames32(out.times.begin(), out.times.end());
    for (std::size_t c = 0; c < channels.size(); ++c) {
        const std::vector<KeyRow>& rows = channels[c];
        ReducedChannel ch;
        for (const KeyRow& k : rows) {
            ch.frames.push_back(k.frame);
            ch.values.push_back(k.value);
            ch.indices.push_back(static_cast<std::size_t>(
                std::lower_bound(frames32.begin(), frames32.end(), static_cast<float>(k.frame)) - frames32.begin()));
        }
        if (handles) {
            const std::size_t K = rows.size();
            std::vector<double> left(2 * K), right(2 * K);
            segment_handles(ch.frames.data(), ch.values.data(), K, left.data(), right.data());
            for (std::size_t k = 0; k < K; ++k) {
                if (rows[k].has_left) std::copy(rows[k].left, rows[k].left + 2, &left[2 * k]);
                if (rows[k].has_right) std::copy(rows[k].right, rows[k].right + 2, &right[2 * k]);
            }
            for (double& x : left) x = static_cast<float>(x);
            for (double& x : right) x = static_cast<float>(x);
            ch.handle_left = std::move(left);
            ch.handle_right = std::move(right);
        }
        out.keys.channels.push_back(std::move(ch));
    }
    out.keys.synchronized = reduce_impl::same_keys(out.keys.channels);
    return out;
}

// The reduction, or the original's own keys when the reduction keeps as many or more, or ends
// unproved: a reduction proved at every instant can need more keys than an original whose keys lie
// closer than its samples can follow (keys a few float32 steps apart far from frame 0), or not be
// proved there at all (add_failing_spans). The original's keys, copied whole as one
// span (join_pieces: each channel's keys bit for bit, a constant channel two keys), play as the
// original does: bound 0.
// Only where every channel's keys lie within the samples' range (the copy then changes nothing
// outside it) and a tolerance above 0 (0 keeps every sample, proving nothing between them).
ProvedKeys or_original_keys(ProvedKeys reduced, const std::vector<FCurveKeys>& original,
                       KeyInterpolation original_interpolation, const std::vector<double>& times, double tolerance,
                       KeyInterpolation interpolation) {
    if (!(tolerance > 0.0)) return reduced;
    const double f0 = static_cast<float>(times.front()), f1 = static_cast<float>(times.back());
    std::size_t count = 0;
    for (const FCurveKeys& ch : original) {
        if (!ch.frames.empty() && (ch.frames.front() < f0 || ch.frames.back() > f1)) return reduced;
        count += constant_channel(ch) ? 2 : ch.frames.size();
    }
    if (count >= reduced.keys.key_count() && reduced.proof.proven()) return reduced;
    return join_pieces(original, original_interpolation, times, {{0, times.size() - 1}}, {}, {}, tolerance,
                       interpolation);
}

// ---- where the proof fails after every round, copied ---------------------------------------------
// A reduction can end unproved where its samples cannot show the reducer what the playback does
// (keys a few hundredths of a frame apart, a violation just outside a key's 1e-4 snap zone, closer to
// a sample than a sample may be added): there the original's keys are copied too, as around its sign
// flips, and the pieces between reduced again, each on its own; the copied spans grow (kFailReach)
// until every piece is proved, and where they do not the original's keys are kept whole
// (or_original_keys), whose playback is the original's.
constexpr std::size_t kFailReach[] = {1, 4, 16};

// `spans` with the sample spans around every time the proof failed (its violations and unproven
// intervals): the samples on either side of it, `reach` more on each side, widened to samples where
// every channel has a key (keyed_at; the range's first or last sample where there is none).
void add_failing_spans(const PlaybackBound& proof, const std::vector<FCurveKeys>& original,
                       const std::vector<double>& times, std::size_t reach,
                       std::vector<std::pair<std::size_t, std::size_t>>& spans) {
    const std::size_t n = times.size();
    std::vector<std::pair<double, double>> failed(proof.unproven.begin(), proof.unproven.end());
    for (double t : proof.violations) failed.emplace_back(t, t);
    for (const auto& [t0, t1] : failed) {
        const std::size_t after = static_cast<std::size_t>(std::lower_bound(times.begin(), times.end(), t1) - times.begin());
        const std::size_t at = static_cast<std::size_t>(std::upper_bound(times.begin(), times.end(), t0) - times.begin());
        std::size_t s0 = at == 0 ? 0 : at - 1, s1 = std::min(after, n - 1);
        s0 = s0 >= reach ? s0 - reach : 0;
        s1 = std::min(n - 1, s1 + reach);
        widen_to_common_keys(original, times, s0, s1);
        if (s1 > s0) spans.emplace_back(s0, s1);
    }
    merge_spans(spans);
}

}  // namespace

ProvedKeys reduce_keys_proved(const std::vector<FCurveKeys>& original, KeyInterpolation original_interpolation,
                              const RotationMode& mode, const std::vector<double>& times,
                              const std::vector<double>& values, double tolerance, KeyInterpolation interpolation,
                              bool synchronized, bool one_key_channels) {
    check_rows(times, values, mode, tolerance);
    const PlaybackMotion playback(original, original_interpolation, mode);
    const std::size_t C = channel_count(mode);
    std::vector<double> rows = values;
    const ValuesAt values_at = [&](double at, const double* before, double* out) {
        playback.values(at, out);
        continue_sign(mode, before, out);
    };
    const ReferenceOn reference_on = sliced_reference(original, original_interpolation, mode);
    std::vector<std::pair<std::size_t, std::size_t>> spans;
    if (mode.kind == RotationMode::Kind::quaternion) {
        // The given samples checked as a whole, before any piece is (errors name their index in `times`).
        reduce_impl::check_float32_storage(
            make_problem(Samples{times, rows, {}, {}, {}}, mode, interpolation), tolerance);
        stored_signs(playback, times, rows);
        spans = flip_spans(original, times, rows);
        if (spans.empty()) make_continuous(rows);  // (the stored signs are continuous then)
    }
    // The samples reduced and proved as a whole, or in pieces between copied spans. A piece's samples
    // and end values follow from its range alone (its ends are the copied spans' ends, or the range's),
    // so a piece that the copied spans leave as it was is reduced once (`reduced`).
    std::map<std::pair<std::size_t, std::size_t>, ProvedKeys> reduced;
    const auto reduce_around = [&](const std::vector<std::pair<std::size_t, std::size_t>>& copied) {
        if (copied.empty()) {
            ProvedKeys out = reduce_proved(playback, reference_on, values_at, mode, times, rows, tolerance,
                                           interpolation, synchronized, {}, 0.0, {}, one_key_channels);
            out.copied_interpolation = original_interpolation;
            return out;
        }
        std::vector<double> pinned = rows;
        for (const auto& span : copied)  // the copied keys' values exactly, where the pieces beside them end
            for (std::size_t i : {span.first, span.second}) playback.values(times[i], &pinned[C * i]);
        std::vector<ProvedKeys> pieces;
        std::vector<std::pair<std::size_t, std::size_t>> piece_of;
        std::size_t begin = 0;
        for (std::size_t s = 0; s <= copied.size(); ++s) {
            const std::size_t end = s < copied.size() ? copied[s].first : times.size() - 1;
            if (end > begin) {
                auto [at, fresh] = reduced.try_emplace({begin, end});
                if (fresh) {
                    const std::vector<double> t(times.begin() + static_cast<std::ptrdiff_t>(begin),
                                                times.begin() + static_cast<std::ptrdiff_t>(end) + 1);
                    std::vector<double> v(pinned.begin() + static_cast<std::ptrdiff_t>(C * begin),
                                          pinned.begin() + static_cast<std::ptrdiff_t>(C * end + C));
                    at->second = reduce_proved(playback, reference_on, values_at, mode, t, std::move(v), tolerance,
                                               interpolation, synchronized);
                }
                pieces.push_back(at->second);
                piece_of.emplace_back(begin, end);
            }
            if (s < copied.size()) begin = copied[s].second;
        }
        return join_pieces(original, original_interpolation, times, copied, pieces, piece_of, tolerance, interpolation);
    };
    ProvedKeys out = reduce_around(spans);
    for (std::size_t reach : kFailReach) {
        if (out.proof.proven() || !(tolerance > 0.0)) break;
        add_failing_spans(out.proof, original, times, reach, spans);
        out = reduce_around(spans);
    }
    return or_original_keys(std::move(out), original, original_interpolation, times, tolerance, interpolation);
}

ProvedKeys reduce_curve_proved(const Curve& curve, const RotationMode& mode, const std::vector<double>& times,
                               const std::vector<double>& values, double tolerance, KeyInterpolation interpolation,
                               bool synchronized, bool one_key_channels) {
    check_rows(times, values, mode, tolerance);
    const CurveMotion motion(curve);
    std::vector<double> rows = values;
    if (mode.kind == RotationMode::Kind::quaternion) make_continuous(rows);
    const ValuesAt values_at = rotation_values(
        [&curve](double at) {
            double q[4];
            curve.sample(&at, 1, q);
            return from_wxyz(q);
        },
        mode);
    const KeptBreaks kept(motion);
    const ReferenceOn whole = [](double, double) { return std::unique_ptr<Motion>(); };
    return reduce_proved(kept, whole, values_at, mode, times, rows, tolerance, interpolation, synchronized, {}, 0.0,
                         euler_relift(mode), one_key_channels);
}

ProvedKeys convert_keys_proved(const std::vector<FCurveKeys>& original, KeyInterpolation original_interpolation,
                               const RotationMode& from, const RotationMode& to, const std::vector<double>& times,
                               const std::vector<double>& values, const std::vector<std::size_t>& forced,
                               double tolerance, double min_gap) {
    check_rows(times, values, to, tolerance);
    if (!(tolerance > 0.0)) throw InvalidArgument("tolerance: must be above 0 (a conversion is proved within it)");
    if (!(min_gap >= 0.0) || !std::isfinite(min_gap)) throw InvalidArgument("min_gap: must be finite and >= 0 frames");
    std::vector<unsigned char> flags(times.size(), 0);
    for (std::size_t a = 0; a < forced.size(); ++a) {
        if (forced[a] >= times.size() || (a > 0 && !(forced[a] > forced[a - 1])))
            throw InvalidArgument("forced[" + std::to_string(a) + "]: sample " + std::to_string(forced[a]) +
                                  (forced[a] >= times.size() ? " does not exist (" + std::to_string(times.size()) +
                                                                   " samples)"
                                                             : " is not after the one before"));
        flags[forced[a]] = 1;
    }
    const PlaybackMotion playback(original, original_interpolation, from);
    std::vector<double> rows = values;
    if (to.kind == RotationMode::Kind::quaternion) make_continuous(rows);
    const ValuesAt values_at = rotation_values([&playback](double at) { return playback.at(at); }, to);
    const ReferenceOn reference_on = sliced_reference(original, original_interpolation, from);
    const Relift relift = euler_relift(to);
    ProvedKeys out = reduce_proved(playback, reference_on, values_at, to, times, std::move(rows), tolerance,
                                   KeyInterpolation::BEZIER, false, std::move(flags), min_gap, relift);
    out.copied_interpolation = original_interpolation;
    return out;
}

}  // namespace quatcurve
