// Key reduction of a skeleton's rotations under one distance bound on the virtual vertices
// (skeleton.hpp: dominant_shell_budgets, reduce_skeleton).
//
// The stages:
//   1. every bone reduced at its dominant-shell budget (reduce_keys*, at the samples);
//   2. measured: each bone's own share D_j(v, s) — the displacement of each virtual vertex v of its
//      subtree at sample s with only bone j's rotation replaced by Blender's evaluation of its keys;
//   3. the budgets rescaled (α_j) under the model E(v, s) = Σ_{j on v's chain} α_j·D_j(v, s): the
//      keys of bone j modelled as K_j·α_j^(−p) (K_j its keys above the two per channel a constant
//      rotation needs), minimized subject to E ≤ distance at every (v, s) — a Lagrangian with one
//      multiplier per (v, s), updated multiplicatively, the budgets normalized each step so the
//      largest predicted E is the target;
//   4. each budget set scaled by the largest factor whose reduction passes the verification (the
//      whole skeleton posed from Blender's evaluation of every bone's keys): bracketed, then bisected;
//   5. each bone loosened on its own where the whole skeleton still passes (only its subtree posed
//      again). Stage 4 runs for the dominant-shell budgets (for one angle for all only where no
//      scale of them passes) and after one round of stages 2–3; the passing result with fewest keys
//      is kept. (One angle for all never beat the dominant shells on the shared mocap clips, and
//      the allocation starts from the best budgets whatever they were.) (A second round of 2–4 from
//      the first's result measured worse budgets on both shared mocap clips, and cost a quarter of
//      the time: the loosening of stage 5 does what it did.)
#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <map>
#include <mutex>
#include <string>
#include <thread>

#include "quatcurve/errors.hpp"
#include "quatcurve/quat.hpp"
#include "quatcurve/skeleton.hpp"
#include "skeleton_impl.hpp"

