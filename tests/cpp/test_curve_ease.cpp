// Tests of ease in / ease out (native/src/curve_ease.cpp), for every method: the path is unchanged,
// keys are hit at their frames, and the angular velocity at a fully eased key is zero.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "quatcurve/curve.hpp"
#include "quatcurve/quat.hpp"

using namespace quatcurve;

namespace {

const std::vector<Method> kMethods = {Method::QUAT_COMPONENTS, Method::NLERP, Method::SLERP,   Method::SQUAD,
                                      Method::CATMULL_ROM,     Method::TCB,   Method::SPLINE_C2};

Quat rv(double angle, Vec3 axis) {
    axis = glm::normalize(axis);
    return Quat(std::cos(angle / 2), std::sin(angle / 2) * axis.x, std::sin(angle / 2) * axis.y,
                std::sin(angle / 2) * axis.z);
}

const std::vector<double> kTimes = {1, 5, 6, 20, 24};
const std::vector<Quat> kKeys = {Quat(1, 0, 0, 0), rv(0.8, Vec3(1, 0, 0)), rv(1.2, Vec3(1, 1, 0)),
                                 rv(2.0, Vec3(0, 1, 1)), rv(1.0, Vec3(0.3, -1, 0.2))};

// Distance from q to the nearest of the dense samples of `c` (the path as a point set).
double off_path(const std::vector<Quat>& path, const Quat& q) {
    double best = 10;
    for (const Quat& p : path) best = std::min(best, angle_between(p, q));
    return best;
}

}  // namespace

TEST(CurveEase, PathUnchangedKeysHitStopAtFullEase) {
    std::vector<double> dense;
    for (double t = 1; t <= 24; t += 0.002) dense.push_back(t);
    std::vector<double> probe;
    for (double t = 1.05; t < 24; t += 0.37) probe.push_back(t);
    for (Method m : kMethods) {
        CurveOptions eased;
        eased.ease_in = {0.0, 1.0, 0.3, 0.0, 0.5};
        eased.ease_out = {1.0, 0.0, 0.6, 1.0, 0.0};
        const Curve plain(kTimes, kKeys, m), slow(kTimes, kKeys, m, eased);
        const auto path = plain.sample(dense);
        for (const Quat& q : slow.sample(probe)) EXPECT_LE(off_path(path, q), 2e-3) << method_name(m);
        for (std::size_t i = 0; i < kTimes.size(); ++i)
            EXPECT_LE(angle_between(slow.sample(std::vector<double>{kTimes[i]})[0], kKeys[i]), 1e-12) << method_name(m);
        // full ease out of key 0 and key 3, full ease in to key 1: zero angular velocity there
        for (double t : {1.0, 20.0})
            EXPECT_LE(glm::length(slow.angular_velocity(std::vector<double>{t})[0]), 1e-12) << method_name(m) << " " << t;
        EXPECT_LE(glm::length(slow.angular_velocity(std::vector<double>{5.0 - 1e-9})[0]), 1e-6) << method_name(m);
        // and the velocity is the derivative of the samples (chain rule through the warp)
        for (double t : {2.3, 5.5, 12.0, 21.7}) {
            const double e = 1e-6;
            const auto q = slow.sample(std::vector<double>{t - e, t + e});
            const double fd = angle_between(q[0], q[1]) / (2 * e);
            EXPECT_NEAR(glm::length(slow.angular_velocity(std::vector<double>{t})[0]), fd, 1e-5) << method_name(m) << " " << t;
        }
    }
}

TEST(CurveEase, OutOfRangeEaseIsRefused) {
    CurveOptions o;
    o.ease_in = {1.5};
    EXPECT_THROW(Curve(kTimes, kKeys, Method::SLERP, o), InvalidArgument);
    o.ease_in = {0.0, 0.5};  // neither one value nor one per key
    EXPECT_THROW(Curve(kTimes, kKeys, Method::SQUAD, o), InvalidArgument);
    CurveOptions ok;
    EXPECT_NO_THROW(set_option(ok, Method::SPLINE_C2, "ease_out", {0.25}));
    EXPECT_THROW(set_option(ok, Method::SLERP, "tension", {0.25}), InvalidArgument);
}
