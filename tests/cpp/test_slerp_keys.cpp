// Tests of slerp_keys.hpp: glTF's slerp formula, and reduce_slerp's bound, key count and bad input.
#include "quatcurve/slerp_keys.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "quatcurve/curve.hpp"
#include "quatcurve/errors.hpp"
#include "quatcurve/quat.hpp"

using namespace quatcurve;

namespace {

constexpr double kPi = 3.141592653589793238462643383279502884;

Quat about(const Vec3& axis, double angle) { return axis_angle_to_quat(axis, angle); }

// The error of the kept keys' slerp at every sample, computed the plain way (acos of the dot, sin
// weights) as glTF's Appendix C writes it: an independent check of reduce_slerp's own bound.
double spec_error(const std::vector<double>& t, const std::vector<Quat>& q, const SlerpKeys& r) {
    double worst = 0.0;
    std::size_t a = 0;
    for (std::size_t k = 0; k < t.size(); ++k) {
        while (a + 2 < r.indices.size() && r.indices[a + 1] <= k) ++a;
        const std::size_t i = r.indices[a], j = r.indices[std::min(a + 1, r.indices.size() - 1)];
        if (i == j) continue;
        const double u = (t[k] - t[i]) / (t[j] - t[i]);
        const Quat v0 = glm::normalize(q[i]), v1 = glm::normalize(q[j]);
        double d = glm::dot(v0, v1);
        const double s = d < 0 ? -1.0 : 1.0;
        d = std::min(1.0, std::abs(d));
        const double ang = std::acos(d);
        Quat v = ang < 1e-9 ? v0 * (1 - u) + v1 * (s * u)
                            : v0 * (std::sin(ang * (1 - u)) / std::sin(ang)) + v1 * (s * std::sin(ang * u) / std::sin(ang));
        worst = std::max(worst, angle_between(v, q[k]));
    }
    return worst;
}

}  // namespace

TEST(GltfSlerp, EndsMidpointAndShortestWay) {
    const Quat a = about(Vec3(0, 0, 1), 0.0), b = about(Vec3(0, 0, 1), 1.0);
    EXPECT_NEAR(angle_between(gltf_slerp(a, b, 0.0), a), 0.0, 1e-12);
    EXPECT_NEAR(angle_between(gltf_slerp(a, b, 1.0), b), 0.0, 1e-12);
    EXPECT_NEAR(angle_between(gltf_slerp(a, b, 0.25), about(Vec3(0, 0, 1), 0.25)), 0.0, 1e-12);
    // b's sign does not matter: the spec's s takes the shortest way.
    EXPECT_NEAR(angle_between(gltf_slerp(a, -b, 0.5), about(Vec3(0, 0, 1), 0.5)), 0.0, 1e-12);
    // Nearly equal keys (the formula's 0/0): the limit, unit.
    const Quat c = about(Vec3(1, 0, 0), 1e-9);
    const Quat m = gltf_slerp(a, c, 0.5);
    EXPECT_NEAR(glm::length(m), 1.0, 1e-15);
    EXPECT_NEAR(angle_between(m, about(Vec3(1, 0, 0), 0.5e-9)), 0.0, 1e-15);
    // Not unit in, unit out.
    EXPECT_NEAR(glm::length(gltf_slerp(a * 3.0, b * 0.5, 0.3)), 1.0, 1e-15);
}

TEST(GltfSlerp, RefusesBadInput) {
    EXPECT_THROW(gltf_slerp(Quat(0, 0, 0, 0), Quat(1, 0, 0, 0), 0.5), InvalidArgument);
    EXPECT_THROW(gltf_slerp(Quat(1, 0, 0, 0), Quat(NAN, 0, 0, 0), 0.5), InvalidArgument);
    EXPECT_THROW(gltf_slerp(Quat(1, 0, 0, 0), Quat(1, 0, 0, 0), INFINITY), InvalidArgument);
}

TEST(ReduceSlerp, ConstantSpeedAboutOneAxisNeedsTwoKeys) {
    std::vector<double> t;
    std::vector<Quat> q;
    for (int k = 0; k <= 100; ++k) {
        t.push_back(k);
        q.push_back(about(Vec3(0.3, -1, 0.2), 0.02 * k));  // 2 rad in all: below 180°
    }
    const SlerpKeys r = reduce_slerp(t, q, 1e-9);
    ASSERT_EQ(r.indices.size(), 2u);
    EXPECT_EQ(r.indices[0], 0u);
    EXPECT_EQ(r.indices[1], 100u);
    EXPECT_LT(r.max_error, 1e-9);
}

