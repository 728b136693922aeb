// Tests of euler.hpp: Blender's semantics for the six orders, the seed's fixed-angle examples,
// gimbal lock, compatible angles, the filter, and bad input.
#include "quatcurve/euler.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

using namespace quatcurve;

namespace {

constexpr double kPi = 3.141592653589793238462643383279502884;
const EulerOrder kOrders[] = {EulerOrder::XYZ, EulerOrder::XZY, EulerOrder::YXZ,
                              EulerOrder::YZX, EulerOrder::ZXY, EulerOrder::ZYX};

double deg(double d) { return d * kPi / 180.0; }
Vec3 deg(double x, double y, double z) { return Vec3(deg(x), deg(y), deg(z)); }

struct Random {
    std::mt19937_64 gen{77};
    double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(gen); }
};

// Reference built independently of euler.cpp: the rotations about the order's axes by axis-angle
// quaternions, the first letter applied first (R = Rc·Rb·Ra for "ABC").
Quat reference_quat(const Vec3& angles, EulerOrder order) {
    const std::string name = euler_order_name(order);
    Quat q(1, 0, 0, 0);
    for (char letter : name) {
        const int axis = letter - 'X';
        Vec3 e(0.0);
        e[axis] = 1.0;
        q = multiply(axis_angle_to_quat(e, angles[axis]), q);
    }
    return q;
}

double l1(const Vec3& a, const Vec3& b) { return std::fabs(a.x - b.x) + std::fabs(a.y - b.y) + std::fabs(a.z - b.z); }

double rotation_error(const Vec3& a, const Vec3& b, EulerOrder order) {
    return angle_between(euler_to_quat(a, order), euler_to_quat(b, order));
}

template <class F>
void expect_invalid(F&& f, const std::string& fragment) {
    try {
        f();
        ADD_FAILURE() << "expected InvalidArgument containing '" << fragment << "'";
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
}

}  // namespace

// ---- the seed's worked examples --------------------------------------------------------------------

TEST(EulerSeed, EpsilonOnFirstOrLastAxisAtMinusNinetyIsTheSameOrientation) {
    // 'XYZ' at Y = −90°: X and Z turn about the same world axis, so (ε, −90°, 0) ≡ (0, −90°, ε).
    for (double eps : {1e-9, 1e-3, deg(1), deg(30)}) {
        const Vec3 a(eps, deg(-90), 0.0), b(0.0, deg(-90), eps);
        EXPECT_LT(angle_between(euler_to_quat(a, EulerOrder::XYZ), euler_to_quat(b, EulerOrder::XYZ)), 1e-15);
        const Mat3 ma = euler_to_matrix(a, EulerOrder::XYZ), mb = euler_to_matrix(b, EulerOrder::XYZ);
        for (int c = 0; c < 3; ++c)
            for (int r = 0; r < 3; ++r) EXPECT_NEAR(ma[c][r], mb[c][r], 1e-15);
        // both read back with the first angle holding the whole rotation
        const Vec3 back = quat_to_euler(euler_to_quat(b, EulerOrder::XYZ), EulerOrder::XYZ);
        EXPECT_NEAR(back.x, eps, 1e-15);
        EXPECT_EQ(back.y, -kPi / 2);
        EXPECT_EQ(back.z, 0.0);
    }
}

TEST(EulerSeed, FixedAngleSlerpMidpointIsNinetySixtySevenAndHalfNinety) {
    const Quat q1 = euler_to_quat(deg(0, 90, 0), EulerOrder::XYZ);
    const Quat q2 = euler_to_quat(deg(90, 45, 90), EulerOrder::XYZ);
    Quat delta = multiply(q2, conjugate(q1));
    if (delta.w < 0.0) delta = Quat(-delta.w, -delta.x, -delta.y, -delta.z);  // shortest path
    const Quat mid = multiply(pow(delta, 0.5), q1);
    EXPECT_NEAR(angle_between(q1, q2), deg(45), 1e-14);
    EXPECT_NEAR(angle_between(q1, mid), deg(22.5), 1e-14);
    const Vec3 e = quat_to_euler(mid, EulerOrder::XYZ);
    EXPECT_NEAR(e.x, deg(90), 1e-13);
    EXPECT_NEAR(e.y, deg(67.5), 1e-13);
    EXPECT_NEAR(e.z, deg(90), 1e-13);
    // not the average of the angles: that orientation lies 17.13° away (Blender's LINEAR Euler)
    EXPECT_NEAR(angle_between(mid, euler_to_quat(deg(45, 67.5, 45), EulerOrder::XYZ)), deg(17.126250085), 1e-9);
}

