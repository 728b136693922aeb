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
//   4. reduced at those budgets and verified (the whole skeleton posed from Blender's evaluation of
//      every bone's keys); each bone on the chain of a vertex above the distance is tightened by the
//      measured ratio and reduced again, until every vertex passes;
//   5. stages 2–4 once more from the verified budgets; the passing result with fewer keys is kept.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>

#include "quatcurve/errors.hpp"
#include "quatcurve/quat.hpp"
#include "quatcurve/skeleton.hpp"
#include "skeleton_impl.hpp"

namespace quatcurve {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kKeysExponent = 0.5;     // keys ∝ tolerance^(−p): the allocation's cost model
constexpr double kTarget = 0.95;          // the allocation aims at this share of the distance
constexpr double kTightenMargin = 0.97;   // a violating chain's bones scaled by this · distance / error
constexpr int kAllocationSteps = 40;      // multiplier updates of the allocation
constexpr double kMultiplierPower = 6.0;  // λ ← λ·(E / target)^this
constexpr int kTightenRounds = 8;         // verifications with tightening per measurement round
constexpr int kMeasureRounds = 2;         // measurement + allocation rounds (stages 2–4)
constexpr double kMinScale = 1.0 / 16.0, kMaxScale = 64.0;  // α_j per allocation

struct Problem {
    const Skeleton& skeleton;
    const std::vector<double>& times;
    const std::vector<BoneChannels>& rotations;
    KeyInterpolation interpolation;
    bool synchronized;
    double distance, shell;
    std::size_t bones, n;
    std::vector<Mat4> offsets;
    SkeletonPose original;                         // rotations from the given channel values
    std::vector<Mat4> pose0;                       // the original pose
    std::vector<Vec3> verts0;                      // its virtual vertices
    std::vector<std::vector<std::size_t>> subtree; // each bone and its descendants, in index order
    std::vector<std::vector<Quat>> quats;          // QUATERNION bones: hemisphere-continuous samples
    std::vector<std::size_t> min_keys;             // 2 per channel (a constant rotation)
};

ReducedKeys reduce_bone(const Problem& pr, std::size_t b, double tolerance) {
    const BoneChannels& ch = pr.rotations[b];
    const std::size_t n = pr.n;
    switch (ch.mode.kind) {
        case RotationMode::Kind::quaternion:
            return reduce_keys(pr.times, pr.quats[b], tolerance, pr.interpolation, pr.synchronized);
        case RotationMode::Kind::euler: {
            std::vector<Vec3> a(n);
            for (std::size_t s = 0; s < n; ++s) a[s] = Vec3(ch.values[3 * s], ch.values[3 * s + 1], ch.values[3 * s + 2]);
            return reduce_keys_euler(pr.times, a, ch.mode.order, tolerance, pr.interpolation, pr.synchronized);
        }
        case RotationMode::Kind::axis_angle: {
            std::vector<Vec4> a(n);
            for (std::size_t s = 0; s < n; ++s)
                a[s] = Vec4(ch.values[4 * s], ch.values[4 * s + 1], ch.values[4 * s + 2], ch.values[4 * s + 3]);
            return reduce_keys_axis_angle(pr.times, a, tolerance, pr.interpolation, pr.synchronized);
        }
    }
    throw InvalidArgument("rotations: unknown rotation mode");
}

// The rotations Blender builds from its evaluation (float32) of the keys at every sample.
std::vector<Quat> evaluate_bone(const Problem& pr, std::size_t b, const ReducedKeys& keys) {
    const std::size_t c = keys.channels.size(), n = pr.n;
    std::vector<double> rows(n * c), column;
    for (std::size_t k = 0; k < c; ++k) {
        blender_evaluate_sorted(keys.channels[k], keys.interpolation, pr.times, column);
        for (std::size_t s = 0; s < n; ++s) rows[s * c + k] = column[s];
    }
    std::vector<Quat> out(n);
    for (std::size_t s = 0; s < n; ++s) out[s] = channels_to_quat(rows.data() + s * c, pr.rotations[b].mode, s);
    return out;
}

// A bone reduced at a budget: its keys and their evaluated rotations (cached per budget).
struct Reduced {
    ReducedKeys keys;
    std::vector<Quat> rotation;
};

class Reducer {
public:
    explicit Reducer(const Problem& pr) : pr_(pr), cache_(pr.bones) {}
    const Reduced& at(std::size_t b, double budget) {
        auto it = cache_[b].find(budget);
        if (it != cache_[b].end()) return it->second;
        Reduced r;
        r.keys = reduce_bone(pr_, b, budget);
        r.rotation = evaluate_bone(pr_, b, r.keys);
        return cache_[b].emplace(budget, std::move(r)).first->second;
    }

private:
    const Problem& pr_;
    std::vector<std::map<double, Reduced>> cache_;
};

// The virtual vertices of the pose with every bone's rotation from `reduced`.
VertexError verify(const Problem& pr, const std::vector<const Reduced*>& reduced, std::vector<Vec3>& verts) {
    const std::size_t n = pr.n;
    std::vector<Mat4> pose(pr.bones * n);
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
// then vertex) with only bone j's rotation replaced.
std::vector<std::vector<float>> shares(const Problem& pr, const std::vector<const Reduced*>& reduced) {
    const std::size_t n = pr.n;
    std::vector<std::vector<float>> out(pr.bones);
    std::vector<Mat4> work(pr.bones);
    Vec3 v[kVirtualVertices];
    for (std::size_t j = 0; j < pr.bones; ++j) {
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
    }
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

std::size_t total_keys(const std::vector<const Reduced*>& reduced) {
    std::size_t k = 0;
    for (const Reduced* r : reduced) k += r->keys.key_count();
    return k;
}

}  // namespace

std::size_t SkeletonReduction::key_count() const {
    std::size_t k = 0;
    for (const ReducedKeys& r : keys) k += r.key_count();
    return k;
}

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
    Problem pr{skeleton, times, rotations, interpolation, synchronized, distance, shell, bones, n, {}, {}, {}, {}, {}, {}, {}};
    pr.original.samples = n;
    pr.original.location = locations;
    pr.original.scale = scales;
    pr.original.rotation.resize(bones * n);
    pr.quats.resize(bones);
    pr.min_keys.resize(bones);
    for (std::size_t b = 0; b < bones; ++b) {
        const std::size_t c = channel_count(rotations[b].mode);
        if (rotations[b].values.size() != n * c)
            throw InvalidArgument("rotations[" + std::to_string(b) + "]: " + std::to_string(rotations[b].values.size()) +
                                  " values for " + std::to_string(n) + " samples of " + std::to_string(c) + " channels");
        for (std::size_t s = 0; s < n; ++s)
            pr.original.rotation[b * n + s] = channels_to_quat(rotations[b].values.data() + s * c, rotations[b].mode, s);
        pr.min_keys[b] = 2 * c;
        if (rotations[b].mode.kind == RotationMode::Kind::quaternion) {
            // reduce_keys keeps the stored scale of each value: the given values, made continuous.
            pr.quats[b].resize(n);
            for (std::size_t s = 0; s < n; ++s) pr.quats[b][s] = from_wxyz(&rotations[b].values[4 * s]);
            hemisphere_continuous(pr.quats[b].data(), n);
        }
    }
    check_pose(skeleton, pr.original, "channels");
    pr.offsets = detail::rest_offsets(skeleton);
    pr.pose0 = pose_matrices(skeleton, pr.original);
    pr.verts0 = virtual_vertices(skeleton, pr.pose0, n, shell);
    pr.subtree.resize(bones);
    for (std::size_t b = 0; b < bones; ++b)
        for (int a = static_cast<int>(b); a >= 0; a = skeleton.parents[a]) pr.subtree[a].push_back(b);

    Reducer reducer(pr);
    SkeletonReduction best;
    bool have_best = false;
    std::vector<double> budgets = dominant_shell_budgets(skeleton, pr.pose0, n, distance, shell);
    std::vector<const Reduced*> reduced(bones);
    std::vector<Vec3> verts;
    int rounds = 0;

    auto reduce_all = [&] {
        for (std::size_t b = 0; b < bones; ++b) reduced[b] = &reducer.at(b, budgets[b]);
        ++rounds;
    };
    auto keep_if_best = [&](const VertexError& error) {
        if (error.distance > distance) return;
        const std::size_t keys = total_keys(reduced);
        if (have_best && keys >= best.key_count()) return;
        best.keys.clear();
        for (const Reduced* r : reduced) best.keys.push_back(r->keys);
        best.budgets = budgets;
        best.error = error;
        have_best = true;
    };
    // Stage 4: verify; tighten the chains of the vertices above the distance; again.
    auto verify_and_tighten = [&] {
        VertexError error;
        for (int t = 0; t < kTightenRounds; ++t) {
            reduce_all();
            error = verify(pr, reduced, verts);
            if (error.distance <= distance) break;
            std::vector<double> factor(bones, 1.0);
            for (std::size_t b = 0; b < bones; ++b)
                for (std::size_t s = 0; s < n; ++s)
                    for (int q = 0; q < kVirtualVertices; ++q) {
                        const std::size_t k = (b * n + s) * kVirtualVertices + q;
                        const double e = glm::length(verts[k] - pr.verts0[k]);
                        if (e <= distance) continue;
                        const double f = kTightenMargin * distance / e;
                        for (int a = static_cast<int>(b); a >= 0; a = skeleton.parents[a])
                            factor[a] = std::min(factor[a], f);
                    }
            for (std::size_t b = 0; b < bones; ++b) budgets[b] *= factor[b];
        }
        return error;
    };

    // Stage 1.
    VertexError error = verify_and_tighten();
    keep_if_best(error);
    // Stages 2–4, twice.
    for (int round = 0; round < kMeasureRounds; ++round) {
        std::vector<std::size_t> keys(bones);
        for (std::size_t b = 0; b < bones; ++b) keys[b] = reduced[b]->keys.key_count();
        const std::vector<double> alpha = allocate(pr, shares(pr, reduced), keys);
        for (std::size_t b = 0; b < bones; ++b) budgets[b] = std::min(kPi, budgets[b] * alpha[b]);
        error = verify_and_tighten();
        keep_if_best(error);
    }
    // Nothing passed (a distance below the float32 floor of the keys): everything tightened by half
    // until it passes or stops changing; the last try is returned.
    for (int t = 0; !have_best && t < 24; ++t) {
        for (double& b : budgets) b *= 0.5;
        reduce_all();
        error = verify(pr, reduced, verts);
        keep_if_best(error);
        if (t == 23 && !have_best) {
            for (const Reduced* r : reduced) best.keys.push_back(r->keys);
            best.budgets = budgets;
            best.error = error;
        }
    }
    best.rounds = rounds;
    return best;
}

}  // namespace quatcurve