TEST(ReduceSlerp, StaysWithinToleranceAndSavesKeys) {
    std::mt19937_64 gen(22);
    std::normal_distribution<double> nd(0.0, 1.0);
    for (double tol : {0.1 * kPi / 180, 0.5 * kPi / 180, 2.0 * kPi / 180}) {
        // A wobbling motion: two rotations at different rates, samples at quarter frames.
        std::vector<double> t;
        std::vector<Quat> q;
        const Vec3 u(nd(gen), nd(gen), nd(gen)), v(nd(gen), nd(gen), nd(gen));
        for (int k = 0; k <= 800; ++k) {
            const double f = 0.25 * k;
            t.push_back(f);
            Quat s = about(u, 1.5 * std::sin(f / 17.0)) * about(v, 0.04 * f);
            if (k % 7 == 3) s = -s;  // sample signs do not matter
            q.push_back(s);
        }
        const SlerpKeys r = reduce_slerp(t, q, tol);
        EXPECT_LE(r.max_error, tol);
        EXPECT_LE(spec_error(t, q, r), tol + 1e-12);
        EXPECT_LT(r.indices.size(), t.size() / 4);  // far fewer keys than one per frame
        EXPECT_EQ(r.indices.front(), 0u);
        EXPECT_EQ(r.indices.back(), t.size() - 1);
        ASSERT_EQ(r.quats.size(), r.indices.size());
        for (std::size_t a = 0; a < r.quats.size(); ++a) {
            EXPECT_NEAR(glm::length(r.quats[a]), 1.0, 1e-14);
            EXPECT_NEAR(angle_between(r.quats[a], q[r.indices[a]]), 0.0, 1e-12);
            if (a) EXPECT_GE(glm::dot(r.quats[a], r.quats[a - 1]), 0.0);  // signs continuous
        }
    }
}

TEST(ReduceSlerp, ToleranceZeroKeepsEverySampleOffTheArc) {
    std::vector<double> t{0, 1, 2, 3};
    std::vector<Quat> q{about(Vec3(0, 0, 1), 0), about(Vec3(0, 0, 1), 0.1), about(Vec3(1, 0, 0), 0.1),
                        about(Vec3(0, 1, 0), 0.3)};
    EXPECT_EQ(reduce_slerp(t, q, 0.0).indices.size(), 4u);
}

TEST(ReduceSlerp, OneAndTwoSamples) {
    EXPECT_EQ(reduce_slerp({5.0}, {Quat(1, 0, 0, 0)}, 0.01).indices, std::vector<std::size_t>{0});
    EXPECT_EQ(reduce_slerp({5.0, 6.0}, {Quat(1, 0, 0, 0), Quat(0, 1, 0, 0)}, 0.01).indices,
              (std::vector<std::size_t>{0, 1}));
}

TEST(ReduceSlerp, AHalfTurnSpinKeepsKeys) {
    // 360° about z over 8 frames: slerp needs a key at least every 180°.
    std::vector<double> t;
    std::vector<Quat> q;
    for (int k = 0; k <= 80; ++k) {
        t.push_back(0.1 * k);
        q.push_back(about(Vec3(0, 0, 1), 2 * kPi * k / 80.0));
    }
    const SlerpKeys r = reduce_slerp(t, q, 1e-3);
    EXPECT_GE(r.indices.size(), 3u);
    EXPECT_LE(r.max_error, 1e-3);
    EXPECT_LE(spec_error(t, q, r), 1e-3 + 1e-12);
}

