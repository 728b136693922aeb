// Skeletons (skeleton.hpp): the pose against a reference written from Blender's pose formulas in
// bone-relative terms (BKE_bone_offset_matrix_get's bone_mat, head and parent length — not the
// rest matrices the library inverts), the virtual vertices and their error, and the distance bound
// of reduce_skeleton and reduce_skeleton_slerp on random skeletons, checked by an independent
// evaluation of the keys (Blender's F-curve evaluation; glTF's slerp written out).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "quatcurve/blender_eval.hpp"
#include "quatcurve/bound.hpp"
#include "quatcurve/curve.hpp"
#include "quatcurve/channels.hpp"
#include "quatcurve/errors.hpp"
#include "quatcurve/euler.hpp"
#include "quatcurve/quat.hpp"
#include "quatcurve/skeleton.hpp"

using namespace quatcurve;

namespace {

constexpr double kPi = 3.14159265358979323846;

// A skeleton in Blender's bone-relative terms, and its rest matrices built from them.
struct BoneSpec {
    int parent = -1;
    Mat3 bone_mat{1.0};  // the rest rotation relative to the parent (any roll)
    Vec3 head{0.0};      // relative to the parent's tail, in the parent's space (0 when connected)
    double length = 1.0;
    bool inherit_rotation = true, connected = false;
    InheritScale inherit_scale = InheritScale::FULL;
};

Quat random_unit(std::mt19937& rng) {
    std::normal_distribution<double> g;
    Quat q(g(rng), g(rng), g(rng), g(rng));
    return glm::normalize(q);
}

std::vector<BoneSpec> random_specs(std::mt19937& rng, int count, bool flags) {
    std::uniform_real_distribution<double> u(-1.0, 1.0), len(0.05, 0.6);
    std::vector<BoneSpec> specs(count);
    for (int b = 0; b < count; ++b) {
        BoneSpec& s = specs[b];
        s.parent = b == 0 ? -1 : std::uniform_int_distribution<int>(0, b - 1)(rng);
        s.bone_mat = glm::mat3_cast(random_unit(rng));  // non-uniform rest rolls
        s.length = len(rng);
        if (flags && b > 0) {
            s.connected = u(rng) < -0.3;
            s.inherit_rotation = u(rng) > -0.4;
            s.inherit_scale = u(rng) > 0.0 ? InheritScale::FULL : InheritScale::NONE;
        }
        s.head = s.connected ? Vec3(0.0) : Vec3(u(rng), u(rng), u(rng)) * 0.2;
    }
    return specs;
}

// offs = [bone_mat | head + (0, parent length, 0)] (BKE_bone_offset_matrix_get).
Mat4 offset_of(const std::vector<BoneSpec>& specs, int b) {
    Mat4 m(specs[b].bone_mat);
    Vec3 t = specs[b].head;
    if (specs[b].parent >= 0) t.y += specs[specs[b].parent].length;
    m[3] = Vec4(t, 1.0);
    return m;
}

Skeleton skeleton_of(const std::vector<BoneSpec>& specs) {
    Skeleton sk;
    for (std::size_t b = 0; b < specs.size(); ++b) {
        const BoneSpec& s = specs[b];
        sk.parents.push_back(s.parent);
        sk.rest.push_back(s.parent < 0 ? offset_of(specs, static_cast<int>(b))
                                       : sk.rest[s.parent] * offset_of(specs, static_cast<int>(b)));
        sk.lengths.push_back(s.length);
        sk.inherit_rotation.push_back(s.inherit_rotation);
        sk.connected.push_back(s.connected);
        sk.inherit_scale.push_back(s.inherit_scale);
    }
    return sk;
}

// Blender's pose of one bone, written out from BKE_pchan_to_mat4 and
// BKE_bone_parent_transform_calc_from_matrices / _apply, for parent pose matrices without shear.
Mat4 reference_pose(const std::vector<BoneSpec>& specs, const Skeleton& sk, int b, const Mat4* parent_pose,
                    const Vec3& loc, const Quat& rot, const Vec3& scale) {
    Mat3 rs = glm::mat3_cast(glm::normalize(rot));
    for (int c = 0; c < 3; ++c) rs[c] *= scale[c];
    Mat4 chan(rs);
    if (!specs[b].connected) chan[3] = Vec4(loc, 1.0);
    if (parent_pose == nullptr) return sk.rest[b] * chan;
    const Mat4 offs = offset_of(specs, b);
    Mat4 rotscale, locmat = *parent_pose * offs;
    if (specs[b].inherit_rotation) {
        Mat4 t = *parent_pose;
        if (specs[b].inherit_scale == InheritScale::NONE)
            for (int c = 0; c < 3; ++c) t[c] = Vec4(glm::normalize(Vec3(t[c])), 0.0);
        rotscale = t * offs;
    } else {
        Mat4 t = sk.rest[specs[b].parent];
        if (specs[b].inherit_scale == InheritScale::FULL)
            for (int c = 0; c < 3; ++c) t[c] *= glm::length(Vec3((*parent_pose)[c]));
        rotscale = t * offs;
    }
    Mat4 out = rotscale * chan;
    out[3] = locmat * Vec4(Vec3(chan[3]), 1.0);
    return out;
}

// Random channels: locations, rotations, and scales uniform per bone except on leaves (so no parent
// pose matrix is sheared, where Blender's orthogonalization of inherit scale NONE would differ from
// plain normalization).
SkeletonPose random_pose(std::mt19937& rng, const std::vector<BoneSpec>& specs, std::size_t samples) {
    std::uniform_real_distribution<double> u(-1.0, 1.0), sc(0.5, 1.6);
    std::vector<bool> leaf(specs.size(), true);
    for (const BoneSpec& s : specs)
        if (s.parent >= 0) leaf[s.parent] = false;
    SkeletonPose p;
    p.samples = samples;
    for (std::size_t b = 0; b < specs.size(); ++b)
        for (std::size_t s = 0; s < samples; ++s) {
            p.location.push_back(Vec3(u(rng), u(rng), u(rng)) * 0.3);
            p.rotation.push_back(random_unit(rng) * sc(rng));  // not unit: Blender normalizes
            const double k = sc(rng);
            p.scale.push_back(leaf[b] ? Vec3(sc(rng), sc(rng), sc(rng)) : Vec3(k));
        }
    return p;
}

void expect_near(const Mat4& a, const Mat4& b, double tol, const char* what) {
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) ASSERT_NEAR(a[c][r], b[c][r], tol) << what << " [" << c << "][" << r << "]";
}

}  // namespace

