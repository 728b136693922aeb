// Tests of the curve engine (native/include/quatcurve/curve.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "quatcurve/curve.hpp"
#include "quatcurve/euler.hpp"
#include "quatcurve/quat.hpp"

using namespace quatcurve;

namespace {

constexpr double kPi = 3.141592653589793238462643383279502884;
constexpr double kDeg = kPi / 180.0;

const std::vector<Method> kAll = {Method::EULER, Method::QUAT_COMPONENTS, Method::NLERP,       Method::SLERP,
                                  Method::SQUAD, Method::CATMULL_ROM,     Method::TCB,         Method::SPLINE_C2};
const std::vector<Method> kQuatMethods = {Method::QUAT_COMPONENTS, Method::NLERP, Method::SLERP, Method::SQUAD,
                                          Method::CATMULL_ROM,     Method::TCB,   Method::SPLINE_C2};

Quat qmul(const Quat& a, const Quat& b) { return multiply(a, b); }
Quat qexp_rv(const Vec3& rv) {  // rotation vector → quaternion
    const double th = glm::length(rv);
    if (th == 0) return Quat(1, 0, 0, 0);
    return Quat(std::cos(th / 2), std::sin(th / 2) * rv.x / th, std::sin(th / 2) * rv.y / th, std::sin(th / 2) * rv.z / th);
}
Vec3 rotvec(const Quat& q) {  // principal rotation vector
    Quat d = q.w < 0 ? -q : q;
    const Vec3 v(d.x, d.y, d.z);
    const double n = glm::length(v);
    return n == 0 ? Vec3(0) : v * (2 * std::atan2(n, d.w) / n);
}
Quat slerp_ref(const Quat& a, Quat b, double t) {  // shortest
    if (glm::dot(a, b) < 0) b = -b;
    return qmul(a, qexp_rv(t * rotvec(qmul(conjugate(a), b))));
}

struct Keys {
    std::vector<double> t;
    std::vector<Quat> q;
    std::vector<Vec3> a;
};
// Non-uniform key times (spacing 0.5 … 3) and random keys; segments turn at most `max_angle`.
Keys random_keys(std::size_t n, unsigned seed, double max_angle = 2.0) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1), sp(0.5, 3.0);
    Keys k;
    double t = 1.5;
    Quat q = normalized_rotation(Quat(u(rng), u(rng), u(rng), u(rng)));
    Vec3 a(u(rng), u(rng), u(rng));
    for (std::size_t i = 0; i < n; ++i) {
        k.t.push_back(t);
        k.q.push_back(q);
        k.a.push_back(a);
        t += sp(rng);
        Vec3 axis(u(rng), u(rng), u(rng));
        q = qmul(q, qexp_rv(glm::normalize(axis) * (max_angle * std::fabs(u(rng)))));
        if (u(rng) < 0) q = -q;  // stored signs are arbitrary
        a += Vec3(u(rng), u(rng), u(rng)) * 0.7 * max_angle;
    }
    return k;
}

Curve make(const Keys& k, Method m, CurveOptions o = {}) {
    if (m == Method::EULER) return Curve::from_euler(k.t, k.a, EulerOrder::XYZ, m, o);
    return Curve(k.t, k.q, m, o);
}

Vec3 fd_velocity(const Curve& c, double t, double e = 1e-6) {
    const auto q = c.sample(std::vector<double>{t - e, t + e});
    return rotvec(qmul(q[1], conjugate(q[0]))) / (2 * e);
}
Vec3 velocity(const Curve& c, double t) { return c.angular_velocity(std::vector<double>{t})[0]; }

}  // namespace

TEST(Curve, MethodNamesRoundTrip) {
    ASSERT_EQ(method_names().size(), 8u);
    for (const auto& n : method_names()) EXPECT_EQ(method_name(parse_method(n)), n);
    EXPECT_THROW(parse_method("slerp"), InvalidArgument);
    EXPECT_THROW(parse_method(""), InvalidArgument);
}

TEST(Curve, PassesThroughKeys) {
    for (unsigned seed = 1; seed <= 5; ++seed) {
        const Keys k = random_keys(9, seed);
        for (Method m : kAll) {
            const Curve c = make(k, m);
            const auto q = c.sample(k.t);
            for (std::size_t i = 0; i < k.t.size(); ++i) {
                const Quat key = m == Method::EULER ? euler_to_quat(k.a[i], EulerOrder::XYZ) : k.q[i];
                EXPECT_LE(angle_between(q[i], key), 1e-9) << method_name(m) << " key " << i;
            }
            // Euler keys, every method
            const Curve e = Curve::from_euler(k.t, k.a, EulerOrder::ZXY, m);
            const auto qe = e.sample(k.t);
            for (std::size_t i = 0; i < k.t.size(); ++i)
                EXPECT_LE(angle_between(qe[i], euler_to_quat(k.a[i], EulerOrder::ZXY)), 1e-9) << method_name(m);
        }
    }
}