namespace quatcurve {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kKeysExponent = 0.5;     // keys ∝ tolerance^(−p): the allocation's cost model
constexpr double kTarget = 0.95;          // the allocation aims at this share of the distance
constexpr double kTightenMargin = 0.97;   // a failing scale shrinks by at least this · distance / error
constexpr int kAllocationSteps = 40;      // multiplier updates of the allocation
constexpr double kMultiplierPower = 6.0;  // λ ← λ·(E / target)^this
constexpr int kBracketSteps = 10;         // verifications to bracket the largest passing scale
constexpr int kBisectSteps = 2;           // then bisections of the bracket
constexpr int kMeasureRounds = 1;         // measurement + allocation rounds (stages 2–4)
constexpr double kMinScale = 1.0 / 16.0, kMaxScale = 64.0;  // α_j per allocation

// What every stage shares: the skeleton, the original motion and its virtual vertices.
struct Problem {
    const Skeleton& skeleton;
    double distance, shell;
    std::size_t bones, n;
    std::vector<Mat4> offsets;
    SkeletonPose original;                         // the original rotations, locations, scales
    std::vector<Mat4> pose0;                       // the original pose
    std::vector<Vec3> verts0;                      // its virtual vertices
    std::vector<std::vector<std::size_t>> subtree; // each bone and its descendants, in index order
    std::vector<std::size_t> min_keys;             // the keys a constant rotation needs (0: a kept bone)
    std::vector<char> reducible;                   // 0: the bone keeps its original rotations
};

// The Problem of `original` (checked by check_pose, named `name`).
Problem make_problem(const Skeleton& skeleton, SkeletonPose original, double distance, double shell,
                     std::vector<std::size_t> min_keys, std::vector<char> reducible, const char* name) {
    const std::size_t bones = skeleton.size(), n = original.samples;
    Problem pr{skeleton, distance, shell, bones, n, {}, std::move(original), {}, {}, {}, std::move(min_keys),
               std::move(reducible)};
    check_pose(skeleton, pr.original, name);
    pr.offsets = detail::rest_offsets(skeleton);
    pr.pose0 = pose_matrices(skeleton, pr.original);
    pr.verts0 = virtual_vertices(skeleton, pr.pose0, n, shell);
    pr.subtree.resize(bones);
    for (std::size_t b = 0; b < bones; ++b)
        for (int a = static_cast<int>(b); a >= 0; a = skeleton.parents[a]) pr.subtree[a].push_back(b);
    return pr;
}

// F-curve keys (reduce_skeleton): each bone's channels reduced by reduce_keys*, played as Blender
// evaluates them (float32).
class FCurveBones {
public:
    using Keys = ReducedKeys;
    FCurveBones(const std::vector<double>& times, const std::vector<BoneChannels>& rotations,
                KeyInterpolation interpolation, bool synchronized)
        : times_(times), rotations_(rotations), interpolation_(interpolation), synchronized_(synchronized),
          quats_(rotations.size()) {
        for (std::size_t b = 0; b < rotations.size(); ++b)
            if (rotations[b].mode.kind == RotationMode::Kind::quaternion) {
                // reduce_keys keeps the stored scale of each value: the given values, made continuous.
                quats_[b].resize(times.size());
                for (std::size_t s = 0; s < times.size(); ++s) quats_[b][s] = from_wxyz(&rotations[b].values[4 * s]);
                hemisphere_continuous(quats_[b].data(), times.size());
            }
    }
    Keys kept() const {
        ReducedKeys k;
        k.interpolation = interpolation_;
        return k;
    }
    Keys reduce(std::size_t b, double tolerance) const {
        const BoneChannels& ch = rotations_[b];
        const std::size_t n = times_.size();
        switch (ch.mode.kind) {
            case RotationMode::Kind::quaternion:
                return reduce_keys(times_, quats_[b], tolerance, interpolation_, synchronized_);
            case RotationMode::Kind::euler: {
                std::vector<Vec3> a(n);
                for (std::size_t s = 0; s < n; ++s)
                    a[s] = Vec3(ch.values[3 * s], ch.values[3 * s + 1], ch.values[3 * s + 2]);
                return reduce_keys_euler(times_, a, ch.mode.order, tolerance, interpolation_, synchronized_);
            }
            case RotationMode::Kind::axis_angle: {
                std::vector<Vec4> a(n);
                for (std::size_t s = 0; s < n; ++s)
                    a[s] = Vec4(ch.values[4 * s], ch.values[4 * s + 1], ch.values[4 * s + 2], ch.values[4 * s + 3]);
                return reduce_keys_axis_angle(times_, a, tolerance, interpolation_, synchronized_);
            }
        }
        throw InvalidArgument("rotations: unknown rotation mode");
    }
    // The rotations Blender builds from its evaluation (float32) of the keys at every sample.
    std::vector<Quat> evaluate(std::size_t b, const Keys& keys) const {
        const std::size_t c = keys.channels.size(), n = times_.size();
        std::vector<double> rows(n * c), column;
        for (std::size_t k = 0; k < c; ++k) {
            blender_evaluate_sorted(keys.channels[k], keys.interpolation, times_, column);
            for (std::size_t s = 0; s < n; ++s) rows[s * c + k] = column[s];
        }
        std::vector<Quat> out(n);
        for (std::size_t s = 0; s < n; ++s) out[s] = channels_to_quat(rows.data() + s * c, rotations_[b].mode, s);
        return out;
    }

private:
    const std::vector<double>& times_;
    const std::vector<BoneChannels>& rotations_;
    KeyInterpolation interpolation_;
    bool synchronized_;
    std::vector<std::vector<Quat>> quats_;  // QUATERNION bones: hemisphere-continuous samples
};

// Slerp keys (reduce_skeleton_slerp): each bone's keys proved against its reference at every
// instant (reduce_slerp_proved) or held at its samples (reduce_slerp), played as glTF plays them.
class SlerpBones {
public:
    using Keys = ProvedSlerpKeys;
    SlerpBones(const std::vector<double>& times, const std::vector<SlerpBone>& bones) : times_(times), bones_(bones) {}
    Keys kept() const { return ProvedSlerpKeys{}; }
    Keys reduce(std::size_t b, double tolerance) const {
        const SlerpBone& bone = bones_[b];
        if (bone.reference)
            return reduce_slerp_proved(*bone.reference, bone.times, tolerance, bone.cyclic, bone.file_unit, bone.excluded);
        ProvedSlerpKeys out;
        out.times = bone.times;
        out.keys = reduce_slerp(bone.times, bone.samples, tolerance, bone.cyclic);
        out.proof.bound = out.proof.max_evaluated = out.keys.max_error;
        out.proof.unproven.emplace_back(bone.times.front(), bone.times.back());  // held at the samples only
        out.rounds = 1;
        return out;
    }
    std::vector<Quat> evaluate(std::size_t b, const Keys& keys) const {
        std::vector<double> key_times;
        for (std::size_t i : keys.keys.indices) key_times.push_back(keys.times[i]);
        return play_slerp_keys(key_times, keys.keys.quats, times_, bones_[b].cyclic);
    }

private:
    const std::vector<double>& times_;
    const std::vector<SlerpBone>& bones_;
};

// f(i) for every i in [0, count), on up to hardware_concurrency() threads (this one included), in
// no set order. f(i) must touch only what belongs to i. The first exception thrown is rethrown here
// once every thread has stopped.
template <class F>
void parallel_for(std::size_t count, F&& f) {
    const std::size_t threads = std::min<std::size_t>(count, std::max(1u, std::thread::hardware_concurrency()));
    if (threads <= 1) {
        for (std::size_t i = 0; i < count; ++i) f(i);
        return;
    }
    std::atomic<std::size_t> next{0};
    std::exception_ptr failure;
    std::mutex failure_mutex;
    auto work = [&] {
        for (std::size_t i; (i = next.fetch_add(1)) < count;) {
            try {
                f(i);
            } catch (...) {
                const std::lock_guard<std::mutex> lock(failure_mutex);
                if (!failure) failure = std::current_exception();
                next = count;  // the others stop at their next item
            }
        }
    };
    std::vector<std::thread> pool;
    for (std::size_t t = 1; t < threads; ++t) pool.emplace_back(work);
    work();
    for (std::thread& thread : pool) thread.join();
    if (failure) std::rethrow_exception(failure);
}

// A bone reduced at a budget: its keys and their evaluated rotations (cached per budget).
template <class Keys>
struct Reduced {
    Keys keys;
    std::vector<Quat> rotation;
};

// Reducer::at for different bones may run on different threads at once (each bone has its own
// cache); for one bone, on one thread at a time.
template <class Bones>
class Reducer {
public:
    using Result = Reduced<typename Bones::Keys>;
    Reducer(const Problem& pr, const Bones& bones) : pr_(pr), bones_(bones), cache_(pr.bones) {}
    const Result& at(std::size_t b, double budget) {
        if (!pr_.reducible[b]) budget = 0.0;  // a kept bone: one entry whatever the budget
        auto it = cache_[b].find(budget);
        if (it != cache_[b].end()) return it->second;
        Result r;
        if (!pr_.reducible[b]) {  // kept as sampled: no keys, the original rotations
            r.keys = bones_.kept();
            r.rotation.assign(pr_.original.rotation.begin() + static_cast<std::ptrdiff_t>(b * pr_.n),
                              pr_.original.rotation.begin() + static_cast<std::ptrdiff_t>((b + 1) * pr_.n));
            return cache_[b].emplace(budget, std::move(r)).first->second;
        }
        r.keys = bones_.reduce(b, budget);
        r.rotation = bones_.evaluate(b, r.keys);
        return cache_[b].emplace(budget, std::move(r)).first->second;
    }

private:
    const Problem& pr_;
    const Bones& bones_;
    std::vector<std::map<double, Result>> cache_;
};

// The virtual vertices of the pose with every bone's rotation from `reduced`.
template <class R>
VertexError verify(const Problem& pr, const std::vector<const R*>& reduced, std::vector<Vec3>& verts,
                   std::vector<Mat4>& pose) {
    const std::size_t n = pr.n;
    pose.resize(pr.bones * n);
    verts.resize(pr.bones * n * kVirtualVertices);
    for (std::size_t b = 0; b < pr.bones; ++b) {
        const int p = pr.skeleton.parents[b];
        for (std::size_t s = 0; s < n; ++s) {
            const std::size_t k = b * n + s;
            pose[k] = detail::pose_bone(pr.skeleton, pr.offsets, b, p < 0 ? nullptr : &pose[p * n + s],
                                        pr.original.location[k], reduced[b]->rotation[s], pr.original.scale[k]);
            detail::bone_vertices(pose[k], pr.skeleton.lengths[b], pr.shell, &verts[k * kVirtualVertices]);
        }
    }
    return detail::vertex_error(verts, pr.verts0, pr.bones, n);
}

// D_j: per bone j, the displacement of every virtual vertex of its subtree (subtree order, then sample,
// then vertex) with only bone j's rotation replaced. Bones on worker threads (each j writes out[j]
// only): the same values as one after the other.
template <class R>
std::vector<std::vector<float>> shares(const Problem& pr, const std::vector<const R*>& reduced) {
    const std::size_t n = pr.n;
    std::vector<std::vector<float>> out(pr.bones);
    parallel_for(pr.bones, [&](std::size_t j) {
        std::vector<Mat4> work(pr.bones);
        Vec3 v[kVirtualVertices];
        const std::vector<std::size_t>& sub = pr.subtree[j];
        out[j].assign(sub.size() * n * kVirtualVertices, 0.0f);
        for (std::size_t s = 0; s < n; ++s)
            for (std::size_t a = 0; a < sub.size(); ++a) {
                const std::size_t i = sub[a], k = i * n + s;
                const int p = pr.skeleton.parents[i];
                const Mat4* parent = p < 0 ? nullptr : (i == j ? &pr.pose0[p * n + s] : &work[p]);
                work[i] = detail::pose_bone(pr.skeleton, pr.offsets, i, parent, pr.original.location[k],
                                            i == j ? reduced[j]->rotation[s] : pr.original.rotation[k],
                                            pr.original.scale[k]);
                detail::bone_vertices(work[i], pr.skeleton.lengths[i], pr.shell, v);
                for (int q = 0; q < kVirtualVertices; ++q)
                    out[j][(a * n + s) * kVirtualVertices + q] =
                        static_cast<float>(glm::length(v[q] - pr.verts0[k * kVirtualVertices + q]));
            }
    });
    return out;
}

// Stage 3: the scale α_j of every bone's budget (see the file comment).
std::vector<double> allocate(const Problem& pr, const std::vector<std::vector<float>>& d,
                             const std::vector<std::size_t>& keys) {
    const std::size_t n = pr.n, m = pr.bones * n * kVirtualVertices;
    const double target = kTarget * pr.distance;
    std::vector<double> alpha(pr.bones, 1.0), e(m), lambda(m);
    auto predict = [&] {
        std::fill(e.begin(), e.end(), 0.0);
        for (std::size_t j = 0; j < pr.bones; ++j)
            for (std::size_t a = 0; a < pr.subtree[j].size(); ++a) {
                const std::size_t base = pr.subtree[j][a] * n * kVirtualVertices, off = a * n * kVirtualVertices;
                for (std::size_t q = 0; q < n * kVirtualVertices; ++q) e[base + q] += alpha[j] * d[j][off + q];
            }
        return *std::max_element(e.begin(), e.end());
    };
    const double e0 = predict();
    if (!(e0 > 0.0)) return std::vector<double>(pr.bones, kMaxScale);
    for (std::size_t c = 0; c < m; ++c) lambda[c] = std::pow(e[c] / e0, kMultiplierPower);
    for (int step = 0; step < kAllocationSteps; ++step) {
        for (std::size_t j = 0; j < pr.bones; ++j) {
            double weight = 0.0;
            for (std::size_t a = 0; a < pr.subtree[j].size(); ++a) {
                const std::size_t base = pr.subtree[j][a] * n * kVirtualVertices, off = a * n * kVirtualVertices;
                for (std::size_t q = 0; q < n * kVirtualVertices; ++q) weight += lambda[base + q] * d[j][off + q];
            }
            const double cost = static_cast<double>(keys[j] - std::min(keys[j], pr.min_keys[j])) + 1.0;
            alpha[j] = weight > 0.0 ? std::pow(kKeysExponent * cost / weight, 1.0 / (1.0 + kKeysExponent))
                                    : std::numeric_limits<double>::infinity();
        }
        // Bones that move no vertex take the largest scale; the rest are normalized so the largest
        // predicted error is the target.
        double finite_max = 0.0;
        for (double a : alpha)
            if (std::isfinite(a)) finite_max = std::max(finite_max, a);
        for (double& a : alpha)
            if (!std::isfinite(a)) a = finite_max > 0.0 ? finite_max : 1.0;
        const double worst = predict();
        if (!(worst > 0.0)) break;
        for (double& a : alpha) a *= target / worst;
        for (double& x : e) x *= target / worst;
        double total = 0.0;
        for (std::size_t c = 0; c < m; ++c) {
            lambda[c] *= std::pow(e[c] / target, kMultiplierPower);
            if (lambda[c] < 1e-300) lambda[c] = 0.0;
            total += lambda[c];
        }
        if (!(total > 0.0)) break;
        for (double& l : lambda) l /= total;
    }
    // Clamped to what the linear model can be trusted for, then made feasible under it again.
    for (double& a : alpha) a = std::clamp(a, kMinScale, kMaxScale);
    const double worst = predict();
    if (worst > target)
        for (double& a : alpha) a *= target / worst;
    return alpha;
}

template <class R>
std::size_t total_keys(const std::vector<const R*>& reduced) {
    std::size_t k = 0;
    for (const R* r : reduced) k += count_keys(r->keys);
    return k;
}

}  // namespace