TEST(ReduceSlerp, RefusesBadInput) {
    const Quat I(1, 0, 0, 0);
    EXPECT_THROW(reduce_slerp({}, {}, 0.1), InvalidArgument);
    EXPECT_THROW(reduce_slerp({0, 1}, {I}, 0.1), InvalidArgument);
    EXPECT_THROW(reduce_slerp({0, 0}, {I, I}, 0.1), InvalidArgument);
    EXPECT_THROW(reduce_slerp({0, NAN}, {I, I}, 0.1), InvalidArgument);
    EXPECT_THROW(reduce_slerp({0, 1}, {I, Quat(0, 0, 0, 0)}, 0.1), InvalidArgument);
    EXPECT_THROW(reduce_slerp({0, 1}, {I, I}, -0.1), InvalidArgument);
    EXPECT_THROW(reduce_slerp({0, 1}, {I, I}, NAN), InvalidArgument);
    try {
        reduce_slerp({0, 1, 1}, {I, I, I}, 0.1);
        FAIL();
    } catch (const InvalidArgument& e) {
        EXPECT_STREQ(e.what(), "times[2]: not increasing");
    }
}

// Samples every 0.05 frame of a fast SQUAD through random keys: reduce_slerp holds its keys to the
// samples only, and between them their slerp leaves the curve by more than the tolerance;
// reduce_slerp_proved's keys are proved at every instant and hold at 64 points per sample interval.
TEST(ReduceSlerpProved, HoldsBetweenTheSamplesWhereReduceSlerpDoesNot) {
    std::mt19937 rng(2);
    std::normal_distribution<double> n;
    std::vector<double> frames;
    std::vector<Quat> keys;
    for (int k = 0; k < 12; ++k) {
        frames.push_back(1.0 + 6.0 * k);
        const Quat q(n(rng), n(rng), n(rng), n(rng));
        keys.push_back(q / std::sqrt(glm::dot(q, q)));
    }
    const Curve curve(frames, keys, Method::SQUAD);
    std::vector<double> t;
    for (double f = frames.front(); f < frames.back(); f += 0.05) t.push_back(f);
    t.push_back(frames.back());
    std::vector<Quat> q(t.size());
    for (std::size_t i = 0; i < t.size(); ++i) {
        double w[4];
        curve.sample(&t[i], 1, w);
        q[i] = from_wxyz(w);
    }
    const double tol = 0.1 * 3.141592653589793 / 180.0;
    auto dense_max = [&](const std::vector<double>& kt, const std::vector<Quat>& kq) {
        const Curve played(kt, kq, Method::SLERP);
        double worst = 0.0;
        for (std::size_t i = 0; i + 1 < t.size(); ++i)
            for (int s = 0; s < 64; ++s) {
                const double at = t[i] + (t[i + 1] - t[i]) * s / 64.0;
                double a[4], b[4];
                played.sample(&at, 1, a);
                curve.sample(&at, 1, b);
                worst = std::max(worst, angle_between(from_wxyz(a), from_wxyz(b)));
            }
        return worst;
    };
    const SlerpKeys plain = reduce_slerp(t, q, tol);
    std::vector<double> plain_t;
    for (std::size_t i : plain.indices) plain_t.push_back(t[i]);
    EXPECT_GT(dense_max(plain_t, plain.quats), tol) << "reduce_slerp alone held between samples: the test shows nothing";

    const ProvedSlerpKeys proved = reduce_slerp_proved(CurveMotion(curve), t, tol);
    EXPECT_TRUE(proved.proof.proven()) << proved.proof.bound;
    std::vector<double> kt;
    for (std::size_t i : proved.keys.indices) kt.push_back(proved.times[i]);
    EXPECT_EQ(kt.front(), t.front());
    EXPECT_EQ(kt.back(), t.back());
    EXPECT_LE(dense_max(kt, proved.keys.quats), std::min(proved.proof.bound, tol) + 1e-9);
    EXPECT_LT(proved.keys.indices.size(), t.size() / 4) << "keys saved";
}

TEST(ReduceSlerpProved, RefusesBadInput) {
    const Curve curve({1.0, 5.0}, {Quat(1, 0, 0, 0), Quat(0, 1, 0, 0)}, Method::SLERP);
    EXPECT_THROW(reduce_slerp_proved(CurveMotion(curve), {1.0}, 0.01), InvalidArgument);
    EXPECT_THROW(reduce_slerp_proved(CurveMotion(curve), {1.0, 5.0}, -1.0), InvalidArgument);
    EXPECT_THROW(reduce_slerp_proved(CurveMotion(curve), {5.0, 1.0}, 0.01), InvalidArgument);
}
