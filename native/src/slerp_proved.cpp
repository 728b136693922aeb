// reduce_slerp_proved (slerp_keys.hpp): glTF LINEAR keys proved against a reference at every instant.
#include <algorithm>
#include <cmath>
#include <string>

#include "quatcurve/bound.hpp"
#include "quatcurve/curve.hpp"
#include "quatcurve/errors.hpp"
#include "quatcurve/slerp_keys.hpp"

namespace quatcurve {

namespace {

constexpr int kRounds = 8;
constexpr double kShare = 0.9;                 // of the tolerance, for the reduction at the samples
constexpr double kAddedGap = 1.0 / 1024.0;     // an added sample keeps this far from its neighbours

// The reference's rotations at `t`, each in the hemisphere of the one before.
std::vector<Quat> rotations(const Motion& reference, const std::vector<double>& t) {
    std::vector<Quat> q(t.size());
    for (std::size_t i = 0; i < t.size(); ++i) {
        q[i] = reference.at(t[i]);
        if (i > 0 && glm::dot(q[i], q[i - 1]) < 0.0) q[i] = -q[i];
    }
    return q;
}

// `times` with the failing times of `proof` added: each moved an eighth of its sample interval in
// from a sample it lies by, none nearer than kAddedGap to another. Returns how many were added.
std::size_t add_failures(const PlaybackBound& proof, std::vector<double>& times, double file_unit) {
    std::vector<double> add = proof.violations;
    for (const auto& span : proof.unproven) add.push_back(0.5 * (span.first + span.second));
    std::sort(add.begin(), add.end());
    std::vector<double> merged;
    merged.reserve(times.size() + add.size());
    std::size_t j = 0, added = 0;
    double below = -HUGE_VAL;
    for (double t : times) {
        for (; j < add.size() && add[j] < t; ++j) {
            if (!std::isfinite(below)) continue;
            const double g = std::fmax(kAddedGap, 0.125 * (t - below));
            double at = std::clamp(add[j], below + g, t - g);
            if (file_unit > 0.0) at = static_cast<double>(static_cast<float>(at * file_unit)) / file_unit;
            if (at - merged.back() > kAddedGap && t - at > kAddedGap) {
                merged.push_back(at);
                ++added;
            }
        }
        merged.push_back(t);
        below = t;
    }
    times.swap(merged);
    return added;
}

// The proof over every run of `times` that crosses no excluded interval, merged.
PlaybackBound prove_pieces(const Motion& a, const Motion& b, const std::vector<double>& times, double tolerance,
                           const std::vector<std::pair<double, double>>& excluded) {
    PlaybackBound all;
    std::vector<double> piece;
    auto prove = [&]() {
        if (piece.size() >= 2) {
            const PlaybackBound p = prove_within(a, b, piece, tolerance);
            if (p.bound > all.bound) all.bound = p.bound, all.worst_time = p.worst_time;
            all.max_evaluated = std::max(all.max_evaluated, p.max_evaluated);
            all.violations.insert(all.violations.end(), p.violations.begin(), p.violations.end());
            all.unproven.insert(all.unproven.end(), p.unproven.begin(), p.unproven.end());
            all.evaluations += p.evaluations;
        }
        piece.clear();
    };
    std::size_t e = 0;
    for (double t : times) {
        while (e < excluded.size() && excluded[e].second < t) ++e;
        if (!piece.empty() && e < excluded.size() && excluded[e].first <= piece.back() && t <= excluded[e].second) {
            prove();  // the interval into t lies in an excluded span: left out
        }
        piece.push_back(t);
    }
    prove();
    return all;
}

}  // namespace

std::vector<std::pair<double, double>> quaternion_flips(const PlaybackMotion& playback, const std::vector<double>& times) {
    // Neighbouring keys (the breaks: every channel's key frames and their snap edges) whose channel
    // values lie in opposite hemispheres, and neighbouring samples that do (a flip between keys of
    // different channels): the flip is the key segment around them — the values pass near zero
    // somewhere in it (a sample may sit right there and see positive dot products on both sides),
    // and the turn spreads as far as they stay small.
    const std::vector<double> keys = playback.breaks();
    std::vector<std::pair<double, double>> spans;
    auto scan = [&](const std::vector<double>& at) {
        double before[4] = {0.0, 0.0, 0.0, 0.0};
        for (std::size_t i = 0; i < at.size(); ++i) {
            double v[4];
            playback.values(at[i], v);
            if (i > 0 && v[0] * before[0] + v[1] * before[1] + v[2] * before[2] + v[3] * before[3] < 0.0) {
                auto hi = std::lower_bound(keys.begin(), keys.end(), at[i]);
                auto lo = std::upper_bound(keys.begin(), keys.end(), at[i - 1]);
                spans.emplace_back(lo == keys.begin() ? at[i - 1] : std::min(*(lo - 1), at[i - 1]),
                                   hi == keys.end() ? at[i] : std::max(*hi, at[i]));
            }
            std::copy(v, v + 4, before);
        }
    };
    scan(keys);
    scan(times);
    std::sort(spans.begin(), spans.end());
    std::vector<std::pair<double, double>> out;
    for (const auto& span : spans) {
        if (!out.empty() && span.first <= out.back().second) out.back().second = std::max(out.back().second, span.second);
        else out.push_back(span);
    }
    return out;
}

ProvedSlerpKeys reduce_slerp_proved(const Motion& reference, const std::vector<double>& times, double tolerance,
                                    bool cyclic, double file_unit,
                                    std::vector<std::pair<double, double>> excluded) {
    if (times.size() < 2) throw InvalidArgument("times: at least two samples");
    if (!(file_unit >= 0.0) || !std::isfinite(file_unit)) throw InvalidArgument("file_unit: must be finite and >= 0");
    if (!std::isfinite(tolerance) || tolerance < 0.0) throw InvalidArgument("tolerance: must be finite and >= 0");
    ProvedSlerpKeys out;
    out.times = times;
    out.excluded = std::move(excluded);
    for (int round = 0;; ++round) {
        const std::vector<Quat> q = rotations(reference, out.times);
        out.keys = reduce_slerp(out.times, q, kShare * tolerance, cyclic);
        out.rounds = round + 1;
        std::vector<double> key_times;
        key_times.reserve(out.keys.indices.size());
        for (std::size_t i : out.keys.indices) key_times.push_back(out.times[i]);
        // glTF's slerp between the keys: the shortest way between neighbours (the keys are in one
        // hemisphere chain), which a SLERP Curve through them plays.
        const Curve played(key_times, out.keys.quats, Method::SLERP);
        out.proof = prove_pieces(CurveMotion(played), reference, out.times, tolerance, out.excluded);
        if (out.proof.proven() || round + 1 >= kRounds) break;
        if (add_failures(out.proof, out.times, file_unit) == 0) break;
    }
    return out;
}

}  // namespace quatcurve
