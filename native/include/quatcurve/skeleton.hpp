// Skeletons: Blender's pose of an armature's bones from their local channels (forward kinematics),
// the virtual-vertex error of two motions in armature object space, and key reduction of every
// bone's rotation under one distance bound on that error.
//
// Conventions: quaternions (w, x, y, z) at the array edges (Quat inside), radians, time in frames,
// lengths in scene units. Matrices are GLM's (column vectors, m[col][row]); a bone's rest matrix is
// Blender's `bone.matrix_local` (armature space, rotation and translation only).
//
// The pose, as BKE_armature.cc computes it (BKE_pchan_to_mat4, BKE_bone_parent_transform_calc_from_
// matrices, BKE_bone_parent_transform_apply), for bone i with parent p:
//
//   local_i  = [R(q_i)·S(s_i) | l_i]   (the location l_i is NOT applied to a connected bone: 0)
//   offs_i   = rest_p⁻¹ · rest_i        (Blender's bone_mat, head and parent length)
//   inherit rotation, inherit scale FULL:  rotscale = locmat = pose_p · offs_i
//   otherwise:                             rotscale = T · offs_i,  locmat = pose_p · offs_i, where
//       T = pose_p             with its axes made orthonormal around Y (orthogonalize_m4_stable(·, 1,
//                              true)) for inherit scale NONE, as is for FULL;
//       T = rest_p             (Inherit Rotation off) scaled along its axes by the lengths of pose_p's
//                              axes for FULL, unscaled for NONE;
//   pose_i   = rotscale · local_i, with its translation replaced by locmat · l_i
//   (a root: rotscale = locmat = rest_i, so pose_i = rest_i · local_i).
// Not modelled: constraints, drivers, B-Bone segments, "Local Location" off, inherit scale modes
// other than FULL and NONE (AVERAGE, FIX_SHEAR, ALIGNED, NONE_LEGACY), the armature object's own
// transform (everything is in armature object space).
//
// Virtual vertices of a posed bone (ACL's error metric with Blender's tail added): the points
//   tail (0, length, 0), shell·X (shell, 0, 0), shell·Y (0, shell, 0), shell·Z (0, 0, shell)
// of the bone's local space, through its pose matrix (so the bone's own scale scales them, as it
// scales a skinned mesh). An object (not a bone) is a one-bone skeleton of length 0: its three shell
// points (the tail is its head).
#pragma once

#include <cstddef>
#include <memory>
#include <utility>
#include <vector>

#include "quatcurve/blender_eval.hpp"
#include "quatcurve/channels.hpp"
#include "quatcurve/reduce.hpp"
#include "quatcurve/slerp_keys.hpp"
#include "quatcurve/types.hpp"

