// Tests of bake.hpp: bake_keys against the curve and sample_channel_keys it stands for, and BakeQueue's
// results, order, errors and early stop on any thread count.
#include "quatcurve/bake.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "quatcurve/errors.hpp"

using namespace quatcurve;

namespace {

// Keys every 10 frames: random quaternions (large arcs), random Euler angles over several turns, or
// random axis-angle channels, as keys_mode asks.
BakeJob random_job(const char* keys_mode, const char* output, Method method, unsigned seed, std::size_t keys = 31) {
    std::mt19937_64 gen(seed);
    std::normal_distribution<double> normal(0.0, 1.0);
    BakeJob job;
    job.keys_mode = parse_rotation_mode(keys_mode);
    job.output = parse_rotation_mode(output);
    job.method = method;
    const std::size_t c = channel_count(job.keys_mode);
    for (std::size_t k = 0; k < keys; ++k) {
        job.times.push_back(10.0 * static_cast<double>(k));
        for (std::size_t i = 0; i < c; ++i) job.values.push_back(3.0 * normal(gen));
    }
    return job;
}

Curve curve_of(const BakeJob& job) {
    const std::size_t n = job.times.size();
    if (job.keys_mode.kind == RotationMode::Kind::euler)
        return Curve::from_euler(job.times.data(), job.values.data(), n, job.keys_mode.order, job.method, job.options);
    if (job.keys_mode.kind == RotationMode::Kind::axis_angle)
        return Curve::from_axis_angle(job.times, job.values, job.method, job.options);
    return Curve(job.times.data(), job.values.data(), n, job.method, job.options);
}

std::vector<double> every_frame(double last) {
    std::vector<double> f;
    for (double t = -5.0; t <= last; t += 1.0) f.push_back(t);
    return f;
}

std::vector<BakeJob> mixed_jobs(std::size_t count) {
    const char* const keys[] = {"QUATERNION", "XYZ", "AXIS_ANGLE", "ZXY"};
    const char* const outputs[] = {"QUATERNION", "YZX", "AXIS_ANGLE", "QUATERNION"};
    const Method methods[] = {Method::SQUAD, Method::TCB, Method::SPLINE_C2, Method::CATMULL_ROM, Method::SLERP};
    std::vector<BakeJob> jobs;
    for (std::size_t i = 0; i < count; ++i)
        jobs.push_back(random_job(keys[i % 4], outputs[(i / 4) % 4], methods[i % 5], static_cast<unsigned>(i)));
    return jobs;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

}  // namespace

TEST(Bake, KeysAreTheCurvesSampledKeysAndPathRuleBreaks) {
    const std::vector<double> frames = every_frame(310.0);
    for (const BakeJob& job : mixed_jobs(16)) {
        const Curve curve = curve_of(job);
        const std::size_t c = channel_count(job.output);
        std::vector<float> expected(c * frames.size() * 2);
        ASSERT_TRUE(sample_channel_keys(curve, frames.data(), frames.size(), job.output, nullptr, 0, expected.data()));
        const BakedKeys baked = bake_keys(job, frames);
        EXPECT_EQ(baked.channels, c);
        EXPECT_TRUE(same_bits(baked.keys, expected));
        const auto breaks = curve.path_rule_breaks();
        ASSERT_EQ(baked.path_rule_breaks.size(), breaks.size());
        for (std::size_t i = 0; i < breaks.size(); ++i) {
            EXPECT_EQ(baked.path_rule_breaks[i].first, breaks[i].first);
            EXPECT_EQ(baked.path_rule_breaks[i].second.length, breaks[i].second.length);
        }
    }
}

TEST(Bake, SplineC2ThroughRandomKeysReportsPathRuleBreaks) {
    // The unclamped spline overshoots between random large-arc keys: the breaks must come through.
    std::size_t total = 0;
    for (unsigned seed = 0; seed < 8; ++seed)
        total += bake_keys(random_job("QUATERNION", "QUATERNION", Method::SPLINE_C2, seed), every_frame(300.0))
                     .path_rule_breaks.size();
    EXPECT_GT(total, 0u);
}

TEST(Bake, ReferenceRowsAreUsed) {
    BakeJob job = random_job("QUATERNION", "QUATERNION", Method::SQUAD, 3);
    const std::vector<double> frames = every_frame(300.0);
    const BakedKeys plain = bake_keys(job, frames);
    // The reference: the negative of the first sample; every channel flips sign.
    job.reference = {-plain.keys[1], -plain.keys[2 * frames.size() + 1], -plain.keys[4 * frames.size() + 1],
                     -plain.keys[6 * frames.size() + 1]};
    job.reference_rows = 1;
    const BakedKeys flipped = bake_keys(job, frames);
    for (std::size_t i = 1; i < plain.keys.size(); i += 2) ASSERT_EQ(flipped.keys[i], -plain.keys[i]) << i;
}

TEST(Bake, ErrorsNameTheCurve) {
    BakeJob job = random_job("QUATERNION", "QUATERNION", Method::SQUAD, 1);
    job.reference = {std::nan(""), 0.0, 0.0, 0.0};
    job.reference_rows = 1;
    try {
        bake_keys(job, every_frame(10.0));
        FAIL() << "a non-finite reference was taken";
    } catch (const InvalidArgument& e) {
        EXPECT_EQ(std::string(e.what()).rfind("the SQUAD curve: reference[0]", 0), 0u) << e.what();
    }
    BakeJob bad_keys = random_job("QUATERNION", "QUATERNION", Method::SQUAD, 1);
    bad_keys.times[2] = bad_keys.times[1];
    EXPECT_THROW(bake_keys(bad_keys, every_frame(10.0)), InvalidArgument);
    BakeJob short_values = random_job("XYZ", "QUATERNION", Method::SLERP, 1);
    short_values.values.pop_back();
    EXPECT_THROW(bake_keys(short_values, every_frame(10.0)), InvalidArgument);
}

TEST(BakeQueue, SameBitsInOrderOnAnyThreadCount) {
    const std::vector<double> frames = every_frame(310.0);
    const std::vector<BakeJob> jobs = mixed_jobs(24);
    std::vector<BakedKeys> expected;
    for (const BakeJob& job : jobs) expected.push_back(bake_keys(job, frames));
    for (std::size_t threads : {0u, 1u, 2u, 5u}) {
        for (std::size_t window : {1u, 3u, 100u}) {
            BakeQueue queue(frames, jobs, threads, window);
            EXPECT_EQ(queue.size(), jobs.size());
            for (std::size_t i = 0; i < jobs.size(); ++i) {
                EXPECT_EQ(queue.remaining(), jobs.size() - i);
                const BakedKeys got = queue.next();
                EXPECT_TRUE(same_bits(got.keys, expected[i].keys)) << "threads " << threads << ", job " << i;
                EXPECT_EQ(got.path_rule_breaks.size(), expected[i].path_rule_breaks.size());
            }
            EXPECT_EQ(queue.remaining(), 0u);
            EXPECT_THROW(queue.next(), InvalidArgument);
        }
    }
}

TEST(BakeQueue, AJobsErrorComesWithItAlone) {
    const std::vector<double> frames = every_frame(100.0);
    std::vector<BakeJob> jobs = mixed_jobs(6);
    jobs[2].times[3] = jobs[2].times[2];  // not increasing
    for (std::size_t threads : {0u, 1u, 3u}) {
        BakeQueue queue(frames, jobs, threads, 2);
        EXPECT_NO_THROW(queue.next());
        EXPECT_NO_THROW(queue.next());
        EXPECT_THROW(queue.next(), InvalidArgument);
        for (int i = 0; i < 3; ++i) EXPECT_NO_THROW(queue.next());
    }
}

TEST(BakeQueue, StoppingEarlyJoinsTheWorkers) {
    // Dropped with jobs running, finished and not started: the destructor must return (and leave
    // nothing running: the sanitizer build sees a thread that outlives the queue's data).
    const std::vector<double> frames = every_frame(2000.0);
    for (std::size_t threads : {1u, 2u, 4u}) {
        BakeQueue queue(frames, mixed_jobs(40), threads, 4);
        queue.next();
    }
    BakeQueue untouched(frames, mixed_jobs(8), 2, 8);
    BakeQueue empty(frames, {}, 3, 1);
    EXPECT_EQ(empty.remaining(), 0u);
    EXPECT_THROW(BakeQueue(frames, {}, 1, 0), InvalidArgument);
}
