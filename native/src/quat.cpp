// Quaternion algebra, rotation of points, axis-angle and matrix conversions (see quat.hpp for the
// formulas and edge cases of each function).
#include "quatcurve/quat.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>

#include "numbers.hpp"

namespace quatcurve {

namespace {

using numbers::kPi;

const char* const kQuatComponents[4] = {"w", "x", "y", "z"};
const char* const kVecComponents[3] = {"x", "y", "z"};

std::string number(double x) {
    if (std::isnan(x)) return "nan";
    return x > 0 ? "inf" : "-inf";
}

std::string non_finite(double x, const std::string& where) {
    return "non-finite value " + number(x) + " in " + where;
}

// sqrt(a² + b² + c² + d²) without overflow or underflow of the squares.
double safe_norm4(double a, double b, double c, double d) {
    const double s = a * a + b * b + c * c + d * d;
    if (s > 1e-290 && s < 1e290) return std::sqrt(s);
    if (std::isnan(s)) return s;
    const double m = std::max({std::fabs(a), std::fabs(b), std::fabs(c), std::fabs(d)});
    if (m == 0.0 || std::isinf(m)) return m;
    a /= m, b /= m, c /= m, d /= m;
    return m * std::sqrt(a * a + b * b + c * c + d * d);
}

double safe_norm3(const Vec3& v) { return safe_norm4(v.x, v.y, v.z, 0.0); }

// The power of two 2^e with the largest |component| of x in [1, 2) (e = 0 for zero): dividing by it
// is exact, so a quaternion's direction, a matrix's polar factor or a sandwich product can be
// computed on x·2^-e without squares overflowing (components near 1e308) or underflowing (1e-300).
// A normal m's exponent is read from its bits (what ilogb returns, without the libm call).
int scale_exponent(double a, double b, double c, double d) {
    const double m = std::max({std::fabs(a), std::fabs(b), std::fabs(c), std::fabs(d)});
    if (m >= std::numeric_limits<double>::min() && m <= std::numeric_limits<double>::max()) {
        std::uint64_t bits;
        std::memcpy(&bits, &m, sizeof bits);
        return static_cast<int>(bits >> 52) - 1023;
    }
    return m > 0.0 && std::isfinite(m) ? std::ilogb(m) : 0;
}

// q·2^-e. Where 2^-e is a normal double (built from its exponent bits) the four products by it are
// ldexp's correctly rounded results, without libm calls; a subnormal q (e < −1022) takes ldexp.
Quat scaled(const Quat& q, int e) {
    if (e >= -1022 && e <= 1022) {
        const std::uint64_t bits = static_cast<std::uint64_t>(1023 - e) << 52;
        double f;
        std::memcpy(&f, &bits, sizeof f);
        return Quat(q.w * f, q.x * f, q.y * f, q.z * f);
    }
    return Quat(std::ldexp(q.w, -e), std::ldexp(q.x, -e), std::ldexp(q.y, -e), std::ldexp(q.z, -e));
}

Quat scaled(const Quat& q) { return scaled(q, scale_exponent(q.w, q.x, q.y, q.z)); }

Mat3 scaled(const Mat3& m) {
    double big = 0.0;
    for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) big = std::max(big, std::fabs(m[c][r]));
    const int e = big > 0.0 && std::isfinite(big) ? std::ilogb(big) : 0;
    Mat3 out;
    for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) out[c][r] = std::ldexp(m[c][r], -e);
    return out;
}

// Frobenius norm of a 3×3 matrix.
double frobenius(const Mat3& m) {
    double s = 0.0;
    for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) s += m[c][r] * m[c][r];
    return std::sqrt(s);
}

[[noreturn]] void fail(const std::string& what, const std::string& problem) {
    throw InvalidArgument(what + ": " + problem);
}

}  // namespace

// ---- validation --------------------------------------------------------------------------------

