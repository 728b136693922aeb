// Regressions found by fuzzing (tests/python/fuzz_native.py) in the orientation core: extreme but
// finite input — components near the largest double, subnormals, badly scaled matrices, angles of
// 1e266 rad — must give a finite, unit result (or throw InvalidArgument), never inf, nan or a
// non-unit quaternion.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <complex>
#include <limits>

#include "quatcurve/euler.hpp"
#include "quatcurve/quat.hpp"

using namespace quatcurve;

namespace {

constexpr double kMax = std::numeric_limits<double>::max();
constexpr double kPi = 3.141592653589793238462643383279502884;

double length(const Quat& q) { return std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z); }
double length(const Vec3& v) { return std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z); }

}  // namespace

TEST(Hardening, NormalizeComponentsNearMaxDouble) {
    // |q| overflows; q/|q| was (0, 0, 0, 0).
    const Quat n = normalized_rotation(Quat(kMax, kMax, 0.0, 0.0));
    EXPECT_NEAR(length(n), 1.0, 1e-15);
    EXPECT_NEAR(n.w, std::sqrt(0.5), 1e-15);
}

TEST(Hardening, LogOfComponentsNearMaxDouble) {
    // ln|q| was inf and the vector part 0.
    const Quat l = log(Quat(kMax, kMax, 0.0, 0.0));
    EXPECT_TRUE(std::isfinite(l.w));
    EXPECT_NEAR(l.w, std::log(kMax) + 0.5 * std::log(2.0), 1e-12);
    EXPECT_NEAR(l.x, kPi / 4.0, 1e-15);
}

TEST(Hardening, InverseOfHugeAndTinyQuaternions) {
    const Quat big = inverse(Quat(kMax, 0.0, 0.0, 0.0));
    EXPECT_TRUE(std::isfinite(big.w));
    EXPECT_NEAR(big.w * kMax, 1.0, 1e-12);  // a subnormal-range result, still right
    const Quat tiny = inverse(Quat(1e-300, 1e-300, 0.0, 0.0));
    EXPECT_NEAR(tiny.w, 0.5e300, 1e285);
    EXPECT_NEAR(tiny.x, -0.5e300, 1e285);
}

TEST(Hardening, AxisNearMaxDouble) {
    // axis/|axis| was 0, leaving (cos(a/2), 0, 0, 0), a non-unit quaternion.
    const Quat q = axis_angle_to_quat(Vec3(kMax, kMax, 0.0), 1.0);
    EXPECT_NEAR(length(q), 1.0, 1e-15);
}

TEST(Hardening, AxisOfASubnormalVectorPart) {
    // |v| of (0, -5e-324, 5e-324) rounds to 5e-324, so v/|v| had length √2.
    Vec3 axis;
    double angle = 0.0;
    quat_to_axis_angle(Quat(0.7551951280657864, 0.0, -5e-324, 5e-324), axis, angle);
    EXPECT_NEAR(length(axis), 1.0, 1e-15);
}

TEST(Hardening, BadlyScaledMatrix) {
    // Entries near 1e178: ‖m‖_F³ and the Newton iteration's inverse overflowed to nan.
    Mat3 m;
    const double rows[3][3] = {{-7.6808892265831930e+177, -2.0056231777034209e+178, 1.0792908155385849e+178},
                               {3.7997668954355075e+176, -1.1501378317683714e+178, -2.1102352318276547e+178},
                               {2.2772679184938136e+178, -6.5727636923254159e+177, 3.9923951508445395e+177}};
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) m[c][r] = rows[r][c];
    EXPECT_EQ(rotation_matrix_problem(m), "");
    const Quat q = matrix_to_quat(m);
    EXPECT_NEAR(length(q), 1.0, 1e-15);
    const Quat small = matrix_to_quat(m * 1e-178 * 1e-178);  // the same rotation, entries near 1e-178
    EXPECT_NEAR(std::fabs(q.w * small.w + q.x * small.x + q.y * small.y + q.z * small.z), 1.0, 1e-12);
}

TEST(Hardening, MatrixRepresentationsNearMaxDouble) {
    const Quat q(kMax, -kMax, 0.5 * kMax, 1.0);
    const Quat c = complex2_to_quat(quat_to_complex2(q));
    const Quat r = real4_to_quat(quat_to_real4(q));
    EXPECT_EQ(c.w, q.w);
    EXPECT_EQ(c.x, q.x);
    EXPECT_EQ(r.w, q.w);
    EXPECT_EQ(r.y, q.y);
}

TEST(Hardening, RotateHugeVectorWithFiniteImage) {
    // 90° about z: (1e308, 1e308, 0) -> (-1e308, 1e308, 0); 2·(u×P) overflowed on the way.
    const Quat q(1.0, 0.0, 0.0, 1.0);
    for (const Vec3& r : {rotate(q, Vec3(1e308, 1e308, 0.0)), rotate_sandwich(q, Vec3(1e308, 1e308, 0.0))}) {
        EXPECT_NEAR(r.x / 1e308, -1.0, 1e-15);
        EXPECT_NEAR(r.y / 1e308, 1.0, 1e-15);
    }
    const Vec3 s = rotate_sandwich(Quat(1e300, 1e300, 0.0, 0.0), Vec3(1.0, 2.0, 3.0));
    EXPECT_NEAR(length(s), length(Vec3(1.0, 2.0, 3.0)), 1e-14);
}

TEST(Hardening, EulerCompatOfAHugeAngleKeepsTheRotation) {
    // x + 2π·k cancelled 1.66e266 rad down to an unrelated angle (and, near 1.8e308, to nan).
    const Vec3 angles(7.853981633974483, 1.657498103492454e266, -6.916919041777452e-323);
    for (EulerOrder order : {EulerOrder::XYZ, EulerOrder::YXZ}) {
        for (const Vec3& ref : {Vec3(0.0), Vec3(3500.0, 769.0, -5520.0)}) {
            const Vec3 out = euler_compat(angles, order, ref);
            EXPECT_TRUE(std::isfinite(out.x) && std::isfinite(out.y) && std::isfinite(out.z));
            EXPECT_LT(angle_between(euler_to_quat(out, order), euler_to_quat(angles, order)), 1e-9);
        }
        const Vec3 edge = euler_compat(Vec3(kMax, -kMax, 1.0), order, Vec3(0.0));
        EXPECT_LT(angle_between(euler_to_quat(edge, order), euler_to_quat(Vec3(kMax, -kMax, 1.0), order)), 1e-9);
    }
}
