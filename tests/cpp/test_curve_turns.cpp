// Tests of turns (curve.hpp, "Turns"): a key segment turns N extra full turns about its own axis in
// every method, from quaternion, Euler and axis-angle keys, with ease; the output stays unit and
// hits the keys; a segment without rotation borrows a neighbour's axis or is refused; bad values
// are refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "quatcurve/curve.hpp"
#include "quatcurve/errors.hpp"
#include "quatcurve/quat.hpp"

using namespace quatcurve;

namespace {

constexpr double kPi = 3.141592653589793238462643383279502884;

const std::vector<Method> kMethods = {Method::NLERP, Method::SLERP, Method::SQUAD,
                                      Method::CATMULL_ROM, Method::TCB, Method::SPLINE_C2};

Quat rv(double angle, Vec3 axis) {
    axis = glm::normalize(axis);
    return Quat(std::cos(angle / 2), std::sin(angle / 2) * axis.x, std::sin(angle / 2) * axis.y,
                std::sin(angle / 2) * axis.z);
}

Quat conj(const Quat& q) { return Quat(q.w, -q.x, -q.y, -q.z); }

const std::vector<double> kTimes = {1, 5, 15, 20};
const std::vector<Quat> kKeys = {Quat(1, 0, 0, 0), rv(0.6, Vec3(1, 0.2, 0)), rv(1.1, Vec3(0.8, 0.5, 0.1)),
                                 rv(1.5, Vec3(0.2, 1, 0.4))};

// The signed turn of `c` over [t0, t1] about the unit axis u (in the frame of the curve at t0): the
// angle 2·atan2(v·u, w) of conj(q(t0))·q(t), unwrapped along 4000 samples (the curve's samples are
// sign-continuous). Also checks that every sample is unit.
double signed_turn(const Curve& c, double t0, double t1, const Vec3& u) {
    std::vector<double> t;
    for (int k = 0; k <= 4000; ++k) t.push_back(t0 + (t1 - t0) * k / 4000.0);
    const std::vector<Quat> q = c.sample(t);
    const Quat base = conj(q[0]);
    double total = 0, prev = 0;
    for (const Quat& s : q) {
        EXPECT_NEAR(glm::length(glm::dvec4(s.w, s.x, s.y, s.z)), 1.0, 1e-12);
        const Quat p = base * s;
        const double a = 2 * std::atan2(p.x * u.x + p.y * u.y + p.z * u.z, p.w);
        double d = a - prev;
        d -= 2 * kPi * std::nearbyint(d / (2 * kPi));
        total += d;
        prev = a;
    }
    return total;
}

void expect_keys_hit(const Curve& c, const std::vector<Quat>& keys, double tol, const std::string& what) {
    const std::vector<Quat> at = c.sample(c.times());
    for (std::size_t k = 0; k < keys.size(); ++k)
        EXPECT_LT(angle_between(at[k], keys[k]), tol) << what << " key " << k;
}

}  // namespace

TEST(CurveTurns, EveryMethodTurnsTheSegmentNMoreTimes) {
    for (Method m : kMethods) {
        const Curve plain(kTimes, kKeys, m);
        const Vec3 r = plain.segment_rotvecs()[1];
        const double theta = glm::length(r);
        const Vec3 u = r / theta;
        EXPECT_NEAR(signed_turn(plain, 5, 15, u), theta, 1e-6) << method_name(m);
        for (double n : {1.0, 2.0, -1.0}) {
            CurveOptions o;
            o.turns = {0, n, 0, 0};
            const Curve c(kTimes, kKeys, m, o);
            const std::string what = std::string(method_name(m)) + " turns " + std::to_string(n);
            EXPECT_NEAR(signed_turn(c, 5, 15, u), theta + 2 * kPi * n, 1e-6) << what;
            // the other segments keep their turn
            const Vec3 r0 = plain.segment_rotvecs()[0];
            EXPECT_NEAR(signed_turn(c, 1, 5, r0 / glm::length(r0)), glm::length(r0), 1e-6) << what;
            expect_keys_hit(c, kKeys, 1e-9, what);
            const Vec3 got = c.segment_rotvecs()[1];
            EXPECT_NEAR(glm::length(got - (theta + 2 * kPi * n) * u), 0.0, 1e-12) << what;
        }
    }
}