// ---- conversions -----------------------------------------------------------------------------------

TEST(EulerConvert, XYZIsRzRyRx) {
    const double a = 0.3, b = -0.4, c = 1.1;
    const Mat3 m = euler_to_matrix(Vec3(a, b, c), EulerOrder::XYZ);
    auto r = [&m](int row, int col) { return m[col][row]; };
    // closed form of Rz(c)·Ry(b)·Rx(a)
    EXPECT_NEAR(r(0, 0), std::cos(c) * std::cos(b), 1e-15);
    EXPECT_NEAR(r(1, 0), std::sin(c) * std::cos(b), 1e-15);
    EXPECT_NEAR(r(2, 0), -std::sin(b), 1e-15);
    EXPECT_NEAR(r(2, 1), std::cos(b) * std::sin(a), 1e-15);
    EXPECT_NEAR(r(2, 2), std::cos(b) * std::cos(a), 1e-15);
    EXPECT_NEAR(r(0, 1), std::cos(c) * std::sin(b) * std::sin(a) - std::sin(c) * std::cos(a), 1e-15);
    // X applied first about the fixed axes: (0, 1, 0) rotated 90° about X is (0, 0, 1), then 90°
    // about Z leaves it: XYZ (90°, 0, 90°) maps Y to Z.
    const Vec3 p = euler_to_matrix(deg(90, 0, 90), EulerOrder::XYZ) * Vec3(0, 1, 0);
    EXPECT_NEAR(p.z, 1.0, 1e-15);
}

TEST(EulerConvert, AllOrdersMatchTheAxisAngleReference) {
    Random rnd;
    for (EulerOrder order : kOrders) {
        for (int trial = 0; trial < 300; ++trial) {
            const Vec3 angles(rnd.uniform(-7, 7), rnd.uniform(-7, 7), rnd.uniform(-7, 7));
            const Quat q = euler_to_quat(angles, order);
            const Quat ref = reference_quat(angles, order);
            EXPECT_NEAR(q.w, ref.w, 1e-15);  // same sign too: continuous in the angles
            EXPECT_NEAR(q.x, ref.x, 1e-15);
            EXPECT_NEAR(q.y, ref.y, 1e-15);
            EXPECT_NEAR(q.z, ref.z, 1e-15);
            const Mat3 m = euler_to_matrix(angles, order), mq = quat_to_matrix(q);
            for (int c = 0; c < 3; ++c)
                for (int r = 0; r < 3; ++r) EXPECT_NEAR(m[c][r], mq[c][r], 2e-15);
        }
    }
}

TEST(EulerConvert, RoundTripAwayFromGimbalLock) {
    Random rnd;
    for (EulerOrder order : kOrders) {
        for (int trial = 0; trial < 1000; ++trial) {
            const Vec3 angles = [&] {
                Vec3 a(rnd.uniform(-kPi, kPi), rnd.uniform(-kPi, kPi), rnd.uniform(-kPi, kPi));
                a[euler_middle_axis(order)] = rnd.uniform(-kPi / 2 + 1e-3, kPi / 2 - 1e-3);
                return a;
            }();
            const Vec3 from_q = quat_to_euler(euler_to_quat(angles, order), order);
            const Vec3 from_m = matrix_to_euler(euler_to_matrix(angles, order), order);
            for (int n = 0; n < 3; ++n) {
                EXPECT_NEAR(from_q[n], angles[n], 1e-11) << euler_order_name(order);
                EXPECT_NEAR(from_m[n], angles[n], 1e-11) << euler_order_name(order);
            }
        }
    }
}