std::string finite_problem(const Quat& q) {
    const double c[4] = {q.w, q.x, q.y, q.z};
    for (int i = 0; i < 4; ++i)
        if (!std::isfinite(c[i])) return non_finite(c[i], std::string("component ") + kQuatComponents[i]);
    return {};
}

std::string finite_problem(const Vec3& v) {
    for (int i = 0; i < 3; ++i)
        if (!std::isfinite(v[i])) return non_finite(v[i], std::string("component ") + kVecComponents[i]);
    return {};
}

// Positions are reported row-major, [row][column], as numpy shows them.
std::string finite_problem(const Mat3& m) {
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            if (!std::isfinite(m[c][r]))
                return non_finite(m[c][r], "entry [" + std::to_string(r) + "][" + std::to_string(c) + "]");
    return {};
}

std::string finite_problem(const Mat4& m) {
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c)
            if (!std::isfinite(m[c][r]))
                return non_finite(m[c][r], "entry [" + std::to_string(r) + "][" + std::to_string(c) + "]");
    return {};
}

std::string finite_problem(double x) {
    if (!std::isfinite(x)) return "non-finite value " + number(x);
    return {};
}

std::string finite_problem(const std::array<std::complex<double>, 4>& m) {
    for (std::size_t n = 0; n < 4; ++n) {
        const std::string where = "entry [" + std::to_string(n / 2) + "][" + std::to_string(n % 2) + "]";
        if (!std::isfinite(m[n].real())) return non_finite(m[n].real(), "the real part of " + where);
        if (!std::isfinite(m[n].imag())) return non_finite(m[n].imag(), "the imaginary part of " + where);
    }
    return {};
}

std::string finite_problem(const std::array<double, 16>& m) {
    for (std::size_t n = 0; n < 16; ++n)
        if (!std::isfinite(m[n]))
            return non_finite(m[n], "entry [" + std::to_string(n / 4) + "][" + std::to_string(n % 4) + "]");
    return {};
}

std::string nonzero_problem(const Quat& q) {
    const double s = q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z;
    if (s > 1e-290 && s < 1e290) return {};  // finite, and norm(q) = √s ≥ 1e-145 (the usual case, first)
    std::string p = finite_problem(q);
    if (p.empty() && norm(q) < kMinNorm) p = "zero-length quaternion";
    return p;
}

std::string nonzero_problem(const Vec3& v, const char* noun) {
    std::string p = finite_problem(v);
    if (p.empty() && safe_norm3(v) < kMinNorm) p = std::string("zero-length ") + noun;
    return p;
}

std::string rotation_matrix_problem(const Mat3& given) {
    std::string p = finite_problem(given);
    if (!p.empty()) return p;
    const Mat3 m = scaled(given);  // f³ and det overflow for entries near 1e103 otherwise
    const double f = frobenius(m);
    const double det = glm::determinant(m);
    if (!(f > 0.0) || std::fabs(det) <= 1e-14 * f * f * f) return "singular matrix (determinant ~ 0)";
    if (det < 0.0) return "reflection (determinant < 0), not a rotation";
    return {};
}

void check_finite(const Quat& q, const std::string& what) {
    const std::string p = finite_problem(q);
    if (!p.empty()) fail(what, p);
}

void check_finite(const Vec3& v, const std::string& what) {
    const std::string p = finite_problem(v);
    if (!p.empty()) fail(what, p);
}

void check_finite(double x, const std::string& what) {
    const std::string p = finite_problem(x);
    if (!p.empty()) fail(what, p);
}

void check_nonzero(const Quat& q, const std::string& what) {
    const std::string p = nonzero_problem(q);
    if (!p.empty()) fail(what, p);
}

void check_nonzero(const Vec3& v, const std::string& what) {
    const std::string p = nonzero_problem(v);
    if (!p.empty()) fail(what, p);
}

