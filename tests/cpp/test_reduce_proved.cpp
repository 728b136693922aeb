// Key reduction proved at every instant (reduce.hpp: reduce_keys_proved, reduce_curve_proved): the
// reduced keys' playback against the original keys' own playback (random BEZIER and LINEAR
// channels keyed at every frame, handles that swing between frames, quaternion sign flips) and
// against a method's curve. Every proved bound is held against Blender's evaluation (emulated,
// blender_eval.hpp) at 64 points per frame and as many random times, inside the original's own sign
// flips too, where the result keeps the original's keys bit for bit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "quatcurve/blender_eval.hpp"
#include "quatcurve/bound.hpp"
#include "quatcurve/channels.hpp"
#include "quatcurve/curve.hpp"
#include "quatcurve/errors.hpp"
#include "quatcurve/quat.hpp"
#include "quatcurve/reduce.hpp"

using namespace quatcurve;

namespace {

constexpr double kPi = 3.141592653589793238462643383279502884;
constexpr double kDeg = kPi / 180.0;

// A rotation's original keys, keyed at every frame, and the reducer's samples of them (Blender's
// evaluation, emulated, at every whole frame).
struct Original {
    RotationMode mode;
    KeyInterpolation interpolation = KeyInterpolation::BEZIER;
    std::vector<FCurveKeys> channels;
    std::vector<double> times;
    std::vector<double> values;  // n rows of channel_count(mode)
};

// Mocap-like motion: rotation vectors on a smooth random walk with per-frame noise, as channel values
// of `mode` continuous along it; quaternions negated from every `flip_every`-th frame on (0: never),
// as a file whose stored signs flip. Keys at frames 1 … n; BEZIER handles at ±1/3 frame along the
// central-difference slope times `wiggle` (1: about Blender's automatic handles; more: the F-curves
// overshoot between frames) plus noise.
Original make_original(unsigned seed, const RotationMode& mode, std::size_t n, KeyInterpolation ipo, double wiggle,
                       std::size_t flip_every = 0) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> step(0.0, 0.05), noise(0.0, 0.004);
    std::vector<Quat> q(n);
    Vec3 v(0.3, -0.2, 0.5), vel(0.0);
    for (std::size_t i = 0; i < n; ++i) {
        vel = 0.9 * vel + Vec3(step(rng), step(rng), step(rng));
        v += 0.1 * vel;
        const Vec3 w = v + Vec3(noise(rng), noise(rng), noise(rng));
        const double a = glm::length(w);
        q[i] = axis_angle_to_quat(w / a, a);
    }
    Original o;
    o.mode = mode;
    o.interpolation = ipo;
    const std::size_t C = channel_count(mode);
    std::vector<double> rows = quats_to_channels(q, mode);
    if (mode.kind == RotationMode::Kind::quaternion && flip_every > 0)
        for (std::size_t i = flip_every; i < n; i += 2 * flip_every)
            for (std::size_t j = i; j < std::min(n, i + flip_every); ++j)
                for (std::size_t c = 0; c < 4; ++c) rows[4 * j + c] = -rows[4 * j + c];
    for (double& x : rows) x = static_cast<float>(x);
    o.channels.resize(C);
    std::uniform_real_distribution<double> jitter(0.6, 1.4);
    for (std::size_t c = 0; c < C; ++c) {
        FCurveKeys& ch = o.channels[c];
        for (std::size_t i = 0; i < n; ++i) {
            const double f = static_cast<double>(i + 1), y = rows[C * i + c];
            const double prev = rows[C * (i ? i - 1 : i) + c], next = rows[C * (i + 1 < n ? i + 1 : i) + c];
            const double slope = 0.5 * (next - prev) * wiggle * jitter(rng);
            ch.frames.push_back(f);
            ch.values.push_back(y);
            ch.handle_left.insert(ch.handle_left.end(), {static_cast<float>(f - 1.0 / 3), static_cast<float>(y - slope / 3)});
            ch.handle_right.insert(ch.handle_right.end(), {static_cast<float>(f + 1.0 / 3), static_cast<float>(y + slope / 3)});
        }
    }
    o.times.resize(n);
    for (std::size_t i = 0; i < n; ++i) o.times[i] = static_cast<double>(i + 1);
    o.values.resize(C * n);
    for (std::size_t c = 0; c < C; ++c) {
        std::vector<double> out;
        blender_evaluate(o.channels[c], ipo, o.times, out);
        for (std::size_t i = 0; i < n; ++i) o.values[C * i + c] = out[i];
    }
    return o;
}

// The times of a dense check of [t0, t1]: `per_frame` evenly spaced points per frame and as many
// random ones.
std::vector<double> dense_times(double t0, double t1, std::size_t per_frame, std::mt19937& rng) {
    const std::size_t n = static_cast<std::size_t>((t1 - t0) * static_cast<double>(per_frame)) + 1;
    std::uniform_real_distribution<double> u(t0, t1);
    std::vector<double> t;
    for (std::size_t i = 0; i < n; ++i) t.push_back(t0 + (t1 - t0) * static_cast<double>(i) / static_cast<double>(n - 1));
    for (std::size_t i = 0; i < n; ++i) t.push_back(u(rng));
    std::sort(t.begin(), t.end());
    return t;
}

bool inside(double t, const std::vector<std::pair<double, double>>& spans) {
    for (const auto& e : spans)
        if (t > e.first && t < e.second) return true;
    return false;
}

// Blender's playback of `keys` at t where the keys in the `copied` spans [f0, f1) have the
// interpolation `copied_ipo` and the others keys.interpolation: a value depends only on the segment
// holding t (and a key within 1e-4 frames), so each channel is evaluated with its segment's key's.
Quat play_mixed(const ReducedKeys& keys, const std::vector<std::pair<double, double>>& copied,
                KeyInterpolation copied_ipo, const RotationMode& mode, double t) {
    double v[4] = {0.0, 0.0, 0.0, 0.0};
    for (std::size_t c = 0; c < keys.channels.size(); ++c) {
        const ReducedChannel& ch = keys.channels[c];
        const float f = static_cast<float>(t);
        const std::size_t after = static_cast<std::size_t>(std::upper_bound(ch.frames.begin(), ch.frames.end(), f) -
                                                           ch.frames.begin());
        const double key = ch.frames[after ? after - 1 : 0];
        bool in_copied = false;
        for (const auto& e : copied) in_copied = in_copied || (key >= e.first && key < e.second);
        v[c] = blender_evaluate(ch, in_copied ? copied_ipo : keys.interpolation, f);
    }
    return channels_to_quat(v, mode);
}

