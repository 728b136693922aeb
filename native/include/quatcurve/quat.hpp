// Quaternion algebra, rotation of points, axis-angle and matrix conversions.
//
// Conventions (see README "Conventions"): quaternions are (w, x, y, z) at array edges; a unit
// quaternion q = (cos α, sin α · u) rotates by 2α about the unit axis u, P' = q·[0,P]·q⁻¹;
// matrices act on column vectors (P' = M·P) and compose right to left (M1·M2·M3·P applies M3 first).
// All functions compute in double. "Where a rotation is meant" a non-unit quaternion is normalized
// first; a zero-length or non-finite one throws InvalidArgument.
#pragma once

#include <array>
#include <complex>
#include <string>

#include "quatcurve/errors.hpp"
#include "quatcurve/types.hpp"

namespace quatcurve {

// ---- validation --------------------------------------------------------------------------------
// Each throws InvalidArgument naming `what` (e.g. "q[3]") when the value is non-finite or, for the
// *_nonzero forms, has zero length (norm below 1e-300 or underflowing).
void check_finite(const Quat& q, const std::string& what);
void check_finite(const Vec3& v, const std::string& what);
void check_finite(double x, const std::string& what);
void check_nonzero(const Quat& q, const std::string& what);
void check_nonzero(const Vec3& v, const std::string& what);
// Normalize a quaternion meant as a rotation; throws on zero length or non-finite input.
Quat normalized_rotation(const Quat& q, const std::string& what = "q");

// ---- algebra -------------------------------------------------------------------------------------
Quat multiply(const Quat& a, const Quat& b);   // Hamilton product a·b
Quat conjugate(const Quat& q);                  // (w, -x, -y, -z)
double norm(const Quat& q);                      // |q|, overflow-safe
Quat inverse(const Quat& q);                    // conj(q)/|q|²; throws on zero
Quat divide(const Quat& a, const Quat& b);      // a·b⁻¹; throws on zero b
Quat exp(const Quat& q);                        // e^q for any q; Taylor branch for |v| → 0
Quat log(const Quat& q);                        // (ln|q|, θ·v/|v|) with θ = atan2(|v|, w); throws on zero
Quat pow(const Quat& q, double t);              // exp(t·log q)

// ---- rotation of points --------------------------------------------------------------------------
Vec3 rotate_sandwich(const Quat& q, const Vec3& p);  // literally q·[0,P]·q⁻¹ (any nonzero q)
Vec3 rotate(const Quat& q, const Vec3& p);           // fast form v + 2w(u×v) + 2u×(u×v), q normalized

// ---- axis-angle ------------------------------------------------------------------------------------
Quat axis_angle_to_quat(const Vec3& axis, double angle);  // axis normalized; throws on zero axis
// Returns angle in [0, 2π] (angle = 2·atan2(|v|, w), as Blender) and a unit axis; the identity gives
// axis (0, 1, 0), angle 0 (Blender's default axis-angle).
void quat_to_axis_angle(const Quat& q, Vec3& axis, double& angle);
// Geodesic rotation angle between the rotations a and b in [0, π]; sign-invariant (q ≡ -q);
// computed as 2·atan2(|vec d|, |w d|) with d = conj(â)·b̂, so it is accurate near 0 and near π.
double angle_between(const Quat& a, const Quat& b);

// ---- matrices --------------------------------------------------------------------------------------
Mat3 quat_to_matrix(const Quat& q);  // rotation matrix of q̂
// Nearest rotation for slightly non-orthonormal input (scale is removed); reflections (det < 0) and
// singular/non-finite matrices throw.
Quat matrix_to_quat(const Mat3& m);
Quat matrix4_to_quat(const Mat4& m);  // from the upper-left 3×3

// Homogeneous 4×4 transforms (column vectors). scale may be negative on any axis (reflection).
Mat4 translation_matrix(const Vec3& t);
Mat4 rotation_matrix4(const Quat& q);
Mat4 scale_matrix(const Vec3& s);
Vec3 transform_point(const Mat4& m, const Vec3& p);      // (M·[P,1]) divided by its w; throws if w == 0
Vec3 transform_direction(const Mat4& m, const Vec3& d);  // M·[D,0]

// The two matrix representations of quaternions: q ↦ 2×2 complex matrix (row-major
// [[w+ix, y+iz], [-y+iz, w-ix]]) and q ↦ 4×4 real left-multiplication matrix L(q) with
// L(a)·vec(b) = vec(a·b) for vec = (w, x, y, z). Both map products to products.
std::array<std::complex<double>, 4> quat_to_complex2(const Quat& q);
Quat complex2_to_quat(const std::array<std::complex<double>, 4>& m);
std::array<double, 16> quat_to_real4(const Quat& q);  // row-major
Quat real4_to_quat(const std::array<double, 16>& m);

}  // namespace quatcurve