namespace {

// q/|q| for a finite nonzero q.
Quat normalized_unchecked(const Quat& q) {
    const Quat s = scaled(q);  // |q| itself overflows for components near 1e308
    const double n = norm(s);
    return Quat(s.w / n, s.x / n, s.y / n, s.z / n);
}

}  // namespace

Quat normalized_rotation(const Quat& q, const std::string& what) {
    check_nonzero(q, what);
    return normalized_unchecked(q);
}

Quat normalized_rotation(const Quat& q, const char* array, std::size_t index) {
    const std::string p = nonzero_problem(q);
    if (!p.empty()) fail(array + ("[" + std::to_string(index) + "]"), p);
    return normalized_unchecked(q);
}

// ---- algebra -------------------------------------------------------------------------------------

Quat multiply(const Quat& a, const Quat& b) {
    return Quat(a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
                a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
                a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
                a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w);
}

Quat conjugate(const Quat& q) { return Quat(q.w, -q.x, -q.y, -q.z); }

double norm(const Quat& q) { return safe_norm4(q.w, q.x, q.y, q.z); }

// conj(s)/|s|² · 2^-e on s = q·2^-e (|s|² in [1, 16)): no intermediate overflows or underflows,
// only the result where it must (|q| beyond 1e308 gives a subnormal result).
Quat inverse(const Quat& q) {
    check_nonzero(q, "q");
    const int e = scale_exponent(q.w, q.x, q.y, q.z);
    const Quat s = scaled(q, e);
    const double n2 = s.w * s.w + s.x * s.x + s.y * s.y + s.z * s.z;
    return scaled(Quat(s.w / n2, -s.x / n2, -s.y / n2, -s.z / n2), e);
}

Quat divide(const Quat& a, const Quat& b) {
    check_nonzero(b, "b");
    return multiply(a, inverse(b));
}

Quat exp(const Quat& q) {
    const Vec3 v(q.x, q.y, q.z);
    const double theta = safe_norm3(v);
    const double t2 = theta * theta;
    // sin θ/θ: the Taylor series 1 − θ²/6 + θ⁴/120 is exact to double precision below θ = 1e-4.
    const double sinc = theta < 1e-4 ? 1.0 - t2 / 6.0 + t2 * t2 / 120.0 : std::sin(theta) / theta;
    const double e = std::exp(q.w);
    return Quat(e * std::cos(theta), e * sinc * v.x, e * sinc * v.y, e * sinc * v.z);
}

Quat log(const Quat& q) {
    check_nonzero(q, "q");
    // On s = q·2^-e: ln|q| = ln|s| + e·ln 2 and the vector part atan2(|v|, w)·v/|v| is scale-free,
    // so components near 1e308 (whose |q| overflows) work too.
    const int e = scale_exponent(q.w, q.x, q.y, q.z);
    const Quat s = scaled(q, e);
    const Vec3 v(s.x, s.y, s.z);
    const double r = safe_norm3(v);
    const double lnn = std::log(norm(s)) + e * 0.693147180559945309417232121458176568;
    if (r == 0.0) return q.w > 0.0 ? Quat(lnn, 0.0, 0.0, 0.0) : Quat(lnn, kPi, 0.0, 0.0);
    // atan2(r, w)/r has no cancellation for any r > 0: for tiny r it is atan(r/w)/r ≈ 1/w.
    const double k = std::atan2(r, s.w) / r;
    return Quat(lnn, k * v.x, k * v.y, k * v.z);
}

Quat pow(const Quat& q, double t) {
    check_nonzero(q, "q");
    const Quat l = log(q);
    return exp(Quat(t * l.w, t * l.x, t * l.y, t * l.z));
}

// ---- rotation of points --------------------------------------------------------------------------