// The largest angle between the playback of `keys` (play_mixed) and `reference` at the dense times
// outside `skip`.
double dense_max(const ReducedKeys& keys, const RotationMode& mode, const Motion& reference,
                 const std::vector<double>& times, const std::vector<std::pair<double, double>>& skip,
                 double* where = nullptr, const std::vector<std::pair<double, double>>& copied = {},
                 KeyInterpolation copied_ipo = KeyInterpolation::LINEAR) {
    double worst = 0.0;
    for (double t : times) {
        if (inside(t, skip)) continue;
        const double d = angle_between(play_mixed(keys, copied, copied_ipo, mode, t), reference.at(t));
        if (d > worst) {
            worst = d;
            if (where) *where = t;
        }
    }
    return worst;
}

double dense_max(const ProvedKeys& r, const RotationMode& mode, const Motion& reference,
                 const std::vector<double>& times, double* where = nullptr) {
    return dense_max(r.keys, mode, reference, times, {}, where, r.copied, r.copied_interpolation);
}

// The sample pairs whose original quaternion values lie in opposite hemispheres.
std::vector<std::pair<double, double>> sign_flips(const Original& o) {
    std::vector<std::pair<double, double>> flips;
    if (o.mode.kind == RotationMode::Kind::quaternion)
        for (std::size_t i = 1; i < o.times.size(); ++i) {
            const double* a = &o.values[4 * (i - 1)];
            const double* b = &o.values[4 * i];
            if (a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] < 0.0) flips.emplace_back(o.times[i - 1], o.times[i]);
        }
    return flips;
}

// Every copied span holds the original's keys there bit for bit — frames, values, and the handles
// its segments use (the first key's right, the last key's left, both of every key between) — and
// every sign flip lies in a copied span.
void expect_copied_bit_for_bit(const std::vector<FCurveKeys>& original, KeyInterpolation original_ipo,
                               const ProvedKeys& r, const std::vector<std::pair<double, double>>& flips) {
    EXPECT_EQ(r.copied_interpolation, original_ipo);
    for (const auto& f : flips) {
        bool covered = false;
        for (const auto& e : r.copied) covered = covered || (e.first <= f.first && f.second <= e.second);
        EXPECT_TRUE(covered) << "the flip at " << f.first << "|" << f.second << " is not in a copied span";
    }
    const bool bezier = original_ipo == KeyInterpolation::BEZIER;
    for (const auto& e : r.copied) {
        for (std::size_t c = 0; c < original.size(); ++c) {
            const FCurveKeys& o = original[c];
            if (o.frames.size() <= 1) continue;  // constant: two keys of its value
            const ReducedChannel& ch = r.keys.channels[c];
            std::vector<std::size_t> a, b;
            for (std::size_t k = 0; k < o.frames.size(); ++k)
                if (o.frames[k] >= e.first && o.frames[k] <= e.second) a.push_back(k);
            for (std::size_t k = 0; k < ch.frames.size(); ++k)
                if (ch.frames[k] >= e.first && ch.frames[k] <= e.second) b.push_back(k);
            ASSERT_EQ(a.size(), b.size()) << "channel " << c << " span " << e.first << "-" << e.second;
            // As Blender stores them (float32): the original's numbers rounded as foreach_set rounds them.
            const auto f32 = [](double x) { return static_cast<double>(static_cast<float>(x)); };
            for (std::size_t j = 0; j < a.size(); ++j) {
                EXPECT_EQ(ch.frames[b[j]], f32(o.frames[a[j]]));
                EXPECT_EQ(ch.values[b[j]], f32(o.values[a[j]]));
                if (!bezier) continue;
                for (int x = 0; x < 2; ++x) {
                    if (j + 1 < a.size()) EXPECT_EQ(ch.handle_right[2 * b[j] + x], f32(o.handle_right[2 * a[j] + x]));
                    if (j > 0) EXPECT_EQ(ch.handle_left[2 * b[j] + x], f32(o.handle_left[2 * a[j] + x]));
                }
            }
        }
    }
}

template <class F>
void expect_invalid(F f, const std::string& fragment) {
    try {
        f();
        ADD_FAILURE() << "no InvalidArgument (expected '" << fragment << "')";
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
}

}  // namespace

// Random original channels of every mode, BEZIER with handles from calm to swinging and LINEAR,
// quaternions with sign flips: the reduction is proved within the tolerance at every instant, the
// original's sign flips included (their keys copied), and 64 points per frame plus random times find
// nothing above the proved bound. The plain reduction of the same samples, checked the same way
// outside the flips, shows what the rounds buy.
TEST(ReduceProved, BoundHoldsAgainstTheOriginalPlaybackDenserThanProved) {
    std::mt19937 rng(3);
    const double tol = 0.1 * kDeg;
    const RotationMode modes[] = {parse_rotation_mode("QUATERNION"), parse_rotation_mode("XYZ"),
                                  parse_rotation_mode("ZXY"), parse_rotation_mode("AXIS_ANGLE")};
    const double wiggles[] = {1.0, 4.0};
    double plain_worst = 0.0, proved_worst = 0.0;
    unsigned seed = 100;
    for (const RotationMode& mode : modes) {
        for (KeyInterpolation ipo : {KeyInterpolation::BEZIER, KeyInterpolation::LINEAR}) {
            for (double wiggle : wiggles) {
                if (ipo == KeyInterpolation::LINEAR && wiggle != 1.0) continue;
                for (bool synchronized : {false, true}) {
                    const std::size_t flip_every = mode.kind == RotationMode::Kind::quaternion ? 23 : 0;
                    const Original o = make_original(++seed, mode, 120, ipo, wiggle, flip_every);
                    const std::string what = "mode " + std::to_string(int(mode.kind)) + " order " +
                                             std::to_string(int(mode.order)) + " " + key_interpolation_name(ipo) +
                                             " wiggle " + std::to_string(wiggle) + (synchronized ? " sync" : "");
                    const ProvedKeys r = reduce_keys_proved(o.channels, ipo, mode, o.times, o.values, tol,
                                                            KeyInterpolation::BEZIER, synchronized);
                    const std::vector<std::pair<double, double>> flips = sign_flips(o);
                    expect_copied_bit_for_bit(o.channels, ipo, r, flips);
                    EXPECT_EQ(r.copied, flips) << what;  // keys at every frame: each flip its own span
                    EXPECT_TRUE(r.proof.proven()) << what << ": bound " << r.proof.bound / kDeg << "° at "
                                                  << r.proof.worst_time << " after " << r.rounds << " rounds";
                    EXPECT_LE(r.proof.bound, tol) << what;
                    // Handles that swing far between frames may need every key (each frame's own curve).
                    EXPECT_LE(r.keys.key_count(), o.channels.size() * o.times.size()) << what;
                    if (wiggle == 1.0) EXPECT_LT(r.keys.key_count(), o.channels.size() * o.times.size()) << what;
                    const PlaybackMotion original(o.channels, ipo, mode);
                    const std::vector<double> dense = dense_times(o.times.front(), o.times.back(), 64, rng);
                    double where = 0.0;
                    const double d = dense_max(r, mode, original, dense, &where);
                    EXPECT_LE(d, r.proof.bound) << what << ": " << d / kDeg << "° at frame " << where;
                    proved_worst = std::max(proved_worst, d);
                    // The plain reduction at the full tolerance, checked the same way.
                    std::vector<double> rows = o.values;
                    if (mode.kind == RotationMode::Kind::quaternion) {
                        std::vector<Quat> q(o.times.size());
                        for (std::size_t i = 0; i < q.size(); ++i) q[i] = from_wxyz(&rows[4 * i]);
                        hemisphere_continuous(q.data(), q.size());
                        const ReducedKeys k = reduce_keys(o.times, q, tol, KeyInterpolation::BEZIER, synchronized);
                        plain_worst = std::max(plain_worst, dense_max(k, mode, original, dense, flips));
                    }
                }
            }
        }
    }
    std::printf("reduce_keys_proved: between frames at most %.4f°; the plain quaternion reduction %.4f°\n",
                proved_worst / kDeg, plain_worst / kDeg);
}