std::vector<double> dominant_shell_budgets(const Skeleton& skeleton, const std::vector<Mat4>& pose,
                                           std::size_t samples, double distance, double shell) {
    if (!std::isfinite(distance) || distance < 0.0) throw InvalidArgument("distance: must be finite and >= 0");
    check_skeleton(skeleton);
    const std::vector<Vec3> verts = virtual_vertices(skeleton, pose, samples, shell);
    std::vector<double> radius(skeleton.size(), 0.0);
    // Each bone's vertices raise the radius of the bone and of every ancestor, sample by sample.
    for (std::size_t b = 0; b < skeleton.size(); ++b)
        for (std::size_t s = 0; s < samples; ++s)
            for (int a = static_cast<int>(b); a >= 0; a = skeleton.parents[a]) {
                const Vec3 head(pose[a * samples + s][3]);
                for (int q = 0; q < kVirtualVertices; ++q)
                    radius[a] = std::max(radius[a], glm::length(verts[(b * samples + s) * kVirtualVertices + q] - head));
            }
    std::vector<double> budgets(skeleton.size());
    for (std::size_t b = 0; b < skeleton.size(); ++b)
        budgets[b] = radius[b] > 0.0 ? std::min(kPi, distance / radius[b]) : kPi;
    return budgets;
}