// On q·2^-e (exact, and the scale cancels): the products do not overflow for |q| near 1e308.
Vec3 rotate_sandwich(const Quat& q, const Vec3& given) {
    check_nonzero(q, "q");
    const Quat s = scaled(q);
    // P·2^-e too (rotation is linear): only a result beyond double range overflows.
    const int e = scale_exponent(given.x, given.y, given.z, 0.0);
    const Vec3 p(std::ldexp(given.x, -e), std::ldexp(given.y, -e), std::ldexp(given.z, -e));
    const Quat r = multiply(multiply(s, Quat(0.0, p.x, p.y, p.z)), inverse(s));
    return Vec3(std::ldexp(r.x, e), std::ldexp(r.y, e), std::ldexp(r.z, e));
}

// On P·2^-e (rotation is linear, the scaling exact): t = 2·(u×P) would overflow for |P| near 1e308
// even where the rotated point is finite.
Vec3 rotate(const Quat& q, const Vec3& given) {
    const Quat n = normalized_rotation(q);
    const Vec3 u(n.x, n.y, n.z);
    const int e = scale_exponent(given.x, given.y, given.z, 0.0);
    const Vec3 p(std::ldexp(given.x, -e), std::ldexp(given.y, -e), std::ldexp(given.z, -e));
    const Vec3 t = 2.0 * glm::cross(u, p);
    const Vec3 r = p + n.w * t + glm::cross(u, t);
    return Vec3(std::ldexp(r.x, e), std::ldexp(r.y, e), std::ldexp(r.z, e));
}

// ---- axis-angle ------------------------------------------------------------------------------------

Quat axis_angle_to_quat(const Vec3& axis, double angle) {
    const std::string p = nonzero_problem(axis, "axis");
    if (!p.empty()) fail("axis", p);
    check_finite(angle, "angle");
    const int e = scale_exponent(axis.x, axis.y, axis.z, 0.0);  // |axis| overflows near 1e308
    const Vec3 u(std::ldexp(axis.x, -e), std::ldexp(axis.y, -e), std::ldexp(axis.z, -e));
    const Vec3 a = u / safe_norm3(u);
    const double s = std::sin(0.5 * angle);
    return Quat(std::cos(0.5 * angle), s * a.x, s * a.y, s * a.z);
}

void quat_to_axis_angle(const Quat& q, Vec3& axis, double& angle) {
    const Quat n = normalized_rotation(q);
    const Vec3 v(n.x, n.y, n.z);
    const double r = safe_norm3(v);
    angle = 2.0 * std::atan2(r, n.w);
    // The direction from v·2^-e: for a subnormal v, |v| itself is rounded to a few bits.
    const int e = scale_exponent(v.x, v.y, v.z, 0.0);
    const Vec3 u(std::ldexp(v.x, -e), std::ldexp(v.y, -e), std::ldexp(v.z, -e));
    axis = r > 0.0 ? u / safe_norm3(u) : Vec3(0.0, 1.0, 0.0);
}

double angle_between(const Quat& a, const Quat& b) {
    // The usual case first, without building the checks' messages (a proof measures thousands of
    // angles): squared norms within (1e-290, 1e290) are finite and nonzero, and dividing by the norm
    // directly gives what normalized_rotation gives (its scaling by a power of two is exact).
    const double na = a.w * a.w + a.x * a.x + a.y * a.y + a.z * a.z;
    const double nb = b.w * b.w + b.x * b.x + b.y * b.y + b.z * b.z;
    const bool plain = na > 1e-290 && na < 1e290 && nb > 1e-290 && nb < 1e290;
    const double ra = std::sqrt(na), rb = std::sqrt(nb);
    const Quat p = plain ? Quat(a.w / ra, a.x / ra, a.y / ra, a.z / ra) : normalized_rotation(a, "a");
    Quat r = plain ? Quat(b.w / rb, b.x / rb, b.y / rb, b.z / rb) : normalized_rotation(b, "b");
    if (p.w * r.w + p.x * r.x + p.y * r.y + p.z * r.z < 0.0) r = Quat(-r.w, -r.x, -r.y, -r.z);
    const double d = safe_norm4(p.w - r.w, p.x - r.x, p.y - r.y, p.z - r.z);
    const double s = safe_norm4(p.w + r.w, p.x + r.x, p.y + r.y, p.z + r.z);
    return 4.0 * std::atan2(d, s);
}