// Inside the original's sign flips Blender swings the channels through near zero, a turn the short way
// misses by more than 90°: the result keeps the original's keys there, so its playback inside those
// frames is the original's, value for value, and the pieces between are reduced.
TEST(ReduceProved, SignFlipsKeepTheOriginalKeysThere) {
    const RotationMode mode = parse_rotation_mode("QUATERNION");
    const Original o = make_original(7, mode, 60, KeyInterpolation::BEZIER, 1.0, 10);
    const ProvedKeys r = reduce_keys_proved(o.channels, o.interpolation, mode, o.times, o.values, 0.1 * kDeg);
    const std::vector<std::pair<double, double>> flips = sign_flips(o);
    ASSERT_EQ(flips.size(), 5u);  // flips at frames 10|11, 20|21, …, 50|51
    EXPECT_EQ(r.copied, flips);
    expect_copied_bit_for_bit(o.channels, o.interpolation, r, flips);
    EXPECT_TRUE(r.proof.proven());
    EXPECT_LT(r.keys.key_count(), 3 * o.channels.size() * o.times.size() / 4);
    const PlaybackMotion original(o.channels, o.interpolation, mode);
    std::vector<Quat> q(o.times.size());
    for (std::size_t i = 0; i < q.size(); ++i) q[i] = from_wxyz(&o.values[4 * i]);
    hemisphere_continuous(q.data(), q.size());
    const ReducedKeys plain = reduce_keys(o.times, q, 0.1 * kDeg, KeyInterpolation::BEZIER, false);
    std::vector<FCurveKeys> ch(plain.channels.begin(), plain.channels.end());
    const PlaybackMotion short_way(std::move(ch), plain.interpolation, mode);
    for (const auto& e : flips) {
        double widest = 0.0;
        for (int i = 1; i < 64; ++i) {
            const double t = e.first + (e.second - e.first) * i / 64.0;
            widest = std::max(widest, angle_between(short_way.at(t), original.at(t)));
            double got[4], want[4];
            for (std::size_t c = 0; c < 4; ++c) {
                got[c] = blender_evaluate(r.keys.channels[c], o.interpolation, static_cast<float>(t));
                want[c] = blender_evaluate(o.channels[c], o.interpolation, static_cast<float>(t));
            }
            for (std::size_t c = 0; c < 4; ++c) EXPECT_EQ(got[c], want[c]) << "frame " << t << " channel " << c;
        }
        EXPECT_GT(widest, 90.0 * kDeg) << "flip at " << e.first;
    }
}

// Sparse keys whose stored signs flip between keys, channels keyed on their own frames (one with a
// key the others lack, one constant), every combination of LINEAR and BEZIER original and output: the
// copied span runs from the last frame before the flip where every keyed channel has a key to the
// first after it, holds the original's keys bit for bit, and the playback of the result (each key's
// own interpolation) is within the proved bound of the original's at 64 points per frame and random
// times, inside the flips too.
TEST(ReduceProved, SparseKeysFlippingBetweenKeysAreCopiedWholeSegments) {
    const RotationMode mode = parse_rotation_mode("QUATERNION");
    std::mt19937 rng(23);
    std::normal_distribution<double> nd(0.0, 0.25);
    // Keys every 6 frames on a slow turn; the stored sign flips at keys 3, 5 and 6 (of 9). Then a key
    // at every frame to frame 300 on a smooth turn, which the reduction thins: the result keeps fewer
    // keys than the original (else it would be the original's keys, or_original_keys).
    std::vector<double> key_t = {1, 7, 13, 19, 25, 31, 37, 43, 49};
    const int signs[] = {1, 1, 1, -1, -1, 1, -1, -1, -1};
    std::vector<Quat> key_q;
    for (std::size_t k = 0; k < key_t.size(); ++k) {
        const Vec3 v(0.2 * double(k) + nd(rng), 0.1 * double(k) + nd(rng), 0.3 + nd(rng));
        key_q.push_back(double(signs[k]) * axis_angle_to_quat(glm::normalize(v), glm::length(v)));
    }
    const Quat last = key_q.back();
    for (double t = 50.0; t <= 300.0; t += 1.0) {
        key_t.push_back(t);
        key_q.push_back(multiply(last, axis_angle_to_quat(Vec3(0.0, 0.0, 1.0), 0.02 * (t - 49.0))));
    }
    for (KeyInterpolation original_ipo : {KeyInterpolation::BEZIER, KeyInterpolation::LINEAR}) {
        std::vector<FCurveKeys> channels(4);
        for (std::size_t c = 0; c < 4; ++c) {
            FCurveKeys& ch = channels[c];
            for (std::size_t k = 0; k < key_t.size(); ++k) {
                double wxyz[4];
                to_wxyz(key_q[k], wxyz);
                const double v = static_cast<float>(wxyz[c]);
                ch.frames.push_back(key_t[k]);
                ch.values.push_back(v);
                if (c == 2 && k == 4) {  // y alone has a key at frame 28 too, inside a flip's segment
                    ch.frames.push_back(28.0);
                    ch.values.push_back(static_cast<float>(0.5 * v));
                }
            }
            for (std::size_t k = 0; k < ch.frames.size(); ++k) {
                // The smooth turn's keys: handles at thirds along the neighbours' slope.
                const bool tail = ch.frames[k] > 49.0 && k + 1 < ch.frames.size();
                const double dt = tail ? 1.0 / 3.0 : 2.0;
                const double slope = tail ? (ch.values[k + 1] - ch.values[k - 1]) / 6.0 : 0.05 * nd(rng);
                ch.handle_left.insert(ch.handle_left.end(), {static_cast<float>(ch.frames[k] - dt),
                                                             static_cast<float>(ch.values[k] - slope)});
                ch.handle_right.insert(ch.handle_right.end(), {static_cast<float>(ch.frames[k] + dt),
                                                               static_cast<float>(ch.values[k] + (tail ? 1 : 2) * slope)});
            }
        }
        channels[3] = FCurveKeys{{1.0}, {0.0}, {0.0, 0.0}, {2.0, 0.0}};  // z constant (a sign of its own otherwise)
        std::vector<double> times;
        for (double t = 1.0; t <= 300.0; t += 1.0) times.push_back(t);
        std::vector<double> values(4 * times.size());
        for (std::size_t c = 0; c < 4; ++c) {
            std::vector<double> out;
            blender_evaluate(channels[c], original_ipo, times, out);
            for (std::size_t i = 0; i < times.size(); ++i) values[4 * i + c] = out[i];
        }
        const Original o{mode, original_ipo, channels, times, values};
        // The keys' stored signs flip between frames 13|19, 25|31 and 31|37; the samples need not show
        // it (the channels pass zero at different times, no two neighbouring samples opposite).
        const std::vector<std::pair<double, double>> flips = {{13.0, 19.0}, {25.0, 31.0}, {31.0, 37.0}};
        const PlaybackMotion original(channels, original_ipo, mode);
        for (KeyInterpolation ipo : {KeyInterpolation::BEZIER, KeyInterpolation::LINEAR}) {
            for (bool synchronized : {false, true}) {
                const std::string what = std::string(key_interpolation_name(original_ipo)) + " → " +
                                         key_interpolation_name(ipo) + (synchronized ? " sync" : "");
                const ProvedKeys r = reduce_keys_proved(channels, original_ipo, mode, times, values, 0.1 * kDeg, ipo,
                                                        synchronized);
                // Two spans: 13-19, and 25-37 (y's key at 28 is not on every channel).
                const std::vector<std::pair<double, double>> spans = {{13.0, 19.0}, {25.0, 37.0}};
                EXPECT_EQ(r.copied, spans) << what;
                expect_copied_bit_for_bit(channels, original_ipo, r, flips);
                EXPECT_TRUE(r.proof.proven()) << what << ": " << r.proof.bound / kDeg << "°";
                double where = 0.0;
                const double d = dense_max(r, mode, original, dense_times(1.0, 300.0, 64, rng), &where);
                EXPECT_LE(d, r.proof.bound) << what << ": " << d / kDeg << "° at frame " << where;
                EXPECT_LT(r.keys.key_count(), 3 * key_t.size() + 3) << what;  // fewer than the original's
                for (const ReducedChannel& ch : r.keys.channels) {
                    const bool bezier = ipo == KeyInterpolation::BEZIER || original_ipo == KeyInterpolation::BEZIER;
                    EXPECT_EQ(ch.handle_left.size(), bezier ? 2 * ch.frames.size() : 0) << what;
                    EXPECT_EQ(ch.indices.size(), ch.frames.size()) << what;
                    for (std::size_t k = 0; k < ch.frames.size(); ++k)
                        EXPECT_EQ(static_cast<float>(r.times[ch.indices[k]]), static_cast<float>(ch.frames[k])) << what;
                }
            }
        }
    }
}

