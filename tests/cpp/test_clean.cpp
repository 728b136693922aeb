// Tests of clean.hpp: flips, the noise estimate, spikes, the smoothing within a deviation bound and
// clean_rotations, on synthetic smooth motion with white rotation noise of known σ.
#include "quatcurve/clean.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <vector>

using namespace quatcurve;

namespace {

constexpr double kPi = 3.141592653589793238462643383279502884;
constexpr double kDeg = kPi / 180.0;

// exp(ρ/2): the rotation by |ρ| about ρ.
Quat rotation(const Vec3& rho) {
    const double a = glm::length(rho);
    return a > 0.0 ? axis_angle_to_quat(rho, a) : Quat(1, 0, 0, 0);
}

std::vector<double> frames(std::size_t n) {
    std::vector<double> t(n);
    for (std::size_t i = 0; i < n; ++i) t[i] = 1.0 + static_cast<double>(i);
    return t;
}

// Smooth motion: a wandering rotation vector (periods 170–310 frames, up to 1.4°/frame) after a fixed
// base rotation.
std::vector<Quat> smooth_motion(const std::vector<double>& t) {
    const Quat base = rotation(Vec3(0.3, -1.1, 0.5));
    std::vector<Quat> q;
    for (double x : t) {
        const Vec3 rho(0.9 * std::sin(2 * kPi * x / 240), 0.6 * std::sin(2 * kPi * x / 170 + 1),
                       1.2 * std::sin(2 * kPi * x / 310 + 2));
        q.push_back(multiply(rotation(rho), base));
    }
    return q;
}

// truth_i·exp(ε_i/2), ε_i ~ N(0, (σ/√3)²·I₃): the RMS noise angle is σ.
std::vector<Quat> add_noise(const std::vector<Quat>& truth, double sigma, unsigned seed) {
    std::mt19937_64 gen(seed);
    std::normal_distribution<double> e(0.0, sigma / std::sqrt(3.0));
    std::vector<Quat> q;
    for (const Quat& x : truth) q.push_back(multiply(x, rotation(Vec3(e(gen), e(gen), e(gen)))));
    return q;
}

// Spikes of 10°–30° (or as given) about random axes: singles and runs of 2 and 3, 60–88 frames apart.
std::set<std::size_t> plant_spikes(std::vector<Quat>& q, unsigned seed, double low = 10 * kDeg,
                                   double high = 30 * kDeg) {
    std::mt19937_64 gen(seed);
    std::uniform_real_distribution<double> angle(low, high);
    std::normal_distribution<double> axis(0.0, 1.0);
    std::set<std::size_t> planted;
    for (std::size_t start = 40, k = 0; start + 40 < q.size(); start += 60 + 7 * (k % 5), ++k) {
        const std::size_t run = 1 + k % 3;
        for (std::size_t i = start; i < start + run; ++i) {
            const Vec3 a = glm::normalize(Vec3(axis(gen), axis(gen), axis(gen)));
            q[i] = multiply(q[i], rotation(angle(gen) * a));
            planted.insert(i);
        }
    }
    return planted;
}

double rms_error(const std::vector<Quat>& a, const std::vector<Quat>& b, const std::set<std::size_t>& skip = {}) {
    double sum = 0.0;
    std::size_t count = 0;
    for (std::size_t i = 0; i < a.size(); ++i)
        if (!skip.count(i)) {
            const double e = angle_between(a[i], b[i]);
            sum += e * e;
            ++count;
        }
    return std::sqrt(sum / static_cast<double>(count));
}

// The geodesic angle on the rows as returned, 4·atan2(|a − b|, |a + b|) with b in a's hemisphere.
double row_angle(const Quat& a, const Quat& b) {
    const Quat s = glm::dot(a, b) < 0.0 ? -b : b;
    return 4.0 * std::atan2(glm::length(a - s), glm::length(a + s));
}

}  // namespace

TEST(Clean, QuatFlipsKeepEveryRotation) {
    std::vector<Quat> q = smooth_motion(frames(100));
    const std::vector<Quat> before = q;
    for (std::size_t i = 10; i < 20; ++i) q[i] = -q[i];
    q[50] = -q[50];
    const std::vector<Quat> flipped = q;
    EXPECT_EQ(remove_quat_flips(q.data(), q.size()), 4u);  // pairs 9|10, 19|20, 49|50, 50|51
    for (std::size_t i = 0; i < q.size(); ++i) {
        EXPECT_LE(angle_between(q[i], flipped[i]), 1e-12) << i;
        EXPECT_EQ(q[i], before[i]) << i;
        if (i > 0) EXPECT_GE(glm::dot(q[i], q[i - 1]), 0.0) << i;
    }
    EXPECT_EQ(remove_quat_flips(q.data(), q.size()), 0u);
}