TEST(Skeleton, PoseMatchesBlenderFormulasOnRandomSkeletons) {
    std::mt19937 rng(29);
    for (int trial = 0; trial < 40; ++trial) {
        const std::vector<BoneSpec> specs = random_specs(rng, 2 + trial % 25, true);
        const Skeleton sk = skeleton_of(specs);
        const std::size_t n = 5;
        const SkeletonPose pose = random_pose(rng, specs, n);
        const std::vector<Mat4> got = pose_matrices(sk, pose);
        std::vector<Mat4> ref(specs.size() * n);
        for (std::size_t b = 0; b < specs.size(); ++b)
            for (std::size_t s = 0; s < n; ++s) {
                const int p = specs[b].parent;
                ref[b * n + s] = reference_pose(specs, sk, static_cast<int>(b), p < 0 ? nullptr : &ref[p * n + s],
                                                pose.location[b * n + s], pose.rotation[b * n + s], pose.scale[b * n + s]);
                expect_near(got[b * n + s], ref[b * n + s], 1e-10, "pose");
            }
        // The vertices: Blender's pose_tail (head + Y axis · length) and the shell points.
        const double shell = 0.1;
        const std::vector<Vec3> v = virtual_vertices(sk, got, n, shell);
        for (std::size_t k = 0; k < got.size(); ++k) {
            const Vec3 head(got[k][3]);
            EXPECT_NEAR(glm::length(v[4 * k] - (head + Vec3(got[k][1]) * specs[k / n].length)), 0.0, 1e-12);
            for (int a = 0; a < 3; ++a)
                EXPECT_NEAR(glm::length(v[4 * k + 1 + a] - transform_point(got[k], Vec3(a == 0, a == 1, a == 2) * shell)),
                            0.0, 1e-12);
        }
    }
}