// An original no reduction within the tolerance thins (sparse BEZIER keys whose random handles bend
// every segment, reduced to LINEAR; Euler BEZIER keys 1/16 frame apart beyond frame 100,000): the
// result is the original's own keys, bit for bit over the whole range (one copied span), and plays as
// the original at 64 points per frame and random times. Never more keys than the original: LINEAR
// Euler keys there are thinned (a reduction, proved).
TEST(ReduceProved, AnOriginalNoReductionThinsIsKeptAsItIs) {
    std::mt19937 rng(29);
    std::normal_distribution<double> nd(0.0, 0.3);
    struct Case {
        const char* mode;
        std::vector<double> frames;
        KeyInterpolation original_ipo, ipo;
        bool kept;  // the original's keys are the result
    };
    std::vector<double> far;
    for (double f = 100050.0; far.size() < 24; f += far.size() % 3 == 2 ? 7.0 : 0.0625) far.push_back(f);
    const Case cases[] = {
        {"QUATERNION", {1, 7, 13, 19, 25, 31, 37}, KeyInterpolation::BEZIER, KeyInterpolation::LINEAR, true},
        {"XYZ", far, KeyInterpolation::LINEAR, KeyInterpolation::BEZIER, false},
        {"XYZ", far, KeyInterpolation::BEZIER, KeyInterpolation::BEZIER, true},
    };
    for (const Case& k : cases) {
        const RotationMode mode = parse_rotation_mode(k.mode);
        const std::size_t C = channel_count(mode), K = k.frames.size();
        std::vector<FCurveKeys> channels(C);
        std::size_t original_keys = 0;
        for (std::size_t c = 0; c < C; ++c) {
            FCurveKeys& ch = channels[c];
            double v = nd(rng);
            for (std::size_t i = 0; i < K; ++i) {
                v += nd(rng);
                const double f = k.frames[i], gap = i + 1 < K ? k.frames[i + 1] - f : 1.0;
                ch.frames.push_back(f);
                ch.values.push_back(static_cast<float>(v));
                ch.handle_left.insert(ch.handle_left.end(), {static_cast<float>(f - gap / 3), static_cast<float>(v + nd(rng))});
                ch.handle_right.insert(ch.handle_right.end(), {static_cast<float>(f + gap / 3), static_cast<float>(v + nd(rng))});
            }
            original_keys += K;
        }
        std::vector<double> times;  // Blender's frames over the range, and the keys' own
        for (double t = std::ceil(k.frames.front()); t <= k.frames.back(); t += 1.0) times.push_back(t);
        times.insert(times.end(), k.frames.begin(), k.frames.end());
        std::sort(times.begin(), times.end());
        times.erase(std::unique(times.begin(), times.end()), times.end());
        std::vector<double> values(C * times.size());
        for (std::size_t c = 0; c < C; ++c) {
            std::vector<double> out;
            blender_evaluate(channels[c], k.original_ipo, times, out);
            for (std::size_t i = 0; i < times.size(); ++i) values[C * i + c] = out[i];
        }
        const std::string what = std::string(k.mode) + " " + key_interpolation_name(k.original_ipo) + " → " +
                                 key_interpolation_name(k.ipo);
        const PlaybackMotion original(channels, k.original_ipo, mode);
        const ProvedKeys r = reduce_keys_proved(channels, k.original_ipo, mode, times, values, 0.1 * kDeg, k.ipo, false);
        const std::vector<std::pair<double, double>> whole = {{k.frames.front(), k.frames.back()}};
        EXPECT_TRUE(r.proof.proven()) << what;
        double where = 0.0;
        const double d = dense_max(r, mode, original, dense_times(k.frames.front(), k.frames.back(), 64, rng), &where);
        EXPECT_LE(d, r.proof.bound + 1e-12) << what << " at frame " << where;
        if (!k.kept) {
            EXPECT_LT(r.keys.key_count(), original_keys) << what;
            EXPECT_TRUE(r.copied.empty()) << what;
            continue;
        }
        EXPECT_EQ(r.copied, whole) << what;
        EXPECT_EQ(r.keys.key_count(), original_keys) << what;
        expect_copied_bit_for_bit(channels, k.original_ipo, r, whole);
        EXPECT_EQ(r.proof.bound, 0.0) << what;
        EXPECT_LE(d, 1e-12) << what << " at frame " << where;
    }
}