TEST(EulerConvert, AnyRotationRoundTripsIncludingNearAndAtGimbalLock) {
    Random rnd;
    for (EulerOrder order : kOrders) {
        const int mid = euler_middle_axis(order);
        for (int trial = 0; trial < 600; ++trial) {
            Vec3 angles(rnd.uniform(-10, 10), rnd.uniform(-10, 10), rnd.uniform(-10, 10));
            if (trial % 3 == 1) angles[mid] = (trial % 2 ? 1 : -1) * (kPi / 2 - std::pow(10.0, -rnd.uniform(1, 16)));
            if (trial % 3 == 2) angles[mid] = (trial % 2 ? 1 : -1) * kPi / 2;
            const Quat q = euler_to_quat(angles, order);
            const Vec3 e = quat_to_euler(q, order);
            EXPECT_LT(angle_between(euler_to_quat(e, order), q), 4e-15) << euler_order_name(order);
            EXPECT_LE(std::fabs(e[mid]), kPi / 2);
            for (int n = 0; n < 3; ++n) EXPECT_LE(std::fabs(e[n]), kPi);
        }
    }
}

TEST(EulerConvert, AtGimbalLockTheFirstAngleTakesTheRotation) {
    for (EulerOrder order : kOrders) {
        const std::string name = euler_order_name(order);
        const int first = name[0] - 'X', mid = name[1] - 'X', last = name[2] - 'X';
        for (double sign : {1.0, -1.0}) {
            Vec3 angles(0.0);
            angles[first] = 0.7;
            angles[mid] = sign * kPi / 2;
            angles[last] = 0.2;
            const Vec3 e = quat_to_euler(euler_to_quat(angles, order), order);
            EXPECT_EQ(e[mid], sign * kPi / 2) << name;
            EXPECT_EQ(e[last], 0.0) << name;
            EXPECT_LT(rotation_error(e, angles, order), 1e-15) << name;
            EXPECT_EQ(gimbal_distance(e, order), std::atan2(std::fabs(std::cos(kPi / 2)), 1.0));
        }
    }
}

TEST(EulerConvert, MatrixInputIsOrthonormalizedAndCheckedFirst) {
    const Vec3 angles(0.3, 0.2, -1.0);
    Mat3 m = 2.5 * euler_to_matrix(angles, EulerOrder::ZYX);
    m[0][1] += 1e-9;  // slightly non-orthonormal and scaled
    const Vec3 e = matrix_to_euler(m, EulerOrder::ZYX);
    for (int n = 0; n < 3; ++n) EXPECT_NEAR(e[n], angles[n], 1e-9);
    expect_invalid([] { matrix_to_euler(-1.0 * Mat3(1.0), EulerOrder::XYZ); }, "reflection");
    expect_invalid([] { quat_to_euler(Quat(0, 0, 0, 0), EulerOrder::XYZ); }, "zero-length quaternion");
}

// ---- compatible angles -------------------------------------------------------------------------------

TEST(EulerCompat, WholeTurnsAndTheOtherSolution) {
    const Vec3 ref(0.1, 0.2, 0.3);
    const Vec3 shifted = ref + Vec3(2 * kPi, -4 * kPi, 6 * kPi);
    const Vec3 e1 = euler_compat(shifted, EulerOrder::XYZ, ref);
    for (int n = 0; n < 3; ++n) EXPECT_NEAR(e1[n], ref[n], 1e-14);
    // the other solution (a+π, π−b, c+π) comes back to ref
    const Vec3 other(ref.x + kPi, kPi - ref.y, ref.z + kPi);
    EXPECT_LT(rotation_error(other, ref, EulerOrder::XYZ), 1e-15);
    const Vec3 e2 = euler_compat(other, EulerOrder::XYZ, ref);
    for (int n = 0; n < 3; ++n) EXPECT_NEAR(e2[n], ref[n], 1e-14);
    // and quat_to_euler_compat keeps a keyed path that leaves the canonical ranges
    const Vec3 wild(4.0, 2.5, -5.0);  // middle angle beyond π/2
    const Vec3 e3 = quat_to_euler_compat(euler_to_quat(wild, EulerOrder::YXZ), EulerOrder::YXZ, wild + Vec3(0.01, -0.02, 0.01));
    for (int n = 0; n < 3; ++n) EXPECT_NEAR(e3[n], wild[n], 1e-12);
    // ties keep the solution given
    const Vec3 same = euler_compat(ref, EulerOrder::XYZ, ref);
    for (int n = 0; n < 3; ++n) EXPECT_EQ(same[n], ref[n]);
}