TEST(Curve, OutputIsSignContinuous) {
    const Keys k = random_keys(12, 7);
    for (Method m : {Method::NLERP, Method::SLERP, Method::SQUAD, Method::CATMULL_ROM, Method::TCB, Method::SPLINE_C2}) {
        const Curve c = make(k, m);
        std::vector<double> t;
        for (double x = k.t.front(); x <= k.t.back(); x += 0.01) t.push_back(x);
        const auto q = c.sample(t);
        for (std::size_t i = 1; i < q.size(); ++i) ASSERT_GT(glm::dot(q[i - 1], q[i]), 0.9) << method_name(m) << " at " << t[i];
    }
}

TEST(Curve, AngularVelocityMatchesFiniteDifferences) {
    for (unsigned seed = 11; seed <= 13; ++seed) {
        const Keys k = random_keys(8, seed);
        for (Method m : kAll) {
            CurveOptions o;
            if (m == Method::TCB) {
                o.tension = {0.3};
                o.bias = {-0.2};
                o.continuity = {0.4};
                o.ease_in = {0, 0.3, 0.0, 0.5, 0, 0, 0.2, 0};
                o.ease_out = {0.25};
            }
            const Curve c = make(k, m, o);
            for (double t = k.t.front() + 0.0137; t < k.t.back(); t += 0.173) {
                bool near_key = false;
                for (double kt : k.t) near_key = near_key || std::fabs(t - kt) < 1e-4;
                if (near_key) continue;
                const Vec3 w = velocity(c, t), f = fd_velocity(c, t);
                EXPECT_LE(glm::length(w - f), 1e-6 * (1 + glm::length(w))) << method_name(m) << " t=" << t;
            }
        }
    }
}

TEST(Curve, C1AtNonUniformKeys) {
    const Keys k = random_keys(10, 21);
    const double e = 1e-7;
    CurveOptions tcb;
    tcb.tension = {0.4};
    tcb.bias = {0.3};
    tcb.continuity = {0.0};
    for (Method m : {Method::SQUAD, Method::CATMULL_ROM, Method::TCB, Method::SPLINE_C2}) {
        const Curve c = make(k, m, m == Method::TCB ? tcb : CurveOptions{});
        for (std::size_t i = 1; i + 1 < k.t.size(); ++i) {
            const Vec3 l = velocity(c, k.t[i] - e), r = velocity(c, k.t[i]);
            EXPECT_LE(glm::length(l - r), 1e-5) << method_name(m) << " key " << i;
        }
    }
    // the check is sharp: SLERP and TCB with continuity ≠ 0 jump
    const Curve s = make(k, Method::SLERP);
    CurveOptions jumpy;
    jumpy.continuity = {0.5};
    const Curve t = make(k, Method::TCB, jumpy);
    double js = 0, jt = 0;
    for (std::size_t i = 1; i + 1 < k.t.size(); ++i) {
        js = std::max(js, glm::length(velocity(s, k.t[i] - e) - velocity(s, k.t[i])));
        jt = std::max(jt, glm::length(velocity(t, k.t[i] - e) - velocity(t, k.t[i])));
    }
    EXPECT_GT(js, 0.05);
    EXPECT_GT(jt, 0.05);
}

TEST(Curve, SplineC2HasContinuousAngularAcceleration) {
    const Keys k = random_keys(10, 31);
    const double e = 1e-5;
    auto jump = [&](const Curve& c, double t) {  // central differences at t ∓ 2e of the exact velocity
        const Vec3 al = (velocity(c, t - e) - velocity(c, t - 3 * e)) / (2 * e);
        const Vec3 ar = (velocity(c, t + 3 * e) - velocity(c, t + e)) / (2 * e);
        return glm::length(al - ar);
    };
    const Curve c2 = make(k, Method::SPLINE_C2);
    const Curve c1 = make(k, Method::SQUAD);
    double worst_c2 = 0, worst_c1 = 0;
    for (std::size_t i = 1; i + 1 < k.t.size(); ++i) {
        worst_c2 = std::max(worst_c2, jump(c2, k.t[i]));
        worst_c1 = std::max(worst_c1, jump(c1, k.t[i]));
        EXPECT_LE(glm::length(velocity(c2, k.t[i] - 1e-9) - velocity(c2, k.t[i])), 1e-6);
    }
    EXPECT_LE(worst_c2, 2e-3);
    EXPECT_GT(worst_c1, 5e-2);  // a C1 method visibly jumps in acceleration
    // also for large rotations per segment and for spins split into sub-arcs
    const Keys big = random_keys(8, 32, 3.0);
    const Curve cb = make(big, Method::SPLINE_C2);
    for (std::size_t i = 1; i + 1 < big.t.size(); ++i) EXPECT_LE(jump(cb, big.t[i]), 5e-3) << i;
    const Curve spin = Curve::from_euler({0, 1, 2.5, 3}, {Vec3(0), Vec3(0, 0, 4), Vec3(1, 0, 9), Vec3(1, 1, 9)},
                                         EulerOrder::XYZ, Method::SPLINE_C2);
    for (double t : {1.0, 2.5}) EXPECT_LE(jump(spin, t), 5e-3) << t;
}