TEST(Skeleton, ConnectedBoneSitsAtItsParentsTailWhateverItsLocation) {
    std::vector<BoneSpec> specs(2);
    specs[0].length = 2.0;
    specs[1].parent = 0;
    specs[1].connected = true;
    specs[1].bone_mat = glm::mat3_cast(glm::angleAxis(0.7, glm::normalize(Vec3(1, 2, 3))));
    const Skeleton sk = skeleton_of(specs);
    SkeletonPose p;
    p.samples = 1;
    p.location = {Vec3(0.0), Vec3(5.0, 6.0, 7.0)};
    p.rotation = {glm::angleAxis(kPi / 2, Vec3(0, 0, 1)), Quat(1, 0, 0, 0)};
    p.scale = {Vec3(1.0), Vec3(1.0)};
    const std::vector<Mat4> m = pose_matrices(sk, p);
    // The root turned 90° about Z: its tail (0, 2, 0) goes to (−2, 0, 0), where the child's head is.
    EXPECT_NEAR(glm::length(Vec3(m[1][3]) - Vec3(-2.0, 0.0, 0.0)), 0.0, 1e-12);
}

TEST(Skeleton, InheritRotationOffFollowsTheParentsTailNotItsTurn) {
    std::vector<BoneSpec> specs(2);
    specs[0].length = 1.0;
    specs[1].parent = 0;
    specs[1].head = Vec3(0.5, 0.0, 0.0);
    specs[1].inherit_rotation = false;
    const Skeleton sk = skeleton_of(specs);
    SkeletonPose p;
    p.samples = 1;
    p.location = {Vec3(0.0), Vec3(0.0)};
    p.rotation = {glm::angleAxis(kPi / 2, Vec3(0, 0, 1)), Quat(1, 0, 0, 0)};
    p.scale = {Vec3(2.0), Vec3(1.0)};  // FULL inherit scale: the child takes the parent's scale
    const std::vector<Mat4> m = pose_matrices(sk, p);
    // Head: the parent's pose of (0.5, 1, 0) = rotate 90° about Z of (1, 2, 0) = (−2, 1, 0).
    EXPECT_NEAR(glm::length(Vec3(m[1][3]) - Vec3(-2.0, 1.0, 0.0)), 0.0, 1e-12);
    // Axes: the rest orientation (identity) scaled by 2, not turned.
    expect_near(Mat4(Mat3(m[1])), Mat4(Mat3(2.0)), 1e-12, "hinge axes");
}

// Inherit scale NONE under a sheared parent pose (a non-uniformly scaled grandparent, a turned parent
// with FULL inherit scale): Blender takes the parent's axes through orthogonalize_stable around Y. The
// reference is that rule's statement, not its steps: Y is the parent's Y direction; in the plane
// across it, the parent's X and Z (projected off Y, at angle phi) each turn by half of (90° − phi),
// away from each other, so X sits at −(90° − phi)/2 from the parent's X and Z at the same angle
// beyond the parent's Z.
TEST(Skeleton, InheritScaleNoneUnderAShearedParentTakesTheStableOrthogonalization) {
    std::mt19937 rng(41);
    std::uniform_real_distribution<double> u(-1.0, 1.0), sc(0.4, 2.5);
    int sheared = 0;
    for (int trial = 0; trial < 200; ++trial) {
        std::vector<BoneSpec> specs(3);
        for (int b = 0; b < 3; ++b) {
            specs[b].parent = b - 1;
            specs[b].bone_mat = glm::mat3_cast(random_unit(rng));
            specs[b].length = 0.3 + 0.2 * std::abs(u(rng));
            specs[b].head = b == 0 ? Vec3(0.0) : Vec3(u(rng), u(rng), u(rng)) * 0.2;
        }
        specs[2].inherit_scale = InheritScale::NONE;
        const Skeleton sk = skeleton_of(specs);
        SkeletonPose p;
        p.samples = 1;
        p.location = {Vec3(u(rng), u(rng), u(rng)) * 0.3, Vec3(u(rng), u(rng), u(rng)) * 0.3,
                      Vec3(u(rng), u(rng), u(rng)) * 0.3};
        p.rotation = {random_unit(rng), random_unit(rng), random_unit(rng)};
        p.scale = {Vec3(sc(rng), sc(rng), sc(rng)), Vec3(sc(rng), sc(rng), sc(rng)), Vec3(sc(rng), sc(rng), sc(rng))};
        const std::vector<Mat4> m = pose_matrices(sk, p);
        const Mat4& parent = m[1];
        const Vec3 y = glm::normalize(Vec3(parent[1]));
        const Vec3 xp = glm::normalize(Vec3(parent[0]) - y * glm::dot(Vec3(parent[0]), y));
        const Vec3 zp = glm::normalize(Vec3(parent[2]) - y * glm::dot(Vec3(parent[2]), y));
        const double phi = std::acos(std::clamp(glm::dot(xp, zp), -1.0, 1.0));
        if (std::abs(std::cos(phi)) < 1e-3) continue;  // (nearly) unsheared: nothing to tell apart
        ++sheared;
        // The plane across Y: u along the parent's X, w towards its Z.
        const Vec3 w = glm::normalize(zp - xp * glm::dot(zp, xp));
        const double turn = (0.5 * kPi - phi) / 2.0;
        Mat4 stable(1.0);
        stable[0] = Vec4(xp * std::cos(-turn) + w * std::sin(-turn), 0.0);
        stable[1] = Vec4(y, 0.0);
        stable[2] = Vec4(xp * std::cos(phi + turn) + w * std::sin(phi + turn), 0.0);
        // The child's pose (BKE_bone_parent_transform_calc_from_matrices, inherit scale NONE): its
        // rotation and scale from the orthonormal axes, its head from the parent's full pose.
        Mat3 rs = glm::mat3_cast(glm::normalize(p.rotation[2]));
        for (int c = 0; c < 3; ++c) rs[c] *= p.scale[2][c];
        Mat4 chan(rs);
        chan[3] = Vec4(p.location[2], 1.0);
        const Mat4 offs = offset_of(specs, 2);
        Mat4 want = stable * offs * chan;
        want[3] = parent * offs * Vec4(p.location[2], 1.0);
        expect_near(m[2], want, 1e-9, "inherit scale NONE under a sheared parent");
    }
    EXPECT_GT(sheared, 150) << "too few sheared parents to test";
}