// ---- matrices --------------------------------------------------------------------------------------

Mat3 quat_to_matrix(const Quat& q) {
    const Quat n = normalized_rotation(q);
    const double w = n.w, x = n.x, y = n.y, z = n.z;
    const double xx = x * x, yy = y * y, zz = z * z;
    const double xy = x * y, xz = x * z, yz = y * z, wx = w * x, wy = w * y, wz = w * z;
    Mat3 m;  // m[column][row]
    m[0][0] = 1.0 - 2.0 * (yy + zz);
    m[1][0] = 2.0 * (xy - wz);
    m[2][0] = 2.0 * (xz + wy);
    m[0][1] = 2.0 * (xy + wz);
    m[1][1] = 1.0 - 2.0 * (xx + zz);
    m[2][1] = 2.0 * (yz - wx);
    m[0][2] = 2.0 * (xz - wy);
    m[1][2] = 2.0 * (yz + wx);
    m[2][2] = 1.0 - 2.0 * (xx + yy);
    return m;
}

Mat3 nearest_rotation(const Mat3& m) {
    const std::string p = rotation_matrix_problem(m);
    if (!p.empty()) fail("m", p);
    Mat3 x = scaled(m);  // the polar factor is scale-free; unscaled, X⁻ᵀ under/overflows near 1e±154
    for (int iteration = 0; iteration < 60; ++iteration) {
        const Mat3 inv_t = glm::transpose(glm::inverse(x));
        const double fx = frobenius(x);
        // Scaling speeds up the first steps for badly scaled m; near convergence γ → 1 and it is
        // switched off, keeping the final quadratic steps plain Newton.
        const double gamma = iteration < 8 ? std::sqrt(frobenius(inv_t) / fx) : 1.0;
        const Mat3 next = 0.5 * (gamma * x + (1.0 / gamma) * inv_t);
        const double step = frobenius(next - x);
        x = next;
        // The error after a step is about the square of the step: 1e-8 leaves ~1e-16.
        if (step < 1e-8 * frobenius(x)) break;
    }
    return x;
}

Quat matrix_to_quat(const Mat3& m) {
    const Mat3 u = nearest_rotation(m);
    // r(row, col) in the usual notation; GLM stores u[col][row].
    auto r = [&u](int row, int col) { return u[col][row]; };
    const double tr = r(0, 0) + r(1, 1) + r(2, 2);
    double w, x, y, z;
    if (tr >= r(0, 0) && tr >= r(1, 1) && tr >= r(2, 2)) {
        const double s = 2.0 * std::sqrt(std::max(0.0, 1.0 + tr));  // 4w
        w = 0.25 * s;
        x = (r(2, 1) - r(1, 2)) / s;
        y = (r(0, 2) - r(2, 0)) / s;
        z = (r(1, 0) - r(0, 1)) / s;
    } else if (r(0, 0) >= r(1, 1) && r(0, 0) >= r(2, 2)) {
        const double s = 2.0 * std::sqrt(std::max(0.0, 1.0 + r(0, 0) - r(1, 1) - r(2, 2)));  // 4x
        w = (r(2, 1) - r(1, 2)) / s;
        x = 0.25 * s;
        y = (r(0, 1) + r(1, 0)) / s;
        z = (r(0, 2) + r(2, 0)) / s;
    } else if (r(1, 1) >= r(2, 2)) {
        const double s = 2.0 * std::sqrt(std::max(0.0, 1.0 + r(1, 1) - r(0, 0) - r(2, 2)));  // 4y
        w = (r(0, 2) - r(2, 0)) / s;
        x = (r(0, 1) + r(1, 0)) / s;
        y = 0.25 * s;
        z = (r(1, 2) + r(2, 1)) / s;
    } else {
        const double s = 2.0 * std::sqrt(std::max(0.0, 1.0 + r(2, 2) - r(0, 0) - r(1, 1)));  // 4z
        w = (r(1, 0) - r(0, 1)) / s;
        x = (r(0, 2) + r(2, 0)) / s;
        y = (r(1, 2) + r(2, 1)) / s;
        z = 0.25 * s;
    }
    // Canonical sign: w ≥ 0; for w = 0 the first nonzero of x, y, z positive.
    const bool flip = w < 0.0 || (w == 0.0 && (x < 0.0 || (x == 0.0 && (y < 0.0 || (y == 0.0 && z < 0.0)))));
    if (flip) w = -w, x = -x, y = -y, z = -z;
    const double n = safe_norm4(w, x, y, z);
    return Quat(w / n, x / n, y / n, z / n);
}

