// Euler angles with Blender's semantics (see euler.hpp). Every order is handled by one set of
// formulas written for the order's axes (i, j, k) = (first, middle, last): an even permutation of
// (X, Y, Z) relabels the axes by a rotation, an odd one by a reflection, which negates every angle
// (Shoemake, Graphics Gems IV).
#include "quatcurve/euler.hpp"

#include <cfloat>
#include <algorithm>
#include <cmath>

#include "numbers.hpp"

namespace quatcurve {

namespace {

using numbers::kPi;
using numbers::kTwoPi;
// cos(middle angle) at or below this is gimbal lock: the first and last axes coincide to the last
// bit (cos(π/2) in double is 6.1e-17).
constexpr double kLockCos = 16.0 * DBL_EPSILON;
// euler_compat treats |cos(middle angle)| at or below this as locked, as Blender does
// (16·FLT_EPSILON): rotations stored in float32 reach a 90° middle angle only to ~4e-8, and there the
// two ordinary solutions are both far from a continuous neighbour while the locked family holds one
// next to it. The family member then represents the input to within π·1.9e-6 rad.
constexpr double kCompatLockCos = 16.0 * static_cast<double>(FLT_EPSILON);

struct Axes {
    int i, j, k;  // first, middle, last axis (0 = X, 1 = Y, 2 = Z)
    bool odd;     // (i, j, k) is an odd permutation of (0, 1, 2)
};

Axes axes_of(EulerOrder order) {
    switch (order) {
        case EulerOrder::XYZ: return {0, 1, 2, false};
        case EulerOrder::XZY: return {0, 2, 1, true};
        case EulerOrder::YXZ: return {1, 0, 2, true};
        case EulerOrder::YZX: return {1, 2, 0, false};
        case EulerOrder::ZXY: return {2, 0, 1, false};
        case EulerOrder::ZYX: return {2, 1, 0, true};
    }
    throw InvalidArgument("order: invalid EulerOrder value");
}

// Rotation by `angle` about the coordinate axis `axis` (right-handed).
Mat3 axis_rotation(int axis, double angle) {
    const double c = std::cos(angle), s = std::sin(angle);
    const int p = (axis + 1) % 3, q = (axis + 2) % 3;
    Mat3 m(1.0);  // m[column][row]
    m[p][p] = c;
    m[q][q] = c;
    m[p][q] = s;
    m[q][p] = -s;
    return m;
}

Quat axis_quat(int axis, double angle) {
    Vec3 v(0.0);
    v[axis] = std::sin(0.5 * angle);
    return Quat(std::cos(0.5 * angle), v.x, v.y, v.z);
}

// x shifted by the multiple of 2π that brings it nearest to ref.
double nearest_turn(double x, double ref) { return x + kTwoPi * std::nearbyint((ref - x) / kTwoPi); }

// Angles beyond this many radians are reduced to (−π, π] before any whole turns are added: for
// them x + 2π·k cancels away x's fractional turn (at 1e16 rad nothing of it is left).
constexpr double kReduceAbove = 65536.0;

// The same rotation with every huge angle reduced as atan2(sin x, cos x): sin and cos reduce their
// argument exactly, so the result is x mod 2π to within an ulp of π, whatever |x|.
Vec3 reduced_angles(const Vec3& angles) {
    Vec3 out = angles;
    for (int n = 0; n < 3; ++n)
        if (std::fabs(out[n]) > kReduceAbove) out[n] = std::atan2(std::sin(out[n]), std::cos(out[n]));
    return out;
}

double l1(const Vec3& a, const Vec3& b) {
    return std::fabs(a.x - b.x) + std::fabs(a.y - b.y) + std::fabs(a.z - b.z);
}

// The solution of a rotation matrix (orthonormal to rounding) described in euler.hpp.
// lock_cos: cos of the middle angle at or below which the rotation counts as locked (`locked` says
// whether it did).
Vec3 rotation_to_euler(const Mat3& m, EulerOrder order, double lock_cos = kLockCos, bool* locked = nullptr) {
    const Axes ax = axes_of(order);
    const int i = ax.i, j = ax.j, k = ax.k;
    auto r = [&m](int row, int col) { return m[col][row]; };
    // For R = Rk(c)·Rj(b)·Ri(a) (even case), column i is (cos c cos b, sin c cos b, −sin b) on (i, j, k).
    const double cy = std::hypot(r(i, i), r(j, i));
    if (locked != nullptr) *locked = !(cy > lock_cos);
    double b, c;
    if (cy > lock_cos) {
        b = std::atan2(-r(k, i), cy);
        c = std::atan2(r(j, i), r(i, i));
    } else {
        b = std::copysign(kPi / 2.0, -r(k, i));
        c = 0.0;
    }
    // Row j of Rk(−c)·R = Rj(b)·Ri(a) is row j of Ri(a): (0, cos a, −sin a) on (i, j, k). These
    // entries are O(1), so a stays consistent with b and c however close the lock is.
    const double cc = std::cos(c), sc = std::sin(c);
    const double mjj = cc * r(j, j) - sc * r(i, j);
    const double mjk = cc * r(j, k) - sc * r(i, k);
    const double a = std::atan2(-mjk, mjj);
    const double sign = ax.odd ? -1.0 : 1.0;
    Vec3 angles;
    angles[i] = sign * a;
    angles[j] = sign * b;
    angles[k] = sign * c;
    return angles;
}

}  // namespace

EulerOrder parse_euler_order(const std::string& name) {
    static const EulerOrder all[] = {EulerOrder::XYZ, EulerOrder::XZY, EulerOrder::YXZ,
                                     EulerOrder::YZX, EulerOrder::ZXY, EulerOrder::ZYX};
    for (EulerOrder o : all)
        if (name == euler_order_name(o)) return o;
    throw InvalidArgument("order: unknown Euler order '" + name +
                          "' (expected one of XYZ, XZY, YXZ, YZX, ZXY, ZYX)");
}

const char* euler_order_name(EulerOrder order) {
    switch (order) {
        case EulerOrder::XYZ: return "XYZ";
        case EulerOrder::XZY: return "XZY";
        case EulerOrder::YXZ: return "YXZ";
        case EulerOrder::YZX: return "YZX";
        case EulerOrder::ZXY: return "ZXY";
        case EulerOrder::ZYX: return "ZYX";
    }
    return "?";
}

int euler_middle_axis(EulerOrder order) { return axes_of(order).j; }

Mat3 euler_to_matrix(const Vec3& angles, EulerOrder order) {
    check_finite(angles, "angles");
    const Axes ax = axes_of(order);
    return axis_rotation(ax.k, angles[ax.k]) * axis_rotation(ax.j, angles[ax.j]) *
           axis_rotation(ax.i, angles[ax.i]);
}

Quat euler_to_quat(const Vec3& angles, EulerOrder order) {
    check_finite(angles, "angles");
    const Axes ax = axes_of(order);
    return multiply(multiply(axis_quat(ax.k, angles[ax.k]), axis_quat(ax.j, angles[ax.j])),
                    axis_quat(ax.i, angles[ax.i]));
}

Vec3 matrix_to_euler(const Mat3& m, EulerOrder order) {
    return rotation_to_euler(nearest_rotation(m), order);
}

Vec3 quat_to_euler(const Quat& q, EulerOrder order) {
    return rotation_to_euler(quat_to_matrix(q), order);
}

Vec3 euler_compat(const Vec3& given, EulerOrder order, const Vec3& ref) {
    check_finite(given, "angles");
    check_finite(ref, "ref");
    const Vec3 angles = reduced_angles(given);
    const Axes ax = axes_of(order);
    const int i = ax.i, j = ax.j, k = ax.k;
    const double b = angles[j];
    // The two ordinary solutions, each angle moved by whole turns towards ref (L1 is separable).
    Vec3 first, second;
    for (int n = 0; n < 3; ++n) first[n] = nearest_turn(angles[n], ref[n]);
    second[i] = nearest_turn(angles[i] + kPi, ref[i]);
    second[j] = nearest_turn(kPi - b, ref[j]);
    second[k] = nearest_turn(angles[k] + kPi, ref[k]);
    Vec3 out = l1(second, ref) < l1(first, ref) ? second : first;
    const double cos_b = std::fabs(std::cos(b));
    if (cos_b > kCompatLockCos) return out;
    // (Near) gimbal lock: only a − σ·c matters (mod 2π), where (a+t, b, c+σt) keeps the rotation;
    // σ = +1 when the middle turn maps the first axis onto minus the last (even order, sin b > 0).
    // The L1 minimum over that family is |d|, reached by splitting d evenly between the two angles.
    const double sigma = (std::sin(b) > 0.0) != ax.odd ? 1.0 : -1.0;
    const double a = angles[i], c = angles[k];
    const double d = std::remainder((ref[i] - a) - sigma * (ref[k] - c), kTwoPi);
    Vec3 family;
    family[i] = ref[i] - 0.5 * d;
    family[k] = nearest_turn(c + sigma * (family[i] - a), ref[k]);
    family[j] = nearest_turn(b, ref[j]);
    // At exact lock the family is the rotation; near it, it is a candidate beside the exact two.
    if (cos_b <= kLockCos || l1(family, ref) < l1(out, ref)) out = family;
    return out;
}

Vec3 quat_to_euler_compat(const Quat& q, EulerOrder order, const Vec3& ref) {
    return euler_compat(quat_to_euler(q, order), order, ref);
}

namespace {

// Blender's compatible_eul (BLI_math_rotation.c, Blender 3.5 on): each angle moved by the whole
// turns that bring it within π of ref, then an angle still more than π away while the other two
// are within π/2 is moved by one more turn.
Vec3 blender_compatible(Vec3 e, const Vec3& ref) {
    Vec3 d;
    for (int n = 0; n < 3; ++n) {
        d[n] = e[n] - ref[n];
        if (d[n] > kPi) {
            e[n] -= std::floor(d[n] / kTwoPi + 0.5) * kTwoPi;
            d[n] = e[n] - ref[n];
        } else if (d[n] < -kPi) {
            e[n] += std::floor(-d[n] / kTwoPi + 0.5) * kTwoPi;
            d[n] = e[n] - ref[n];
        }
    }
    for (int n = 0, p = 1, q = 2; n < 3; p = q, q = n++)
        if (std::fabs(d[n]) > kPi && std::fabs(d[p]) < kPi / 2 && std::fabs(d[q]) < kPi / 2)
            e[n] += d[n] > 0.0 ? -kTwoPi : kTwoPi;
    return e;
}

// Blender's two solutions of q (mat3_normalized_to_eulo2): the one with the middle angle in
// [−π/2, π/2] and (a+π, π−b, c+π), each angle in [−π, π]; within 16·FLT_EPSILON of gimbal lock
// both are the locked solution (last angle 0).
void blender_solutions(const Quat& q, EulerOrder order, Vec3& first, Vec3& second) {
    bool locked = false;
    first = rotation_to_euler(quat_to_matrix(q), order, kCompatLockCos, &locked);
    second = first;
    if (locked) return;
    const Axes ax = axes_of(order);
    second[ax.i] = std::remainder(first[ax.i] + kPi, kTwoPi);
    second[ax.j] = std::remainder(kPi - first[ax.j], kTwoPi);
    second[ax.k] = std::remainder(first[ax.k] + kPi, kTwoPi);
}

}  // namespace

Vec3 blender_quat_to_euler(const Quat& q, EulerOrder order) {
    Vec3 first, second;
    blender_solutions(q, order, first, second);
    const Vec3 zero(0.0);
    return l1(first, zero) > l1(second, zero) ? second : first;
}

Vec3 blender_quat_to_euler(const Quat& q, EulerOrder order, const Vec3& compat) {
    check_finite(compat, "compat");
    Vec3 first, second;
    blender_solutions(q, order, first, second);
    first = blender_compatible(first, compat);
    second = blender_compatible(second, compat);
    return l1(first, compat) > l1(second, compat) ? second : first;
}

void euler_filter(Vec3* angles, std::size_t n, EulerOrder order) {
    for (std::size_t s = 1; s < n; ++s) angles[s] = euler_compat(angles[s], order, angles[s - 1]);
}

void euler_filter_from_anchor(Vec3* angles, std::size_t n, EulerOrder order) {
    if (n < 2) return;
    std::size_t anchor = 0;
    for (std::size_t s = 1; s < n; ++s)
        if (gimbal_distance(angles[s], order) > gimbal_distance(angles[anchor], order)) anchor = s;
    euler_filter(angles + anchor, n - anchor, order);
    std::reverse(angles, angles + anchor + 1);
    euler_filter(angles, anchor + 1, order);
    std::reverse(angles, angles + anchor + 1);
}

double gimbal_distance(const Vec3& angles, EulerOrder order) {
    check_finite(angles, "angles");
    const double b = angles[axes_of(order).j];
    return std::atan2(std::fabs(std::cos(b)), std::fabs(std::sin(b)));
}

}  // namespace quatcurve
