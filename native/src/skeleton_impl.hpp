// Private to skeleton*.cpp: one bone's pose step and the vertex comparison, shared by the forward
// kinematics (skeleton.cpp) and the reduction under a distance bound (skeleton_reduce.cpp).
#pragma once

#include <cstddef>
#include <vector>

#include "quatcurve/skeleton.hpp"

namespace quatcurve::detail {

// BoneParentTransform: what the parent does to a bone's rotation/scale and to its location.
struct ParentTransform {
    Mat4 rotscale{1.0};
    Mat4 loc{1.0};
};

// [R(q̂)·S(s) | l], l left out for a connected bone (BKE_pchan_to_mat4).
Mat4 local_matrix(const Vec3& location, const Quat& rotation, const Vec3& scale, bool connected);
// rest_p⁻¹·rest_b per bone (identity for roots).
std::vector<Mat4> rest_offsets(const Skeleton& skeleton);
// The parent transform of `bone` (parent_pose: the parent's pose matrix; nullptr for a root).
ParentTransform parent_transform(const Skeleton& skeleton, const std::vector<Mat4>& offsets, std::size_t bone,
                                 const Mat4* parent_pose);
// BKE_bone_parent_transform_apply with post_scale 1.
Mat4 apply(const ParentTransform& t, const Mat4& local);
// The pose matrix of `bone` from its parent's and its channels.
Mat4 pose_bone(const Skeleton& skeleton, const std::vector<Mat4>& offsets, std::size_t bone, const Mat4* parent_pose,
               const Vec3& location, const Quat& rotation, const Vec3& scale);
// The four virtual vertices of one posed bone into out[0..3].
void bone_vertices(const Mat4& pose, double length, double shell, Vec3* out);
void check_shell(double shell);
// The virtual-vertex error of two vertex arrays laid out as virtual_vertices returns them.
VertexError vertex_error(const std::vector<Vec3>& a, const std::vector<Vec3>& b, std::size_t bones,
                         std::size_t samples);

}  // namespace quatcurve::detail
