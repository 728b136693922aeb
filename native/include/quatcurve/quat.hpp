// Quaternion algebra, rotation of points, axis-angle and matrix conversions.
//
// Conventions (see docs/conventions.md): quaternions are (w, x, y, z) at array edges; a unit
// quaternion q = (cos α, sin α · u) rotates by 2α about the unit axis u, P' = q·[0,P]·q⁻¹;
// matrices act on column vectors (P' = M·P) and compose right to left (M1·M2·M3·P applies M3 first).
// All functions compute in double. "Where a rotation is meant" a non-unit quaternion is normalized
// first; a zero-length or non-finite one throws InvalidArgument. The pure algebra (multiply,
// conjugate, norm, exp) does not check its input: non-finite values propagate.
#pragma once

#include <array>
#include <complex>
#include <cstddef>
#include <string>

#include "quatcurve/errors.hpp"
#include "quatcurve/types.hpp"

namespace quatcurve {

// A quaternion or vector whose (overflow-safe) norm is below this is "zero-length".
inline constexpr double kMinNorm = 1e-300;

// ---- validation --------------------------------------------------------------------------------
// The *_problem functions return "" when the value is fine, else a short description of what is
// wrong, without a name ("non-finite value nan in component x", "zero-length quaternion"): callers
// that loop over arrays prefix it with the element's name ("q[3]: zero-length quaternion").
std::string finite_problem(const Quat& q);
std::string finite_problem(const Vec3& v);
std::string finite_problem(const Mat3& m);
std::string finite_problem(const Mat4& m);
std::string finite_problem(double x);
std::string finite_problem(const std::array<std::complex<double>, 4>& m);  // 2×2 complex, row-major
std::string finite_problem(const std::array<double, 16>& m);                // 4×4 real, row-major
// Non-finite, or norm below kMinNorm ("zero-length quaternion").
std::string nonzero_problem(const Quat& q);
// Non-finite, or norm below kMinNorm ("zero-length <noun>", e.g. noun = "axis").
std::string nonzero_problem(const Vec3& v, const char* noun = "vector");
// Non-finite, singular (det ≤ 1e-14·‖m‖_F³) or a reflection (det < 0): what matrix_to_quat refuses.
std::string rotation_matrix_problem(const Mat3& m);

// Each throws InvalidArgument "<what>: <problem>" when the matching *_problem is not "".
void check_finite(const Quat& q, const std::string& what);
void check_finite(const Vec3& v, const std::string& what);
void check_finite(double x, const std::string& what);
void check_nonzero(const Quat& q, const std::string& what);
void check_nonzero(const Vec3& v, const std::string& what);
// q/|q| for a quaternion meant as a rotation; throws on zero length or non-finite input. Exact for
// tiny or huge finite q, up to components of 1.8e308 (computed on q·2^-e, e the largest exponent).
Quat normalized_rotation(const Quat& q, const std::string& what = "q");
// The same for element `index` of the array named `array`: the name "array[index]" is built for the
// error message only (for loops over many keys, where building it cost more than the check).
Quat normalized_rotation(const Quat& q, const char* array, std::size_t index);

// ---- algebra -------------------------------------------------------------------------------------
// Hamilton product a·b = (wa·wb − va·vb, wa·vb + wb·va + va×vb). Not commutative.
Quat multiply(const Quat& a, const Quat& b);
// (w, −x, −y, −z); for unit q this is q⁻¹.
Quat conjugate(const Quat& q);
// |q| = √(w²+x²+y²+z²), rescaled when the squares would overflow or underflow (exact for 1e±300).
double norm(const Quat& q);
// conj(q)/|q|² (on q·2^-e, so only the result itself can under/overflow); throws InvalidArgument
// ("q: zero-length quaternion") when |q| < kMinNorm.
Quat inverse(const Quat& q);
// a·b⁻¹ (right division: divide(a·b, b) = a); throws when |b| < kMinNorm.
Quat divide(const Quat& a, const Quat& b);
// e^q = e^w·(cos θ, sin θ·v/θ) with θ = |v|; sin θ/θ by its Taylor series below θ = 1e-4 (θ = 0
// gives (e^w, 0, 0, 0)). Defined for every finite q; overflows to ±inf for w > ~709.
Quat exp(const Quat& q);
// (ln|q|, θ·v/|v|) with θ = atan2(|v|, w) ∈ [0, π] (no acos, accurate for |v| → 0). A real q
// (v = 0) gives (ln|w|, 0, 0, 0) for w > 0 and (ln|w|, π, 0, 0) for w < 0 (the x axis is chosen).
// Throws when |q| < kMinNorm.
Quat log(const Quat& q);
// q^t = exp(t·log q). For unit q: the rotation by t times q's angle about q's axis, turning the way
// q's hemisphere says (w < 0 turns the long way round). Throws when |q| < kMinNorm.
Quat pow(const Quat& q, double t);

// ---- rotation of points --------------------------------------------------------------------------
// Literally q·[0,P]·q⁻¹ (two Hamilton products) on q·2^-e: any nonzero q, up to components of
// 1.8e308 (its scale cancels); throws on zero.
Vec3 rotate_sandwich(const Quat& q, const Vec3& p);
// The fast equivalent on q̂ = q/|q|: t = 2·(u×P), P' = P + w·t + u×t. Throws on zero q.
Vec3 rotate(const Quat& q, const Vec3& p);

// ---- axis-angle ------------------------------------------------------------------------------------
// (cos(angle/2), sin(angle/2)·â) with â = axis/|axis|; any finite angle (no wrapping, so 2π gives
// −identity); throws on a zero-length or non-finite axis or a non-finite angle.
Quat axis_angle_to_quat(const Vec3& axis, double angle);
// For q̂ = q/|q|: angle = 2·atan2(|v|, w) ∈ [0, 2π] (as Blender: w < 0 gives angles above π) and
// axis = v/|v|. When v = 0 (identity, or −identity with angle 2π) the axis is (0, 1, 0), Blender's
// default axis-angle. Throws on zero q.
void quat_to_axis_angle(const Quat& q, Vec3& axis, double& angle);
// Geodesic angle ∈ [0, π] between the rotations a and b, sign-invariant (q ≡ −q):
// 4·atan2(|â − s·b̂|, |â + s·b̂|) with s = ±1 the sign of â·b̂. The difference of nearly equal unit
// quaternions is exact, so this is accurate to ~1e-16 rad absolute near 0 (no acos of a dot near 1)
// and near π. Throws on zero a or b.
double angle_between(const Quat& a, const Quat& b);

// ---- matrices --------------------------------------------------------------------------------------
// The rotation matrix of q̂ (exactly orthonormal up to rounding). Throws on zero q.
Mat3 quat_to_matrix(const Quat& q);
// The orthogonal factor U of the polar decomposition m = U·P (P symmetric positive definite): the
// rotation nearest to m in the Frobenius norm. Removes any scale, uniform or not, applied before
// (R·S) or after (S·R) the rotation, and shear. Scaled Newton iteration X ← (γX + X⁻ᵀ/γ)/2
// (Higham), converging quadratically (one or two steps for nearly orthonormal m).
// Throws on non-finite, singular (det ≤ 1e-14·‖m‖_F³) and reflecting (det < 0) matrices.
Mat3 nearest_rotation(const Mat3& m);
// The unit quaternion of nearest_rotation(m): Shepperd's method (largest of w, x, y, z first, so
// no cancellation), normalized, sign chosen with w ≥ 0 (w = 0: first nonzero of x, y, z positive).
// Throws as nearest_rotation.
Quat matrix_to_quat(const Mat3& m);
// matrix_to_quat of the upper-left 3×3 (translation and the bottom row are ignored).
Quat matrix4_to_quat(const Mat4& m);

// Homogeneous 4×4 transforms (column vectors, P' = M·[P,1]).
Mat4 translation_matrix(const Vec3& t);
// The rotation of q̂ in the upper-left 3×3; throws on zero q.
Mat4 rotation_matrix4(const Quat& q);
// diag(sx, sy, sz, 1); any finite scale: negative entries reflect, zero entries project.
Mat4 scale_matrix(const Vec3& s);
// (M·[P,1]).xyz divided by its w (w = 1 for affine M); throws when that w is 0 or non-finite.
Vec3 transform_point(const Mat4& m, const Vec3& p);
// (M·[D,0]).xyz: a direction ignores translation (no division).
Vec3 transform_direction(const Mat4& m, const Vec3& d);

// The two matrix representations of quaternions, on any quaternion (no normalization):
// q ↦ 2×2 complex matrix, row-major [[w+ix, y+iz], [−y+iz, w−ix]], and q ↦ 4×4 real left-
// multiplication matrix L(q) (row-major) with L(a)·vec(b) = vec(a·b) for vec = (w, x, y, z).
// Both map products to products: C(a·b) = C(a)·C(b), L(a·b) = L(a)·L(b). The inverse maps
// project any matrix onto the representation (average of the entries that hold each component),
// so they are exact on representations and least-squares otherwise.
std::array<std::complex<double>, 4> quat_to_complex2(const Quat& q);
Quat complex2_to_quat(const std::array<std::complex<double>, 4>& m);
std::array<double, 16> quat_to_real4(const Quat& q);
Quat real4_to_quat(const std::array<double, 16>& m);

}  // namespace quatcurve