// Keys of a random test scene (tests/blender/test_random_scenes.py, seed 413, Blender 3.4.1): Euler
// YXZ with spins, keys 0.0125 frame apart beside gaps of 1 to 4 frames and turns of 50°–170°. From
// the chord averages whole Newton steps cycle (50 steps left a jump of 0.97 of the acceleration at
// key 5); the damped steps that follow reach the C2 solution.
TEST(Curve, SplineC2ConvergesWhereWholeNewtonStepsCycle) {
    const std::vector<double> t = {-17.25, -13.25, -12.25, double(-12.2375f), double(-9.2375f), double(-6.2375f),
                                   double(-3.2375f)};
    std::vector<Vec3> angles = {{-8.490345335075938, -3.847753917001023, -8.284693021598152},
                                {-9.540115973884372, -3.5628993575493553, -8.520707435313668},
                                {-8.238147725890409, -4.704435498659068, -8.537034807128274},
                                {-7.143115083608756, -5.850486637051373, -6.419103917202591},
                                {-6.657261971421573, -4.982530569163043, -5.947323439440152},
                                {-6.253210806562513, -6.696298863934768, -5.0306172721454985},
                                {-5.315198654149182, -8.444829697916514, -2.9649993334199283}};
    for (Vec3& a : angles) a = Vec3(float(a.x), float(a.y), float(a.z));
    const Curve c = Curve::from_euler(t, angles, EulerOrder::YXZ, Method::SPLINE_C2);
    // The acceleration's jump at a key from differences of the exact velocity on either side, with
    // the jerk's share (linear in the step, large beside the short segment) taken out by Richardson's
    // extrapolation from steps e and e/2.
    auto jump = [&](double tk, double e) {
        const Vec3 al = (velocity(c, tk - e) - velocity(c, tk - 3 * e)) / (2 * e);
        const Vec3 ar = (velocity(c, tk + 3 * e) - velocity(c, tk + e)) / (2 * e);
        return std::make_pair(ar - al, glm::length(al));
    };
    for (std::size_t i = 1; i + 1 < t.size(); ++i) {
        const auto [d1, size] = jump(t[i], 1e-5);
        const Vec3 d2 = jump(t[i], 5e-6).first;
        EXPECT_LE(glm::length(2.0 * d2 - d1), 1e-3 * (1.0 + size)) << "key " << i;
        EXPECT_LE(glm::length(velocity(c, t[i] - 1e-9) - velocity(c, t[i])), 1e-6 * (1.0 + size));
    }
    for (std::size_t i = 0; i < t.size(); ++i)  // through the keys
        EXPECT_LE(angle_between(c.sample(std::vector<double>{t[i]})[0], euler_to_quat(angles[i], EulerOrder::YXZ)),
                  1e-9);
}

TEST(Curve, SlerpHasConstantSpeedAndShortestPath) {
    const Keys k = random_keys(6, 41, 3.0);
    const Curve c = make(k, Method::SLERP);
    for (std::size_t i = 0; i + 1 < k.t.size(); ++i) {
        const double h = k.t[i + 1] - k.t[i];
        const double angle = angle_between(k.q[i], k.q[i + 1]);
        for (double f : {0.0, 0.1, 0.37, 0.5, 0.93}) {
            const double t = k.t[i] + f * h;
            EXPECT_NEAR(glm::length(velocity(c, t)), angle / h, 1e-12);
            EXPECT_LE(angle_between(c.sample(std::vector<double>{t})[0], slerp_ref(k.q[i], k.q[i + 1], f)), 1e-12);
        }
    }
    // keyed path: q and a key in the opposite hemisphere → the long way (2π − angle)
    const Quat a(1, 0, 0, 0), b = -qexp_rv(Vec3(0, 0, 1.0));
    CurveOptions keyed;
    keyed.shortest_path = false;
    const Curve lng({0, 1}, {a, b}, Method::SLERP, keyed);
    const Curve sht({0, 1}, {a, b}, Method::SLERP);
    EXPECT_NEAR(glm::length(velocity(lng, 0.5)), 2 * kPi - 1.0, 1e-12);
    EXPECT_NEAR(glm::length(velocity(sht, 0.5)), 1.0, 1e-12);
    EXPECT_NEAR(angle_between(lng.sample(std::vector<double>{0.5})[0], a), kPi - 0.5, 1e-12);
    EXPECT_LE(angle_between(lng.sample(std::vector<double>{1.0})[0], b), 1e-12);
}

