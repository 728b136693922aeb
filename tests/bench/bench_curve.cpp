// Benchmark of the curve engine (built with the tests, run by hand: build-dir/bench_curve).
//
// Same work for every contender: 1,000 keys at unit spacing, 10 samples per segment (9,990 sorted
// times), one core, on two key sets: random unit keys (arcs up to π, most above 1.6 rad: the
// 12-term polynomials and every branch of the log) and smooth motion (keys of a slow rotation, a few
// degrees apart, as mocap keys every frame or hand keys every 10 frames). Ours: Curve::sample. GLM: a
// loop over the same sorted times calling glm::slerp per sample, or glm::squad per sample with the
// two glm::intermediate control points computed once per segment (as a user's loop would). Accuracy: the largest geodesic angle from a long-double evaluation of the same curve.
// Prints per key set a table of M samples/s and the ratios, then the targets: SLERP ≥ 10×
// glm::slerp, SQUAD ≥ 8× glm::squad, SPLINE_C2 ≥ 250 M samples/s. Timings on a shared machine are
// noisy: compare ratios within one run, and repeat.
// `bench_curve --smoke`: 20 keys, every call timed once (every code path, no meaningful time; CTest's
// bench.smoke.bench_curve.cpp).
#include <glm/gtc/quaternion.hpp>
#include <glm/gtx/quaternion.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "quatcurve/curve.hpp"
#include "quatcurve/quat.hpp"

using namespace quatcurve;