TEST(CurveTurns, OneValueTurnsEverySegmentAndEaseKeepsTheTurns) {
    for (Method m : kMethods) {
        CurveOptions o;
        o.turns = {1};
        o.ease_in = {0, 1, 0.5, 0};
        o.ease_out = {1, 0.3, 0, 0};
        const Curve c(kTimes, kKeys, m, o);
        const Curve plain(kTimes, kKeys, m);
        for (std::size_t i = 0; i < 3; ++i) {
            const Vec3 r = plain.segment_rotvecs()[i];
            EXPECT_NEAR(signed_turn(c, kTimes[i], kTimes[i + 1], r / glm::length(r)), glm::length(r) + 2 * kPi, 1e-6)
                << method_name(m) << " segment " << i;
        }
        expect_keys_hit(c, kKeys, 1e-9, method_name(m));
    }
}

TEST(CurveTurns, SlerpIsConstantSpeedAboutTheAxis) {
    CurveOptions o;
    o.turns = {2, 0};
    const std::vector<Quat> keys = {Quat(1, 0, 0, 0), rv(0.5, Vec3(0, 0, 1))};
    const Curve c({0, 10}, keys, Method::SLERP, o);
    const std::vector<Vec3> w = c.angular_velocity(std::vector<double>{0.0, 2.5, 7.3, 9.99});
    for (const Vec3& v : w) EXPECT_NEAR(glm::length(v - Vec3(0, 0, (0.5 + 4 * kPi) / 10)), 0.0, 1e-12);
}

TEST(CurveTurns, AddToEulerAndAxisAnglePaths) {
    // 0 → 90° about Z with one more turn: 450°; 0 → 400° (a spin) with −1: 40°; 2 turns on 0 → 0.5.
    const std::vector<double> t = {0, 10, 20, 30};
    const std::vector<Vec3> angles = {Vec3(0, 0, 0), Vec3(0, 0, kPi / 2), Vec3(0.3, 0, 400 * kPi / 180),
                                      Vec3(0.3, 0.5, 400 * kPi / 180)};
    for (Method m : kMethods) {
        const Curve plain = Curve::from_euler(t, angles, EulerOrder::XYZ, m);
        CurveOptions o;
        o.turns = {1, -1, 2, 0};
        const Curve c = Curve::from_euler(t, angles, EulerOrder::XYZ, m, o);
        for (std::size_t i = 0; i < 3; ++i) {
            const Vec3 r = plain.segment_rotvecs()[i];
            const double n = o.turns[i];
            EXPECT_NEAR(signed_turn(c, t[i], t[i + 1], r / glm::length(r)), glm::length(r) + 2 * kPi * n, 1e-6)
                << method_name(m) << " Euler segment " << i;
        }
        std::vector<Quat> keys;
        for (const Vec3& a : angles) keys.push_back(euler_to_quat(a, EulerOrder::XYZ));
        expect_keys_hit(c, keys, 1e-9, method_name(m));
        EXPECT_NEAR(glm::length(plain.segment_rotvecs()[1]), 400 * kPi / 180 - kPi / 2, 0.4);  // the spin is there

        // axis-angle keys (angle, x, y, z): 0 → 90° about Z, 90° → 400° about Z
        const std::vector<double> aa = {0, 0, 0, 1, kPi / 2, 0, 0, 1, 400 * kPi / 180, 0, 0, 1, 400 * kPi / 180, 0, 1, 1};
        const Curve pa = Curve::from_axis_angle(t, aa, m);
        const Curve ca = Curve::from_axis_angle(t, aa, m, o);
        for (std::size_t i = 0; i < 3; ++i) {
            const Vec3 r = pa.segment_rotvecs()[i];
            EXPECT_NEAR(signed_turn(ca, t[i], t[i + 1], r / glm::length(r)), glm::length(r) + 2 * kPi * o.turns[i], 1e-6)
                << method_name(m) << " axis-angle segment " << i;
        }
    }
}

TEST(CurveTurns, KeyedSlerpPathAfterAnOddTurnIsUnchanged) {
    // shortest_path = false follows the keys as stored; a turn before must not change that arc.
    const std::vector<Quat> keys = {Quat(1, 0, 0, 0), rv(0.5, Vec3(0, 0, 1)), -rv(1.0, Vec3(0, 0, 1))};
    CurveOptions plain_o, o;
    plain_o.shortest_path = o.shortest_path = false;
    o.turns = {1, 0, 0};
    const Curve plain({0, 10, 20}, keys, Method::SLERP, plain_o), c({0, 10, 20}, keys, Method::SLERP, o);
    EXPECT_NEAR(glm::length(c.segment_rotvecs()[1] - plain.segment_rotvecs()[1]), 0.0, 1e-12);
    EXPECT_NEAR(std::fabs(signed_turn(c, 10, 20, Vec3(0, 0, 1))), glm::length(plain.segment_rotvecs()[1]), 1e-6);
}