TEST(Skeleton, VertexErrorIsTheWorstDisplacementAndWhereItIs) {
    std::vector<BoneSpec> specs(3);
    specs[0].length = 1.0;
    specs[1].parent = 0;
    specs[1].connected = true;
    specs[1].length = 0.5;
    specs[2].parent = 1;
    specs[2].connected = true;
    specs[2].length = 0.25;
    const Skeleton sk = skeleton_of(specs);
    SkeletonPose a;
    a.samples = 4;
    for (int b = 0; b < 3; ++b)
        for (int s = 0; s < 4; ++s) {
            a.location.push_back(Vec3(0.0));
            a.rotation.push_back(Quat(1, 0, 0, 0));
            a.scale.push_back(Vec3(1.0));
        }
    SkeletonPose b = a;
    const double angle = 0.01;
    b.rotation[1 * 4 + 2] = glm::angleAxis(angle, Vec3(1, 0, 0));  // bone 1 at sample 2 turns about X
    const VertexError e = virtual_vertex_error(sk, a, b, 0.1);
    // Bone 2's tail is 0.75 from bone 1's head: it moves by 2·0.75·sin(angle/2).
    EXPECT_NEAR(e.distance, 2 * 0.75 * std::sin(angle / 2), 1e-12);
    EXPECT_EQ(e.bone, 2);
    EXPECT_EQ(e.vertex, 0);
    EXPECT_EQ(e.sample, 2u);
    EXPECT_EQ(e.per_bone[0], 0.0);
    EXPECT_NEAR(e.per_bone[1], 2 * 0.5 * std::sin(angle / 2), 1e-12);
    // Per bone and sample: only sample 2 of bones 1 and 2 moves; their maxima are vertex_error's.
    const std::vector<double> d = virtual_vertex_distances(sk, a, b, 0.1);
    ASSERT_EQ(d.size(), 12u);
    for (int bone = 0; bone < 3; ++bone)
        for (int s = 0; s < 4; ++s)
            if (bone == 0 || s != 2) EXPECT_EQ(d[bone * 4 + s], 0.0) << bone << " " << s;
    EXPECT_EQ(d[1 * 4 + 2], e.per_bone[1]);
    EXPECT_EQ(d[2 * 4 + 2], e.distance);
    EXPECT_THROW(virtual_vertex_distances(sk, a, b, -1.0), InvalidArgument);
}