TEST(Curve, SquadAtUniformSpacingIsShoemake) {
    // textbook: s_i = q_i·exp(−(log(q_i⁻¹q_{i+1}) + log(q_i⁻¹q_{i−1}))/4), s_0 = q_0, s_n = q_n,
    // squad = slerp(slerp(q_i, q_{i+1}, h), slerp(s_i, s_{i+1}, h), 2h(1−h))
    Keys k = random_keys(8, 51, 1.5);
    for (std::size_t i = 0; i < k.t.size(); ++i) k.t[i] = 2.0 * static_cast<double>(i) - 3.0;
    std::vector<Quat> q = k.q, s(q.size());
    for (std::size_t i = 1; i < q.size(); ++i)
        if (glm::dot(q[i - 1], q[i]) < 0) q[i] = -q[i];
    s.front() = q.front();
    s.back() = q.back();
    for (std::size_t i = 1; i + 1 < q.size(); ++i)
        s[i] = qmul(q[i], qexp_rv(-(rotvec(qmul(conjugate(q[i]), q[i + 1])) + rotvec(qmul(conjugate(q[i]), q[i - 1]))) / 4.0));
    CurveOptions textbook;
    textbook.clamped = false;  // random axes turn back at some keys, where the clamp would act
    const Curve c = make(k, Method::SQUAD, textbook);
    for (std::size_t i = 0; i + 1 < q.size(); ++i)
        for (double h : {0.0, 0.13, 0.5, 0.71, 0.99}) {
            const Quat ref = slerp_ref(slerp_ref(q[i], q[i + 1], h), slerp_ref(s[i], s[i + 1], h), 2 * h * (1 - h));
            EXPECT_LE(angle_between(c.sample(std::vector<double>{k.t[i] + 2 * h})[0], ref), 1e-9) << i << " " << h;
        }
}

TEST(Curve, EulerIsAnglesLinear) {
    const Keys k = random_keys(6, 61, 4.0);
    for (EulerOrder order : {EulerOrder::XYZ, EulerOrder::ZYX, EulerOrder::YZX}) {
        const Curve c = Curve::from_euler(k.t, k.a, order, Method::EULER);
        for (std::size_t i = 0; i + 1 < k.t.size(); ++i)
            for (double f : {0.0, 0.25, 0.6}) {
                const Quat ref = euler_to_quat(k.a[i] + f * (k.a[i + 1] - k.a[i]), order);
                const Quat got = c.sample(std::vector<double>{k.t[i] + f * (k.t[i + 1] - k.t[i])})[0];
                EXPECT_LE(angle_between(got, ref), 1e-12);
            }
    }
    EXPECT_THROW(Curve({0, 1}, {Quat(1, 0, 0, 0), Quat(1, 0, 0, 0)}, Method::EULER), InvalidArgument);
}

TEST(Curve, QuatComponentsIsComponentLerpWithFlips) {
    // keys as stored, including a flipped sign: Blender lerps the stored components, no hemisphere fix
    const std::vector<Quat> keys = {Quat(1, 0, 0, 0), Quat(-0.8, 0.0, 0.6, 0.0), Quat(0.2, 0.9, -0.3, 0.1)};
    const std::vector<double> t = {0, 2, 3};
    const Curve c(t, keys, Method::QUAT_COMPONENTS);
    for (std::size_t i = 0; i + 1 < keys.size(); ++i)
        for (double f : {0.0, 0.3, 0.5, 0.8}) {
            const Quat p = keys[i] + f * (keys[i + 1] - keys[i]);
            const Quat ref = p / std::sqrt(glm::dot(p, p));
            const Quat got = c.sample(std::vector<double>{t[i] + f * (t[i + 1] - t[i])})[0];
            EXPECT_NEAR(got.w, ref.w, 1e-15);
            EXPECT_NEAR(got.x, ref.x, 1e-15);
            EXPECT_NEAR(got.y, ref.y, 1e-15);
            EXPECT_NEAR(got.z, ref.z, 1e-15);
        }
    // the flip takes the long way: the middle of segment 0 is far from the short slerp
    const Quat mid = c.sample(std::vector<double>{1.0})[0];
    EXPECT_GT(angle_between(mid, slerp_ref(keys[0], keys[1], 0.5)), 1.0);
    // exactly opposite stored keys pass through zero: Blender's normalize gives (0, 1, 0, 0)
    const Curve z({0, 1}, {Quat(1, 0, 0, 0), Quat(-1, 0, 0, 0)}, Method::QUAT_COMPONENTS);
    const Quat q = z.sample(std::vector<double>{0.5})[0];
    EXPECT_EQ(q.x, 1.0);
    EXPECT_EQ(q.w, 0.0);
}

TEST(Curve, FixedAngleExampleSlerpMidpoint) {
    const Curve c = Curve::from_euler({0, 10}, {Vec3(0, 90 * kDeg, 0), Vec3(90 * kDeg, 45 * kDeg, 90 * kDeg)},
                                      EulerOrder::XYZ, Method::SLERP);
    const Quat mid = c.sample(std::vector<double>{5})[0];
    EXPECT_LE(angle_between(mid, euler_to_quat(Vec3(90 * kDeg, 67.5 * kDeg, 90 * kDeg), EulerOrder::XYZ)), 1e-9);
    const Vec3 e = quat_to_euler_compat(mid, EulerOrder::XYZ, Vec3(90 * kDeg, 67.5 * kDeg, 90 * kDeg));
    EXPECT_NEAR(e.x / kDeg, 90.0, 1e-7);
    EXPECT_NEAR(e.y / kDeg, 67.5, 1e-7);
    EXPECT_NEAR(e.z / kDeg, 90.0, 1e-7);
}