namespace {

// Stages 1–5 (the file comment) over one kind of keys.
template <class Bones>
SkeletonReductionOf<typename Bones::Keys> run(const Problem& pr, const Bones& bones_keys) {
    using Result = SkeletonReductionOf<typename Bones::Keys>;
    using R = Reduced<typename Bones::Keys>;
    const Skeleton& skeleton = pr.skeleton;
    const std::size_t bones = pr.bones, n = pr.n;
    const double distance = pr.distance, shell = pr.shell;
    if (bones == 0) return Result{};
    Reducer<Bones> reducer(pr, bones_keys);
    Result best;
    bool have_best = false;
    std::vector<double> budgets = dominant_shell_budgets(skeleton, pr.pose0, n, distance, shell);
    std::vector<const R*> reduced(bones);
    std::vector<Vec3> verts;
    std::vector<Mat4> poses;
    int rounds = 0;

    // Every bone's reduction is independent of the others': on worker threads (the caller's Python
    // releases the GIL), the same keys as one after the other.
    auto reduce_all = [&] {
        parallel_for(bones, [&](std::size_t b) { reduced[b] = &reducer.at(b, budgets[b]); });
        ++rounds;
    };
    auto keep_if_best = [&](const VertexError& error) {
        if (error.distance > distance) return;
        const std::size_t keys = total_keys(reduced);
        if (have_best && keys >= best.key_count()) return;
        best.keys.clear();
        for (const R* r : reduced) best.keys.push_back(r->keys);
        best.budgets = budgets;
        best.error = error;
        have_best = true;
    };
    auto verify_at = [&](const std::vector<double>& shape, double g) {
        for (std::size_t b = 0; b < bones; ++b) budgets[b] = std::min(kPi, shape[b] * g);
        reduce_all();
        const VertexError e = verify(pr, reduced, verts, poses);
        keep_if_best(e);
        return e;
    };
    // Stage 4: the budgets g·shape with the largest g that passes the verification: grown (or
    // shrunk by the measured ratio) until the pass/fail boundary is bracketed, then bisected.
    auto fit_scale = [&](const std::vector<double>& shape) {
        double pass = 0.0, fail = 0.0, g = 1.0;
        for (int t = 0; t < kBracketSteps && (pass == 0.0 || fail == 0.0); ++t) {
            const VertexError e = verify_at(shape, g);
            if (e.distance <= distance) {
                pass = g;
                g = fail > 0.0 ? 0.5 * (g + fail) : g * std::clamp(distance / std::max(e.distance, 1e-300), 1.05, 2.0);
            } else {
                fail = g;
                g = pass > 0.0 ? 0.5 * (g + pass) : g * std::min(0.95, kTightenMargin * distance / e.distance);
            }
        }
        for (int t = 0; t < kBisectSteps && pass > 0.0 && fail > 0.0; ++t) {
            g = std::sqrt(pass * fail);
            (verify_at(shape, g).distance <= distance ? pass : fail) = g;
        }
    };

    // Stage 5: from the best passing budgets, each bone loosened on its own (most keys first) by a
    // factor of 2, then √2, then 2^¼, kept where the whole skeleton still passes: only the bone's
    // subtree is posed again, the other bones keep their measured error.
    auto loosen = [&] {
        budgets = best.budgets;
        reduce_all();
        VertexError e = verify(pr, reduced, verts, poses);
        std::vector<double> per_bone = e.per_bone;
        std::vector<Mat4> work(bones);
        std::vector<double> trial_error(bones);
        Vec3 v[kVirtualVertices];
        for (const double factor : {2.0, std::sqrt(2.0), std::sqrt(std::sqrt(2.0))}) {
            std::vector<std::size_t> order(bones);
            for (std::size_t b = 0; b < bones; ++b) order[b] = b;
            std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
                return count_keys(reduced[a]->keys) > count_keys(reduced[b]->keys);
            });
            // Each bone's loosened reduction, ahead on worker threads: bone j's budget and keys change
            // only at its own turn below, so these are the reductions the turns ask for.
            parallel_for(bones, [&](std::size_t j) {
                if (count_keys(reduced[j]->keys) > pr.min_keys[j] && budgets[j] < kPi)
                    reducer.at(j, std::min(kPi, budgets[j] * factor));
            });
            for (const std::size_t j : order) {
                if (count_keys(reduced[j]->keys) <= pr.min_keys[j] || budgets[j] >= kPi) continue;
                const double budget = std::min(kPi, budgets[j] * factor);
                const R& r = reducer.at(j, budget);
                if (count_keys(r.keys) >= count_keys(reduced[j]->keys)) continue;
                double worst = 0.0;
                std::vector<char> inside(bones, 0);
                for (const std::size_t i : pr.subtree[j]) inside[i] = 1, trial_error[i] = 0.0;
                for (std::size_t b = 0; b < bones; ++b)
                    if (!inside[b]) worst = std::max(worst, per_bone[b]);
                for (std::size_t s = 0; s < n && worst <= distance; ++s)
                    for (const std::size_t i : pr.subtree[j]) {
                        const std::size_t k = i * n + s;
                        const int p = skeleton.parents[i];
                        const Mat4* parent = p < 0 ? nullptr : (i == j ? &poses[p * n + s] : &work[p]);
                        work[i] = detail::pose_bone(skeleton, pr.offsets, i, parent, pr.original.location[k],
                                                    i == j ? r.rotation[s] : reduced[i]->rotation[s], pr.original.scale[k]);
                        detail::bone_vertices(work[i], skeleton.lengths[i], shell, v);
                        for (int q = 0; q < kVirtualVertices; ++q)
                            trial_error[i] = std::max(trial_error[i], glm::length(v[q] - pr.verts0[k * kVirtualVertices + q]));
                        worst = std::max(worst, trial_error[i]);
                    }
                if (worst > distance) continue;
                budgets[j] = budget;
                reduced[j] = &r;
                for (const std::size_t i : pr.subtree[j]) per_bone[i] = trial_error[i];
                // The accepted subtree's poses, for the next trials.
                for (std::size_t s = 0; s < n; ++s)
                    for (const std::size_t i : pr.subtree[j]) {
                        const std::size_t k = i * n + s;
                        const int p = skeleton.parents[i];
                        poses[k] = detail::pose_bone(skeleton, pr.offsets, i, p < 0 ? nullptr : &poses[p * n + s],
                                                     pr.original.location[k], reduced[i]->rotation[s], pr.original.scale[k]);
                    }
            }
        }
        keep_if_best(verify(pr, reduced, verts, poses));
    };

    // Stage 1: the dominant-shell budgets at their best scale; one angle for every bone only where
    // no scale of them passes.
    const std::vector<double> shell_budgets = budgets;
    fit_scale(shell_budgets);
    if (!have_best) fit_scale(std::vector<double>(bones, *std::min_element(shell_budgets.begin(), shell_budgets.end())));
    // Stages 2–4 from the best passing budgets.
    for (int round = 0; round < kMeasureRounds && have_best; ++round) {
        std::vector<std::size_t> keys(bones);
        for (std::size_t b = 0; b < bones; ++b) {
            reduced[b] = &reducer.at(b, best.budgets[b]);
            keys[b] = count_keys(reduced[b]->keys);
        }
        const std::vector<double> alpha = allocate(pr, shares(pr, reduced), keys);
        std::vector<double> shape(bones);
        for (std::size_t b = 0; b < bones; ++b) shape[b] = best.budgets[b] * alpha[b];
        fit_scale(shape);
    }
    if (have_best) loosen();
    // Nothing passed (a distance below the float32 floor of the keys): the last try is returned.
    if (!have_best) {
        for (const R* r : reduced) best.keys.push_back(r->keys);
        best.budgets = budgets;
        best.error = verify(pr, reduced, verts, poses);
    }
    best.rounds = rounds;
    return best;
}

}  // namespace