TEST(Clean, EulerFlipsKeepEveryRotation) {
    // A motion away from gimbal lock in every order tested (there the angles themselves turn fast).
    std::vector<Quat> truth;
    for (double x : frames(400))
        truth.push_back(rotation(Vec3(0.4 * std::sin(2 * kPi * x / 240), 0.3 * std::sin(2 * kPi * x / 170 + 1),
                                      3.0 * std::sin(2 * kPi * x / 310 + 2))));
    for (const char* name : {"XYZ", "YXZ", "ZYX"}) {  // Z, which turns up to 172°, not the middle axis
        const EulerOrder order = parse_euler_order(name);
        std::vector<Vec3> a;
        for (std::size_t i = 0; i < truth.size(); ++i) {
            Vec3 e = quat_to_euler(truth[i], order);  // principal angles: jumps at ±π
            if (i % 37 == 5) {                        // the other solution: (a+π, π−b, c+π) about the middle axis
                const int m = euler_middle_axis(order);
                for (int k = 0; k < 3; ++k) e[k] = k == m ? kPi - e[k] : e[k] + kPi;
            }
            if (i % 53 == 7) e.x += 2 * kPi;
            a.push_back(e);
        }
        const std::vector<Vec3> input = a;
        const std::size_t flips = remove_euler_flips(a.data(), a.size(), order);
        EXPECT_GE(flips, 2u * (400 / 53)) << name;
        for (std::size_t i = 0; i < a.size(); ++i) {
            EXPECT_LE(angle_between(euler_to_quat(a[i], order), euler_to_quat(input[i], order)), 1e-12) << name << i;
            if (i > 0) EXPECT_LT(glm::length(a[i] - a[i - 1]), 0.2) << name << " " << i;
        }
    }
}

TEST(Clean, NoiseEstimateRecoversSigma) {
    const std::vector<double> t = frames(2000);
    const std::vector<Quat> truth = smooth_motion(t);
    for (double sigma_deg : {0.5, 2.0}) {
        for (unsigned seed : {1u, 2u, 3u}) {
            std::vector<Quat> q = add_noise(truth, sigma_deg * kDeg, seed);
            const double sigma = estimate_rotation_noise(t, q);
            EXPECT_NEAR(sigma / (sigma_deg * kDeg), 1.0, 0.2) << sigma_deg << "° seed " << seed;
            plant_spikes(q, seed);  // a median ignores them
            const double spiky = estimate_rotation_noise(t, q);
            EXPECT_NEAR(spiky / (sigma_deg * kDeg), 1.0, 0.2) << sigma_deg << "° spiky";
            std::printf("[ figures  ] σ %.1f°, seed %u: estimate %.3f°, with spikes %.3f°\n", sigma_deg, seed,
                        sigma / kDeg, spiky / kDeg);
        }
    }
}

TEST(Clean, NoiseEstimateOnUnevenTimes) {
    std::vector<double> t{0.0};
    std::mt19937_64 gen(9);
    std::uniform_real_distribution<double> step(0.5, 1.5);
    for (int i = 1; i < 2000; ++i) t.push_back(t.back() + step(gen));
    const std::vector<Quat> q = add_noise(smooth_motion(t), 1.0 * kDeg, 4);
    EXPECT_NEAR(estimate_rotation_noise(t, q) / kDeg, 1.0, 0.2);
}

TEST(Clean, SpikesFoundEveryOneAndNoFalsePositives) {
    const std::vector<double> t = frames(2000);
    const std::vector<Quat> truth = smooth_motion(t);
    for (unsigned seed : {11u, 12u, 13u}) {
        std::vector<Quat> q = add_noise(truth, 0.5 * kDeg, seed);
        const double sigma = estimate_rotation_noise(t, q);
        EXPECT_TRUE(find_spikes(t, q, sigma).frames.empty()) << "clean clip, seed " << seed;
        const std::vector<Quat> clean = q;
        const std::set<std::size_t> planted = plant_spikes(q, seed);
        ASSERT_GE(planted.size(), 50u);
        const Spikes s = find_spikes(t, q, estimate_rotation_noise(t, q));
        EXPECT_EQ(std::set<std::size_t>(s.frames.begin(), s.frames.end()), planted) << "seed " << seed;
        ASSERT_EQ(s.departures.size(), s.frames.size());
        for (std::size_t k = 0; k < s.frames.size(); ++k) {
            // The departure is the spike's own angle, give or take the noise and the prediction's error.
            const double planted_angle = angle_between(q[s.frames[k]], clean[s.frames[k]]);
            EXPECT_NEAR(s.departures[k], planted_angle, 3 * kDeg) << s.frames[k];
        }
        // Replaced by the curve through the neighbours: back near the truth.
        const std::vector<Quat> r = replace_spikes(t, q, s.frames);
        for (std::size_t i : s.frames) EXPECT_LT(angle_between(r[i], truth[i]), 2 * kDeg) << i;
    }
}

