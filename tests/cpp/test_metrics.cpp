// Tests of metrics.hpp against closed forms: constant-speed paths, normalized lerp's speed profile,
// paths with a known velocity or acceleration jump at a key, and the bad-input messages.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "quatcurve/errors.hpp"
#include "quatcurve/metrics.hpp"

namespace qc = quatcurve;

namespace {

constexpr double kPi = 3.14159265358979323846;

qc::Quat about(const qc::Vec3& axis, double angle) { return glm::angleAxis(angle, glm::normalize(axis)); }

std::vector<double> grid(double t0, double t1, int n) {
    std::vector<double> t(n + 1);
    for (int i = 0; i <= n; ++i) t[i] = t0 + (t1 - t0) * i / n;
    return t;
}

// Rotation about a fixed axis by the angle phi(t).
template <class F>
std::vector<qc::Quat> about_path(const qc::Vec3& axis, const std::vector<double>& t, F phi) {
    std::vector<qc::Quat> q;
    for (double x : t) q.push_back(about(axis, phi(x)));
    return q;
}

// Normalized lerp from q0 to q1 over [0, 1] (the path of Blender's LINEAR quaternion keys).
std::vector<qc::Quat> nlerp_path(const qc::Quat& q0, const qc::Quat& q1, const std::vector<double>& t) {
    std::vector<qc::Quat> q;
    for (double x : t) q.push_back(glm::normalize(q0 * (1.0 - x) + q1 * x));
    return q;
}

template <class F>
void expect_invalid(F f, const std::string& fragment) {
    try {
        f();
        FAIL() << "expected InvalidArgument containing \"" << fragment << "\"";
    } catch (const qc::InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
}

}  // namespace

TEST(Metrics, DeviationIsGeodesicAndSignInvariant) {
    const qc::Quat a = about({1, 2, 3}, 0.7);
    const std::vector<qc::Quat> path{a, -a, about({0, 0, 1}, 0.3), qc::Quat(2, 0, 0, 0)};
    const std::vector<qc::Quat> ref{a, a, qc::Quat(1, 0, 0, 0), about({1, 0, 0}, kPi)};
    const std::vector<double> d = qc::angular_deviation(path, ref);
    ASSERT_EQ(d.size(), 4u);
    EXPECT_NEAR(d[0], 0.0, 1e-12);
    EXPECT_NEAR(d[1], 0.0, 1e-12);
    EXPECT_NEAR(d[2], 0.3, 1e-12);
    EXPECT_NEAR(d[3], kPi, 1e-9);
}

TEST(Metrics, ConstantSpeedGivesRatioOne) {
    const std::vector<double> t = grid(0, 10, 40);
    const auto q = about_path({1, -2, 0.5}, t, [](double x) { return 0.25 * x; });
    for (double s : qc::interval_speeds(t, q)) EXPECT_NEAR(s, 0.25, 1e-12);
    const auto r = qc::segment_speed_ratios(t, q, {0, 2.5, 10});
    ASSERT_EQ(r.size(), 2u);
    EXPECT_NEAR(r[0], 1.0, 1e-9);
    EXPECT_NEAR(r[1], 1.0, 1e-9);
}

TEST(Metrics, NlerpSpeedRatioMatchesClosedForm) {
    // One segment of rotation angle θ: speed ∝ 1/|lerp|², so max/min = 2/(1 + cos(θ/2)).
    for (double deg : {30.0, 90.0, 150.0, 179.0}) {
        const double theta = deg * kPi / 180.0;
        const std::vector<double> t = grid(0, 1, 2000);
        const auto q = nlerp_path(qc::Quat(1, 0, 0, 0), about({0.3, 1, 0.2}, theta), t);
        const auto r = qc::segment_speed_ratios(t, q, {0, 1});
        ASSERT_EQ(r.size(), 1u);
        EXPECT_NEAR(r[0], 2.0 / (1.0 + std::cos(theta / 2)), 1e-5) << deg;
    }
}

TEST(Metrics, StillAndStoppingSegments) {
    const std::vector<double> t{0, 1, 2, 3, 4};
    const std::vector<qc::Quat> still(5, about({0, 1, 0}, 0.4));
    EXPECT_EQ(qc::segment_speed_ratios(t, still, {0, 4})[0], 1.0);
    const auto stop = about_path({0, 1, 0}, t, [](double x) { return x < 2 ? 0.1 * x : 0.2; });
    EXPECT_TRUE(std::isinf(qc::segment_speed_ratios(t, stop, {0, 4})[0]));
}

TEST(Metrics, SpeedRatioFromVelocity) {
    const std::vector<double> t{0, 1, 2, 3, 4, 5};
    std::vector<qc::Vec3> w{{0, 0, 1}, {0, 0, 1}, {0, 2, 0}, {0, 0, 1}, {0, 0, 3}, {1, 0, 0}};
    const auto r = qc::segment_speed_ratios_from_velocity(t, w, {0, 3, 4, 5});
    ASSERT_EQ(r.size(), 3u);
    EXPECT_DOUBLE_EQ(r[0], 2.0);     // samples 1, 2 (the keys' own samples excluded)
    EXPECT_TRUE(std::isnan(r[1]));   // no sample strictly inside [3, 4]
    EXPECT_TRUE(std::isnan(r[2]));
}

TEST(Metrics, PathLengthAgainstKeyGeodesics) {
    const std::vector<double> t = grid(0, 2, 200);
    // Out by 1 rad about z and back: the keys (ends) coincide, the path is 2 rad long.
    const auto q = about_path({0, 0, 1}, t, [](double x) { return x < 1 ? x : 2 - x; });
    EXPECT_NEAR(qc::path_length(q), 2.0, 1e-9);
    EXPECT_NEAR(qc::path_length({q.front(), q[100], q.back()}), 2.0, 1e-9);
    EXPECT_NEAR(qc::path_length({q.front(), q.back()}), 0.0, 1e-9);
    EXPECT_EQ(qc::path_length({}), 0.0);
    const qc::PathMetrics m = qc::path_metrics(t, q, {0, 2}, q);
    EXPECT_NEAR(m.path_length, 2.0, 1e-9);
    EXPECT_NEAR(m.key_path_length, 0.0, 1e-9);
    EXPECT_TRUE(std::isinf(m.path_length_ratio));
}

TEST(Metrics, VelocityJumpAtKeyBetweenAxes) {
    // About x at rate a until the key, then about world y at rate b: |ω+ − ω−| = √(a² + b²).
    const double a = 0.3, b = 0.4, k = 1.0;
    const std::vector<double> t = grid(0, 2, 20);
    std::vector<qc::Quat> q;
    const qc::Quat qk = about({1, 0, 0}, a * k);
    for (double x : t) q.push_back(x <= k ? about({1, 0, 0}, a * x) : about({0, 1, 0}, b * (x - k)) * qk);
    const qc::KeyJumps j = qc::key_jumps(t, q, {0, k, 2});
    ASSERT_EQ(j.velocity.size(), 3u);
    EXPECT_TRUE(std::isnan(j.velocity[0]));
    EXPECT_TRUE(std::isnan(j.velocity[2]));
    EXPECT_NEAR(j.velocity[1], 0.5, 1e-9);
    EXPECT_NEAR(j.acceleration[1], 0.0, 1e-7);
}

TEST(Metrics, AccelerationJumpAtKey) {
    // φ = t² then continuing with the same speed linearly: ω continuous, α jumps by 2.
    const std::vector<double> t = grid(0, 2, 40);
    const auto q = about_path({1, 1, 0}, t, [](double x) { return x <= 1 ? x * x : 1 + 2 * (x - 1); });
    const qc::KeyJumps j = qc::key_jumps(t, q, {0, 1, 2});
    EXPECT_NEAR(j.velocity[1], 0.0, 1e-9);
    EXPECT_NEAR(j.acceleration[1], 2.0, 1e-7);
}

TEST(Metrics, SmoothPathHasNoJumps) {
    // q(t) = exp(ω2 t/2)·exp(ω1 t/2) is smooth; the key is arbitrary, so the jumps are estimation error.
    const std::vector<double> t = grid(0, 1, 100);
    std::vector<qc::Quat> q;
    for (double x : t) q.push_back(about({0, 1, 0}, 0.9 * x) * about({1, 0, 0.2}, 1.3 * x * x));
    const qc::KeyJumps j = qc::key_jumps(t, q, {0, 0.5, 1});
    EXPECT_LT(j.velocity[1], 1e-5);
    EXPECT_LT(j.acceleration[1], 1e-3);
    // Only one sample each side: velocity still estimated, acceleration not.
    const qc::KeyJumps short_side = qc::key_jumps({0, 1, 2}, {q[0], q[1], q[2]}, {0, 1, 2});
    EXPECT_FALSE(std::isnan(short_side.velocity[1]));
    EXPECT_TRUE(std::isnan(short_side.acceleration[1]));
}

TEST(Metrics, GimbalDistances) {
    using qc::EulerOrder;
    const std::vector<qc::Vec3> angles{{0.3, kPi / 2 - 0.1, -0.2}, {0, 0, 0}, {1, kPi / 2 - 0.1, 0}};
    const auto d = qc::gimbal_distances(angles, EulerOrder::XYZ);  // middle axis of XYZ is Y
    EXPECT_NEAR(d[0], 0.1, 1e-12);
    EXPECT_NEAR(d[1], kPi / 2, 1e-12);
    const auto dq = qc::gimbal_distances(std::vector<qc::Quat>{about({0, 1, 0}, kPi / 2 - 0.1)}, EulerOrder::XYZ);
    EXPECT_NEAR(dq[0], 0.1, 1e-9);
    const auto g = qc::closest_gimbal_approach({10, 11, 12}, d, 1e-9);
    EXPECT_NEAR(g.distance, 0.1, 1e-12);
    ASSERT_EQ(g.times.size(), 2u);
    EXPECT_EQ(g.times[0], 10);
    EXPECT_EQ(g.times[1], 12);
}

TEST(Metrics, PathMetricsSummary) {
    const std::vector<double> t = grid(0, 4, 40);
    const auto ref = about_path({0, 0, 1}, t, [](double x) { return 0.2 * x; });
    const auto q = about_path({0, 0, 1}, t, [](double x) { return 0.2 * x + 0.05 * std::sin(kPi * x / 4); });
    const qc::PathMetrics m = qc::path_metrics(t, q, {0, 2, 4}, ref);
    EXPECT_NEAR(m.max_deviation, 0.05, 1e-12);
    EXPECT_NEAR(m.max_deviation_time, 2.0, 1e-12);
    EXPECT_NEAR(m.mean_deviation, 0.05 * 2 / kPi, 2e-3);  // mean of a half sine on a 40-interval grid
    EXPECT_EQ(m.speeds.size(), t.size() - 1);
    EXPECT_EQ(m.segment_speed_ratios.size(), 2u);
    EXPECT_GT(m.speed_ratio, 1.0);
    EXPECT_NEAR(m.path_length, 0.8, 1e-9);
    EXPECT_NEAR(m.key_path_length, 0.8, 1e-9);
    EXPECT_NEAR(m.path_length_ratio, 1.0, 1e-9);
    EXPECT_NEAR(m.max_velocity_jump, 0.0, 1e-4);
    EXPECT_EQ(m.max_velocity_jump_time, 2.0);
}

TEST(Metrics, BadInputNamesTheElement) {
    const std::vector<double> t{0, 1, 2, 3};
    const std::vector<qc::Quat> q(4, qc::Quat(1, 0, 0, 0));
    std::vector<qc::Quat> zero = q;
    zero[2] = qc::Quat(0, 0, 0, 0);
    std::vector<qc::Quat> nan = q;
    nan[1].x = std::numeric_limits<double>::quiet_NaN();
    expect_invalid([&] { qc::angular_deviation(q, zero); }, "reference[2]");
    expect_invalid([&] { qc::angular_deviation(nan, q); }, "quats[1]");
    expect_invalid([&] { qc::angular_deviation(q, {q[0]}); }, "reference: 1 values, expected 4");
    expect_invalid([&] { qc::interval_speeds({0, 1, 1, 3}, q); }, "times[2]: not increasing");
    expect_invalid([&] { qc::interval_speeds({0, 1, NAN, 3}, q); }, "times[2]: not finite");
    expect_invalid([&] { qc::interval_speeds({0}, {q[0]}); }, "at least 2");
    expect_invalid([&] { qc::segment_speed_ratios(t, q, {0, 1.5}); }, "key_times[1]: not a sample time");
    expect_invalid([&] { qc::segment_speed_ratios(t, q, {2, 1}); }, "key_times[1]: not increasing");
    expect_invalid([&] { qc::segment_speed_ratios_from_velocity(t, {{0, 0, 0}}, {0, 3}); }, "velocities");
    expect_invalid([&] { qc::key_jumps(t, zero, {0, 3}); }, "quats[2]");
    expect_invalid([&] { qc::path_length(zero); }, "quats[2]");
    expect_invalid([&] { qc::gimbal_distances(std::vector<qc::Vec3>{{0, INFINITY, 0}}, qc::EulerOrder::XYZ); },
                   "angles[0]");
    expect_invalid([&] { qc::closest_gimbal_approach({}, {}, 0); }, "at least 1");
    expect_invalid([&] { qc::closest_gimbal_approach({0}, {0.1}, -1); }, "tolerance");
    expect_invalid([&] { qc::closest_gimbal_approach({0, 1}, {0.1, -0.1}, 0); }, "distances[1]: negative");
    expect_invalid([&] { qc::path_metrics(t, q, {0, 3}, q, {q[0]}); }, "key_quats: 1 values, expected 2");
}
