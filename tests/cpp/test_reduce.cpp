// Key reduction (reduce.hpp): the reducer's bound (under Blender's evaluation, emulated by
// blender_eval.hpp and tested in test_blender_eval.cpp), key choice, edge cases and bad input. The Python suite (test_reduce.py) checks the
// bound again with an independent numpy re-implementation of Blender's evaluation.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "quatcurve/channels.hpp"
#include "quatcurve/curve.hpp"
#include "quatcurve/errors.hpp"
#include "quatcurve/euler.hpp"
#include "quatcurve/quat.hpp"
#include "quatcurve/reduce.hpp"

using namespace quatcurve;

namespace {

constexpr double kDeg = M_PI / 180.0;

// Random smooth quaternion motion: rotation vectors on a Catmull-Rom spline through a random walk.
std::vector<Quat> smooth_quats(unsigned seed, std::size_t n, std::size_t every = 10,
                               double step_deg = 15.0) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> step(0.0, step_deg * kDeg);
    std::vector<Vec3> keys(n / every + 4);
    for (std::size_t k = 1; k < keys.size(); ++k)
        keys[k] = keys[k - 1] + Vec3(step(rng), step(rng), step(rng));
    std::vector<Quat> q(n);
    Quat prev(1, 0, 0, 0);
    for (std::size_t f = 0; f < n; ++f) {
        const std::size_t k = f / every + 1;
        const double u = double(f % every) / double(every);
        const Vec3 &p0 = keys[k - 1], &p1 = keys[k], &p2 = keys[k + 1], &p3 = keys[k + 2];
        const Vec3 v = 0.5 * ((2.0 * p1) + (-p0 + p2) * u + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * u * u +
                              (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * u * u * u);
        const double a = glm::length(v);
        Quat r = a > 0 ? axis_angle_to_quat(v / a, a) : Quat(1, 0, 0, 0);
        if (r.w * prev.w + r.x * prev.x + r.y * prev.y + r.z * prev.z < 0) r = -r;
        q[f] = prev = r;
    }
    return q;
}

std::vector<double> frames_of(std::size_t n, double start = 0.0, double dt = 1.0) {
    std::vector<double> t(n);
    for (std::size_t k = 0; k < n; ++k) t[k] = start + dt * double(k);
    return t;
}

// Largest rotation error over every sample under Blender's evaluation (emulated) of the result.
double quat_max_error(const ReducedKeys& r, const std::vector<double>& times,
                      const std::vector<Quat>& q) {
    std::vector<std::vector<double>> vals(4);
    for (int c = 0; c < 4; ++c) blender_evaluate(r.channels[c], r.interpolation, times, vals[c]);
    double worst = 0.0;
    for (std::size_t k = 0; k < times.size(); ++k) {
        const Quat e(vals[0][k], vals[1][k], vals[2][k], vals[3][k]);
        worst = std::max(worst, angle_between(e, q[k]));
    }
    return worst;
}

double euler_max_error(const ReducedKeys& r, const std::vector<double>& times,
                       const std::vector<Vec3>& a, EulerOrder order) {
    std::vector<std::vector<double>> vals(3);
    for (int c = 0; c < 3; ++c) blender_evaluate(r.channels[c], r.interpolation, times, vals[c]);
    double worst = 0.0;
    for (std::size_t k = 0; k < times.size(); ++k) {
        const Vec3 e(vals[0][k], vals[1][k], vals[2][k]);
        worst = std::max(worst, angle_between(euler_to_quat(e, order), euler_to_quat(a[k], order)));
    }
    return worst;
}

// The rotation Blender builds from axis-angle channels (angle, x, y, z): the axis normalized.
Quat axis_angle_rotation(double angle, double x, double y, double z) {
    return axis_angle_to_quat(Vec3(x, y, z), angle);
}

double axis_angle_max_error(const ReducedKeys& r, const std::vector<double>& times, const std::vector<Vec4>& v) {
    std::vector<std::vector<double>> vals(4);
    for (int c = 0; c < 4; ++c) blender_evaluate(r.channels[c], r.interpolation, times, vals[c]);
    double worst = 0.0;
    for (std::size_t k = 0; k < times.size(); ++k)
        worst = std::max(worst, angle_between(axis_angle_rotation(vals[0][k], vals[1][k], vals[2][k], vals[3][k]),
                                              axis_angle_rotation(v[k][0], v[k][1], v[k][2], v[k][3])));
    return worst;
}

// A method's curve through axis-angle keys (spins kept), sampled every 1/4 frame as channels
// continuous from each key to the next (axis_angle_span_channels), the keys exact.
std::vector<Vec4> axis_angle_samples(const std::vector<double>& key_t, const std::vector<double>& key_v,
                                     Method method, std::vector<double>& t, std::vector<std::size_t>& forced) {
    const Curve curve = Curve::from_axis_angle(key_t, key_v, method);
    t.clear();
    forced.clear();
    for (double x = key_t.front(); x <= key_t.back() + 1e-9; x += 0.25) t.push_back(x);
    for (double k : key_t) forced.push_back(static_cast<std::size_t>(std::lround((k - key_t.front()) * 4)));
    const std::vector<Quat> q = curve.sample(t);
    std::vector<Vec4> v(t.size());
    for (std::size_t a = 0; a + 1 < key_t.size(); ++a) {
        const std::vector<Quat> span(q.begin() + forced[a], q.begin() + forced[a + 1] + 1);
        const std::vector<double> ch = axis_angle_span_channels(span, &key_v[4 * a], &key_v[4 * a + 4]);
        for (std::size_t s = 0; s < span.size(); ++s)
            v[forced[a] + s] = Vec4(ch[4 * s], ch[4 * s + 1], ch[4 * s + 2], ch[4 * s + 3]);
    }
    for (std::size_t a = 0; a < key_t.size(); ++a)
        v[forced[a]] = Vec4(key_v[4 * a], key_v[4 * a + 1], key_v[4 * a + 2], key_v[4 * a + 3]);
    return v;
}

void expect_structure(const ReducedKeys& r, std::size_t n, bool synchronized) {
    for (const ReducedChannel& ch : r.channels) {
        ASSERT_FALSE(ch.indices.empty());
        EXPECT_EQ(ch.indices.front(), 0u);
        EXPECT_EQ(ch.indices.back(), n - 1);
        for (std::size_t a = 1; a < ch.indices.size(); ++a) EXPECT_LT(ch.indices[a - 1], ch.indices[a]);
        if (r.interpolation == KeyInterpolation::BEZIER) {
            EXPECT_EQ(ch.handle_left.size(), 2 * ch.indices.size());
            EXPECT_EQ(ch.handle_right.size(), 2 * ch.indices.size());
        }
    }
    if (synchronized)
        for (const ReducedChannel& ch : r.channels) EXPECT_EQ(ch.indices, r.channels[0].indices);
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

// ---- the reducer --------------------------------------------------------------------------------------

TEST(Reduce, QuaternionBoundHoldsForEveryVariant) {
    const std::vector<Quat> q = smooth_quats(1, 500);
    const std::vector<double> t = frames_of(q.size());
    for (double tol_deg : {0.02, 0.1, 1.0, 4.0}) {
        const double tol = tol_deg * kDeg;
        for (KeyInterpolation ipo : {KeyInterpolation::LINEAR, KeyInterpolation::BEZIER}) {
            std::size_t sync_keys = 0;
            for (bool sync : {true, false}) {
                const ReducedKeys r = reduce_keys(t, q, tol, ipo, sync);
                expect_structure(r, q.size(), sync);
                const double err = quat_max_error(r, t, q);
                EXPECT_LE(err, tol) << tol_deg << " deg, " << key_interpolation_name(ipo);
                EXPECT_NEAR(r.max_error, err, 1e-9);
                EXPECT_LT(r.key_count(), 4 * q.size());
                if (sync) sync_keys = r.key_count();
                else EXPECT_LE(r.key_count(), sync_keys);
            }
        }
    }
}

TEST(Reduce, EulerBoundHoldsForEveryOrder) {
    const std::vector<Quat> q = smooth_quats(2, 300);
    const std::vector<double> t = frames_of(q.size());
    for (EulerOrder order : {EulerOrder::XYZ, EulerOrder::XZY, EulerOrder::YXZ, EulerOrder::YZX,
                             EulerOrder::ZXY, EulerOrder::ZYX}) {
        std::vector<Vec3> a(q.size());
        for (std::size_t k = 0; k < q.size(); ++k) a[k] = quat_to_euler(q[k], order);
        euler_filter(a.data(), a.size(), order);
        for (KeyInterpolation ipo : {KeyInterpolation::LINEAR, KeyInterpolation::BEZIER}) {
            for (bool sync : {true, false}) {
                const ReducedKeys r = reduce_keys_euler(t, a, order, 0.1 * kDeg, ipo, sync);
                expect_structure(r, q.size(), sync);
                EXPECT_EQ(r.channels.size(), 3u);
                EXPECT_LE(euler_max_error(r, t, a, order), 0.1 * kDeg) << euler_order_name(order);
            }
        }
    }
}

TEST(Reduce, BezierNeedsFarFewerKeysThanLinearOnSmoothMotion) {
    const std::vector<Quat> q = smooth_quats(4, 1000);
    const std::vector<double> t = frames_of(q.size());
    const std::size_t lin = reduce_keys(t, q, 0.1 * kDeg).key_count();
    const std::size_t bez = reduce_keys(t, q, 0.1 * kDeg, KeyInterpolation::BEZIER).key_count();
    EXPECT_LT(bez, lin / 2);
    EXPECT_LT(bez, 4000u / 5);
}

TEST(Reduce, FarFramesKeepTheBound) {
    // Near frame 100,000 float32 frames are coarse (ulp 0.0078): Blender's frame→parameter map of
    // the stored handle frames is not linear; verification and repair still hold the bound.
    const std::vector<Quat> q = smooth_quats(5, 600, 20, 25.0);
    const std::vector<double> t = frames_of(q.size(), 100000.0, 0.41);
    for (bool sync : {true, false}) {
        const ReducedKeys r = reduce_keys(t, q, 0.05 * kDeg, KeyInterpolation::BEZIER, sync);
        EXPECT_LE(quat_max_error(r, t, q), 0.05 * kDeg);
    }
}

TEST(Reduce, ToleranceZeroKeepsEverySample) {
    const std::vector<Quat> q = smooth_quats(6, 40);
    const std::vector<double> t = frames_of(q.size());
    for (KeyInterpolation ipo : {KeyInterpolation::LINEAR, KeyInterpolation::BEZIER})
        for (bool sync : {true, false})
            for (const ReducedChannel& ch : reduce_keys(t, q, 0.0, ipo, sync).channels)
                EXPECT_EQ(ch.indices.size(), q.size());
}

TEST(Reduce, ConstantMotionGivesTwoKeysOneSampleOneKey) {
    const std::vector<double> t = frames_of(50);
    const std::vector<Quat> q(50, Quat(0.5, 0.5, -0.5, 0.5));
    const std::vector<Vec3> a(50, Vec3(0.3, -0.2, 1.0));
    for (KeyInterpolation ipo : {KeyInterpolation::LINEAR, KeyInterpolation::BEZIER}) {
        for (bool sync : {true, false}) {
            for (const ReducedChannel& ch : reduce_keys(t, q, 1e-3, ipo, sync).channels)
                EXPECT_EQ(ch.indices, (std::vector<std::size_t>{0, 49}));
            for (const ReducedChannel& ch :
                 reduce_keys_euler(t, a, EulerOrder::ZYX, 1e-3, ipo, sync).channels)
                EXPECT_EQ(ch.indices, (std::vector<std::size_t>{0, 49}));
            const ReducedKeys one = reduce_keys({7.0}, {Quat(1, 0, 0, 0)}, 0.1, ipo, sync);
            for (const ReducedChannel& ch : one.channels) {
                EXPECT_EQ(ch.indices, std::vector<std::size_t>{0});
                EXPECT_EQ(ch.frames, std::vector<double>{7.0});
            }
        }
    }
}

TEST(Reduce, KeysAreFloat32InputValuesAndHandlesSitInsideTheirSegment) {
    const std::vector<Quat> q = smooth_quats(7, 200);
    const std::vector<double> t = frames_of(q.size(), 3.0, 0.7);
    const ReducedKeys r = reduce_keys(t, q, 0.2 * kDeg, KeyInterpolation::BEZIER, false);
    int thirds = 0, others = 0;
    for (int c = 0; c < 4; ++c) {
        const ReducedChannel& ch = r.channels[c];
        for (std::size_t a = 0; a < ch.indices.size(); ++a) {
            const std::size_t k = ch.indices[a];
            const double v[4] = {q[k].w, q[k].x, q[k].y, q[k].z};
            EXPECT_EQ(ch.values[a], double(float(v[c])));
            EXPECT_EQ(ch.frames[a], double(float(t[k])));
            if (a + 1 < ch.indices.size()) {
                // The handle frames at the fractions the reducer tries (1/3 first, then 0.2, 0.4, 0.5
                // or 0.6), together at most the segment: Blender plays them uncorrected.
                const double d = ch.frames[a + 1] - ch.frames[a];
                const double a1 = (ch.handle_right[2 * a] - ch.frames[a]) / d;
                const double a2 = (ch.frames[a + 1] - ch.handle_left[2 * (a + 1)]) / d;
                for (double f : {a1, a2}) {
                    EXPECT_TRUE(std::fabs(f - 1.0 / 3.0) < 1e-5 || std::fabs(f - 0.2) < 1e-5 ||
                                std::fabs(f - 0.4) < 1e-5 || std::fabs(f - 0.5) < 1e-5 ||
                                std::fabs(f - 0.6) < 1e-5)
                        << "channel " << c << " key " << a << ": fraction " << f;
                }
                EXPECT_LE(ch.handle_right[2 * a], ch.handle_left[2 * (a + 1)]);
                (std::fabs(a1 - 1.0 / 3.0) < 1e-5 && std::fabs(a2 - 1.0 / 3.0) < 1e-5 ? thirds : others)++;
            }
        }
    }
    EXPECT_GT(thirds, 0);
    EXPECT_LE(quat_max_error(r, t, q), 0.2 * kDeg);
}

// A turn about Z whose quaternion's z channel is a Bezier segment with handle frames at 0.2 and 0.5 of
// it (an ease out of the first key, a late ease into the last): cubic in its parameter, not in the
// frame. Handles at the thirds need a key in between at 0.1°; the reducer's other handle frames take
// it in one segment, handles where they were.
TEST(Reduce, OtherHandleFramesTakeAnEaseInOneSegment) {
    const double a1 = 0.2, a2 = 0.5, y0 = 0.0, y1 = 0.1, y2 = 0.9, y3 = 1.0;
    const std::size_t n = 31;
    const std::vector<double> t = frames_of(n);
    std::vector<Quat> q(n);
    for (std::size_t k = 0; k < n; ++k) {
        const double tau = t[k] / t[n - 1];
        double lo = 0.0, hi = 1.0;
        for (int it = 0; it < 200; ++it) {
            const double s = 0.5 * (lo + hi), v = 1.0 - s;
            (3 * v * v * s * a1 + 3 * v * s * s * (1 - a2) + s * s * s < tau ? lo : hi) = s;
        }
        const double s = 0.5 * (lo + hi), v = 1.0 - s;
        const double z = v * v * v * y0 + 3 * v * v * s * y1 + 3 * v * s * s * y2 + s * s * s * y3;
        q[k] = Quat(1.0, 0.0, 0.0, z);  // the rotation of its direction; the scale is kept as given
    }
    const ReducedKeys r = reduce_keys(t, q, 0.1 * kDeg, KeyInterpolation::BEZIER, true);
    EXPECT_LE(quat_max_error(r, t, q), 0.1 * kDeg);
    const ReducedChannel& z = r.channels[3];
    ASSERT_EQ(z.indices, (std::vector<std::size_t>{0, n - 1}));
    EXPECT_NEAR(z.handle_right[0], a1 * t[n - 1], 1e-4);
    EXPECT_NEAR(z.handle_left[2], t[n - 1] * (1.0 - a2), 1e-4);
    EXPECT_NEAR(z.handle_right[1], y1, 1e-4);
    EXPECT_NEAR(z.handle_left[3], y2, 1e-4);
}

TEST(Reduce, HemisphereFlipForcesKeysOnBothSides) {
    std::vector<Quat> q = smooth_quats(8, 120);
    for (std::size_t k = 60; k < q.size(); ++k) q[k] = -q[k];
    const std::vector<double> t = frames_of(q.size());
    for (KeyInterpolation ipo : {KeyInterpolation::LINEAR, KeyInterpolation::BEZIER}) {
        const ReducedKeys r = reduce_keys(t, q, 0.5 * kDeg, ipo, false);
        EXPECT_LE(quat_max_error(r, t, q), 0.5 * kDeg);
        for (const ReducedChannel& ch : r.channels) {
            EXPECT_NE(std::find(ch.indices.begin(), ch.indices.end(), 59u), ch.indices.end());
            EXPECT_NE(std::find(ch.indices.begin(), ch.indices.end(), 60u), ch.indices.end());
        }
    }
}

TEST(Reduce, Deterministic) {
    const std::vector<Quat> q = smooth_quats(9, 300);
    const std::vector<double> t = frames_of(q.size());
    const ReducedKeys a = reduce_keys(t, q, 0.1 * kDeg, KeyInterpolation::BEZIER, false);
    const ReducedKeys b = reduce_keys(t, q, 0.1 * kDeg, KeyInterpolation::BEZIER, false);
    for (int c = 0; c < 4; ++c) {
        EXPECT_EQ(a.channels[c].indices, b.channels[c].indices);
        EXPECT_EQ(a.channels[c].handle_right, b.channels[c].handle_right);
    }
}

TEST(Reduce, BadInputNamesTheArgument) {
    const std::vector<double> t = frames_of(4);
    const std::vector<Quat> q(4, Quat(1, 0, 0, 0));
    const std::vector<Vec3> a(4, Vec3(0.0));
    expect_invalid([&] { reduce_keys(t, q, -1.0); }, "tolerance");
    expect_invalid([&] { reduce_keys(t, q, std::nan("")); }, "tolerance");
    expect_invalid([&] { reduce_keys_euler(t, a, EulerOrder::XYZ, INFINITY); }, "tolerance");
    expect_invalid([&] { reduce_keys({}, {}, 0.1); }, "times: at least one sample");
    expect_invalid([&] { reduce_keys({0, 1, 1, 2}, q, 0.1); }, "times[2]: not increasing");
    expect_invalid([&] { reduce_keys({0, 2, 1, 3}, q, 0.1); }, "times[2]: not increasing");
    expect_invalid([&] { reduce_keys({0, 1, NAN, 3}, q, 0.1); }, "times[2]: non-finite");
    expect_invalid([&] { reduce_keys({1e8, 1e8 + 1, 1e8 + 8, 1e8 + 16}, q, 0.1); },
                   "times[1]: same float32 frame as times[0]");
    expect_invalid([&] { reduce_keys({0, 1, 2, 1e39}, q, 0.1); }, "times[3]: beyond float32");
    expect_invalid([&] { reduce_keys(t, {q[0], q[1], q[2]}, 0.1); }, "quats: 3 quaternions for 4");
    std::vector<Quat> bad = q;
    bad[2] = Quat(0, 0, 0, 0);
    expect_invalid([&] { reduce_keys(t, bad, 0.1); }, "quats[2]: zero-length");
    bad[2] = Quat(1, NAN, 0, 0);
    expect_invalid([&] { reduce_keys(t, bad, 0.1, KeyInterpolation::BEZIER); }, "quats[2]");
    // Blender stores float32: a quaternion whose every component underflows it, or whose float32
    // rounding (subnormal, a few bits) turns it by more than the tolerance, is refused
    bad[2] = Quat(1e-50, 2e-50, 0, 0);
    expect_invalid([&] { reduce_keys(t, bad, 0.1); }, "quats[2]: every component underflows float32");
    bad[2] = Quat(3.1e-42, 1.7e-42, 0, 0);
    expect_invalid([&] { reduce_keys(t, bad, 0.0); }, "quats[2]: storing it as float32 (as Blender does) turns it by");
    bad[2] = Quat(3.1e-30, 1.7e-30, 0, 0);  // normal float32: stored within 1e-6 rad
    EXPECT_NO_THROW(reduce_keys(t, bad, 0.0));
    std::vector<Vec3> bad_a = a;
    bad_a[1] = Vec3(0, INFINITY, 0);
    expect_invalid([&] { reduce_keys_euler(t, bad_a, EulerOrder::XYZ, 0.1); }, "angles[1]");
    expect_invalid([&] { reduce_keys_euler(t, {a[0]}, EulerOrder::XYZ, 0.1); }, "angles: 1 triples");
}

// ---- fit_keys: the reducer with forced keys (an animator's own keys) ----------------------------

TEST(FitKeys, ForcedKeysStayWithTheirValuesAndTheBoundHolds) {
    const std::vector<double> t = frames_of(401, 1.0, 0.25);  // frames 1..101, 4 samples per frame
    const std::vector<Quat> q = smooth_quats(21, t.size(), 40, 25.0);
    const std::vector<std::size_t> forced = {0, 17, 60, 61, 200, 333, 400};
    for (bool sync : {true, false}) {
        const ReducedKeys r = fit_keys(t, q, forced, 0.05 * kDeg, KeyInterpolation::BEZIER, sync);
        EXPECT_LE(quat_max_error(r, t, q), 0.05 * kDeg);
        EXPECT_LE(r.max_error, 0.05 * kDeg);
        for (int c = 0; c < 4; ++c) {
            const auto& ch = r.channels[c];
            for (std::size_t f : forced) {
                const auto it = std::find(ch.indices.begin(), ch.indices.end(), f);
                ASSERT_NE(it, ch.indices.end()) << "channel " << c << " lost forced sample " << f;
                const std::size_t a = static_cast<std::size_t>(it - ch.indices.begin());
                EXPECT_EQ(ch.values[a], double(float(q[f][c == 0 ? 3 : c - 1])));  // glm stores x, y, z, w
                EXPECT_EQ(ch.frames[a], double(float(t[f])));
            }
        }
    }
    // without forced keys it is reduce_keys, bit for bit
    const ReducedKeys a = fit_keys(t, q, {}, 0.1 * kDeg, KeyInterpolation::BEZIER, true, 0.0);
    const ReducedKeys b = reduce_keys(t, q, 0.1 * kDeg, KeyInterpolation::BEZIER, true);
    ASSERT_EQ(a.channels.size(), b.channels.size());
    for (std::size_t c = 0; c < a.channels.size(); ++c) {
        EXPECT_EQ(a.channels[c].indices, b.channels[c].indices);
        EXPECT_EQ(a.channels[c].handle_left, b.channels[c].handle_left);
    }
}

TEST(FitKeys, InsertedKeysKeepTheirDistanceFromForcedOnes) {
    // samples every 0.005 frames near forced keys at fractional frames: nothing inserted closer
    // than min_gap (Blender merges keys within 0.01 frames)
    std::vector<double> t;
    for (double x = 0.0; x <= 4.0 + 1e-9; x += 0.005) t.push_back(x);
    const std::vector<Quat> q = smooth_quats(5, t.size(), 50, 40.0);
    const std::vector<std::size_t> forced = {0, 101, 203, t.size() - 1};
    const ReducedKeys r = fit_keys(t, q, forced, 0.01 * kDeg, KeyInterpolation::BEZIER, false, 0.05);
    for (const auto& ch : r.channels)
        for (double f : ch.frames) {
            double gap = 1e9;
            for (std::size_t k : forced) gap = std::min(gap, std::fabs(f - float(t[k])));
            EXPECT_TRUE(gap == 0.0 || gap >= 0.05 - 1e-6) << f;
        }
    EXPECT_LE(quat_max_error(r, t, q), 0.01 * kDeg) << r.max_error / kDeg << " keys " << r.key_count();
}

TEST(FitKeys, EulerForcedKeys) {
    const std::vector<double> t = frames_of(121, 0.0, 0.25);
    std::vector<Vec3> a(t.size());
    for (std::size_t k = 0; k < t.size(); ++k) {
        const double x = t[k];
        a[k] = Vec3(0.3 * std::sin(0.2 * x), 1.2 * std::sin(0.1 * x + 0.4), 2.0 * x / 30.0 * M_PI);  // a spin in Z
    }
    const std::vector<std::size_t> forced = {0, 40, 80, 120};
    const ReducedKeys r = fit_keys_euler(t, a, EulerOrder::XZY, forced, 0.02 * kDeg);
    ASSERT_EQ(r.channels.size(), 3u);
    for (const auto& ch : r.channels)
        for (std::size_t f : forced) EXPECT_NE(std::find(ch.indices.begin(), ch.indices.end(), f), ch.indices.end());
    EXPECT_LE(r.max_error, 0.02 * kDeg);
}

TEST(FitKeys, BadForcedKeysAreRefused) {
    const std::vector<double> t = frames_of(10);
    const std::vector<Quat> q = smooth_quats(3, t.size());
    EXPECT_THROW(fit_keys(t, q, {0, 10}, 0.01), InvalidArgument);  // out of range
    EXPECT_THROW(fit_keys(t, q, {0, 5, 5}, 0.01), InvalidArgument);  // not increasing
    EXPECT_THROW(fit_keys(t, q, {0, 9}, 0.01, KeyInterpolation::BEZIER, false, -1.0), InvalidArgument);
    try {
        fit_keys(t, q, {3, 2}, 0.01);
        FAIL();
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find("forced[1]"), std::string::npos) << e.what();
    }
}

TEST(FitKeys, AxisAngleKeepsForcedKeysAndSpinsWithinTheBound) {
    // 0 → 400° → 760° about a tilted, non-unit axis (full turns between keys), an axis change, and a
    // turn back through 720° (the identity) with the axis changing; every fitted method.
    const std::vector<double> key_t = {1.0, 9.0, 20.0, 26.0, 40.0};
    const std::vector<double> key_v = {0.0,          0.0, 0.0, 2.0, 400 * kDeg, 0.0, 0.3,  1.0,
                                       760 * kDeg,   0.0, 0.3, 1.0, 800 * kDeg, 1.0, 0.2,  0.4,
                                       700 * kDeg,   0.5, -0.5, 0.7};
    for (Method method : {Method::SLERP, Method::SQUAD, Method::CATMULL_ROM, Method::SPLINE_C2}) {
        std::vector<double> t;
        std::vector<std::size_t> forced;
        const std::vector<Vec4> v = axis_angle_samples(key_t, key_v, method, t, forced);
        const ReducedKeys r = fit_keys_axis_angle(t, v, forced, 0.05 * kDeg);
        SCOPED_TRACE(method_name(method));
        ASSERT_EQ(r.channels.size(), 4u);
        EXPECT_LE(r.max_error, 0.05 * kDeg);
        EXPECT_LE(axis_angle_max_error(r, t, v), 0.05 * kDeg - 1e-6);  // the emulator, bit-identical to Blender
        for (int c = 0; c < 4; ++c) {
            const ReducedChannel& ch = r.channels[c];
            for (std::size_t a = 0; a < forced.size(); ++a) {
                const auto it = std::find(ch.indices.begin(), ch.indices.end(), forced[a]);
                ASSERT_NE(it, ch.indices.end()) << "channel " << c << " lost forced sample " << forced[a];
                EXPECT_EQ(ch.values[static_cast<std::size_t>(it - ch.indices.begin())], double(float(key_v[4 * a + c])));
            }
            for (std::size_t a = 0; a < ch.frames.size(); ++a) {  // everything float32, as Blender stores it
                EXPECT_EQ(ch.values[a], double(float(ch.values[a])));
                EXPECT_EQ(ch.handle_left[2 * a + 1], double(float(ch.handle_left[2 * a + 1])));
                EXPECT_EQ(ch.handle_right[2 * a + 1], double(float(ch.handle_right[2 * a + 1])));
            }
        }
        // The spin 400° → 760° (one axis) is in the angle channel: Blender's evaluation climbs it.
        std::vector<double> inside, angle;
        for (double x = 9.0; x <= 20.0; x += 0.125) inside.push_back(x);
        blender_evaluate(r.channels[0], r.interpolation, inside, angle);
        for (std::size_t k = 1; k < angle.size(); ++k) EXPECT_GT(angle[k], angle[k - 1]) << inside[k];
    }
}

TEST(Reduce, AxisAngleBoundHoldsOnTheNormalizedAxis) {
    const std::vector<double> t = frames_of(121);
    std::vector<Vec4> v(t.size());
    for (std::size_t k = 0; k < t.size(); ++k) {
        const double s = t[k] / 120.0;
        v[k] = Vec4(9.0 * s, 0.4 * std::sin(3 * s), 0.3 + s, 2.0 - 1.5 * s);  // over a full turn, non-unit axis
    }
    for (KeyInterpolation ipo : {KeyInterpolation::LINEAR, KeyInterpolation::BEZIER})
        for (bool sync : {true, false}) {
            const ReducedKeys r = reduce_keys_axis_angle(t, v, 0.1 * kDeg, ipo, sync);
            expect_structure(r, t.size(), sync);
            EXPECT_LE(r.max_error, 0.1 * kDeg);
            EXPECT_LE(axis_angle_max_error(r, t, v), 0.1 * kDeg);
            EXPECT_LT(r.key_count(), 4 * t.size() / 2);
        }
    std::vector<Vec4> bad = v;
    bad[7] = Vec4(1.0, 0.0, 0.0, 0.0);
    expect_invalid([&] { reduce_keys_axis_angle(t, bad, 0.01); }, "values[7]: zero-length axis");
    bad[7] = Vec4(NAN, 0.0, 0.0, 1.0);
    expect_invalid([&] { fit_keys_axis_angle(t, bad, {0}, 0.01); }, "values[7] angle");
}

TEST(CurveAxisAngle, FullTurnsSurviveFloat32Keys) {
    // 400° → 760° about one axis is exactly a full turn; the keys as float32 (as Blender holds them)
    // must give the same curve, not a turn about a rounding-noise axis or another sub-arc count.
    const std::vector<double> key_t = {1.0, 9.0, 20.0, 26.0};
    const std::vector<double> key_v = {0.0, 0.0, 0.0, 2.0, 400 * kDeg, 0.0, 0.3, 1.0, 760 * kDeg, 0.0, 0.3, 1.0,
                                       800 * kDeg, 1.0, 0.2, 0.4};
    std::vector<double> key_f(key_v.size());
    for (std::size_t a = 0; a < key_v.size(); ++a) key_f[a] = double(float(key_v[a]));
    std::vector<double> t;
    for (double x = 1.0; x <= 26.0; x += 0.25) t.push_back(x);
    for (Method method : {Method::SLERP, Method::SQUAD, Method::SPLINE_C2}) {
        const std::vector<Quat> a = Curve::from_axis_angle(key_t, key_v, method).sample(t);
        const std::vector<Quat> b = Curve::from_axis_angle(key_t, key_f, method).sample(t);
        for (std::size_t k = 0; k < t.size(); ++k) EXPECT_LT(angle_between(a[k], b[k]), 1e-5) << t[k];
        const std::vector<SegmentPath> paths = Curve::from_axis_angle(key_t, key_v, method).segment_paths();
        EXPECT_NEAR(paths[1].arc, 2 * M_PI, 1e-9);
    }
    expect_invalid([&] { Curve::from_axis_angle({0.0, 1.0}, {0, 0, 0, 1, 1, 0, 0, 0}); }, "values[1] axis");
}