// A turn about Z with a little noise on the other channels (quaternion and XYZ Euler, LINEAR keys at
// every frame): the channels one value meets keep one key each, at the first frame with flat handles,
// the result is proved within the tolerance and 64 points per frame and random times find nothing
// above the bound; with one_key_channels off (a loop's period) every channel keeps its first and last
// key (at least one more on each such channel).
TEST(ReduceProved, AChannelOneValueMeetsKeepsOneKey) {
    std::mt19937 rng(37);
    std::normal_distribution<double> noise(0.0, 2e-5);
    for (const char* name : {"QUATERNION", "XYZ"}) {
        const RotationMode mode = parse_rotation_mode(name);
        const std::size_t C = channel_count(mode), n = 60;
        std::vector<Quat> q(n);
        for (std::size_t i = 0; i < n; ++i) {
            const double a = 1.5 * std::sin(0.05 * double(i));
            q[i] = axis_angle_to_quat(Vec3(0.0, 0.0, 1.0), a);
        }
        std::vector<double> rows = quats_to_channels(q, mode);
        std::vector<double> frames(n);
        std::vector<FCurveKeys> channels(C);
        for (std::size_t i = 0; i < n; ++i) {
            frames[i] = double(i + 1);
            for (std::size_t c = 0; c < C; ++c) {
                const bool still = mode.kind == RotationMode::Kind::quaternion ? (c == 1 || c == 2) : c < 2;
                double& v = rows[C * i + c];
                if (still) v += noise(rng);
                v = static_cast<float>(v);
                channels[c].frames.push_back(frames[i]);
                channels[c].values.push_back(v);
            }
        }
        const double tol = 0.1 * kDeg;
        const PlaybackMotion original(channels, KeyInterpolation::LINEAR, mode);
        const std::vector<double> dense = dense_times(frames.front(), frames.back(), 64, rng);
        const ProvedKeys r = reduce_keys_proved(channels, KeyInterpolation::LINEAR, mode, frames, rows, tol);
        const ProvedKeys two = reduce_keys_proved(channels, KeyInterpolation::LINEAR, mode, frames, rows, tol,
                                                  KeyInterpolation::BEZIER, false, false);
        for (const ProvedKeys* k : {&r, &two}) {
            const std::string what = std::string(name) + (k == &r ? "" : " (one_key_channels off)");
            EXPECT_TRUE(k->proof.proven()) << what;
            EXPECT_LE(k->proof.bound, tol) << what;
            double where = 0.0;
            const double d = dense_max(*k, mode, original, dense, &where);
            EXPECT_LE(d, k->proof.bound) << what << ": " << d / kDeg << "° at frame " << where;
        }
        std::size_t single = 0;
        for (std::size_t c = 0; c < C; ++c) {
            const ReducedChannel& ch = r.keys.channels[c];
            EXPECT_GE(two.keys.channels[c].frames.size(), 2u) << name << " channel " << c;
            if (ch.frames.size() != 1) continue;
            ++single;
            EXPECT_EQ(ch.frames[0], frames.front());
            ASSERT_EQ(ch.handle_left.size(), 2u);
            EXPECT_EQ(ch.handle_left[1], ch.values[0]);  // flat: Blender plays the value everywhere
            EXPECT_EQ(ch.handle_right[1], ch.values[0]);
        }
        EXPECT_EQ(single, 2u) << name;
        EXPECT_LE(r.keys.key_count() + single, two.keys.key_count()) << name;
    }
}

// Keys 0.05 frame apart on a fast turn at 0.02°: the playback just outside key 2.55's snap zone
// (2.5499, 2.5501) is above the tolerance after every round (0.028°), nearer the key than a sample
// may be added. The original's keys are copied around it, bit for bit, and the
// pieces beside them reduced: proved within the tolerance, no more keys than the original, and
// 64 points per frame, random times and every float32 frame around each key's snap zone find
// nothing above the bound. Per channel and synchronized.
TEST(ReduceProved, WhereNoReductionIsProvedTheOriginalKeysAreCopied) {
    const RotationMode mode = parse_rotation_mode("QUATERNION");
    const std::vector<double> frames = {1.0f, 1.25f, 2.25f, 2.5f, 2.55f, 2.6f, 3.6f, 4.1f, 5.4f};
    const float q[4][9] = {
        {1.0f, 0.9995918869972229f, 0.9946082234382629f, 0.9779520630836487f, 0.9452459216117859f,
         0.8984717726707458f, 0.8467193841934204f, 0.8042831420898438f, 0.7869796752929688f},
        {0.0f, 0.012927747331559658f, 0.046931855380535126f, 0.09450743347406387f, 0.14769631624221802f,
         0.19868706166744232f, 0.24077878892421722f, 0.2689308524131775f, 0.2792186737060547f},
        {0.0f, -0.010069439187645912f, -0.03655528277158737f, -0.07361196726560593f, -0.1150408536195755f,
         -0.15475760400295258f, -0.18754291534423828f, -0.20947059988975525f, -0.21748380362987518f},
        {0.0f, -0.02339857630431652f, -0.08494430780410767f, -0.1710537225008011f, -0.26732295751571655f,
         -0.3596136271953583f, -0.4357975721359253f, -0.48675140738487244f, -0.5053718686103821f}};
    const std::size_t n = frames.size();
    std::vector<FCurveKeys> channels(4);
    std::vector<double> values(4 * n);
    for (std::size_t c = 0; c < 4; ++c) {
        channels[c].frames = frames;
        for (std::size_t i = 0; i < n; ++i) {
            channels[c].values.push_back(q[c][i]);
            values[4 * i + c] = q[c][i];
        }
    }
    const double tol = 0.02 * kDeg;
    const PlaybackMotion original(channels, KeyInterpolation::LINEAR, mode);
    std::mt19937 rng(31);
    std::vector<double> dense = dense_times(frames.front(), frames.back(), 64, rng);
    for (double key : frames) {  // both sides of every snap zone's edges, float32 step by step
        float lo = static_cast<float>(key - 1.2e-4), hi = static_cast<float>(key + 1.2e-4);
        for (float f = lo; f <= hi; f = std::nextafter(f, HUGE_VALF)) dense.push_back(f);
    }
    std::sort(dense.begin(), dense.end());
    for (bool synchronized : {false, true}) {
        const std::string what = synchronized ? "synchronized" : "per channel";
        const ProvedKeys r = reduce_keys_proved(channels, KeyInterpolation::LINEAR, mode, frames, values, tol,
                                                KeyInterpolation::BEZIER, synchronized);
        EXPECT_TRUE(r.proof.proven()) << what << ": bound " << r.proof.bound / kDeg << "°";
        EXPECT_LE(r.proof.bound, tol) << what;
        ASSERT_FALSE(r.copied.empty()) << what;
        bool covers = false;
        for (const auto& e : r.copied) covers = covers || (e.first < 2.5499 && 2.5501 < e.second);
        EXPECT_TRUE(covers) << what << ": no copied span around frame 2.55";
        expect_copied_bit_for_bit(channels, KeyInterpolation::LINEAR, r, {});
        EXPECT_LE(r.keys.key_count(), 4 * n) << what;
        if (!synchronized) EXPECT_LT(r.keys.key_count(), 4 * n) << what;  // a span, not the whole original
        double where = 0.0;
        const double d = dense_max(r, mode, original, dense, &where);
        EXPECT_LE(d, r.proof.bound) << what << ": " << d / kDeg << "° at frame " << where;
    }
}