namespace quatcurve {

// Blender's Bone.inherit_scale, the two modes modelled.
enum class InheritScale { FULL, NONE };

// The armature's bones as plain arrays, one entry per bone. Parents come before their children.
struct Skeleton {
    std::vector<int> parents;                      // −1 for a root, else an index < the bone's own
    std::vector<Mat4> rest;                        // bone.matrix_local (rigid: rotation + translation)
    std::vector<double> lengths;                   // bone.length, ≥ 0 (the tail is at (0, length, 0))
    std::vector<unsigned char> inherit_rotation;   // bone.use_inherit_rotation (1: Blender's default)
    std::vector<unsigned char> connected;          // bone.use_connect (the location channel is unused)
    std::vector<InheritScale> inherit_scale;       // bone.inherit_scale
    std::size_t size() const { return parents.size(); }
};

// Throws InvalidArgument naming the array and bone unless every array has size() entries, each parent
// is −1 or an earlier bone, rest matrices are finite and rigid (orthonormal 3×3 with determinant +1
// within 1e-5, last row 0 0 0 1), lengths finite and ≥ 0.
void check_skeleton(const Skeleton& skeleton);

// The local channels of every bone at `samples` samples, bone-major: entry [bone·samples + sample].
// Rotations need not be unit (normalized as Blender normalizes them); a zero one is refused.
struct SkeletonPose {
    std::size_t samples = 0;
    std::vector<Vec3> location;  // pose_bone.location
    std::vector<Quat> rotation;  // the rotation Blender builds from the bone's rotation channels
    std::vector<Vec3> scale;     // pose_bone.scale
};

// Throws InvalidArgument (naming `name`, the array, bone and sample) unless `pose` has
// skeleton.size()·samples finite entries in each array and no zero rotation.
void check_pose(const Skeleton& skeleton, const SkeletonPose& pose, const char* name = "pose");

// Blender's pose_bone.matrix (armature space) of every bone at every sample, [bone·samples + sample]
// (formulas above). Throws as check_skeleton and check_pose.
std::vector<Mat4> pose_matrices(const Skeleton& skeleton, const SkeletonPose& pose);

// The four virtual vertices per bone and sample, [(bone·samples + sample)·4 + k], k = 0 tail, 1..3 the
// shell points along X, Y, Z, from pose matrices as pose_matrices returns them. shell: finite, ≥ 0.
constexpr int kVirtualVertices = 4;
std::vector<Vec3> virtual_vertices(const Skeleton& skeleton, const std::vector<Mat4>& pose, std::size_t samples,
                                   double shell);

// The largest distance between the same virtual vertex in two motions, and where it is.
struct VertexError {
    double distance = 0.0;          // max over bones, samples and vertices (scene units)
    int bone = -1;                  // where it is (−1: no bone or no sample)
    int vertex = -1;                // 0 tail, 1..3 shell X, Y, Z
    std::size_t sample = 0;
    std::vector<double> per_bone;   // the max over samples and vertices of each bone
};

// The virtual-vertex error of motions a and b of one skeleton (same sample count). Throws as
// pose_matrices, for a sample count that differs, and for a shell that is not finite and ≥ 0.
VertexError virtual_vertex_error(const Skeleton& skeleton, const SkeletonPose& a, const SkeletonPose& b,
                                 double shell);

// The same distances, not reduced to their maximum: per bone and sample the largest of its four virtual
// vertices' distances, [bone·samples + sample] (callers that leave some samples out of a bound, as the
// clean leaves out its spike frames, take their maximum over the rest). Throws as virtual_vertex_error.
std::vector<double> virtual_vertex_distances(const Skeleton& skeleton, const SkeletonPose& a, const SkeletonPose& b,
                                             double shell);

// ---- key reduction under a distance bound ---------------------------------------------------------
//
// Per-bone angular budgets of ACL's dominant shells: budget_i = distance / R_i, where R_i is the
// largest distance, over the samples of `pose` (pose_matrices' output), from bone i's head to any
// virtual vertex of bone i and its descendants. A bone with R_i = 0 moves nothing: budget π.
// A rotation error of ε at bone i alone moves no vertex by more than ε·R_i, so these budgets bound a
// chain of one reduced bone; a whole chain adds its bones' shares (reduce_skeleton verifies it).
std::vector<double> dominant_shell_budgets(const Skeleton& skeleton, const std::vector<Mat4>& pose,
                                           std::size_t samples, double distance, double shell);

// One bone's rotation channels sampled at the skeleton's times: n rows of channel_count(mode) values
// (Blender's evaluation of its keys, as reduce.py reads them; a bone without rotation keys holds its
// constant value in every row). reduce false: the bone's rotation is kept as sampled (a bone the
// caller does not reduce, or without rotation keys) and its ReducedKeys are empty (no channels).
struct BoneChannels {
    RotationMode mode;
    std::vector<double> values;
    bool reduce = true;
};

inline std::size_t count_keys(const ReducedKeys& keys) { return keys.key_count(); }
inline std::size_t count_keys(const ProvedSlerpKeys& keys) { return keys.keys.indices.size(); }

// The keys each bone's rotation was reduced to, under one distance bound, verified.
template <class Keys>
struct SkeletonReductionOf {
    std::vector<Keys> keys;         // per bone: its keys (empty for a bone kept as it is)
    std::vector<double> budgets;    // per bone: the angular tolerance (radians) its keys were reduced at
    VertexError error;              // verified: reduced vs original, every bone, sample and vertex
    int rounds = 0;                 // reductions of the skeleton made (each reduces the bones that changed)
    std::size_t key_count() const { // keys summed over bones (and channels)
        std::size_t k = 0;
        for (const Keys& r : keys) k += count_keys(r);
        return k;
    }
};

using SkeletonReduction = SkeletonReductionOf<ReducedKeys>;        // F-curve keys (reduce_keys*)
using SkeletonSlerpReduction = SkeletonReductionOf<ProvedSlerpKeys>;  // glTF LINEAR keys (reduce_slerp*)

// Reduce the rotation keys of every bone so that the virtual vertices of Blender's pose of the
// reduced keys stay within `distance` of the original pose's at every sample (times: the frames
// every bone was sampled at — every whole frame and every original key — strictly increasing and
// still so as float32). locations and scales ([bone·n + sample]) are the bones' own channels, read
// and kept. The reduced keys are evaluated as Blender evaluates them (blender_eval, float32), turned
// into rotations, posed and measured against the original: `error` is that verification, ≤ distance
// unless even every bone at its float32 floor cannot reach it (then the last, tightest, try).
//
// How the budgets are chosen (every candidate verified as above, the passing one with fewest keys
// kept): the dominant-shell budgets scaled by the largest factor that passes (where none passes, one
// angle for every bone, scaled so); then each bone's own share of the error is measured — the virtual vertices of
// its subtree with only that bone reduced — and the budgets are rescaled under a model linear in
// each budget, loosening most the bones whose reduction saves many keys for little error, and
// scaled to pass again; last, each bone is loosened on its own (×2, ×√2, ×2^¼, most keys first)
// where the whole skeleton still passes.
// Throws InvalidArgument as check_skeleton, for channel or row counts that do not match, for times
// as reduce_keys, and for distance or shell not finite and ≥ 0 (distance > 0).
SkeletonReduction reduce_skeleton(const Skeleton& skeleton, const std::vector<double>& times,
                                  const std::vector<BoneChannels>& rotations, const std::vector<Vec3>& locations,
                                  const std::vector<Vec3>& scales, double distance, double shell,
                                  KeyInterpolation interpolation = KeyInterpolation::BEZIER,
                                  bool synchronized = false);

// ---- slerp keys (glTF LINEAR rotation samplers) under a distance bound ------------------------------
//
// What a glTF file plays for each bone: keys chosen among its own candidate times (the file's,
// float32 seconds as frames), played by glTF's slerp (slerp_keys.hpp), each bone's keys proved within
// its angular budget of its reference motion at EVERY instant of its times (reduce_slerp_proved), and
// the skeleton posed from the keys (float32, as the file stores them) verified within `distance` of
// the original pose at every sample of `times`, as reduce_skeleton verifies F-curve keys. The budgets
// are chosen by the same stages as reduce_skeleton.
struct SlerpBone {
    // The motion the keys are proved against at every instant; null: the keys hold at `samples` only
    // (reduce_slerp), and the ProvedSlerpKeys' proof says unproven over the whole range.
    std::shared_ptr<const Motion> reference;
    std::vector<double> times;      // candidate key times (frames), increasing: the file's times
    std::vector<Quat> samples;      // with no reference: the motion at `times`
    bool cyclic = false;            // a loop's one period (reduce_slerp's cyclic): played wrapped
    double file_unit = 0.0;         // as reduce_slerp_proved: seconds per frame of the file
    std::vector<std::pair<double, double>> excluded;  // as reduce_slerp_proved (quaternion sign flips)
    bool reduce = true;             // false: the bone keeps its original rotations and gets no keys
};

// Reduce every bone's rotation to slerp keys (above) so that the virtual vertices of the pose they
// play stay within `distance` of the original pose's at every sample of `times` (strictly increasing
// frames: every frame and every original key). rotations: the original rotation of every bone at
// every sample ([bone·n + sample], the reference motions sampled there); locations and scales as
// reduce_skeleton. Throws InvalidArgument as reduce_skeleton, for a bone count that differs, and as
// reduce_slerp_proved for a bone's times.
SkeletonSlerpReduction reduce_skeleton_slerp(const Skeleton& skeleton, const std::vector<double>& times,
                                             const std::vector<Quat>& rotations, const std::vector<Vec3>& locations,
                                             const std::vector<Vec3>& scales, double distance, double shell,
                                             const std::vector<SlerpBone>& bones);

}  // namespace quatcurve
