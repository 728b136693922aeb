// Blender's pose of a skeleton (forward kinematics), its virtual vertices and the virtual-vertex
// error of two motions (skeleton.hpp).
#include "quatcurve/skeleton.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "quatcurve/errors.hpp"
#include "quatcurve/quat.hpp"
#include "skeleton_impl.hpp"

namespace quatcurve {

namespace {

// How far a rest matrix's 3x3 may be from orthonormal (check_skeleton): 75 times the drift Blender's
// float32 bone.matrix_local was seen to reach, 1,000 times below a 0.1 % scale.
constexpr double kRestRigidSlack = 1e-3;

std::string at(const char* array, std::size_t bone) { return std::string(array) + "[" + std::to_string(bone) + "]"; }

std::string at(const char* name, const char* array, std::size_t bone, std::size_t sample) {
    return std::string(name) + "." + array + "[" + std::to_string(bone) + "][" + std::to_string(sample) + "]";
}

// Blender's orthogonalize_stable(v1, v2, v3, normalize = true) with v1 the Y axis: X and Z projected
// off Y, then turned symmetrically (half the shear angle each) until orthogonal, all unit length.
Mat4 orthonormal_around_y(const Mat4& m) {
    Vec3 y(m[1]), x(m[0]), z(m[2]);
    const double yy = glm::dot(y, y);
    if (yy > 0.0) {
        x -= y * (glm::dot(x, y) / yy);
        z -= y * (glm::dot(z, y) / yy);
        y /= std::sqrt(yy);
    }
    const double lx = glm::length(x), lz = glm::length(z);
    Vec3 nx = lx > 0.0 ? x / lx : x, nz = lz > 0.0 ? z / lz : z;
    const double c = glm::dot(nx, nz);
    if (std::abs(c) > 1e-4 && std::abs(c) < 1.0 - 1.1920929e-7) {
        const double angle = std::acos(c);
        const double target = angle + (0.5 * 3.14159265358979323846 - angle) / 2.0;
        nx -= nz * c;
        nx *= std::sin(target) / glm::length(nx);
        nx += nz * std::cos(target);
        nz = glm::normalize(glm::cross(glm::cross(nx, nz), nx));
    }
    Mat4 out = m;
    out[0] = Vec4(nx, m[0][3]);
    out[1] = Vec4(y, m[1][3]);
    out[2] = Vec4(nz, m[2][3]);
    return out;
}

}  // namespace

namespace detail {

Mat4 local_matrix(const Vec3& location, const Quat& rotation, const Vec3& scale, bool connected) {
    const Quat q = rotation / std::sqrt(glm::dot(rotation, rotation));
    const Mat3 r = glm::mat3_cast(q);
    Mat4 m(1.0);
    for (int c = 0; c < 3; ++c) m[c] = Vec4(r[c] * scale[c], 0.0);
    if (!connected) m[3] = Vec4(location, 1.0);
    return m;
}

ParentTransform parent_transform(const Skeleton& skeleton, const std::vector<Mat4>& offsets, std::size_t bone,
                                 const Mat4* parent_pose) {
    ParentTransform t;
    const int p = skeleton.parents[bone];
    if (p < 0 || parent_pose == nullptr) {
        t.rotscale = t.loc = skeleton.rest[bone];
        return t;
    }
    const Mat4& offs = offsets[bone];
    const bool use_rotation = skeleton.inherit_rotation[bone] != 0;
    const bool full = skeleton.inherit_scale[bone] == InheritScale::FULL;
    if (use_rotation && full) {
        t.rotscale = t.loc = *parent_pose * offs;
        return t;
    }
    Mat4 tmat;
    if (use_rotation) {
        tmat = orthonormal_around_y(*parent_pose);  // inherit scale NONE
    } else {
        tmat = skeleton.rest[p];
        if (full)
            for (int c = 0; c < 3; ++c) tmat[c] *= glm::length(Vec3((*parent_pose)[c]));
    }
    t.rotscale = tmat * offs;
    t.loc = *parent_pose * offs;
    return t;
}

Mat4 apply(const ParentTransform& t, const Mat4& local) {
    Mat4 out = t.rotscale * local;
    out[3] = t.loc * Vec4(Vec3(local[3]), 1.0);
    return out;
}

std::vector<Mat4> rest_offsets(const Skeleton& skeleton) {
    std::vector<Mat4> offs(skeleton.size(), Mat4(1.0));
    for (std::size_t b = 0; b < skeleton.size(); ++b)
        if (skeleton.parents[b] >= 0) offs[b] = glm::inverse(skeleton.rest[skeleton.parents[b]]) * skeleton.rest[b];
    return offs;
}

Mat4 pose_bone(const Skeleton& skeleton, const std::vector<Mat4>& offsets, std::size_t bone, const Mat4* parent_pose,
               const Vec3& location, const Quat& rotation, const Vec3& scale) {
    return apply(parent_transform(skeleton, offsets, bone, parent_pose),
                 local_matrix(location, rotation, scale, skeleton.connected[bone] != 0));
}

void bone_vertices(const Mat4& pose, double length, double shell, Vec3* out) {
    const Vec3 head(pose[3]);
    out[0] = head + Vec3(pose[1]) * length;
    out[1] = head + Vec3(pose[0]) * shell;
    out[2] = head + Vec3(pose[1]) * shell;
    out[3] = head + Vec3(pose[2]) * shell;
}

void check_shell(double shell) {
    if (!std::isfinite(shell) || shell < 0.0) throw InvalidArgument("shell: must be finite and >= 0");
}

}  // namespace detail

void check_skeleton(const Skeleton& s) {
    const std::size_t n = s.size();
    auto sized = [n](std::size_t size, const char* name) {
        if (size != n)
            throw InvalidArgument(std::string(name) + ": " + std::to_string(size) + " entries for " +
                                  std::to_string(n) + " bones");
    };
    sized(s.rest.size(), "rest");
    sized(s.lengths.size(), "lengths");
    sized(s.inherit_rotation.size(), "inherit_rotation");
    sized(s.connected.size(), "connected");
    sized(s.inherit_scale.size(), "inherit_scale");
    for (std::size_t b = 0; b < n; ++b) {
        if (s.parents[b] < -1 || s.parents[b] >= static_cast<int>(b))
            throw InvalidArgument(at("parents", b) + ": " + std::to_string(s.parents[b]) +
                                  " is not -1 or an earlier bone (parents come before their children)");
        const Mat4& m = s.rest[b];
        const std::string problem = finite_problem(m);
        if (!problem.empty()) throw InvalidArgument(at("rest", b) + ": " + problem);
        if (m[0][3] != 0.0 || m[1][3] != 0.0 || m[2][3] != 0.0 || m[3][3] != 1.0)
            throw InvalidArgument(at("rest", b) + ": the last row must be 0 0 0 1");
        // Blender's float32 bone.matrix_local drifts from orthonormal down a chain (|RᵀR − I| = 1.3e-5
        // three bones deep, at a 2 cm bone), and posing inverts the rest matrices as Blender does, not
        // by transposing: only a scale or shear is refused.
        const Mat3 r(m);
        const Mat3 e = glm::transpose(r) * r;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                if (std::abs(e[i][j] - (i == j ? 1.0 : 0.0)) > kRestRigidSlack)
                    throw InvalidArgument(at("rest", b) + ": not a rigid transform (its 3x3 is not orthonormal: |RᵀR − I| = " +
                                          std::to_string(std::abs(e[i][j] - (i == j ? 1.0 : 0.0))) + ")");
        if (glm::determinant(r) < 0.0) throw InvalidArgument(at("rest", b) + ": a reflection, not a rotation");
        if (!std::isfinite(s.lengths[b]) || s.lengths[b] < 0.0)
            throw InvalidArgument(at("lengths", b) + ": must be finite and >= 0");
    }
}

void check_pose(const Skeleton& skeleton, const SkeletonPose& pose, const char* name) {
    const std::size_t count = skeleton.size() * pose.samples;
    auto sized = [&](std::size_t size, const char* array) {
        if (size != count)
            throw InvalidArgument(std::string(name) + "." + array + ": " + std::to_string(size) + " entries for " +
                                  std::to_string(skeleton.size()) + " bones x " + std::to_string(pose.samples) +
                                  " samples");
    };
    sized(pose.location.size(), "location");
    sized(pose.rotation.size(), "rotation");
    sized(pose.scale.size(), "scale");
    const std::size_t n = pose.samples;
    for (std::size_t k = 0; k < count; ++k) {
        std::string problem = finite_problem(pose.location[k]);
        if (!problem.empty()) throw InvalidArgument(at(name, "location", k / n, k % n) + ": " + problem);
        problem = finite_problem(pose.scale[k]);
        if (!problem.empty()) throw InvalidArgument(at(name, "scale", k / n, k % n) + ": " + problem);
        problem = finite_problem(pose.rotation[k]);
        if (problem.empty()) problem = nonzero_problem(pose.rotation[k]);
        if (!problem.empty()) throw InvalidArgument(at(name, "rotation", k / n, k % n) + ": " + problem);
    }
}

std::vector<Mat4> pose_matrices(const Skeleton& skeleton, const SkeletonPose& pose) {
    check_skeleton(skeleton);
    check_pose(skeleton, pose);
    const std::size_t n = pose.samples;
    const std::vector<Mat4> offs = detail::rest_offsets(skeleton);
    std::vector<Mat4> out(skeleton.size() * n);
    for (std::size_t b = 0; b < skeleton.size(); ++b) {
        const int p = skeleton.parents[b];
        for (std::size_t s = 0; s < n; ++s) {
            const std::size_t k = b * n + s;
            out[k] = detail::pose_bone(skeleton, offs, b, p < 0 ? nullptr : &out[p * n + s], pose.location[k],
                                       pose.rotation[k], pose.scale[k]);
            if (!finite_problem(out[k]).empty())
                throw InvalidArgument(at("pose", "matrix", b, s) + ": overflows double precision (the input is too large)");
        }
    }
    return out;
}

std::vector<Vec3> virtual_vertices(const Skeleton& skeleton, const std::vector<Mat4>& pose, std::size_t samples,
                                   double shell) {
    detail::check_shell(shell);
    if (pose.size() != skeleton.size() * samples)
        throw InvalidArgument("pose: " + std::to_string(pose.size()) + " matrices for " +
                              std::to_string(skeleton.size()) + " bones x " + std::to_string(samples) + " samples");
    if (skeleton.lengths.size() != skeleton.size())
        throw InvalidArgument("lengths: " + std::to_string(skeleton.lengths.size()) + " entries for " +
                              std::to_string(skeleton.size()) + " bones");
    std::vector<Vec3> out(pose.size() * kVirtualVertices);
    for (std::size_t k = 0; k < pose.size(); ++k) {
        detail::bone_vertices(pose[k], skeleton.lengths[k / std::max<std::size_t>(samples, 1)], shell,
                              &out[k * kVirtualVertices]);
        for (int v = 0; v < kVirtualVertices; ++v)
            if (!finite_problem(out[k * kVirtualVertices + v]).empty())
                throw InvalidArgument(at("pose", "vertex", k / std::max<std::size_t>(samples, 1),
                                         k % std::max<std::size_t>(samples, 1)) +
                                      ": overflows double precision (the input is too large)");
    }
    return out;
}

VertexError detail::vertex_error(const std::vector<Vec3>& a, const std::vector<Vec3>& b, std::size_t bones,
                                 std::size_t samples) {
    VertexError e;
    e.per_bone.assign(bones, 0.0);
    for (std::size_t bone = 0; bone < bones; ++bone)
        for (std::size_t s = 0; s < samples; ++s)
            for (int v = 0; v < kVirtualVertices; ++v) {
                const std::size_t k = (bone * samples + s) * kVirtualVertices + v;
                const double d = glm::length(a[k] - b[k]);
                if (d > e.per_bone[bone]) e.per_bone[bone] = d;
                if (d > e.distance || e.bone < 0) {
                    e.distance = d;
                    e.bone = static_cast<int>(bone);
                    e.vertex = v;
                    e.sample = s;
                }
            }
    return e;
}

namespace {

// The virtual vertices of two motions of the skeleton (a's, then b's), their inputs checked.
std::pair<std::vector<Vec3>, std::vector<Vec3>> vertices_of_both(const Skeleton& skeleton, const SkeletonPose& a,
                                                                const SkeletonPose& b, double shell) {
    detail::check_shell(shell);
    if (a.samples != b.samples)
        throw InvalidArgument("b: " + std::to_string(b.samples) + " samples, a has " + std::to_string(a.samples));
    check_skeleton(skeleton);
    check_pose(skeleton, a, "a");
    check_pose(skeleton, b, "b");
    return {virtual_vertices(skeleton, pose_matrices(skeleton, a), a.samples, shell),
            virtual_vertices(skeleton, pose_matrices(skeleton, b), b.samples, shell)};
}

}  // namespace

VertexError virtual_vertex_error(const Skeleton& skeleton, const SkeletonPose& a, const SkeletonPose& b,
                                 double shell) {
    const auto [va, vb] = vertices_of_both(skeleton, a, b, shell);
    const VertexError e = detail::vertex_error(va, vb, skeleton.size(), a.samples);
    if (!std::isfinite(e.distance))
        throw InvalidArgument("b: its distance from a overflows double precision (the input is too large)");
    return e;
}

std::vector<double> virtual_vertex_distances(const Skeleton& skeleton, const SkeletonPose& a, const SkeletonPose& b,
                                             double shell) {
    const auto [va, vb] = vertices_of_both(skeleton, a, b, shell);
    std::vector<double> out(skeleton.size() * a.samples, 0.0);
    for (std::size_t k = 0; k < out.size(); ++k)
        for (int v = 0; v < kVirtualVertices; ++v) {
            const double d = glm::length(va[k * kVirtualVertices + v] - vb[k * kVirtualVertices + v]);
            if (!std::isfinite(d))
                throw InvalidArgument("b: its distance from a overflows double precision (the input is too large)");
            out[k] = std::max(out[k], d);
        }
    return out;
}

}  // namespace quatcurve