TEST(EulerCompat, IsTheClosestEquivalentByBruteForce) {
    Random rnd;
    for (EulerOrder order : kOrders) {
        const int mid = euler_middle_axis(order);
        for (int trial = 0; trial < 300; ++trial) {
            const Vec3 angles(rnd.uniform(-8, 8), rnd.uniform(-8, 8), rnd.uniform(-8, 8));
            const Vec3 ref(rnd.uniform(-8, 8), rnd.uniform(-8, 8), rnd.uniform(-8, 8));
            const Vec3 out = euler_compat(angles, order, ref);
            EXPECT_LT(rotation_error(out, angles, order), 1e-13);
            // every candidate: both solutions, shifts of −3..3 turns per angle
            const std::string name = euler_order_name(order);
            const int i = name[0] - 'X', k = name[2] - 'X';
            Vec3 second = angles;
            second[i] += kPi;
            second[mid] = kPi - angles[mid];
            second[k] += kPi;
            double best = 1e300;
            for (const Vec3& base : {angles, second})
                for (int a = -3; a <= 3; ++a)
                    for (int b = -3; b <= 3; ++b)
                        for (int c = -3; c <= 3; ++c)
                            best = std::min(best, l1(base + 2 * kPi * Vec3(a, b, c), ref));
            EXPECT_NEAR(l1(out, ref), best, 1e-12) << name;
        }
    }
}

TEST(EulerCompat, AtGimbalLockSearchesTheWholeFamily) {
    for (EulerOrder order : kOrders) {
        const std::string name = euler_order_name(order);
        const int first = name[0] - 'X', mid = name[1] - 'X', last = name[2] - 'X';
        for (double sign : {1.0, -1.0}) {
            Vec3 angles(0.0), ref(0.0);
            angles[first] = 1.2;
            angles[mid] = sign * kPi / 2;
            ref[first] = 0.1;
            ref[mid] = sign * kPi / 2 + 0.05;
            ref[last] = 0.4;
            const Vec3 out = euler_compat(angles, order, ref);
            EXPECT_LT(rotation_error(out, angles, order), 1e-14) << name;
            // brute force along the family (a + t, c ± t): no member is closer
            double best = 1e300;
            for (double s : {1.0, -1.0})
                for (int n = -4000; n <= 4000; ++n) {
                    Vec3 cand = angles;
                    const double t = n * 1e-3;
                    cand[first] += t;
                    cand[last] += s * t;
                    if (rotation_error(cand, angles, order) < 1e-12) best = std::min(best, l1(cand, ref));
                }
            EXPECT_LE(l1(out, ref), best + 1e-12) << name;
        }
    }
}

// ---- the filter ----------------------------------------------------------------------------------------

