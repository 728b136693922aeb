// Euler angles with Blender's semantics: order "XYZ" means R = Rz·Ry·Rx — X is applied first, about
// fixed (world) axes — which is scipy's extrinsic "xyz". angles[i] is the angle about the axis named
// by the i-th letter of X, Y, Z in that fixed slot: angles = (ax, ay, az) whatever the order, as in
// Blender's rotation_euler. Radians.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "quatcurve/quat.hpp"

namespace quatcurve {

enum class EulerOrder { XYZ, XZY, YXZ, YZX, ZXY, ZYX };

// "XYZ" … "ZYX"; anything else throws InvalidArgument listing the valid orders.
EulerOrder parse_euler_order(const std::string& name);
const char* euler_order_name(EulerOrder order);

Mat3 euler_to_matrix(const Vec3& angles, EulerOrder order);
Quat euler_to_quat(const Vec3& angles, EulerOrder order);
// One solution, middle angle in [-π/2, π/2]; at gimbal lock the first angle takes all the rotation.
Vec3 matrix_to_euler(const Mat3& m, EulerOrder order);
Vec3 quat_to_euler(const Quat& q, EulerOrder order);
// The equivalent angles closest to `ref` (both Euler solutions and 2π shifts per angle considered,
// as Blender's compatible Euler does), by the sum of absolute differences.
Vec3 quat_to_euler_compat(const Quat& q, EulerOrder order, const Vec3& ref);
Vec3 euler_compat(const Vec3& angles, EulerOrder order, const Vec3& ref);
// In place over n consecutive triples: removes flips and 2π jumps without changing any orientation.
void euler_filter(Vec3* angles, std::size_t n, EulerOrder order);
// Distance (radians, ≥ 0) of the middle angle from the gimbal-lock singularity ±π/2; 0 is locked.
double gimbal_distance(const Vec3& angles, EulerOrder order);
// Index (0..2, into angles = (ax, ay, az)) of the order's middle axis: the one whose ±π/2 locks.
int euler_middle_axis(EulerOrder order);

}  // namespace quatcurve
