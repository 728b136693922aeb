// Tests of channels.hpp: channel values of each rotation mode, continuity along sequences, Blender's
// Euler branch, and the sampling policies.
#include "quatcurve/channels.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

using namespace quatcurve;

namespace {

constexpr double kPi = 3.141592653589793238462643383279502884;
const char* const kModes[] = {"QUATERNION", "XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX", "AXIS_ANGLE"};

std::vector<Quat> wandering_path(std::size_t n, unsigned seed) {
    std::mt19937_64 gen(seed);
    std::normal_distribution<double> step(0.0, 0.1);
    std::vector<Quat> q{Quat(1, 0, 0, 0)};
    for (std::size_t s = 1; s < n; ++s) {
        const Vec3 v(step(gen), step(gen), step(gen));
        Quat next = multiply(axis_angle_to_quat(v, glm::length(v)), q.back());
        if (s % 7 == 3) next = -next;  // hemisphere flips the channels must remove
        q.push_back(next);
    }
    return q;
}

}  // namespace

TEST(Channels, RoundTripEveryMode) {
    const std::vector<Quat> q = wandering_path(100, 1);
    for (const char* name : kModes) {
        const RotationMode mode = parse_rotation_mode(name);
        const std::size_t c = channel_count(mode);
        const std::vector<double> v = quats_to_channels(q, mode);
        ASSERT_EQ(v.size(), c * q.size()) << name;
        for (std::size_t s = 0; s < q.size(); ++s)
            EXPECT_LT(angle_between(channels_to_quat(v.data() + c * s, mode, s), q[s]), 1e-9) << name << " " << s;
    }
}

TEST(Channels, QuaternionsShareAHemisphere) {
    std::vector<Quat> q = wandering_path(50, 2);
    const Quat ref = -q[0];
    hemisphere_continuous(q.data(), q.size(), &ref);
    EXPECT_LT(q[0].w, 0.0);
    for (std::size_t s = 1; s < q.size(); ++s) EXPECT_GE(glm::dot(q[s], q[s - 1]), 0.0);
}

TEST(Channels, AxisAngleUnwrapsASpin) {
    std::vector<Quat> q;
    for (int s = 0; s <= 60; ++s) q.push_back(axis_angle_to_quat(Vec3(0, 0, 1), s * 0.1));
    const std::vector<double> v = quats_to_channels(q, parse_rotation_mode("AXIS_ANGLE"));
    for (int s = 0; s <= 60; ++s) {
        EXPECT_NEAR(v[4 * s], s * 0.1, 1e-9);
        EXPECT_NEAR(v[4 * s + 3], 1.0, 1e-12);
    }
}

TEST(Channels, BlenderPicksTheSmallerSolution) {
    const Quat q = euler_to_quat(Vec3(170, 10, 170) * (kPi / 180), EulerOrder::XYZ);
    const Vec3 e = blender_quat_to_euler(q, EulerOrder::XYZ) * (180 / kPi);
    EXPECT_NEAR(e.x, -10, 1e-9);
    EXPECT_NEAR(e.y, 170, 1e-9);
    EXPECT_NEAR(e.z, -10, 1e-9);
    // With compat near the first solution plus two turns, that solution two turns on.
    const Vec3 c = blender_quat_to_euler(q, EulerOrder::XYZ, Vec3(170 + 720, 12, 168) * (kPi / 180)) * (180 / kPi);
    EXPECT_NEAR(c.x, 170 + 720, 1e-9);
    EXPECT_NEAR(c.y, 10, 1e-9);
    EXPECT_NEAR(c.z, 170, 1e-9);
}

TEST(Channels, BlenderLockedSolutionHasNoLastAngle) {
    const Quat q = euler_to_quat(Vec3(0.3, kPi / 2, 0.2), EulerOrder::XYZ);
    const Vec3 e = blender_quat_to_euler(q, EulerOrder::XYZ);
    EXPECT_EQ(e.z, 0.0);
    EXPECT_NEAR(e.y, kPi / 2, 1e-12);
    EXPECT_LT(angle_between(euler_to_quat(e, EulerOrder::XYZ), q), 1e-9);
}

TEST(Channels, BadInputNamesTheRow) {
    const std::vector<Quat> q{Quat(1, 0, 0, 0), Quat(0, 0, 0, 0)};
    try {
        quats_to_channels(q, parse_rotation_mode("XYZ"));
        FAIL();
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find("quats[1]"), std::string::npos) << e.what();
    }
    EXPECT_THROW(parse_rotation_mode("xyz"), InvalidArgument);
    const double zero_axis[4] = {1, 0, 0, 0};
    EXPECT_THROW(channels_to_quat(zero_axis, parse_rotation_mode("AXIS_ANGLE")), InvalidArgument);
}

TEST(Channels, SamplingPolicies) {
    EXPECT_EQ(step_frames(1, 10, 4), (std::vector<double>{1, 5, 9, 10}));
    EXPECT_EQ(sample_frames({1, 2.5, 3}, 2), (std::vector<double>{1, 1.5, 2, 2.5, 3}));
    EXPECT_EQ(whole_frame_samples({0.5, 2.25, 3}), (std::vector<double>{0.5, 1, 2, 2.25, 3}));
    EXPECT_THROW(step_frames(1, 0, 1), InvalidArgument);
    EXPECT_THROW(sample_frames({2, 1}, 1), InvalidArgument);
    // Beyond frame 2048 half a float32 step passes 1e-4 frame: a grid point on a key's float32 frame
    // gives way to it too (the conversion then refused the samples: "same float32 frame as").
    const std::vector<double> keys = {5000.0, 5000.250122, 5001.0, 100050.00390625};
    const std::vector<double> far = sample_frames(keys, 4);
    for (std::size_t i = 1; i < far.size(); ++i) ASSERT_LT(float(far[i - 1]), float(far[i])) << i;
    for (double key : keys) EXPECT_NE(std::find(far.begin(), far.end(), key), far.end());
    EXPECT_EQ(std::find(far.begin(), far.end(), 5000.25), far.end());
    const double f[3] = {0, 3, 9}, v[3] = {0, 3, 0};
    double left[6], right[6];
    segment_handles(f, v, 3, left, right);
    const double want_left[6] = {-1, -1, 2, 2, 7, 1}, want_right[6] = {1, 1, 5, 2, 11, -1};
    for (int k = 0; k < 6; ++k) {
        EXPECT_DOUBLE_EQ(left[k], want_left[k]);
        EXPECT_DOUBLE_EQ(right[k], want_right[k]);
    }
}
