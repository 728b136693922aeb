// reduce_impl::repair: the keys of an earlier reduction made to meet the tolerance on more samples
// (reduce_keys_proved's rounds after the first), segment by segment.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "quatcurve/blender_eval.hpp"
#include "quatcurve/quat.hpp"
#include "quatcurve/reduce.hpp"
#include "reduce_impl.hpp"

using namespace quatcurve;

namespace {

constexpr double kTolerance = 0.1 * 3.14159265358979323846 / 180.0;

// A swing about X, fast and uneven, carried by a slow turn about Z: the channels move at different
// speeds, so each keeps its own keys (the result is per channel, as on motion capture).
Quat turning(double t) {
    const double x = 0.3 * std::sin(0.5 * t) + 0.1 * std::sin(1.3 * t), z = 0.02 * t;
    return multiply(Quat(std::cos(0.5 * z), 0.0, 0.0, std::sin(0.5 * z)), Quat(std::cos(0.5 * x), std::sin(0.5 * x), 0.0, 0.0));
}

// Blender's playback of the keys at t (normalized).
Quat played(const ReducedKeys& keys, double t) {
    double v[4];
    for (int c = 0; c < 4; ++c) v[c] = blender_evaluate(keys.channels[c], keys.interpolation, static_cast<float>(t));
    const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
    return Quat(v[0] / n, v[1] / n, v[2] / n, v[3] / n);
}

struct Case {
    std::vector<double> times;
    std::vector<Quat> quats;
    ReducedKeys first;
};

Case first_reduction() {
    Case c;
    for (int k = 0; k < 120; ++k) {
        c.times.push_back(k);
        c.quats.push_back(turning(k));
    }
    const reduce_impl::Problem p = reduce_impl::make_quat_problem(c.times, c.quats, true);
    c.first = reduce_impl::reduce(p, kTolerance, KeyInterpolation::BEZIER, false);
    return c;
}

// The samples with one more at each of `added` (value: `at(t)`), and where each earlier one went.
template <class At>
reduce_impl::Problem with_samples(const Case& c, const std::vector<double>& added, At at,
                                  std::vector<std::size_t>& index) {
    std::vector<double> times;
    std::vector<Quat> quats;
    index.clear();
    std::size_t a = 0;
    for (std::size_t k = 0; k < c.times.size(); ++k) {
        for (; a < added.size() && added[a] < c.times[k]; ++a) {
            times.push_back(added[a]);
            quats.push_back(at(added[a]));
        }
        index.push_back(times.size());
        times.push_back(c.times[k]);
        quats.push_back(c.quats[k]);
    }
    return reduce_impl::make_quat_problem(times, quats, true);
}

bool same_channel(const ReducedChannel& a, const ReducedChannel& b) {
    return a.frames == b.frames && a.values == b.values && a.handle_left == b.handle_left &&
           a.handle_right == b.handle_right;
}

}  // namespace

TEST(ReduceRepair, SamplesTheKeysAlreadyMeetChangeNothing) {
    const Case c = first_reduction();
    ASSERT_FALSE(c.first.synchronized);  // per channel: the case the rounds after the first meet on the clips
    std::vector<std::size_t> index;
    const std::vector<double> added{3.5, 17.25, 30.5, 44.75, 58.5, 101.5};
    const reduce_impl::Problem p = with_samples(c, added, [&](double t) { return played(c.first, t); }, index);
    const ReducedKeys r = reduce_impl::repair(p, kTolerance, KeyInterpolation::BEZIER, c.first, index);
    ASSERT_EQ(r.channels.size(), 4u);
    EXPECT_LE(r.max_error, kTolerance);
    for (int ch = 0; ch < 4; ++ch) {
        EXPECT_TRUE(same_channel(r.channels[ch], c.first.channels[ch])) << "channel " << ch;
        for (std::size_t a = 0; a < r.channels[ch].indices.size(); ++a)
            EXPECT_EQ(r.channels[ch].indices[a], index[c.first.channels[ch].indices[a]]) << "channel " << ch;
    }
}

TEST(ReduceRepair, ASampleOffTheKeysChangesOnlyTheSegmentsAroundIt) {
    const Case c = first_reduction();
    const double t = 30.5;
    // 3× the tolerance off the keys' playback there, about an axis across the motion.
    const Quat off = multiply(played(c.first, t), Quat(std::cos(1.5 * kTolerance), std::sin(1.5 * kTolerance), 0.0, 0.0));
    std::vector<std::size_t> index;
    const reduce_impl::Problem p = with_samples(c, {t}, [&](double) { return off; }, index);
    const ReducedKeys r = reduce_impl::repair(p, kTolerance, KeyInterpolation::BEZIER, c.first, index);
    ASSERT_EQ(r.channels.size(), 4u);
    EXPECT_LE(r.max_error, kTolerance);
    EXPECT_LE(angle_between(played(r, t), off), kTolerance);
    int changed = 0;
    for (int ch = 0; ch < 4; ++ch) {
        const ReducedChannel& before = c.first.channels[ch];
        const ReducedChannel& after = r.channels[ch];
        changed += same_channel(before, after) ? 0 : 1;
        // Every earlier key stays, and every segment ending before t or starting after it keeps its
        // handles: the keys are repaired where the new sample fails, nowhere else.
        for (std::size_t a = 0; a < before.frames.size(); ++a) {
            const auto it = std::find(after.frames.begin(), after.frames.end(), before.frames[a]);
            ASSERT_NE(it, after.frames.end()) << "channel " << ch << " lost the key at " << before.frames[a];
            const std::size_t b = static_cast<std::size_t>(it - after.frames.begin());
            if (a + 1 < before.frames.size() && before.frames[a + 1] <= t) {
                EXPECT_EQ(after.handle_right[2 * b + 1], before.handle_right[2 * a + 1]) << "channel " << ch;
            }
            if (a > 0 && before.frames[a - 1] >= t) {
                EXPECT_EQ(after.handle_left[2 * b + 1], before.handle_left[2 * a + 1]) << "channel " << ch;
            }
        }
    }
    EXPECT_GE(changed, 1);
}

TEST(ReduceRepair, KeysNotOfTheReducersKindAreLeftForAFreshReduction) {
    Case c = first_reduction();
    ReducedChannel& ch = c.first.channels[1];
    ASSERT_GE(ch.frames.size(), 2u);
    // A handle frame off every pair of handle fractions the reducer places.
    ch.handle_right[0] = static_cast<float>(ch.frames[0] + 0.123 * (ch.frames[1] - ch.frames[0]));
    std::vector<std::size_t> index;
    const reduce_impl::Problem p = with_samples(c, {}, [](double t) { return turning(t); }, index);
    EXPECT_TRUE(reduce_impl::repair(p, kTolerance, KeyInterpolation::BEZIER, c.first, index).channels.empty());
}