TEST(Curve, AntipodalNeighbouringKeys) {
    const Quat q = qexp_rv(Vec3(0.3, -0.2, 0.5));
    for (Method m : {Method::NLERP, Method::SLERP, Method::SQUAD, Method::CATMULL_ROM, Method::TCB, Method::SPLINE_C2}) {
        // q, −q is the same rotation: the curve stays put
        const Curve c({0, 1, 2}, {q, -q, q}, m);
        for (double t : {0.25, 0.5, 1.5}) {
            EXPECT_LE(angle_between(c.sample(std::vector<double>{t})[0], q), 1e-12) << method_name(m);
            EXPECT_LE(glm::length(velocity(c, t)), 1e-12) << method_name(m);
        }
        // nearly opposite stored key: the short way
        const Quat r = -qmul(q, qexp_rv(Vec3(0, 0, 0.2)));
        const Curve d({0, 1}, {q, r}, m);
        // (NLERP is not constant speed: 1e-3 at 0.2 rad)
        EXPECT_NEAR(glm::length(velocity(d, 0.5)), 0.2, m == Method::NLERP ? 1e-3 : 1e-9) << method_name(m);
        EXPECT_LE(angle_between(d.sample(std::vector<double>{0.5})[0], qmul(q, qexp_rv(Vec3(0, 0, 0.1)))), 1e-9);
    }
    CurveOptions keyed;
    keyed.shortest_path = false;
    EXPECT_THROW(Curve({0, 1}, {q, -q}, Method::SLERP, keyed), InvalidArgument);
}

TEST(Curve, NearIdenticalKeys) {
    const Quat q = qexp_rv(Vec3(1, 2, 3) * 0.1);
    for (double eps : {1e-15, 1e-12, 1e-9}) {
        const std::vector<Quat> keys = {q, qmul(q, qexp_rv(Vec3(eps, 0, 0))), qmul(q, qexp_rv(Vec3(eps, eps, 0))),
                                        qmul(q, qexp_rv(Vec3(0.5, 0, 0)))};
        for (Method m : kQuatMethods) {
            const Curve c({0, 1, 2, 3}, keys, m);
            for (double t : {0.0, 0.5, 1.0, 1.5, 2.5}) {
                const Quat s = c.sample(std::vector<double>{t})[0];
                const Vec3 w = velocity(c, t);
                ASSERT_TRUE(std::isfinite(s.w + s.x + s.y + s.z + w.x + w.y + w.z)) << method_name(m);
                EXPECT_NEAR(glm::dot(s, s), 1.0, 1e-14);
            }
            for (std::size_t i = 0; i < keys.size(); ++i)
                EXPECT_LE(angle_between(c.sample(std::vector<double>{double(i)})[0], keys[i]), 1e-9) << method_name(m);
            // the local methods stay at the (almost) repeated key; the C2 spline may overshoot a little
            if (m != Method::SPLINE_C2)
                EXPECT_LE(angle_between(c.sample(std::vector<double>{0.5})[0], q), 1e-8) << method_name(m);
        }
    }
}

TEST(Curve, ExactlyHalfTurnSegments) {
    // 0 → 180° about Z, from quaternions and from Euler angles
    const Quat a(1, 0, 0, 0), b(0, 0, 0, 1);
    for (Method m : kQuatMethods) {
        const Curve c({0, 2}, {a, b}, m);
        const Quat mid = c.sample(std::vector<double>{1})[0];
        EXPECT_NEAR(angle_between(mid, a), kPi / 2, 1e-9) << method_name(m);
        EXPECT_NEAR(std::fabs(mid.z), std::sin(kPi / 4), 1e-9) << method_name(m);
        const Curve e = Curve::from_euler({0, 2}, {Vec3(0), Vec3(0, 0, kPi)}, EulerOrder::XYZ, m);
        const Quat me = e.sample(std::vector<double>{1})[0];
        EXPECT_LE(angle_between(me, qexp_rv(Vec3(0, 0, kPi / 2))), 1e-9) << method_name(m);  // turns +Z like the path
        EXPECT_LE(angle_between(e.sample(std::vector<double>{2})[0], b), 1e-9);
    }
    // a chain of half turns with neighbours
    const Curve c({0, 1, 2, 3}, {a, b, a, b}, Method::SPLINE_C2);
    for (double t = 0; t <= 3; t += 0.25) {
        const Vec3 w = velocity(c, t);
        EXPECT_TRUE(std::isfinite(w.x + w.y + w.z));
    }
}