SkeletonReduction reduce_skeleton(const Skeleton& skeleton, const std::vector<double>& times,
                                  const std::vector<BoneChannels>& rotations, const std::vector<Vec3>& locations,
                                  const std::vector<Vec3>& scales, double distance, double shell,
                                  KeyInterpolation interpolation, bool synchronized) {
    check_skeleton(skeleton);
    detail::check_shell(shell);
    if (!std::isfinite(distance) || !(distance > 0.0)) throw InvalidArgument("distance: must be finite and > 0");
    const std::size_t bones = skeleton.size(), n = times.size();
    if (rotations.size() != bones)
        throw InvalidArgument("rotations: " + std::to_string(rotations.size()) + " bones for " +
                              std::to_string(bones) + " in the skeleton");
    SkeletonPose original;
    original.samples = n;
    original.location = locations;
    original.scale = scales;
    original.rotation.resize(bones * n);
    std::vector<std::size_t> min_keys(bones);
    std::vector<char> reducible(bones);
    for (std::size_t b = 0; b < bones; ++b) {
        const std::size_t c = channel_count(rotations[b].mode);
        if (rotations[b].values.size() != n * c)
            throw InvalidArgument("rotations[" + std::to_string(b) + "]: " + std::to_string(rotations[b].values.size()) +
                                  " values for " + std::to_string(n) + " samples of " + std::to_string(c) + " channels");
        for (std::size_t s = 0; s < n; ++s)
            original.rotation[b * n + s] = channels_to_quat(rotations[b].values.data() + s * c, rotations[b].mode, s);
        min_keys[b] = rotations[b].reduce ? 2 * c : 0;
        reducible[b] = rotations[b].reduce;
    }
    const Problem pr = make_problem(skeleton, std::move(original), distance, shell, std::move(min_keys),
                                    std::move(reducible), "channels");
    return run(pr, FCurveBones(times, rotations, interpolation, synchronized));
}