Quat matrix4_to_quat(const Mat4& m) { return matrix_to_quat(Mat3(m)); }

Mat4 translation_matrix(const Vec3& t) {
    Mat4 m(1.0);
    m[3] = Vec4(t, 1.0);
    return m;
}

Mat4 rotation_matrix4(const Quat& q) { return Mat4(quat_to_matrix(q)); }

Mat4 scale_matrix(const Vec3& s) {
    Mat4 m(1.0);
    m[0][0] = s.x;
    m[1][1] = s.y;
    m[2][2] = s.z;
    return m;
}

Vec3 transform_point(const Mat4& m, const Vec3& p) {
    const Vec4 h = m * Vec4(p, 1.0);
    if (h.w == 0.0 || !std::isfinite(h.w))
        throw InvalidArgument(std::string("transform_point: the point maps to infinity (homogeneous w ") +
                              (h.w == 0.0 ? "= 0)" : "is not finite)"));
    return Vec3(h) / h.w;
}

Vec3 transform_direction(const Mat4& m, const Vec3& d) { return Vec3(m * Vec4(d, 0.0)); }

// ---- matrix representations ----------------------------------------------------------------------

std::array<std::complex<double>, 4> quat_to_complex2(const Quat& q) {
    using C = std::complex<double>;
    return {C(q.w, q.x), C(q.y, q.z), C(-q.y, q.z), C(q.w, -q.x)};
}

namespace {
// The mean of a and b, or (a − b)/2 when b is negated: (a + b)/2 unless the sum overflows.
double half_sum(double a, double b) {
    const double s = a + b;
    return std::isfinite(s) ? 0.5 * s : 0.5 * a + 0.5 * b;
}

double quarter_sum(double a, double b, double c, double d) {
    const double s = a + b + c + d;
    return std::isfinite(s) ? 0.25 * s : 0.25 * a + 0.25 * b + 0.25 * c + 0.25 * d;
}
}  // namespace

Quat complex2_to_quat(const std::array<std::complex<double>, 4>& m) {
    return Quat(half_sum(m[0].real(), m[3].real()), half_sum(m[0].imag(), -m[3].imag()),
                half_sum(m[1].real(), -m[2].real()), half_sum(m[1].imag(), m[2].imag()));
}

std::array<double, 16> quat_to_real4(const Quat& q) {
    const double w = q.w, x = q.x, y = q.y, z = q.z;
    return {w, -x, -y, -z,
            x, w, -z, y,
            y, z, w, -x,
            z, -y, x, w};
}

Quat real4_to_quat(const std::array<double, 16>& m) {
    auto e = [&m](int r, int c) { return m[static_cast<std::size_t>(4 * r + c)]; };
    return Quat(quarter_sum(e(0, 0), e(1, 1), e(2, 2), e(3, 3)),
                quarter_sum(e(1, 0), -e(0, 1), e(3, 2), -e(2, 3)),
                quarter_sum(e(2, 0), -e(0, 2), e(1, 3), -e(3, 1)),
                quarter_sum(e(3, 0), -e(0, 3), e(2, 1), -e(1, 2)));
}

}  // namespace quatcurve