TEST(CurveTurns, StillSegmentTakesTheNeighboursAxis) {
    const Quat a = rv(0.4, Vec3(1, 0, 0)), b = rv(0.9, Vec3(0, 1, 0));
    for (Method m : kMethods) {
        // still segment 1 (keys 1, 2 equal): the previous segment's axis
        {
            const std::vector<Quat> keys = {Quat(1, 0, 0, 0), a, a, b};
            CurveOptions o;
            o.turns = {0, 1, 0, 0};
            const Curve c({0, 10, 20, 30}, keys, m, o);
            EXPECT_NEAR(signed_turn(c, 10, 20, Vec3(1, 0, 0)), 2 * kPi, 1e-6) << method_name(m);
            expect_keys_hit(c, keys, 1e-9, method_name(m));
        }
        // still first segment: no previous one, the next segment's axis (rotation from a to b, frame of a)
        {
            const std::vector<Quat> keys = {a, a, b};
            CurveOptions o;
            o.turns = {-2, 0, 0};
            const Curve c({0, 10, 20}, keys, m, o);
            const Vec3 r = Curve({0, 10, 20}, keys, m).segment_rotvecs()[1];
            EXPECT_NEAR(signed_turn(c, 0, 10, r / glm::length(r)), -4 * kPi, 1e-6) << method_name(m);
            expect_keys_hit(c, keys, 1e-9, method_name(m));
        }
    }
}

TEST(CurveTurns, StillSegmentWithoutANeighbourAxisIsRefused) {
    const Quat a = rv(0.4, Vec3(1, 0, 0));
    CurveOptions o;
    o.turns = {1};
    for (Method m : kMethods) {
        try {
            Curve({0, 10}, std::vector<Quat>{a, a}, m, o);
            ADD_FAILURE() << method_name(m) << ": two equal keys with a turn were accepted";
        } catch (const InvalidArgument& e) {
            EXPECT_NE(std::string(e.what()).find("turns[0]: key 0 and key 1 are the same rotation"), std::string::npos)
                << e.what();
        }
        // q and −q are the same rotation too; three equal keys: neither neighbour turns
        CurveOptions o2;
        o2.turns = {0, 1, 0};
        EXPECT_THROW(Curve({0, 10, 20}, std::vector<Quat>{a, -a, a}, m, o2), InvalidArgument) << method_name(m);
        // no turns on the still segment: fine
        EXPECT_NO_THROW(Curve({0, 10}, std::vector<Quat>{a, a}, m));
    }
}

TEST(CurveTurns, BadValuesAreRefused) {
    auto refuses = [](std::vector<double> turns, const std::string& message) {
        CurveOptions o;
        o.turns = std::move(turns);
        try {
            Curve(kTimes, kKeys, Method::SQUAD, o);
            ADD_FAILURE() << "accepted: " << message;
        } catch (const InvalidArgument& e) {
            EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
        }
    };
    refuses({0.5}, "turns[0]: 0.500000 is not a whole number");
    refuses({0, 1, 1.25, 0}, "turns[2]: 1.250000 is not a whole number");
    refuses({0, NAN, 0, 0}, "turns[1]: not a finite number");
    refuses({INFINITY}, "turns[0]: not a finite number");
    refuses({1, 1}, "turns: expected one value or one per key (4), got 2");
    refuses({1e5}, "beyond the supported ±10000 turns");
    CurveOptions o;
    EXPECT_THROW(set_option(o, Method::SLERP, "turns", {NAN}), InvalidArgument);
    EXPECT_THROW(set_option(o, Method::EULER, "turns", {1}), InvalidArgument);
    EXPECT_THROW(set_option(o, Method::QUAT_COMPONENTS, "turns", {1}), InvalidArgument);
    o.turns = {1};
    EXPECT_THROW(Curve(kTimes, kKeys, Method::QUAT_COMPONENTS, o), InvalidArgument);
    for (Method m : kMethods) {
        const auto names = option_names(m);
        EXPECT_NE(std::find(names.begin(), names.end(), "turns"), names.end()) << method_name(m);
        CurveOptions s;
        set_option(s, m, "turns", {0, 1, -2, 0});
        EXPECT_EQ(s.turns, (std::vector<double>{0, 1, -2, 0}));
    }
}