namespace {

bool smoke = false;  // --smoke: each call timed once

// ---- timing: the fastest of many single calls ------------------------------------------------------
// Every call is timed on its own (one call is 10⁴ samples: 20 µs to 3 ms) for at least 0.3 s and 30
// calls, and the fastest counts: on a shared machine a call that no other process interrupted. The
// thread's CPU time where the system has one (POSIX), so time spent waiting for a core is not counted;
// otherwise the wall clock.
double now() {
#if defined(CLOCK_THREAD_CPUTIME_ID)
    timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
#else
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
#endif
}

double seconds_per_call(const std::function<void()>& f) {
    f();  // warm up
    double best = 1e300, total = 0.0;
    for (int calls = 0; smoke ? calls < 1 : calls < 30 || total < 0.3; ++calls) {
        const double t0 = now();
        f();
        const double dt = now() - t0;
        best = std::min(best, dt);
        total += dt;
    }
    return best;
}

// ---- long-double reference quaternions ------------------------------------------------------------
using LD = long double;
struct LQ {
    LD w, x, y, z;
};
LQ lq(const Quat& q) { return {q.w, q.x, q.y, q.z}; }
LQ lmul(const LQ& a, const LQ& b) {
    return {a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z, a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
            a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x, a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}
LQ lconj(const LQ& a) { return {a.w, -a.x, -a.y, -a.z}; }
LQ lneg(const LQ& a) { return {-a.w, -a.x, -a.y, -a.z}; }
LD ldot(const LQ& a, const LQ& b) { return a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z; }
LQ lnormalize(const LQ& a) {
    const LD n = std::sqrt(ldot(a, a));
    return {a.w / n, a.x / n, a.y / n, a.z / n};
}
// exp of the pure quaternion (0, v) and log of a unit quaternion (vector part, half angle units)
LQ lexp(LD vx, LD vy, LD vz) {
    const LD n = std::sqrt(vx * vx + vy * vy + vz * vz);
    const LD k = n > 0 ? std::sin(n) / n : 1;
    return {std::cos(n), k * vx, k * vy, k * vz};
}
void llog(const LQ& q, LD& vx, LD& vy, LD& vz) {
    const LD n = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
    const LD k = n > 0 ? std::atan2(n, q.w) / n : 1;
    vx = k * q.x;
    vy = k * q.y;
    vz = k * q.z;
}
LQ lpow(const LQ& q, LD t) {
    LD x, y, z;
    llog(q, x, y, z);
    return lexp(t * x, t * y, t * z);
}
LQ lslerp(const LQ& a, const LQ& b, LD t) {  // shortest
    LQ d = lmul(lconj(a), b);
    if (d.w < 0) d = lneg(d);
    return lmul(a, lpow(d, t));
}
LQ lslerp_plain(const LQ& a, const LQ& b, LD t) {  // as stored: Shoemake's slerp inside squad
    return lmul(a, lpow(lmul(lconj(a), b), t));
}
double angle_to(const LQ& ref, const double* q) {
    const LQ d = lmul(lconj(ref), LQ{q[0], q[1], q[2], q[3]});
    const LD n = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    return static_cast<double>(2 * std::atan2(n, std::fabs(d.w)));
}
// Textbook Shoemake control point s_i = q_i·exp(−(log(q_i⁻¹q_{i+1}) + log(q_i⁻¹q_{i−1}))/4)
LQ lintermediate(const LQ& p, const LQ& q, const LQ& n) {
    LD ax, ay, az, bx, by, bz;
    llog(lmul(lconj(q), n), ax, ay, az);
    llog(lmul(lconj(q), p), bx, by, bz);
    return lmul(q, lexp(-(ax + bx) / 4, -(ay + by) / 4, -(az + bz) / 4));
}

// The GLM loops get the same x86-64-v4 and x86-64-v3 clones as the library's hot samplers (fair
// comparison).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define BENCH_HOT __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define BENCH_HOT
#endif

BENCH_HOT void glm_slerp_loop(const std::vector<double>& kt, const std::vector<Quat>& keys,
                              const std::vector<double>& times, std::vector<glm::dquat>& out) {
    const std::size_t K = kt.size();
    std::size_t j = 0;
    for (std::size_t i = 0; i < times.size(); ++i) {
        const double t = times[i];
        while (j + 2 < K && t >= kt[j + 1]) ++j;
        out[i] = glm::slerp(keys[j], keys[j + 1], t - kt[j]);
    }
}

BENCH_HOT void glm_squad_loop(const std::vector<double>& kt, const std::vector<glm::dquat>& chain,
                              const std::vector<double>& times, std::vector<glm::dquat>& out) {
    const std::size_t K = kt.size();
    std::size_t j = 0, segment = K;  // the segment whose inner control points s1, s2 are computed
    glm::dquat s1, s2;
    for (std::size_t i = 0; i < times.size(); ++i) {
        const double t = times[i];
        while (j + 2 < K && t >= kt[j + 1]) ++j;
        if (j != segment) {  // as a user's loop does: glm::intermediate once per segment
            s1 = j == 0 ? chain[0] : glm::intermediate(chain[j - 1], chain[j], chain[j + 1]);
            s2 = j + 2 >= K ? chain[j + 1] : glm::intermediate(chain[j], chain[j + 1], chain[j + 2]);
            segment = j;
        }
        out[i] = glm::squad(chain[j], chain[j + 1], s1, s2, t - kt[j]);
    }
}

// Keys of a slow smooth rotation: ρ(t) a sum of sinusoids (about 0.05 rad per unit time).
std::vector<Quat> smooth_keys(const std::vector<double>& kt) {
    std::vector<Quat> keys(kt.size());
    for (std::size_t i = 0; i < kt.size(); ++i) {
        const double t = kt[i];
        const Vec3 rho(1.5 * std::sin(0.031 * t) + 0.4 * std::sin(0.11 * t + 1.0),
                       1.2 * std::sin(0.023 * t + 2.0) + 0.3 * std::cos(0.07 * t),
                       2.0 * std::sin(0.017 * t + 0.5));
        keys[i] = quatcurve::exp(Quat(0.0, 0.5 * rho.x, 0.5 * rho.y, 0.5 * rho.z));
    }
    return keys;
}

void run_case(const char* title, const std::vector<double>& kt, const std::vector<Quat>& keys, bool all_methods) {
    const std::size_t K = kt.size(), per = 10;

    // hemisphere-continuous copy for the GLM loops (glm::squad does not fix signs)
    std::vector<glm::dquat> chain(keys.begin(), keys.end());
    for (std::size_t i = 1; i < K; ++i)
        if (glm::dot(chain[i - 1], chain[i]) < 0) chain[i] = -chain[i];
    const std::size_t N = (K - 1) * per;
    std::vector<double> times(N);
    for (std::size_t i = 0; i < N; ++i) times[i] = static_cast<double>(i) / static_cast<double>(per);
    std::vector<double> out(4 * N);

    auto msps = [&](double sec) { return static_cast<double>(N) / sec * 1e-6; };

    // ---- GLM loops -----------------------------------------------------------------------------------
    std::vector<glm::dquat> glm_out(N);
    const double t_glm_slerp = seconds_per_call([&] { glm_slerp_loop(kt, keys, times, glm_out); });
    const double t_glm_squad = seconds_per_call([&] { glm_squad_loop(kt, chain, times, glm_out); });

    // ---- ours ------------------------------------------------------------------------------------------
    // glm::squad is the textbook formula: our SQUAD against it takes the textbook tangents too
    // (clamped = false); the default clamped tangents are timed on their own line.
    CurveOptions textbook;
    textbook.clamped = false;
    auto bench_method = [&](const char* name, const CurveOptions& o = {}) {
        const Curve c(kt, keys, parse_method(name), o);
        const double sec = seconds_per_call([&] { c.sample(times.data(), N, out.data()); });
        const double build = seconds_per_call([&] { Curve tmp(kt, keys, parse_method(name), o); });
        return std::make_pair(sec, build);
    };

    std::printf("\n==== %s: %zu keys at unit spacing, %zu samples per segment (%zu sorted times), one core\n\n",
                title, K, per, N);
    std::printf("%-28s %12s %12s %10s %14s\n", "contender", "M samples/s", "ns/sample", "ratio", "prepare (ms)");
    auto line = [&](const std::string& name, double sec, const std::string& ratio, double build_ms) {
        char b[32] = "";
        if (build_ms >= 0) std::snprintf(b, sizeof b, "%.3f", build_ms);
        std::printf("%-28s %12.1f %12.2f %10s %14s\n", name.c_str(), msps(sec), sec / N * 1e9, ratio.c_str(), b);
    };
    auto ratio = [](double a, double b) {
        char s[32];
        std::snprintf(s, sizeof s, "%.1fx", a / b);
        return std::string(s);
    };

    const auto slerp = bench_method("SLERP");
    const auto squad = bench_method("SQUAD", textbook);
    const auto squad_clamped = bench_method("SQUAD");
    const auto spline = bench_method("SPLINE_C2");
    line("glm::slerp loop", t_glm_slerp, "", -1);
    line("SLERP (ours)", slerp.first, ratio(t_glm_slerp, slerp.first), slerp.second * 1e3);
    line("glm::intermediate+squad", t_glm_squad, "", -1);
    line("SQUAD (ours, textbook)", squad.first, ratio(t_glm_squad, squad.first), squad.second * 1e3);
    line("SQUAD (ours, clamped)", squad_clamped.first, ratio(t_glm_squad, squad_clamped.first),
         squad_clamped.second * 1e3);
    line("SPLINE_C2 (ours)", spline.first, "", spline.second * 1e3);
    for (const char* name : {"QUAT_COMPONENTS", "NLERP", "TCB", "CATMULL_ROM"}) {
        if (!all_methods) break;
        const auto r = bench_method(name);
        line(std::string(name) + " (ours)", r.first, "", r.second * 1e3);
    }
    if (all_methods) {
        std::vector<Vec3> angles(K);
        std::mt19937_64 rng(777);
        std::uniform_real_distribution<double> ud(-3.0, 3.0);
        for (auto& a : angles) a = Vec3(ud(rng), ud(rng), ud(rng));
        const Curve c = Curve::from_euler(kt, angles, EulerOrder::XYZ, Method::EULER);
        line("EULER (ours)", seconds_per_call([&] { c.sample(times.data(), N, out.data()); }), "", -1);
    }

    // ---- accuracy against long double ------------------------------------------------------------------
    std::printf("\naccuracy (max geodesic angle from a long-double evaluation, rad):\n");
    {
        const Curve c(kt, keys, Method::SLERP);
        c.sample(times.data(), N, out.data());
        double err = 0;
        for (std::size_t i = 0; i < N; ++i) {
            const std::size_t j = std::min<std::size_t>(static_cast<std::size_t>(times[i]), K - 2);
            err = std::max(err, angle_to(lslerp(lq(keys[j]), lq(keys[j + 1]), times[i] - kt[j]), &out[4 * i]));
        }
        double glm_err = 0;
        for (std::size_t i = 0; i < N; ++i) {
            const std::size_t j = std::min<std::size_t>(static_cast<std::size_t>(times[i]), K - 2);
            const glm::dquat q = glm::slerp(keys[j], keys[j + 1], times[i] - kt[j]);
            const double gq[4] = {q.w, q.x, q.y, q.z};
            glm_err = std::max(glm_err, angle_to(lslerp(lq(keys[j]), lq(keys[j + 1]), times[i] - kt[j]), gq));
        }
        std::printf("  SLERP      %.2e   (glm::slerp %.2e)\n", err, glm_err);
    }
    {
        const Curve c(kt, keys, Method::SQUAD, textbook);
        c.sample(times.data(), N, out.data());
        std::vector<LQ> q(K), s(K);
        q[0] = lq(keys[0]);
        for (std::size_t i = 1; i < K; ++i) {
            q[i] = lq(keys[i]);
            if (ldot(q[i - 1], q[i]) < 0) q[i] = lneg(q[i]);
        }
        s[0] = q[0];
        s[K - 1] = q[K - 1];
        for (std::size_t i = 1; i + 1 < K; ++i) s[i] = lintermediate(q[i - 1], q[i], q[i + 1]);
        double err = 0;
        for (std::size_t i = 0; i < N; ++i) {
            const std::size_t j = std::min<std::size_t>(static_cast<std::size_t>(times[i]), K - 2);
            const LD h = times[i] - kt[j];
            // Shoemake's formula with plain slerps: no hemisphere choice inside the quadrangle.
            const LQ ref =
                lslerp_plain(lslerp(q[j], q[j + 1], h), lslerp_plain(s[j], s[j + 1], h), 2 * h * (1 - h));
            err = std::max(err, angle_to(ref, &out[4 * i]));
        }
        std::printf("  SQUAD      %.2e   (vs textbook Shoemake in long double)\n", err);
    }
    {
        // The same spline (knot velocities read back through angular_velocity) evaluated in long double.
        const Curve c(kt, keys, Method::SPLINE_C2);
        c.sample(times.data(), N, out.data());
        std::vector<double> kq(4 * K), kw(3 * K);
        c.sample(kt.data(), K, kq.data());
        c.angular_velocity(kt.data(), K, kw.data());
        double err = 0;
        for (std::size_t j = 0; j + 1 < K; ++j) {
            const LQ q0 = lq(from_wxyz(&kq[4 * j])), q1 = lq(from_wxyz(&kq[4 * (j + 1)]));
            LD rx, ry, rz;
            llog(lmul(lconj(q0), q1), rx, ry, rz);
            rx *= 2, ry *= 2, rz *= 2;
            // body velocities: w_j = R(q_j)ᵀ ω_j (start of segment j), w_{j+1} likewise
            auto body = [&](const LQ& q, std::size_t k) {
                const LQ v = lmul(lmul(lconj(q), LQ{0, kw[3 * k], kw[3 * k + 1], kw[3 * k + 2]}), q);
                return v;
            };
            const LQ w0 = body(q0, j);
            LQ w1 = body(q1, j + 1);
            if (j + 2 == K) {  // last key: the velocity reported there is the end of the last segment
                w1 = body(q1, j + 1);
            }
            // b = J_r(r)⁻¹·w1 = w1 + ½ r×w1 + C r×(r×w1)
            const LD th2 = rx * rx + ry * ry + rz * rz, th = std::sqrt(th2);
            const LD C = th2 < 1e-8L ? 1.0L / 12 : (1 - 0.5L * th * std::cos(th / 2) / std::sin(th / 2)) / th2;
            const LD cx = ry * w1.z - rz * w1.y, cy = rz * w1.x - rx * w1.z, cz = rx * w1.y - ry * w1.x;
            const LD ccx = ry * cz - rz * cy, ccy = rz * cx - rx * cz, ccz = rx * cy - ry * cx;
            const LD bx = w1.x + cx / 2 + C * ccx, by = w1.y + cy / 2 + C * ccy, bz = w1.z + cz / 2 + C * ccz;
            const LD ax = w0.x, ay = w0.y, az = w0.z;  // h = 1
            for (std::size_t k = 0; k < per; ++k) {
                const std::size_t i = j * per + k;
                const LD sv = static_cast<LD>(k) / per;
                auto poly = [&](LD r, LD a, LD b) { return ((((a + b - 2 * r) * sv) + (3 * r - 2 * a - b)) * sv + a) * sv; };
                const LD px = poly(rx, ax, bx), py = poly(ry, ay, by), pz = poly(rz, az, bz);
                const LQ ref = lmul(q0, lexp(px / 2, py / 2, pz / 2));
                err = std::max(err, angle_to(ref, &out[4 * i]));
            }
        }
        std::printf("  SPLINE_C2  %.2e   (same knot velocities, long-double evaluation)\n", err);
    }

    auto verdict = [](bool met) { return met ? "met" : "NOT met"; };
    std::printf("\ntargets (%s):\n", title);
    std::printf("  SLERP      %5.1fx glm::slerp              (>= 10x: %s)\n", t_glm_slerp / slerp.first,
                verdict(t_glm_slerp / slerp.first >= 10.0));
    std::printf("  SQUAD      %5.1fx glm::squad textbook, %.1fx clamped (>= 8x: %s)\n", t_glm_squad / squad.first,
                t_glm_squad / squad_clamped.first, verdict(t_glm_squad / squad.first >= 8.0));
    std::printf("  SPLINE_C2  %5.1f M samples/s              (>= 250: %s)\n", msps(spline.first),
                verdict(msps(spline.first) >= 250.0));
}

}  // namespace

int main(int argc, char** argv) {
    for (int i = 1; i < argc; ++i) {
        if (std::string(argv[i]) != "--smoke") {
            std::fprintf(stderr, "usage: %s [--smoke]\n", argv[0]);
            return 2;
        }
        smoke = true;
    }
    const std::size_t K = smoke ? 20 : 1000;
    std::vector<double> kt(K);
    for (std::size_t i = 0; i < K; ++i) kt[i] = static_cast<double>(i);
    std::mt19937_64 rng(12345);
    std::normal_distribution<double> nd;
    std::vector<Quat> random(K);
    for (auto& q : random) q = glm::normalize(Quat(nd(rng), nd(rng), nd(rng), nd(rng)));
    std::printf("quatcurve curve benchmark\n");
    run_case("random keys (large arcs)", kt, random, true);
    run_case("smooth motion (arcs of a few degrees)", kt, smooth_keys(kt), false);
    return 0;
}
