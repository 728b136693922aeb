// Key reduction, stage 3: which samples become keys (reduce_impl.hpp: select_keys).
#include <algorithm>
#include <utility>

#include "reduce_impl.hpp"

namespace quatcurve::reduce_impl {

// Keys for the channels `chans` (shared), fitted against the other channels' current F, every sample
// within tan²(θ/2) ≤ limit. The forced keys split the samples into ranges, each keyed on its own.
// Greedy within a range: from key i the farthest feasible end, bracketed around the previous
// segment's length (growing or shrinking by doubling steps) and then pinned down by binary search;
// an end that is not a candidate (too close to a forced key) steps back to the nearest candidate.
// A second pass, one key behind the greedy, drops an inserted key wherever the segment joining its
// neighbours passes. A probe that passes commits its fit, and the ends only grow, so the chosen
// segment's fit is the one held. The keys that pass kept are final, and with the forced keys still
// ahead they bound the result from below: as soon as that bound reaches `budget`, the choice gives
// up (a per-channel or synchronized run that cannot beat the other stops early).
std::vector<std::size_t> select_keys(const Problem& p, Fitter& fitter, const int* chans, int nc,
                                     double limit, std::size_t budget,
                                     const std::vector<std::size_t>* pace) {
    const std::size_t n = p.n;
    std::vector<std::size_t> keys{0};
    if (n == 1) return keys;
    std::size_t forced_ahead = 0;  // forced samples after the current range's start
    for (std::size_t k = 1; k < n; ++k) forced_ahead += p.is_forced(k) ? 1 : 0;
    std::vector<std::size_t> kept{keys[0]};
    auto behind = [&] {
        return pace && double(kept.size()) > kPaceSlack * double((*pace)[kept.back()]) / nc + kPaceExtra;
    };
    std::size_t next = 1;  // the first key of `keys` the removal pass has not decided on
    auto probe = [&](std::size_t i, std::size_t j) {
        return fitter.fit(i, j, chans, nc, limit, false);
    };
    // A probe's outcome depends on its segment alone: the other channels stay fixed while these
    // keys are chosen, a fit reads none of its own channels' committed values (Fitter::other_'s
    // terms are filled once per key choice), and a failed probe commits nothing. So a segment that
    // failed once fails again: the removal pass does not refit the segments the greedy search
    // found too long (often a range in one piece). `failed`: the greedy's failed segments of the
    // current range (no segment spans two), in increasing order of their start.
    std::vector<std::pair<std::size_t, std::size_t>> failed;
    auto greedy_probe = [&](std::size_t i, std::size_t j) {
        const bool ok = probe(i, j);
        if (!ok) failed.emplace_back(i, j);
        return ok;
    };
    auto failed_before = [&](std::size_t i, std::size_t j) {
        auto it = std::lower_bound(failed.begin(), failed.end(), i,
                                   [](const std::pair<std::size_t, std::size_t>& f, std::size_t start) {
                                       return f.first < start;
                                   });
        for (; it != failed.end() && it->first == i; ++it)
            if (it->second == j) return true;
        return false;
    };
    std::size_t i = 0, last_len = 2;
    std::size_t end = 0;  // the range's end: the first forced key after i
    while (i < n - 1) {
        // Found again only once i reaches it: no forced key lies between i and end (i never passes
        // end), so rescanning from i + 1 each time — quadratic in the samples — would find the same.
        if (end <= i) {
            end = i + 1;
            while (!p.is_forced(end)) ++end;
            failed.clear();
        }
        std::size_t good = i + 1, bad = kNone;  // good: feasible (committed unless i + 1)
        const std::size_t guess = i + std::min(std::max<std::size_t>(last_len, 2), end - i);
        std::size_t step = std::max<std::size_t>(1, last_len / 4);
        if (guess > i + 1) {
            if (greedy_probe(i, guess)) {
                good = guess;
                while (good < end) {
                    const std::size_t j = std::min(good + step, end);
                    if (!greedy_probe(i, j)) {
                        bad = j;
                        break;
                    }
                    good = j;
                    step *= 2;
                }
            } else {
                bad = guess;
                while (bad > i + 2) {
                    const std::size_t j = bad > i + 1 + step ? bad - step : i + 1;
                    if (j == i + 1) break;
                    if (greedy_probe(i, j)) {
                        good = j;
                        break;
                    }
                    bad = j;
                    step *= 2;
                }
            }
            if (bad != kNone) {
                while (bad - good > 1) {
                    const std::size_t mid = good + (bad - good) / 2;
                    if (greedy_probe(i, mid)) {
                        good = mid;
                    } else {
                        bad = mid;
                    }
                }
            }
        }
        if (good != end && !p.is_candidate(good)) {
            // Back to the nearest candidate; with none between i and the range's end, the segment
            // runs to the end (verification then reports what it cannot meet).
            std::size_t c = good;
            while (c > i + 1 && !p.is_candidate(c)) --c;
            if (!p.is_candidate(c)) {
                c = good;
                while (c < end && !p.is_candidate(c)) ++c;
            }
            good = c;
            fitter.fit(i, good, chans, nc, limit, true);
        } else if (good == i + 1) {
            fitter.fit(i, good, chans, nc, limit, true);
        }
        keys.push_back(good);
        last_len = good - i;
        i = good;
        // Removal pass over the keys chosen so far, up to the one before the newest: join
        // neighbours where one segment suffices (never across a forced key). It runs as the greedy
        // goes — its probes end at keys already chosen and commit only segments before the greedy's
        // start, whose fits the greedy never reads — so the keys it keeps are final at once and,
        // with the forced samples ahead, bound the result from below (`budget`). A failed probe
        // changes nothing, so the fits already committed stay valid.
        for (; next + 1 < keys.size(); ++next) {
            if (!p.is_forced(keys[next]) && !failed_before(kept.back(), keys[next + 1]) &&
                probe(kept.back(), keys[next + 1]))
                continue;
            kept.push_back(keys[next]);
        }
        if (good != end) {
            // The keys between kept.back() and the range's end may all go; the forced ones stay.
            if (kept.size() + forced_ahead >= budget || behind()) return {};
            continue;
        }
        --forced_ahead;  // `end`, the next range's start, is the last key and counts as kept below
        if (kept.size() + 1 + forced_ahead >= budget || behind()) return {};
    }
    kept.push_back(keys.back());
    return kept;
}

// Drops every inserted key of `keys` (the channels' current keys, fitted) whose neighbours can be
// joined by one segment within `limit`, in one pass from the start; a joined segment's fit is
// committed, a failed probe commits nothing, so the fits kept stay those of the keys kept.
std::vector<std::size_t> remove_keys(const Problem& p, Fitter& fitter, const int* chans, int nc,
                                     double limit, const std::vector<std::size_t>& keys) {
    if (keys.size() < 3) return keys;
    std::vector<std::size_t> kept{keys[0]};
    for (std::size_t a = 1; a + 1 < keys.size(); ++a) {
        if (!p.is_forced(keys[a]) && fitter.fit(kept.back(), keys[a + 1], chans, nc, limit, false))
            continue;
        kept.push_back(keys[a]);
    }
    kept.push_back(keys.back());
    return kept;
}

}  // namespace quatcurve::reduce_impl
