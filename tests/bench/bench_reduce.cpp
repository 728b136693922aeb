// Key reduction speed in C++: 100 bones × 10,000 frames of smooth motion (a random walk of keys
// every 10 frames, Catmull-Rom in rotation-vector space, dense samples), reduced at 0.1° with each
// variant. Prints seconds for the whole rig and the share of keys kept.
// `bench_reduce --smoke`: 2 bones × 200 frames (every code path, no meaningful time; CTest's
// bench.smoke.bench_reduce.cpp).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "quatcurve/quat.hpp"
#include "quatcurve/reduce.hpp"

using namespace quatcurve;

namespace {

struct Bone {
    std::vector<double> times;
    std::vector<Quat> quats;
};

Bone make_bone(std::mt19937_64& rng, std::size_t frames, std::size_t every) {
    std::normal_distribution<double> step(0.0, 12.0 * M_PI / 180.0);
    const std::size_t nkeys = frames / every + 4;
    std::vector<Vec3> keys(nkeys);
    for (std::size_t k = 1; k < nkeys; ++k)
        keys[k] = keys[k - 1] + Vec3(step(rng), step(rng), step(rng));
    Bone b;
    b.times.resize(frames);
    b.quats.resize(frames);
    Quat prev(1, 0, 0, 0);
    for (std::size_t f = 0; f < frames; ++f) {
        const std::size_t k = f / every + 1;
        const double u = double(f % every) / double(every);
        const Vec3 &p0 = keys[k - 1], &p1 = keys[k], &p2 = keys[k + 1], &p3 = keys[k + 2];
        const Vec3 v = 0.5 * ((2.0 * p1) + (-p0 + p2) * u + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * u * u +
                              (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * u * u * u);
        const double a = glm::length(v);
        Quat q = a > 0 ? axis_angle_to_quat(v / a, a) : Quat(1, 0, 0, 0);
        if (q.w * prev.w + q.x * prev.x + q.y * prev.y + q.z * prev.z < 0) q = -q;
        prev = q;
        b.times[f] = double(f);
        b.quats[f] = q;
    }
    return b;
}

}  // namespace

int main(int argc, char** argv) {
    bool smoke = false;
    for (int i = 1; i < argc; ++i) {
        if (std::string(argv[i]) != "--smoke") {
            std::fprintf(stderr, "usage: %s [--smoke]\n", argv[0]);
            return 2;
        }
        smoke = true;
    }
    std::mt19937_64 rng(7);
    const std::size_t bones = smoke ? 2 : 100, frames = smoke ? 200 : 10000;
    std::vector<Bone> rig;
    for (std::size_t b = 0; b < bones; ++b) rig.push_back(make_bone(rng, frames, 10));
    const double tol = 0.1 * M_PI / 180.0;
    std::printf("reduce_keys, %zu bones x %zu frames, tolerance 0.1 deg (target: <= 2 s per rig)\n",
                bones, frames);
    const struct {
        KeyInterpolation ipo;
        bool sync;
        const char* name;
    } variants[] = {{KeyInterpolation::LINEAR, true, "LINEAR synchronized"},
                    {KeyInterpolation::LINEAR, false, "LINEAR per-channel"},
                    {KeyInterpolation::BEZIER, true, "BEZIER synchronized"},
                    {KeyInterpolation::BEZIER, false, "BEZIER per-channel"}};
    for (const auto& v : variants) {
        std::size_t keys = 0;
        double worst = 0.0;
        const auto t0 = std::chrono::steady_clock::now();
        for (const Bone& b : rig) {
            const ReducedKeys r = reduce_keys(b.times, b.quats, tol, v.ipo, v.sync);
            keys += r.key_count();
            worst = std::max(worst, r.max_error);
        }
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf("  %-22s %6.3f s   keys kept %6.2f %%   max error %.4f deg\n", v.name, s,
                    100.0 * double(keys) / double(4 * bones * frames), worst * 180.0 / M_PI);
    }
    return 0;
}