TEST(Curve, OneKeyIsConstantAndTwoKeysAreSlerp) {
    const Quat q = qexp_rv(Vec3(0.4, 0.1, -0.7));
    for (Method m : kQuatMethods) {
        const Curve c({3.0}, {q}, m);
        for (double t : {-1e9, 0.0, 3.0, 7.5}) {
            EXPECT_LE(angle_between(c.sample(std::vector<double>{t})[0], q), 1e-15);
            EXPECT_EQ(glm::length(velocity(c, t)), 0.0);
        }
    }
    const Curve one = Curve::from_euler({1.0}, {Vec3(0.1, 0.2, 0.3)}, EulerOrder::XYZ, Method::EULER);
    EXPECT_LE(angle_between(one.sample(std::vector<double>{5})[0], euler_to_quat(Vec3(0.1, 0.2, 0.3), EulerOrder::XYZ)), 1e-15);
    const Quat r = qexp_rv(Vec3(-1.0, 0.5, 1.2));
    const Curve s({1, 4}, {q, r}, Method::SLERP);
    for (Method m : {Method::SQUAD, Method::CATMULL_ROM, Method::TCB, Method::SPLINE_C2}) {
        const Curve c({1, 4}, {q, r}, m);
        for (double t : {1.0, 1.7, 2.5, 3.9, 4.0}) {
            EXPECT_LE(angle_between(c.sample(std::vector<double>{t})[0], s.sample(std::vector<double>{t})[0]), 1e-12)
                << method_name(m);
            EXPECT_LE(glm::length(velocity(c, t) - velocity(s, t)), 1e-12) << method_name(m);
        }
    }
}

TEST(Curve, ConstantExtrapolationWithZeroVelocity) {
    const Keys k = random_keys(5, 71);
    for (Method m : kAll) {
        const Curve c = make(k, m);
        const auto q = c.sample(std::vector<double>{k.t.front() - 5, k.t.back() + 100, k.t.front(), k.t.back()});
        EXPECT_LE(angle_between(q[0], q[2]), 1e-15) << method_name(m);
        EXPECT_LE(angle_between(q[1], q[3]), 1e-15) << method_name(m);
        EXPECT_EQ(glm::length(velocity(c, k.t.front() - 0.1)), 0.0);
        EXPECT_EQ(glm::length(velocity(c, k.t.back() + 0.1)), 0.0);
    }
}

TEST(Curve, SpinsSurviveInEveryMethod) {
    // 0 → 720° about Z over 10 frames turns twice; 0 → 200° keeps its 200°
    for (Method m : kAll) {
        const Curve c = Curve::from_euler({0, 10}, {Vec3(0), Vec3(0, 0, 4 * kPi)}, EulerOrder::XYZ, m);
        double turned = 0;
        Quat prev = c.sample(std::vector<double>{0})[0];
        for (int i = 1; i <= 1000; ++i) {
            const Quat q = c.sample(std::vector<double>{i * 0.01})[0];
            const Vec3 step = rotvec(qmul(q, conjugate(prev)));
            turned += step.z;
            prev = q;
        }
        EXPECT_NEAR(turned, 4 * kPi, 1e-6) << method_name(m);
        if (m == Method::SLERP || m == Method::EULER)
            EXPECT_NEAR(velocity(c, 3.3).z, 4 * kPi / 10, 1e-12) << method_name(m);
        const Curve d = Curve::from_euler({0, 1}, {Vec3(0), Vec3(0, 0, 200 * kDeg)}, EulerOrder::XYZ, m);
        EXPECT_GT(velocity(d, 0.5).z, 0.0) << method_name(m);
        EXPECT_LE(angle_between(d.sample(std::vector<double>{0.5})[0], qexp_rv(Vec3(0, 0, 100 * kDeg))), 1e-6)
            << method_name(m);
    }
    // a 100°-per-key spin: every segment turns +100° about Z
    std::vector<double> t;
    std::vector<Vec3> a;
    for (int i = 0; i < 8; ++i) {
        t.push_back(i * 5.0);
        a.push_back(Vec3(0, 0, i * 100 * kDeg));
    }
    for (Method m : kAll) {
        const Curve c = Curve::from_euler(t, a, EulerOrder::XYZ, m);
        for (const Vec3& r : c.segment_rotvecs()) EXPECT_NEAR(r.z, 100 * kDeg, 1e-12);
        for (double x = 0.5; x < 35; x += 1.0) EXPECT_GT(velocity(c, x).z, 0.0) << method_name(m);
    }
    // the number of turns follows the Euler path, also off-axis: 0 → (0, 0, 720°) plus a small tilt
    for (Method m : kAll) {
        const Curve tilt = Curve::from_euler({0, 1}, {Vec3(0), Vec3(0.1, 0, 4 * kPi)}, EulerOrder::XYZ, m);
        EXPECT_NEAR(glm::length(tilt.segment_rotvecs()[0]), 4 * kPi, 0.2);
        double turned = 0;
        Quat prev = tilt.sample(std::vector<double>{0})[0];
        for (int i = 1; i <= 1000; ++i) {
            const Quat q = tilt.sample(std::vector<double>{i * 0.001})[0];
            turned += rotvec(qmul(q, conjugate(prev))).z;
            prev = q;
        }
        EXPECT_NEAR(turned, 4 * kPi, 0.05) << method_name(m);  // about Z, as the Euler path
    }
}