// Against a method's curve (the bake's reduction): every method, quaternion, Euler and axis-angle
// output, proved at every instant and checked at 64 points per frame.
TEST(ReduceProved, CurveReductionIsProvedDenserThanChecked) {
    std::mt19937 rng(5);
    const double tol = 0.1 * kDeg;
    std::normal_distribution<double> nd;
    const Method methods[] = {Method::SLERP, Method::SQUAD, Method::CATMULL_ROM, Method::SPLINE_C2, Method::NLERP};
    const RotationMode modes[] = {parse_rotation_mode("QUATERNION"), parse_rotation_mode("XYZ"),
                                  parse_rotation_mode("AXIS_ANGLE")};
    for (Method method : methods) {
        for (const RotationMode& mode : modes) {
            std::vector<double> key_t;
            std::vector<Quat> key_q;
            for (std::size_t k = 0; k < 6; ++k) {
                key_t.push_back(1.0 + 12.0 * static_cast<double>(k));
                Quat q(nd(rng), nd(rng), nd(rng), nd(rng));
                key_q.push_back(q / std::sqrt(glm::dot(q, q)));
            }
            const Curve curve(key_t, key_q, method, {});
            std::vector<double> times;
            for (double t = key_t.front(); t <= key_t.back(); t += 1.0) times.push_back(t);
            const std::vector<double> values = quats_to_channels(curve.sample(times), mode);
            const std::string what = std::string(method_name(method)) + " mode " + std::to_string(int(mode.kind));
            const ProvedKeys r = reduce_curve_proved(curve, mode, times, values, tol);
            EXPECT_TRUE(r.copied.empty());
            EXPECT_TRUE(r.proof.proven()) << what << ": bound " << r.proof.bound / kDeg << "° at "
                                          << r.proof.worst_time << " after " << r.rounds << " rounds";
            EXPECT_LT(r.keys.key_count(), channel_count(mode) * times.size()) << what;
            const CurveMotion reference(curve);
            double where = 0.0;
            const double d = dense_max(r.keys, mode, reference, dense_times(times.front(), times.back(), 64, rng), {},
                                       &where);
            EXPECT_LE(d, r.proof.bound) << what << ": " << d / kDeg << "° at frame " << where;
        }
    }
}

// Tolerance 0 keeps every sample, as reduce_keys does, and promises nothing between them.
TEST(ReduceProved, ToleranceZeroKeepsEverySampleAndProvesNothing) {
    const RotationMode mode = parse_rotation_mode("XYZ");
    const Original o = make_original(9, mode, 20, KeyInterpolation::BEZIER, 1.0);
    const ProvedKeys r = reduce_keys_proved(o.channels, o.interpolation, mode, o.times, o.values, 0.0);
    EXPECT_EQ(r.keys.key_count(), 3 * o.times.size());
    EXPECT_FALSE(r.proof.proven());
    EXPECT_TRUE(std::isinf(r.proof.bound));
    EXPECT_EQ(r.rounds, 1);
}

// A tolerance a hundred times tighter than the usual 0.1° (0.001°, 1.7e-5 rad): the proof's fixed
// allowances (Blender's float32 arithmetic, a flat segment's step) must not eat the room between the
// reducer's share and the tolerance, or the proof stalls at its smallest step everywhere and the
// reduction ends unproved after every round (mocapbank.bvh's joints at 0.001°: 50 s each, unproved).
// Quaternion keys at every frame, LINEAR and BEZIER, with a still stretch (frames 40-60 hold one
// value: flat segments, which Blender plays as their first value): proved in a few rounds, and 64
// points per frame plus random times find nothing above the bound.
TEST(ReduceProved, TightToleranceIsProvedInAFewRounds) {
    std::mt19937 rng(17);
    const RotationMode mode = parse_rotation_mode("QUATERNION");
    for (KeyInterpolation ipo : {KeyInterpolation::LINEAR, KeyInterpolation::BEZIER}) {
        for (double tol_deg : {0.001, 0.003}) {
            Original o = make_original(40, mode, 120, ipo, 1.0);
            for (FCurveKeys& ch : o.channels)
                for (std::size_t i = 40; i < 60; ++i) {
                    const double y = ch.values[39];
                    ch.values[i] = y;
                    ch.handle_left[2 * i + 1] = ch.handle_right[2 * i + 1] = y;
                    if (i == 40) ch.handle_right[2 * 39 + 1] = y;
                }
            for (std::size_t c = 0; c < 4; ++c) {
                std::vector<double> out;
                blender_evaluate(o.channels[c], ipo, o.times, out);
                for (std::size_t i = 0; i < o.times.size(); ++i) o.values[4 * i + c] = out[i];
            }
            const double tol = tol_deg * kDeg;
            const std::string what = std::string(key_interpolation_name(ipo)) + " at " + std::to_string(tol_deg) + "°";
            const ProvedKeys r = reduce_keys_proved(o.channels, ipo, mode, o.times, o.values, tol);
            EXPECT_TRUE(r.proof.proven()) << what << ": bound " << r.proof.bound / kDeg << "° at "
                                          << r.proof.worst_time << " after " << r.rounds << " rounds";
            EXPECT_LE(r.rounds, 4) << what;
            EXPECT_LE(r.proof.bound, tol) << what;
            EXPECT_LT(r.keys.key_count(), 4 * o.times.size()) << what;
            const PlaybackMotion original(o.channels, ipo, mode);
            double where = 0.0;
            const double d = dense_max(r, mode, original, dense_times(o.times.front(), o.times.back(), 64, rng), &where);
            EXPECT_LE(d, r.proof.bound) << what << ": " << d / kDeg << "° at frame " << where;
        }
    }
}