SkeletonSlerpReduction reduce_skeleton_slerp(const Skeleton& skeleton, const std::vector<double>& times,
                                             const std::vector<Quat>& rotations, const std::vector<Vec3>& locations,
                                             const std::vector<Vec3>& scales, double distance, double shell,
                                             const std::vector<SlerpBone>& bones) {
    check_skeleton(skeleton);
    detail::check_shell(shell);
    if (!std::isfinite(distance) || !(distance > 0.0)) throw InvalidArgument("distance: must be finite and > 0");
    const std::size_t count = skeleton.size(), n = times.size();
    if (bones.size() != count)
        throw InvalidArgument("bones: " + std::to_string(bones.size()) + " for " + std::to_string(count) +
                              " in the skeleton");
    for (std::size_t s = 0; s < n; ++s)
        if (!std::isfinite(times[s]) || (s > 0 && !(times[s] > times[s - 1])))
            throw InvalidArgument("times[" + std::to_string(s) + "]: not finite and increasing");
    std::vector<std::size_t> min_keys(count);
    std::vector<char> reducible(count);
    for (std::size_t b = 0; b < count; ++b) {
        const SlerpBone& bone = bones[b];
        const std::string name = "bones[" + std::to_string(b) + "]";
        reducible[b] = bone.reduce;
        if (!bone.reduce) continue;
        min_keys[b] = 2;
        if (bone.times.size() < 2) throw InvalidArgument(name + ".times: fewer than two times");
        if (!bone.reference && bone.samples.size() != bone.times.size())
            throw InvalidArgument(name + ".samples: " + std::to_string(bone.samples.size()) + " rotations for " +
                                  std::to_string(bone.times.size()) + " times (and no reference)");
    }
    SkeletonPose original;
    original.samples = n;
    original.location = locations;
    original.rotation = rotations;
    original.scale = scales;
    const Problem pr = make_problem(skeleton, std::move(original), distance, shell, std::move(min_keys),
                                    std::move(reducible), "rotations");
    return run(pr, SlerpBones(times, bones));
}

}  // namespace quatcurve