TEST(Curve, TcbParameters) {
    const Keys k = random_keys(6, 81);
    // tension 1 at a key stops the curve there
    CurveOptions o;
    o.tension = {0, 0, 1, 0, 0, 0};
    const Curve c = make(k, Method::TCB, o);
    EXPECT_LE(glm::length(velocity(c, k.t[2])), 1e-12);
    EXPECT_LE(glm::length(velocity(c, k.t[2] - 1e-9)), 1e-6);
    // ease out of key 1 and into key 3: zero velocity leaving 1 and arriving at 3
    CurveOptions e;
    e.ease_out = {0, 1, 0, 0, 0, 0};
    e.ease_in = {0, 0, 0, 0.5, 0, 0};
    const Curve ce = make(k, Method::TCB, e);
    EXPECT_LE(glm::length(velocity(ce, k.t[1])), 1e-12);
    EXPECT_LE(glm::length(velocity(ce, k.t[3] - 1e-9)), 1e-6);
    for (std::size_t i = 0; i < k.t.size(); ++i)
        EXPECT_LE(angle_between(ce.sample(std::vector<double>{k.t[i]})[0], k.q[i]), 1e-9);
    // bias changes the shape, defaults equal SQUAD
    const Curve tcb0 = make(k, Method::TCB), squad = make(k, Method::SQUAD);
    CurveOptions b;
    b.bias = {0.8};
    const Curve tb = make(k, Method::TCB, b);
    const double t = 0.5 * (k.t[2] + k.t[3]);
    EXPECT_LE(angle_between(tcb0.sample(std::vector<double>{t})[0], squad.sample(std::vector<double>{t})[0]), 1e-15);
    EXPECT_GT(angle_between(tb.sample(std::vector<double>{t})[0], squad.sample(std::vector<double>{t})[0]), 1e-3);
}

TEST(Curve, SortedUniformAndUnsortedTimesAgree) {
    const Keys k = random_keys(7, 91, 3.0);
    std::vector<double> uni;
    for (int i = 0; i < 2000; ++i) uni.push_back(k.t.front() - 1 + i * (k.t.back() - k.t.front() + 2) / 1999.0);
    std::vector<double> shuffled = uni;
    std::mt19937 rng(5);
    std::shuffle(shuffled.begin(), shuffled.end(), rng);
    for (Method m : kAll) {
        const Curve c = make(k, m);
        const auto a = c.sample(uni), b = c.sample(shuffled);
        for (std::size_t i = 0; i < uni.size(); ++i) {
            const std::size_t j = static_cast<std::size_t>(std::find(uni.begin(), uni.end(), shuffled[i]) - uni.begin());
            ASSERT_LE(angle_between(a[j], b[i]), 1e-12) << method_name(m);
            ASSERT_NEAR(glm::dot(a[j], a[j]), 1.0, 1e-13);
        }
    }
}

TEST(Curve, BadInput) {
    const Quat q(1, 0, 0, 0);
    const double nan = std::nan(""), inf = INFINITY;
    EXPECT_THROW(Curve(std::vector<double>{}, std::vector<Quat>{}), InvalidArgument);
    EXPECT_THROW(Curve({0, nan}, {q, q}), InvalidArgument);
    EXPECT_THROW(Curve({0, inf}, {q, q}), InvalidArgument);
    EXPECT_THROW(Curve({0, 1, 1}, {q, q, q}), InvalidArgument);
    EXPECT_THROW(Curve({0, 2, 1}, {q, q, q}), InvalidArgument);
    EXPECT_THROW(Curve({0, 1}, {q}), InvalidArgument);
    EXPECT_THROW(Curve({0, 1}, {q, Quat(0, 0, 0, 0)}), InvalidArgument);
    EXPECT_THROW(Curve({0, 1}, {q, Quat(nan, 0, 0, 1)}), InvalidArgument);
    EXPECT_THROW(Curve::from_euler({0, 1}, {Vec3(0), Vec3(nan, 0, 0)}, EulerOrder::XYZ), InvalidArgument);
    EXPECT_THROW(Curve::from_euler({0, 1}, {Vec3(0)}, EulerOrder::XYZ), InvalidArgument);
    EXPECT_THROW(Curve::from_euler({1, 0}, {Vec3(0), Vec3(0)}, EulerOrder::XYZ), InvalidArgument);
    try {
        Curve({0, 1, 0.5}, {q, q, q});
        FAIL();
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find("times[2]"), std::string::npos) << e.what();
    }
    try {
        Curve({0, 1, 2}, {q, q, Quat(0, 0, 0, 0)});
        FAIL();
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find("quats[2]"), std::string::npos) << e.what();
    }
    // options
    CurveOptions o;
    EXPECT_THROW(set_option(o, Method::SLERP, "tension", {0.1}), InvalidArgument);
    EXPECT_THROW(set_option(o, Method::TCB, "shortest_path", {0}), InvalidArgument);
    EXPECT_THROW(set_option(o, Method::TCB, "stiffness", {0.1}), InvalidArgument);
    EXPECT_THROW(set_option(o, Method::SLERP, "shortest_path", {0.5}), InvalidArgument);
    EXPECT_THROW(set_option(o, Method::TCB, "bias", {}), InvalidArgument);
    EXPECT_THROW(set_option(o, Method::TCB, "bias", {nan}), InvalidArgument);
    set_option(o, Method::TCB, "tension", {1.5});
    EXPECT_THROW(Curve({0, 1}, {q, q}, Method::TCB, o), InvalidArgument);
    CurveOptions len;
    len.bias = {0, 0, 0};
    EXPECT_THROW(Curve({0, 1}, {q, q}, Method::TCB, len), InvalidArgument);
    CurveOptions ease;
    ease.ease_in = {-0.1};
    EXPECT_THROW(Curve({0, 1}, {q, q}, Method::TCB, ease), InvalidArgument);
    CurveOptions wrong;
    wrong.tension = {0.2};
    EXPECT_THROW(Curve({0, 1}, {q, q}, Method::SQUAD, wrong), InvalidArgument);
    CurveOptions sp;
    sp.shortest_path = false;
    EXPECT_THROW(Curve({0, 1}, {q, q}, Method::NLERP, sp), InvalidArgument);
    EXPECT_THROW(Curve({0, 1}, {q, q}, static_cast<Method>(42)), InvalidArgument);
    // sample times
    const Curve c({0, 1}, {q, q});
    EXPECT_THROW(c.sample(std::vector<double>{0.5, nan}), InvalidArgument);
    EXPECT_THROW(c.angular_velocity(std::vector<double>{inf}), InvalidArgument);
    const Curve one({0}, {q});
    EXPECT_THROW(one.sample(std::vector<double>{nan}), InvalidArgument);
}