TEST(EulerFilter, RemovesFlipsAndJumpsKeepsOrientations) {
    for (EulerOrder order : kOrders) {
        const int mid = euler_middle_axis(order);
        std::vector<Vec3> path, converted;
        for (int s = 0; s < 400; ++s) {
            const double t = 0.02 * s;
            Vec3 a(3.0 * t, 1.0 - 2.0 * t, 0.5 + 5.0 * t);  // several full turns
            a[mid] = 2.0 * std::sin(t);                      // beyond ±π/2: crosses gimbal lock
            path.push_back(a);
            converted.push_back(quat_to_euler(euler_to_quat(a, order), order));
        }
        std::vector<Vec3> filtered = converted;
        filtered[0] = path[0];  // the filter keeps the first triple: start where the path starts
        euler_filter(filtered.data(), filtered.size(), order);
        double max_jump_before = 0.0;
        for (std::size_t s = 0; s < path.size(); ++s) {
            EXPECT_LT(rotation_error(filtered[s], converted[s], order), 1e-13);
            for (int n = 0; n < 3; ++n) EXPECT_NEAR(filtered[s][n], path[s][n], 1e-9) << euler_order_name(order) << s;
            if (s) max_jump_before = std::max(max_jump_before, l1(converted[s], converted[s - 1]));
        }
        EXPECT_GT(max_jump_before, 3.0);  // the unfiltered conversion does jump
    }
    std::vector<Vec3> one = {Vec3(7, 8, 9)};
    euler_filter(one.data(), 1, EulerOrder::XYZ);
    EXPECT_EQ(one[0], Vec3(7, 8, 9));
    euler_filter(nullptr, 0, EulerOrder::XYZ);
}

// ---- gimbal distance, orders, bad input ------------------------------------------------------------------

TEST(EulerGimbal, DistanceOfTheMiddleAngle) {
    EXPECT_NEAR(gimbal_distance(deg(0, 90, 0), EulerOrder::XYZ), 0.0, 1e-16);
    EXPECT_NEAR(gimbal_distance(deg(0, -90, 0), EulerOrder::XYZ), 0.0, 1e-16);
    EXPECT_NEAR(gimbal_distance(deg(0, 0, 0), EulerOrder::XYZ), kPi / 2, 1e-16);
    EXPECT_NEAR(gimbal_distance(deg(0, 60, 0), EulerOrder::XYZ), deg(30), 1e-15);
    EXPECT_NEAR(gimbal_distance(deg(0, 180, 0), EulerOrder::XYZ), kPi / 2, 1e-15);
    EXPECT_NEAR(gimbal_distance(deg(0, 270 + 10, 0), EulerOrder::XYZ), deg(10), 1e-14);
    EXPECT_NEAR(gimbal_distance(deg(90, 0, 0), EulerOrder::ZXY), 0.0, 1e-16);  // middle axis X
    EXPECT_NEAR(gimbal_distance(deg(0, 90, 0), EulerOrder::ZXY), kPi / 2, 1e-16);
    EXPECT_NEAR(gimbal_distance(deg(0, 0, 89), EulerOrder::XZY), deg(1), 1e-15);
    const int expected_mid[] = {1, 2, 0, 2, 0, 1};
    for (int n = 0; n < 6; ++n) EXPECT_EQ(euler_middle_axis(kOrders[n]), expected_mid[n]);
}

TEST(EulerOrders, ParseAndName) {
    for (EulerOrder order : kOrders) EXPECT_EQ(parse_euler_order(euler_order_name(order)), order);
    expect_invalid([] { parse_euler_order("xyz"); }, "order: unknown Euler order 'xyz'");
    expect_invalid([] { parse_euler_order("XYX"); }, "expected one of XYZ, XZY, YXZ, YZX, ZXY, ZYX");
    expect_invalid([] { parse_euler_order(""); }, "unknown Euler order");
}

TEST(EulerBadInput, NonFiniteAnglesThrow) {
    const Vec3 bad(0.0, NAN, 0.0);
    expect_invalid([&] { euler_to_quat(bad, EulerOrder::XYZ); }, "angles: non-finite value nan in component y");
    expect_invalid([&] { euler_to_matrix(bad, EulerOrder::XYZ); }, "angles: non-finite");
    expect_invalid([&] { euler_compat(bad, EulerOrder::XYZ, Vec3(0.0)); }, "angles: non-finite");
    expect_invalid([&] { euler_compat(Vec3(0.0), EulerOrder::XYZ, Vec3(INFINITY, 0, 0)); }, "ref: non-finite value inf");
    expect_invalid([&] { gimbal_distance(bad, EulerOrder::XYZ); }, "angles: non-finite");
    std::vector<Vec3> seq = {Vec3(0.0), bad};
    expect_invalid([&] { euler_filter(seq.data(), seq.size(), EulerOrder::XYZ); }, "non-finite");
}