TEST(ReduceProved, BadInputIsNamed) {
    const RotationMode quat = parse_rotation_mode("QUATERNION");
    const Original o = make_original(11, quat, 10, KeyInterpolation::BEZIER, 1.0);
    std::vector<double> short_values(o.values.begin(), o.values.end() - 1);
    expect_invalid([&] { reduce_keys_proved(o.channels, o.interpolation, quat, o.times, short_values, 0.01); },
                   "values: 39 numbers for 10 times of 4 channels");
    expect_invalid([&] { reduce_keys_proved(o.channels, o.interpolation, quat, o.times, o.values, NAN); },
                   "tolerance");
    expect_invalid([&] { reduce_keys_proved(o.channels, o.interpolation, quat, o.times, o.values, -1.0); },
                   "tolerance");
    std::vector<FCurveKeys> three(o.channels.begin(), o.channels.begin() + 3);
    expect_invalid([&] { reduce_keys_proved(three, o.interpolation, quat, o.times, o.values, 0.01); }, "channels");
    std::vector<double> backwards = o.times;
    std::swap(backwards[3], backwards[4]);
    expect_invalid([&] { reduce_keys_proved(o.channels, o.interpolation, quat, backwards, o.values, 0.01); }, "times[4]");
    std::vector<double> bad_t = o.times;
    bad_t[2] = INFINITY;
    expect_invalid([&] { reduce_keys_proved(o.channels, o.interpolation, quat, bad_t, o.values, 0.01); }, "times[2]");
    FCurveKeys broken = o.channels[1];
    broken.handle_left.pop_back();
    std::vector<FCurveKeys> with_broken = o.channels;
    with_broken[1] = broken;
    expect_invalid([&] { reduce_keys_proved(with_broken, KeyInterpolation::BEZIER, quat, o.times, o.values, 0.01); },
                   "handle_left");
    const Curve curve(o.times, std::vector<Quat>(o.times.size(), Quat(1, 0, 0, 0)), Method::SLERP, {});
    expect_invalid([&] { reduce_curve_proved(curve, quat, o.times, short_values, 0.01); }, "values");
    expect_invalid([&] { reduce_curve_proved(curve, quat, {}, {}, 0.01); }, "times");
}

// The gimbal-lock keys and spins (Euler XYZ, NLERP): the Euler channels sweep through the
// lock within a frame, which keys on whole frames cannot follow; the added samples there become
// candidates, and a key between frames makes the bound hold at every instant.
TEST(ReduceProved, GimbalLockWithinAFrameGetsAKeyBetweenFrames) {
    const double keys_deg[][4] = {{1, 0, 90, 0},     {4, 90, 45, 90},   {12, 30, 10, 200}, {20, -40, -90, 250},
                                  {28, 0, 40, 500}, {40, 10, 0, 405}, {44, 0, 20, 380}};
    std::vector<double> key_t, key_v;
    for (const auto& k : keys_deg) {
        key_t.push_back(k[0]);
        for (int c = 1; c < 4; ++c) key_v.push_back(static_cast<float>(k[c] * kDeg));
    }
    const RotationMode mode = parse_rotation_mode("XYZ");
    const Curve curve = curve_from_channels(key_t, key_v, mode, Method::NLERP, {});
    std::vector<double> times, reference;
    for (double t = 1.0; t <= 44.0; t += 1.0) {
        times.push_back(t);
        // The keyed angles, linear between keys: the guide to the Euler branch, as the bake's.
        const std::size_t k = static_cast<std::size_t>(std::upper_bound(key_t.begin(), key_t.end(), t) - key_t.begin());
        const std::size_t a = std::min(k, key_t.size() - 1) - 1, b = a + 1;
        const double u = (t - key_t[a]) / (key_t[b] - key_t[a]);
        for (int c = 0; c < 3; ++c) reference.push_back((1 - u) * key_v[3 * a + c] + u * key_v[3 * b + c]);
    }
    const std::vector<double> values = quats_to_channels(curve.sample(times), mode, reference.data(), times.size());
    const ProvedKeys r = reduce_curve_proved(curve, mode, times, values, 0.1 * kDeg);
    EXPECT_TRUE(r.proof.proven()) << r.proof.bound / kDeg << "° at " << r.proof.worst_time;
    std::size_t between = 0;
    for (const ReducedChannel& ch : r.keys.channels)
        for (double f : ch.frames) between += f != std::round(f) ? 1 : 0;
    EXPECT_GE(between, 1u);
    EXPECT_LE(between, 6u);  // only where nothing on whole frames follows the curve
    std::mt19937 rng(17);
    const CurveMotion reference_motion(curve);
    EXPECT_LE(dense_max(r.keys, mode, reference_motion, dense_times(1.0, 44.0, 64, rng), {}), r.proof.bound);
}

// A change of rotation mode (convert_keys_proved): Euler XYZ keys whose BEZIER handles swing between
// frames, converted to quaternion, ZXY and axis-angle with every tenth frame kept as a key. The
// result is proved against the XYZ playback at every instant, and Blender's playback of the new keys
// (emulated) stays within the proved bound at 64 points per frame and as many random times.
TEST(ReduceProved, ConversionIsProvedAgainstTheOriginalModesPlayback) {
    std::mt19937 rng(13);
    const double tol = 0.05 * kDeg;
    const RotationMode from = parse_rotation_mode("XYZ");
    const Original o = make_original(21, from, 60, KeyInterpolation::BEZIER, 4.0);
    const PlaybackMotion original(o.channels, o.interpolation, from);
    std::vector<std::size_t> forced;
    for (std::size_t i = 0; i < o.times.size(); i += 10) forced.push_back(i);
    forced.push_back(o.times.size() - 1);
    std::vector<Quat> q(o.times.size());
    for (std::size_t i = 0; i < q.size(); ++i) q[i] = original.at(o.times[i]);
    for (const char* name : {"QUATERNION", "ZXY", "AXIS_ANGLE"}) {
        const RotationMode to = parse_rotation_mode(name);
        const std::vector<double> values = quats_to_channels(q, to);
        const ProvedKeys r = convert_keys_proved(o.channels, o.interpolation, from, to, o.times, values, forced, tol, 0.01);
        EXPECT_TRUE(r.proof.proven()) << name << ": bound " << r.proof.bound / kDeg << "° at " << r.proof.worst_time;
        EXPECT_LE(r.proof.bound, tol) << name;
        EXPECT_TRUE(r.copied.empty()) << name;
        for (const ReducedChannel& ch : r.keys.channels) {
            for (std::size_t k : forced)
                EXPECT_TRUE(std::binary_search(ch.frames.begin(), ch.frames.end(), o.times[k]))
                    << name << ": no key at forced frame " << o.times[k];
            for (std::size_t a = 1; a < ch.frames.size(); ++a)
                EXPECT_GT(ch.frames[a] - ch.frames[a - 1], 0.0) << name;
        }
        double where = 0.0;
        const double d = dense_max(r.keys, to, original, dense_times(o.times.front(), o.times.back(), 64, rng), {}, &where);
        EXPECT_LE(d, r.proof.bound) << name << ": " << d / kDeg << "° at frame " << where;
    }
    const RotationMode quat = parse_rotation_mode("QUATERNION");
    const std::vector<double> values = quats_to_channels(q, quat);
    expect_invalid([&] { convert_keys_proved(o.channels, o.interpolation, from, quat, o.times, values, {3, 2}, tol, 0.01); },
                   "forced[1]: sample 2 is not after the one before");
    expect_invalid([&] { convert_keys_proved(o.channels, o.interpolation, from, quat, o.times, values, {0, 60}, tol, 0.01); },
                   "forced[1]: sample 60 does not exist (60 samples)");
    expect_invalid([&] { convert_keys_proved(o.channels, o.interpolation, from, quat, o.times, values, {}, 0.0, 0.01); },
                   "tolerance: must be above 0");
    expect_invalid([&] { convert_keys_proved(o.channels, o.interpolation, from, quat, o.times, values, {}, tol, -1.0); },
                   "min_gap");
    expect_invalid([&] { convert_keys_proved(o.channels, o.interpolation, quat, quat, o.times, values, {}, tol, 0.01); },
                   "channels");
}