// The samplers work per run of times inside one segment, four at a time (native/src/curve_simd.hpp;
// SQUAD eight at a time where the CPU has AVX2): a time gives the same rotation, bit for bit, alone,
// inside a sorted batch (full groups, pairs of groups, the overlapping last group, runs of 1 to 9)
// and in a shuffled one; knots, ends, times outside the keys, n = 0 and a
// non-finite time anywhere in a run keep their meaning.
TEST(Curve, RunsAgreeWithSingleTimes) {
    for (const double max_angle : {0.05, 2.0, 3.1}) {
        const Keys k = random_keys(9, 123, max_angle);
        std::vector<double> t = {k.t.front() - 5.0, k.t.front(), k.t.back(), k.t.back() + 1.0};
        std::mt19937 rng(7);
        std::uniform_real_distribution<double> u(k.t.front() - 0.5, k.t.back() + 0.5);
        for (double x : k.t) {  // the knots and their neighbours
            t.push_back(x);
            t.push_back(std::nextafter(x, -HUGE_VAL));
            t.push_back(std::nextafter(x, HUGE_VAL));
        }
        for (int i = 0; i < 300; ++i) t.push_back(u(rng));
        std::vector<double> sorted = t;
        std::sort(sorted.begin(), sorted.end());
        for (Method m : {Method::SLERP, Method::SQUAD, Method::TCB, Method::SPLINE_C2}) {
            for (const bool clamped : {true, false}) {
                CurveOptions o;
                if (m == Method::SQUAD) o.clamped = clamped;
                const Curve c = make(k, m, o);
                for (const auto* times : {&t, &sorted}) {
                    const std::vector<Quat> batch = c.sample(*times);
                    for (std::size_t i = 0; i < times->size(); ++i) {
                        const Quat one = c.sample(std::vector<double>{(*times)[i]})[0];
                        ASSERT_EQ(batch[i], one) << method_name(m) << " t=" << (*times)[i];  // bit for bit
                        ASSERT_NEAR(glm::dot(batch[i], batch[i]), 1.0, 1e-14);
                    }
                }
                // runs of every length 1…9 at each position of a segment
                for (std::size_t len = 1; len <= 9; ++len) {
                    std::vector<double> run;
                    for (std::size_t i = 0; i < len; ++i) run.push_back(k.t[3] + (k.t[4] - k.t[3]) * i / 9.0);
                    const std::vector<Quat> q = c.sample(run);
                    for (std::size_t i = 0; i < len; ++i)
                        ASSERT_EQ(q[i], c.sample(std::vector<double>{run[i]})[0]) << method_name(m) << " run " << len;
                }
                // ends and outside: the end keys exactly
                const std::vector<Quat> ends = c.sample(std::vector<double>{k.t.front() - 1, k.t.back() + 1});
                EXPECT_LE(angle_between(ends[0], k.q.front()), 1e-15);
                EXPECT_LE(angle_between(ends[1], k.q.back()), 1e-15);
                c.sample(sorted.data(), 0, nullptr);  // n = 0
                for (const double bad : {std::nan(""), HUGE_VAL, -HUGE_VAL}) {
                    for (std::size_t at : {std::size_t{0}, std::size_t{2}, std::size_t{5}, std::size_t{9}}) {
                        std::vector<double> run(10);
                        for (std::size_t i = 0; i < 10; ++i) run[i] = k.t[2] + 0.05 * static_cast<double>(i);
                        run[at] = bad;
                        EXPECT_THROW(c.sample(run), InvalidArgument) << method_name(m) << " at " << at;
                    }
                }
            }
        }
    }
}