TEST(Clean, SpikeOnUniformRotationIsSlerpOfNeighbours) {
    const std::vector<double> t = frames(50);
    std::vector<Quat> q;
    for (double x : t) q.push_back(rotation(Vec3(0.02, -0.05, 0.03) * x));
    q[20] = multiply(q[20], rotation(Vec3(0.0, 0.0, 15 * kDeg)));
    const Spikes s = find_spikes(t, q, 0.0);
    ASSERT_EQ(s.frames, std::vector<std::size_t>{20});
    const Quat slerp = multiply(q[19], pow(multiply(conjugate(q[19]), q[21]), 0.5));
    EXPECT_NEAR(s.departures[0], angle_between(slerp, q[20]), 1e-12);
    EXPECT_NEAR(s.departures[0], 15 * kDeg, 1e-12);
    EXPECT_LT(angle_between(replace_spikes(t, q, s.frames)[20], slerp), 1e-12);
}

TEST(Clean, SmoothingStaysWithinDeviationAndHalvesTheError) {
    const std::vector<double> t = frames(2000);
    const std::vector<Quat> truth = smooth_motion(t);
    for (double sigma_deg : {0.5, 2.0}) {
        for (bool spiky : {false, true}) {
            std::vector<Quat> q = add_noise(truth, sigma_deg * kDeg, 21);
            // Spikes well beyond the noise: 10°–30° at 0.5° (20σ–60σ), 25°–45° at 2° (12σ–22σ).
            const std::set<std::size_t> planted =
                !spiky ? std::set<std::size_t>{}
                       : sigma_deg < 1.0 ? plant_spikes(q, 21) : plant_spikes(q, 21, 25 * kDeg, 45 * kDeg);
            const CleanResult r = clean_rotations(t, q);
            ASSERT_EQ(r.q.size(), q.size());
            EXPECT_NEAR(r.deviation, 2.5 * r.noise, 1e-15);
            EXPECT_LE(r.max_deviation, r.deviation);
            const std::set<std::size_t> spikes(r.spike_frames.begin(), r.spike_frames.end());
            EXPECT_EQ(spikes, planted);
            double largest = 0.0;
            for (std::size_t i = 0; i < q.size(); ++i) {
                if (spikes.count(i)) continue;
                const double d = row_angle(r.q[i], glm::normalize(q[i]));
                EXPECT_LE(d, r.deviation) << i;
                largest = std::max(largest, d);
                if (i > 0) EXPECT_GE(glm::dot(r.q[i], r.q[i - 1]), 0.0);
            }
            EXPECT_NEAR(largest, r.max_deviation, 1e-12);
            const double before = rms_error(q, truth, planted), after = rms_error(r.q, truth, planted);
            std::printf("[ figures  ] %.1f° noise%s: noise estimate %.3f°, deviation %.3f°, spikes %zu of %zu, "
                        "pulled %zu, λ %.3g, RMS to the truth %.3f° -> %.3f°\n",
                        sigma_deg, spiky ? " + spikes" : "", r.noise / kDeg, r.deviation / kDeg,
                        r.spike_frames.size(), planted.size(), r.pulled, r.smoothness, before / kDeg, after / kDeg);
            EXPECT_LE(after, 0.5 * before) << sigma_deg << "°: RMS " << before / kDeg << "° -> " << after / kDeg << "°";
            // Every frame, spikes included, ends near the truth.
            EXPECT_LT(rms_error(r.q, truth), 0.5 * sigma_deg * kDeg);
        }
    }
}

TEST(Clean, SmoothingAtAGivenSmoothnessAndTightBound) {
    const std::vector<double> t = frames(500);
    const std::vector<Quat> q = add_noise(smooth_motion(t), 2.0 * kDeg, 5);
    SmoothOptions options;
    options.smoothness = 1e6;  // much smoother than the data: the bound does the work
    const double deviation = 1.0 * kDeg;
    const Smoothed s = smooth_rotations(t, q, deviation, options);
    EXPECT_GT(s.pulled, 100u);
    EXPECT_EQ(s.kept, 0u);  // the raised weights alone kept every frame within the bound
    EXPECT_LE(s.max_deviation, deviation);
    for (std::size_t i = 0; i < q.size(); ++i) EXPECT_LE(row_angle(s.q[i], glm::normalize(q[i])), deviation) << i;
}