TEST(Skeleton, RefusesBadInputNamingIt) {
    std::vector<BoneSpec> specs(2);
    specs[1].parent = 0;
    Skeleton sk = skeleton_of(specs);
    SkeletonPose p;
    p.samples = 1;
    p.location = {Vec3(0.0), Vec3(0.0)};
    p.rotation = {Quat(1, 0, 0, 0), Quat(1, 0, 0, 0)};
    p.scale = {Vec3(1.0), Vec3(1.0)};
    EXPECT_NO_THROW(pose_matrices(sk, p));
    auto message = [&](const Skeleton& s, const SkeletonPose& q) {
        try {
            pose_matrices(s, q);
        } catch (const InvalidArgument& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    Skeleton bad = sk;
    bad.parents[1] = 1;
    EXPECT_NE(message(bad, p).find("parents[1]"), std::string::npos);
    bad = sk;
    bad.rest[1][0][0] = 2.0;
    EXPECT_NE(message(bad, p).find("rest[1]"), std::string::npos);
    bad.rest[1][0][0] = 1.01;  // a 1 % scale
    EXPECT_NE(message(bad, p).find("rest[1]: not a rigid transform"), std::string::npos);
    // Blender's float32 matrix_local three bones down a chain: 1.3e-5 off orthonormal, posed as it is
    bad.rest[1][0][0] = 1.0 + 1.3e-5;
    bad.rest[1][1][0] = 8e-6;
    EXPECT_EQ(message(bad, p), "");
    bad = sk;
    bad.lengths[0] = -1.0;
    EXPECT_NE(message(bad, p).find("lengths[0]"), std::string::npos);
    SkeletonPose q = p;
    q.rotation[1] = Quat(0, 0, 0, 0);
    EXPECT_NE(message(sk, q).find("rotation[1][0]"), std::string::npos);
    q = p;
    q.scale.pop_back();
    EXPECT_NE(message(sk, q).find("scale"), std::string::npos);
    EXPECT_THROW(virtual_vertex_error(sk, p, p, -1.0), InvalidArgument);
}

TEST(SkeletonReduce, DominantShellBudgetsOfAChain) {
    std::vector<BoneSpec> specs(2);
    specs[0].length = 1.0;
    specs[1].parent = 0;
    specs[1].connected = true;
    specs[1].length = 0.5;
    const Skeleton sk = skeleton_of(specs);
    SkeletonPose p;
    p.samples = 1;
    p.location = {Vec3(0.0), Vec3(0.0)};
    p.rotation = {Quat(1, 0, 0, 0), Quat(1, 0, 0, 0)};
    p.scale = {Vec3(1.0), Vec3(1.0)};
    const std::vector<double> b = dominant_shell_budgets(sk, pose_matrices(sk, p), 1, 0.001, 0.1);
    // Root: the farthest vertex is the child's tail, 1.5 away; the child: its own tail, 0.5.
    EXPECT_NEAR(b[0], 0.001 / 1.5, 1e-15);
    EXPECT_NEAR(b[1], 0.001 / 0.5, 1e-15);
}

namespace {

// Smooth random motion of every bone over n frames in its rotation mode.
std::vector<BoneChannels> random_motion(std::mt19937& rng, std::size_t bones, std::size_t n) {
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::vector<BoneChannels> out(bones);
    for (std::size_t b = 0; b < bones; ++b) {
        const int kind = static_cast<int>(b % 3);
        out[b].mode = parse_rotation_mode(kind == 0 ? "QUATERNION" : kind == 1 ? "YXZ" : "XYZ");
        double f[3], ph[3], am[3];
        for (int a = 0; a < 3; ++a) f[a] = 0.02 + 0.1 * std::abs(u(rng)), ph[a] = 3 * u(rng), am[a] = 0.8 * u(rng);
        std::vector<Quat> q(n);
        for (std::size_t s = 0; s < n; ++s) {
            const double t = static_cast<double>(s);
            const Vec3 e(am[0] * std::sin(f[0] * t + ph[0]), am[1] * std::sin(f[1] * t + ph[1]),
                         am[2] * std::sin(f[2] * t + ph[2]) + 0.0005 * u(rng));  // a little capture noise
            if (kind == 0) {
                q[s] = euler_to_quat(e, EulerOrder::XYZ);
            } else {
                out[b].values.insert(out[b].values.end(), {e.x, e.y, e.z});
            }
        }
        if (kind == 0) out[b].values = quats_to_channels(q, out[b].mode);
    }
    return out;
}

}  // namespace

TEST(SkeletonReduce, DistanceBoundHoldsOnRandomSkeletons) {
    std::mt19937 rng(2929);
    for (int trial = 0; trial < 6; ++trial) {
        const std::vector<BoneSpec> specs = random_specs(rng, 4 + 3 * trial, true);
        const Skeleton sk = skeleton_of(specs);
        const std::size_t n = 60;
        std::vector<double> times(n);
        for (std::size_t s = 0; s < n; ++s) times[s] = 1.0 + static_cast<double>(s);
        const std::vector<BoneChannels> rot = random_motion(rng, specs.size(), n);
        SkeletonPose original = random_pose(rng, specs, n);  // locations and scales (kept)
        for (std::size_t b = 0; b < specs.size(); ++b)
            for (std::size_t s = 0; s < n; ++s) {
                original.rotation[b * n + s] = channels_to_quat(&rot[b].values[s * channel_count(rot[b].mode)], rot[b].mode);
                original.location[b * n + s] = original.location[b * n] * (1.0 + 0.01 * static_cast<double>(s));
            }
        const double distance = 0.001, shell = 0.1;
        const KeyInterpolation ipo = trial % 2 ? KeyInterpolation::LINEAR : KeyInterpolation::BEZIER;
        const SkeletonReduction r =
            reduce_skeleton(sk, times, rot, original.location, original.scale, distance, shell, ipo, trial % 3 == 0);
        ASSERT_EQ(r.keys.size(), specs.size());
        // Independently: Blender's evaluation of every key, posed, against the original.
        SkeletonPose reduced = original;
        std::size_t keys = 0;
        for (std::size_t b = 0; b < specs.size(); ++b) {
            const std::size_t c = channel_count(rot[b].mode);
            ASSERT_EQ(r.keys[b].channels.size(), c);
            for (std::size_t s = 0; s < n; ++s) {
                std::vector<double> row(c);
                for (std::size_t k = 0; k < c; ++k)
                    row[k] = blender_evaluate(r.keys[b].channels[k], r.keys[b].interpolation, static_cast<float>(times[s]));
                reduced.rotation[b * n + s] = channels_to_quat(row.data(), rot[b].mode);
            }
            keys += r.keys[b].key_count();
            EXPECT_GT(r.budgets[b], 0.0);
        }
        const VertexError e = virtual_vertex_error(sk, original, reduced, shell);
        EXPECT_LE(e.distance, distance) << "trial " << trial;
        EXPECT_NEAR(e.distance, r.error.distance, 1e-12);
        EXPECT_EQ(keys, r.key_count());
        std::size_t dense = 0;
        for (const BoneChannels& b : rot) dense += n * channel_count(b.mode);
        EXPECT_LT(keys, ipo == KeyInterpolation::BEZIER ? dense / 2 : dense) << "trial " << trial;
    }
}

TEST(SkeletonReduce, RefusesBadInput) {
    std::vector<BoneSpec> specs(1);
    const Skeleton sk = skeleton_of(specs);
    std::vector<BoneChannels> rot(1);
    rot[0].mode = parse_rotation_mode("XYZ");
    rot[0].values = {0, 0, 0, 0.1, 0, 0};
    const std::vector<Vec3> loc(2, Vec3(0.0)), scale(2, Vec3(1.0));
    EXPECT_NO_THROW(reduce_skeleton(sk, {1.0, 2.0}, rot, loc, scale, 0.001, 0.1));
    EXPECT_THROW(reduce_skeleton(sk, {1.0, 2.0}, rot, loc, scale, 0.0, 0.1), InvalidArgument);
    EXPECT_THROW(reduce_skeleton(sk, {1.0, 2.0}, rot, loc, scale, 0.001, NAN), InvalidArgument);
    EXPECT_THROW(reduce_skeleton(sk, {1.0, 2.0, 3.0}, rot, {Vec3(0.0)}, scale, 0.001, 0.1), InvalidArgument);
    EXPECT_THROW(reduce_skeleton(sk, {2.0, 1.0}, rot, loc, scale, 0.001, 0.1), InvalidArgument);
}

// ---- slerp keys (glTF LINEAR samplers) under a distance bound ---------------------------------------

namespace {

// glTF 2.0 Appendix C written out: the keys as float32, the shortest way between the two around t.
Quat spec_play(const std::vector<double>& kt, const std::vector<Quat>& kq, double t) {
    auto stored = [&](std::size_t i) {
        const Quat q(static_cast<float>(kq[i].w), static_cast<float>(kq[i].x), static_cast<float>(kq[i].y),
                     static_cast<float>(kq[i].z));
        return glm::normalize(q);
    };
    if (t <= kt.front()) return stored(0);
    if (t >= kt.back()) return stored(kt.size() - 1);
    std::size_t j = 1;
    while (kt[j] <= t) ++j;
    const Quat a = stored(j - 1);
    Quat b = stored(j);
    double d = glm::dot(a, b);
    if (d < 0.0) b = -b, d = -d;
    const double u = (t - kt[j - 1]) / (kt[j] - kt[j - 1]);
    const double angle = std::acos(std::min(1.0, d));
    if (angle < 1e-9) return glm::normalize(a * (1.0 - u) + b * u);
    return glm::normalize(a * (std::sin(angle * (1.0 - u)) / std::sin(angle)) + b * (std::sin(angle * u) / std::sin(angle)));
}

}  // namespace

TEST(SkeletonSlerp, PlaySlerpKeysIsGltfsSlerpClampedOrWrapped) {
    const std::vector<double> kt = {2.0, 5.0, 9.0};
    const std::vector<Quat> kq = {Quat(1, 0, 0, 0), euler_to_quat(Vec3(0.4, 0, 0), EulerOrder::XYZ),
                                  -euler_to_quat(Vec3(0.4, 1.0, 0), EulerOrder::XYZ)};
    const std::vector<double> at = {0.0, 2.0, 3.5, 5.0, 7.25, 9.0, 12.0};
    const std::vector<Quat> got = play_slerp_keys(kt, kq, at);
    for (std::size_t i = 0; i < at.size(); ++i)
        EXPECT_LT(angle_between(got[i], spec_play(kt, kq, at[i])), 1e-7) << "t " << at[i];
    // A loop: one period [2, 9] repeats (its last key is its first rotation).
    const std::vector<Quat> loop = {kq[0], kq[1], -kq[0]};
    const std::vector<Quat> wrapped = play_slerp_keys(kt, loop, {3.5, 3.5 + 7.0, 3.5 - 14.0}, true);
    EXPECT_LT(angle_between(wrapped[0], wrapped[1]), 1e-9);
    EXPECT_LT(angle_between(wrapped[0], wrapped[2]), 1e-9);
    EXPECT_THROW(play_slerp_keys({}, {}, {1.0}), InvalidArgument);
    EXPECT_THROW(play_slerp_keys(kt, {kq[0]}, {1.0}), InvalidArgument);
    EXPECT_THROW(play_slerp_keys({2.0, 1.0}, {kq[0], kq[1]}, {1.0}), InvalidArgument);
    EXPECT_THROW(play_slerp_keys(kt, kq, {NAN}), InvalidArgument);
}

TEST(SkeletonSlerp, DistanceBoundHoldsAndEachBoneIsProvedBetweenSamples) {
    std::mt19937 rng(4141);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int trial = 0; trial < 4; ++trial) {
        const std::vector<BoneSpec> specs = random_specs(rng, 4 + 3 * trial, true);
        const Skeleton sk = skeleton_of(specs);
        const std::size_t n = 50, bones = specs.size();
        std::vector<double> times(n), dense;
        for (std::size_t s = 0; s < n; ++s) times[s] = 1.0 + static_cast<double>(s);
        for (std::size_t s = 0; s + 1 < n; ++s)
            for (int k = 0; k < 4; ++k) dense.push_back(times[s] + 0.25 * k);
        dense.push_back(times.back());
        const std::vector<BoneChannels> rot = random_motion(rng, bones, n);
        SkeletonPose original = random_pose(rng, specs, n);  // locations and scales (kept)
        std::vector<std::shared_ptr<const Motion>> curves(bones);
        std::vector<SlerpBone> spec(bones);
        for (std::size_t b = 0; b < bones; ++b) {
            // Bone 1 keeps its rotation; bone 2 is held at its samples; the others are proved
            // against a SQUAD curve through the frames' rotations.
            std::vector<Quat> keys(n);
            for (std::size_t s = 0; s < n; ++s)
                keys[s] = channels_to_quat(&rot[b].values[s * channel_count(rot[b].mode)], rot[b].mode);
            hemisphere_continuous(keys.data(), n);
            curves[b] = std::make_shared<OwnedCurveMotion>(Curve(times, keys, Method::SQUAD));
            for (std::size_t s = 0; s < n; ++s) original.rotation[b * n + s] = curves[b]->at(times[s]);
            spec[b].times = dense;
            if (b == 1) {
                spec[b].reduce = false;
            } else if (b == 2) {
                for (double t : dense) spec[b].samples.push_back(curves[b]->at(t));
            } else {
                spec[b].reference = curves[b];
            }
        }
        const double distance = 0.005, shell = 0.1;
        const SkeletonSlerpReduction r =
            reduce_skeleton_slerp(sk, times, original.rotation, original.location, original.scale, distance, shell, spec);
        ASSERT_EQ(r.keys.size(), bones);
        // Independently: the keys played as glTF's specification says, posed, against the original.
        SkeletonPose played = original;
        std::size_t keys = 0;
        for (std::size_t b = 0; b < bones; ++b) {
            const ProvedSlerpKeys& k = r.keys[b];
            if (b == 1) {
                EXPECT_TRUE(k.keys.indices.empty());
                continue;
            }
            std::vector<double> kt;
            for (std::size_t i : k.keys.indices) kt.push_back(k.times[i]);
            ASSERT_GE(kt.size(), 2u);
            EXPECT_EQ(kt.front(), dense.front());
            EXPECT_EQ(kt.back(), dense.back());
            for (std::size_t s = 0; s < n; ++s) played.rotation[b * n + s] = spec_play(kt, k.keys.quats, times[s]);
            keys += kt.size();
            // Each proved bone within its budget at 64 points per frame, denser than its samples.
            if (b != 2) {
                EXPECT_TRUE(k.proof.proven()) << "trial " << trial << " bone " << b;
                double worst = 0.0;
                for (double t = dense.front(); t <= dense.back(); t += 1.0 / 64.0)
                    worst = std::max(worst, angle_between(spec_play(kt, k.keys.quats, t), curves[b]->at(t)));
                for (int i = 0; i < 100; ++i) {
                    const double t = dense.front() + u(rng) * (dense.back() - dense.front());
                    worst = std::max(worst, angle_between(spec_play(kt, k.keys.quats, t), curves[b]->at(t)));
                }
                EXPECT_LE(worst, r.budgets[b] + 1e-6) << "trial " << trial << " bone " << b;
            } else {
                EXPECT_FALSE(k.proof.proven());
            }
        }
        const VertexError e = virtual_vertex_error(sk, original, played, shell);
        EXPECT_LE(e.distance, distance) << "trial " << trial;
        EXPECT_NEAR(e.distance, r.error.distance, 1e-9);
        EXPECT_EQ(keys, r.key_count());
        EXPECT_LT(keys, (bones - 1) * n / 2) << "trial " << trial;
    }
}

TEST(SkeletonSlerp, RefusesBadInput) {
    std::vector<BoneSpec> specs(1);
    const Skeleton sk = skeleton_of(specs);
    const std::vector<Quat> rot = {Quat(1, 0, 0, 0), Quat(1, 0, 0, 0)};
    const std::vector<Vec3> loc(2, Vec3(0.0)), scale(2, Vec3(1.0));
    std::vector<SlerpBone> bones(1);
    bones[0].times = {1.0, 2.0};
    bones[0].samples = rot;
    EXPECT_NO_THROW(reduce_skeleton_slerp(sk, {1.0, 2.0}, rot, loc, scale, 0.001, 0.1, bones));
    EXPECT_THROW(reduce_skeleton_slerp(sk, {1.0, 2.0}, rot, loc, scale, 0.0, 0.1, bones), InvalidArgument);
    EXPECT_THROW(reduce_skeleton_slerp(sk, {1.0, 2.0}, rot, loc, scale, 0.001, -1.0, bones), InvalidArgument);
    EXPECT_THROW(reduce_skeleton_slerp(sk, {2.0, 1.0}, rot, loc, scale, 0.001, 0.1, bones), InvalidArgument);
    EXPECT_THROW(reduce_skeleton_slerp(sk, {1.0, 2.0}, rot, loc, scale, 0.001, 0.1, {}), InvalidArgument);
    std::vector<SlerpBone> short_samples = bones;
    short_samples[0].samples.pop_back();
    EXPECT_THROW(reduce_skeleton_slerp(sk, {1.0, 2.0}, rot, loc, scale, 0.001, 0.1, short_samples), InvalidArgument);
    std::vector<SlerpBone> one_time = bones;
    one_time[0].times = {1.0};
    EXPECT_THROW(reduce_skeleton_slerp(sk, {1.0, 2.0}, rot, loc, scale, 0.001, 0.1, one_time), InvalidArgument);
    EXPECT_THROW(reduce_skeleton_slerp(sk, {1.0, 2.0}, {rot[0]}, loc, scale, 0.001, 0.1, bones), InvalidArgument);
}