// Samples at times that are not float32 frames (the add-on's 3.3 + k/4 in doubles: 43.29999995 where
// Blender shows 43.2999992): the proof's pieces end at float32 frames, and a sample just above a
// piece's end was left out of it, so the interval from the piece's last sample inside to its end was
// proved by no piece. Axis-angle LINEAR keys turning 2 rad a frame (a random test scene, seed 438),
// converted to XYZ: before, "proved within 0.05°" while the playback left it by 0.065° at frame
// 43.24, inside such an interval; now every bound holds at 64 points per frame.
TEST(ReduceProved, SampleTimesOffFloat32FramesAreProvedToThePiecesEnds) {
    std::mt19937 rng(29);
    const double tol = 0.05 * kDeg;
    const RotationMode from = parse_rotation_mode("AXIS_ANGLE"), to = parse_rotation_mode("XYZ");
    const double key_frames[] = {3.3, 11.3, 17.3, 26.3, 32.3, 42.3, 50.3};
    const double keys[][4] = {{0.5535327326208721, -0.37828509705564234, 0.7118003614530043, -0.32117016045476765},
                              {-3.1401498459411843, -0.3502923295443603, 0.37700815539832083, 0.06877390984656094},
                              {5.813096876731867, 0.540931014415736, -1.8689673602982722, -0.16124672739047974},
                              {-8.086207522345843, -1.3393258604777873, -0.3325337773115098, 0.997769290267673},
                              {2.992794465226982, -1.2167181678000902, 0.07753812324376615, -0.6839548044433332},
                              {8.680379348485921, -0.4161041120300296, 0.7809987763937948, -1.0793958152779584},
                              {-7.360291248313001, 0.32797971066708875, -0.02262184420023024, 0.7536989443933644}};
    std::vector<FCurveKeys> channels(4);
    for (std::size_t c = 0; c < 4; ++c)
        for (std::size_t k = 0; k < 7; ++k) {
            channels[c].frames.push_back(static_cast<float>(key_frames[k]));
            channels[c].values.push_back(static_cast<float>(keys[k][c]));
        }
    const PlaybackMotion original(channels, KeyInterpolation::LINEAR, from);
    std::vector<double> times;
    std::vector<Quat> q;
    std::vector<std::size_t> forced;
    for (std::size_t k = 0; k <= 188; ++k) {
        times.push_back(static_cast<double>(static_cast<float>(3.3)) + 0.25 * static_cast<double>(k));
        q.push_back(original.at(times.back()));
        for (std::size_t j = 0; j < 7; ++j)
            if (static_cast<float>(times.back()) == static_cast<float>(key_frames[j])) forced.push_back(k);
    }
    ASSERT_EQ(forced.size(), 7u);
    ASSERT_NE(static_cast<double>(static_cast<float>(times[160])), times[160]);  // 43.29999995: not a float32 frame
    const ProvedKeys r = convert_keys_proved(channels, KeyInterpolation::LINEAR, from, to, times,
                                             quats_to_channels(q, to), forced, tol, 0.01);
    double where = 0.0;
    const double d = dense_max(r.keys, to, original, dense_times(times.front(), times.back(), 64, rng), {}, &where);
    EXPECT_LE(d, r.proof.bound) << d / kDeg << "° at frame " << where << ", proved " << r.proof.bound / kDeg << "°";
    EXPECT_LE(r.proof.bound, tol);
}

// A bake's reduction to Euler channels (reduce_curve_proved): SQUAD and SLERP through random keys
// 10-20 frames apart, reduced to XYZ and ZXY at 0.05°. Paths that swing past gimbal lock between
// frames change Euler branch between two samples unless the rows are chained again after the proof
// adds samples (before: 34 of 240 such reductions above the tolerance after 8 rounds, up to 11.7°).
// Every one is proved, and the emulated playback stays within its bound at 64 points per frame.
TEST(ReduceProved, EulerRowsStayOneBranchWhereThePathSwingsPastGimbalLock) {
    std::mt19937 rng(17);
    std::normal_distribution<double> nd;
    const double tol = 0.05 * kDeg;
    const std::vector<double> key_t = {1, 11, 26, 40, 60, 75};
    std::vector<double> times;
    for (double t = 1; t <= 75; t += 1.0) times.push_back(t);
    int cases = 0;
    for (int seed = 0; seed < 40; ++seed) {
        std::vector<Quat> key_q;
        for (std::size_t k = 0; k < key_t.size(); ++k) key_q.push_back(Quat(nd(rng), nd(rng), nd(rng), nd(rng)));
        for (Method method : {Method::SQUAD, Method::SLERP}) {
            const Curve curve(key_t, key_q, method, {});
            for (const char* name : {"XYZ", "ZXY"}) {
                const RotationMode mode = parse_rotation_mode(name);
                const std::vector<double> values = quats_to_channels(curve.sample(times), mode);
                const ProvedKeys r = reduce_curve_proved(curve, mode, times, values, tol);
                const std::string what = std::string(method_name(method)) + " " + name + " case " + std::to_string(seed);
                EXPECT_TRUE(r.proof.proven()) << what << ": bound " << r.proof.bound / kDeg << "° at "
                                              << r.proof.worst_time << " after " << r.rounds << " rounds";
                if (seed % 8 == 0) {
                    const CurveMotion reference(curve);
                    double where = 0.0;
                    const double d = dense_max(r.keys, mode, reference, dense_times(1.0, 75.0, 64, rng), {}, &where);
                    EXPECT_LE(d, r.proof.bound) << what << ": " << d / kDeg << "° at frame " << where;
                }
                ++cases;
            }
        }
    }
    EXPECT_EQ(cases, 160);
}