TEST(Clean, NoiseFreeClipStaysWithinItsTinyDeviation) {
    const std::vector<double> t = frames(1000);
    const std::vector<Quat> truth = smooth_motion(t);
    const CleanResult r = clean_rotations(t, truth);
    EXPECT_LT(r.noise, 0.05 * kDeg);
    EXPECT_TRUE(r.spike_frames.empty());
    EXPECT_LE(r.max_deviation, r.deviation);
    for (std::size_t i = 0; i < t.size(); ++i) EXPECT_LE(row_angle(r.q[i], truth[i]), r.deviation) << i;
    // A uniform rotation has no noise at all (σ of rounding size): every frame as given, to rounding.
    std::vector<Quat> uniform;
    for (double x : t) uniform.push_back(rotation(Vec3(0.01, 0.02, -0.01) * x));
    const CleanResult u = clean_rotations(t, uniform);
    EXPECT_LT(u.noise, 1e-12);
    EXPECT_LE(u.max_deviation, u.deviation);
    for (std::size_t i = 0; i < t.size(); ++i)
        EXPECT_LE(row_angle(u.q[i], uniform[i]), std::max(u.deviation, 1e-14)) << i;
}

TEST(Clean, FlipsCountedAndRemovedByCleanRotations) {
    const std::vector<double> t = frames(300);
    std::vector<Quat> q = add_noise(smooth_motion(t), 0.5 * kDeg, 8);
    for (std::size_t i = 100; i < 300; ++i) q[i] = -q[i];
    q[30] = -q[30];
    const CleanResult r = clean_rotations(t, q);
    EXPECT_EQ(r.flips, 3u);
    EXPECT_TRUE(r.spike_frames.empty());
    for (std::size_t i = 1; i < t.size(); ++i) EXPECT_GE(glm::dot(r.q[i], r.q[i - 1]), 0.0) << i;
}

TEST(Clean, BadInputNamesTheArgument) {
    const std::vector<double> t = frames(10);
    const std::vector<Quat> q = smooth_motion(t);
    auto message = [](auto&& f) {
        try {
            f();
        } catch (const InvalidArgument& e) {
            return std::string(e.what());
        }
        return std::string("no throw");
    };
    std::vector<Quat> bad = q;
    bad[3] = Quat(0, 0, 0, 0);
    EXPECT_NE(message([&] { clean_rotations(t, bad); }).find("quats[3]"), std::string::npos);
    bad[3] = Quat(std::nan(""), 0, 0, 1);
    EXPECT_NE(message([&] { estimate_rotation_noise(t, bad); }).find("quats[3]"), std::string::npos);
    std::vector<double> unsorted = t;
    unsorted[4] = unsorted[3];
    EXPECT_NE(message([&] { clean_rotations(unsorted, q); }).find("times[4]"), std::string::npos);
    unsorted[4] = std::numeric_limits<double>::infinity();
    EXPECT_NE(message([&] { find_spikes(unsorted, q, 0.01); }).find("times[4]"), std::string::npos);
    CleanOptions options;
    options.deviation = -1.0;
    EXPECT_NE(message([&] { clean_rotations(t, q, options); }).find("deviation"), std::string::npos);
    EXPECT_NE(message([&] { smooth_rotations(t, q, -0.1); }).find("deviation"), std::string::npos);
    EXPECT_NE(message([&] { clean_rotations({1.0, 2.0}, {q[0], q[1]}); }).find("quats: 2 frames"), std::string::npos);
    EXPECT_NE(message([&] { clean_rotations(t, {q.begin(), q.begin() + 9}); }).find("times"), std::string::npos);
    EXPECT_NE(message([&] { replace_spikes(t, q, {4, 2}); }).find("frames[1]"), std::string::npos);
    EXPECT_NE(message([&] { replace_spikes(t, q, {0, 1, 2, 3, 4, 5, 6, 7, 8}); }).find("frames[0]"), std::string::npos);
    SpikeOptions spike;
    spike.max_run = 0;
    EXPECT_NE(message([&] { find_spikes(t, q, 0.01, spike); }).find("max_run"), std::string::npos);
    std::vector<Vec3> angles{Vec3(0.0), Vec3(std::nan(""), 0, 0)};
    EXPECT_NE(message([&] { remove_euler_flips(angles.data(), 2, EulerOrder::XYZ); }).find("angles[1]"),
              std::string::npos);
}
