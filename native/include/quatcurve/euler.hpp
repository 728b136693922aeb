// Euler angles with Blender's semantics: order "XYZ" means R = Rz·Ry·Rx — X is applied first, about
// fixed (world) axes — which is scipy's extrinsic "xyz". In general order "ABC" gives R = Rc·Rb·Ra.
// angles = (ax, ay, az) — the angle about X, about Y, about Z — whatever the order, as in Blender's
// rotation_euler. Radians.
//
// Every rotation has two Euler solutions per order, (a, b, c) and (a+π, π−b, c+π) with b the
// middle angle, each up to 2π per angle; at gimbal lock (cos b = 0) a whole family.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "quatcurve/quat.hpp"

namespace quatcurve {

enum class EulerOrder { XYZ, XZY, YXZ, YZX, ZXY, ZYX };

// "XYZ" … "ZYX" (upper case, as Blender); anything else throws InvalidArgument
// ("order: unknown Euler order 'xyz' (expected one of XYZ, XZY, YXZ, YZX, ZXY, ZYX)").
EulerOrder parse_euler_order(const std::string& name);
const char* euler_order_name(EulerOrder order);

// Rc·Rb·Ra for order "ABC" (the product of the three elementary rotations). Any finite angles.
Mat3 euler_to_matrix(const Vec3& angles, EulerOrder order);
// qc·qb·qa, the product of the three elementary half-angle quaternions: continuous in the angles
// (no sign canonicalization, so w may be negative).
Quat euler_to_quat(const Vec3& angles, EulerOrder order);
// One solution: the middle angle in [−π/2, π/2] (as scipy), the others in [−π, π]. Near gimbal
// lock the last angle is found first and removed from the matrix before the first angle is read,
// so the three stay consistent however close to the lock; at the lock itself (cos of the middle
// angle below 16·ε) the middle angle is exactly ±π/2, the last angle 0 and the first angle takes
// all the rotation. m is first replaced by nearest_rotation(m) (so scale and slight
// non-orthonormality are harmless); throws as nearest_rotation.
Vec3 matrix_to_euler(const Mat3& m, EulerOrder order);
// matrix_to_euler of quat_to_matrix(q̂) (no orthonormalization needed). Throws on zero q.
Vec3 quat_to_euler(const Quat& q, EulerOrder order);
// The Euler angles equivalent to `angles` (same rotation) closest to `ref` by the sum of absolute
// differences: both solutions, each angle shifted by the multiple of 2π nearest to ref (the exact
// minimum; Blender's compatible Euler does this with thresholds). At gimbal lock the family
// (a+t, b, c±t) is searched too, which Blender does not. Ties keep the solution given. Angles
// beyond 65536 rad are first reduced mod 2π through sin and cos (exactly), so any finite angle
// keeps its rotation (adding whole turns to 1e16 rad would cancel its fraction of a turn away).
Vec3 euler_compat(const Vec3& angles, EulerOrder order, const Vec3& ref);
// euler_compat(quat_to_euler(q, order), order, ref). Throws on zero q.
Vec3 quat_to_euler_compat(const Quat& q, EulerOrder order, const Vec3& ref);
// Blender's Quaternion.to_euler(order) (mathutils, in double instead of float32): of the two
// solutions — the middle angle in [−π/2, π/2], or (a+π, π−b, c+π) — each angle in [−π, π], the
// one with the smaller sum of absolute angles (ties: the first). Within 16·FLT_EPSILON of gimbal
// lock (cos of the middle angle), as Blender, the locked solution: middle angle ±π/2, last angle 0.
// Differs from quat_to_euler, which always returns the first solution. Throws on zero q.
Vec3 blender_quat_to_euler(const Quat& q, EulerOrder order);
// Blender's Quaternion.to_euler(order, compat): both solutions, each made compatible with `compat`
// as Blender's compatible_eul does (3.5 on: whole turns bringing each angle within π of compat),
// then the one with the smaller sum of absolute differences from compat (ties: the first). Unlike
// euler_compat it searches no gimbal-lock family. Blender 3.4's compatible_eul moved an angle only
// beyond 5.1 rad from compat: it agrees whenever each angle of the result is within 2π − 5.1 rad
// of compat. Throws on zero q or non-finite compat.
Vec3 blender_quat_to_euler(const Quat& q, EulerOrder order, const Vec3& compat);
// In place over n consecutive triples: each triple after the first becomes euler_compat of itself
// against the (already filtered) previous one. Removes flips between the two solutions and 2π
// jumps without changing any orientation. n = 0 or 1 leaves the array unchanged.
void euler_filter(Vec3* angles, std::size_t n, EulerOrder order);
// euler_filter both ways from the triple farthest from gimbal lock (gimbal_distance; the first of
// equals), which keeps its values: filtering from a locked triple would leave the choice between its
// two (equally near) solutions to rounding, from the farthest one it is unambiguous.
void euler_filter_from_anchor(Vec3* angles, std::size_t n, EulerOrder order);
// Distance (radians, in [0, π/2]) of the middle angle b from the gimbal-lock set b ≡ π/2 (mod π):
// atan2(|cos b|, |sin b|). 0 is locked, π/2 is as far as it gets.
double gimbal_distance(const Vec3& angles, EulerOrder order);
// Index (0..2, into angles = (ax, ay, az)) of the order's middle axis: the one whose ±π/2 locks.
int euler_middle_axis(EulerOrder order);

}  // namespace quatcurve
