// Tests of quat.hpp: the seed's worked examples, algebraic identities, edge cases and bad input.
#include "quatcurve/quat.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

using namespace quatcurve;

namespace {

constexpr double kPi = 3.141592653589793238462643383279502884;

double deg(double d) { return d * kPi / 180.0; }

struct Random {
    std::mt19937_64 gen{20260101};
    double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(gen); }
    double normal() { return std::normal_distribution<double>(0.0, 1.0)(gen); }
    Quat quat() { return Quat(normal(), normal(), normal(), normal()); }           // not unit
    Quat unit() { return normalized_rotation(quat()); }
    Vec3 vec() { return Vec3(normal(), normal(), normal()); }
};

void expect_vec_near(const Vec3& a, const Vec3& b, double tol) {
    EXPECT_NEAR(a.x, b.x, tol);
    EXPECT_NEAR(a.y, b.y, tol);
    EXPECT_NEAR(a.z, b.z, tol);
}

void expect_quat_near(const Quat& a, const Quat& b, double tol) {
    EXPECT_NEAR(a.w, b.w, tol);
    EXPECT_NEAR(a.x, b.x, tol);
    EXPECT_NEAR(a.y, b.y, tol);
    EXPECT_NEAR(a.z, b.z, tol);
}

// Same rotation (q ≡ −q).
void expect_same_rotation(const Quat& a, const Quat& b, double tol) { EXPECT_LT(angle_between(a, b), tol); }

Mat3 matrix_of_map(const Quat& q) {  // columns: images of the basis vectors under the sandwich
    Mat3 m;
    for (int c = 0; c < 3; ++c) {
        Vec3 e(0.0);
        e[c] = 1.0;
        m[c] = rotate_sandwich(q, e);
    }
    return m;
}

template <class F>
void expect_invalid(F&& f, const std::string& fragment) {
    try {
        f();
        ADD_FAILURE() << "expected InvalidArgument containing '" << fragment << "'";
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
}

}  // namespace

// ---- the seed's worked examples --------------------------------------------------------------------

TEST(QuatSeed, RotatingZeroOneOneByNinetyAboutYGivesOneOneZero) {
    const Quat q = axis_angle_to_quat(Vec3(0, 1, 0), deg(90));
    expect_vec_near(rotate(q, Vec3(0, 1, 1)), Vec3(1, 1, 0), 1e-15);
    expect_vec_near(rotate_sandwich(q, Vec3(0, 1, 1)), Vec3(1, 1, 0), 1e-15);
    expect_vec_near(quat_to_matrix(q) * Vec3(0, 1, 1), Vec3(1, 1, 0), 1e-15);
}

TEST(QuatSeed, SandwichPreservesLengthIsLinearHasDetOneFixesAxisTurnsByTwoAlpha) {
    Random rnd;
    for (int trial = 0; trial < 200; ++trial) {
        const Vec3 u = glm::normalize(rnd.vec());
        const double alpha = rnd.uniform(-kPi, kPi);
        const Quat q(std::cos(alpha), std::sin(alpha) * u.x, std::sin(alpha) * u.y, std::sin(alpha) * u.z);
        const Vec3 p = rnd.vec(), r = rnd.vec();
        const double s = rnd.normal(), t = rnd.normal();
        // length
        EXPECT_NEAR(glm::length(rotate_sandwich(q, p)), glm::length(p), 1e-14);
        // linear
        expect_vec_near(rotate_sandwich(q, s * p + t * r), s * rotate_sandwich(q, p) + t * rotate_sandwich(q, r), 1e-13);
        // orthogonal with determinant +1 (a rotation, not a reflection)
        const Mat3 m = matrix_of_map(q);
        EXPECT_NEAR(glm::determinant(m), 1.0, 1e-14);
        const Mat3 mtm = glm::transpose(m) * m;
        for (int c = 0; c < 3; ++c)
            for (int k = 0; k < 3; ++k) EXPECT_NEAR(mtm[c][k], c == k ? 1.0 : 0.0, 1e-14);
        // axis fixed
        expect_vec_near(rotate_sandwich(q, 3.0 * u), 3.0 * u, 1e-14);
        // a vector perpendicular to the axis turns by 2α, counter-clockwise about u
        const Vec3 perp = glm::normalize(glm::cross(u, p));
        const Vec3 image = rotate_sandwich(q, perp);
        const double turned = std::atan2(glm::dot(glm::cross(perp, image), u), glm::dot(perp, image));
        EXPECT_NEAR(std::remainder(turned - 2.0 * alpha, 2.0 * kPi), 0.0, 1e-13);
    }
}

TEST(QuatSeed, CompoundingM1M2M3AppliesM3First) {
    const Mat4 m1 = translation_matrix(Vec3(1, 2, 3));
    const Mat4 m2 = rotation_matrix4(axis_angle_to_quat(Vec3(0, 0, 1), deg(90)));
    const Mat4 m3 = scale_matrix(Vec3(2, -1, 0.5));  // with a reflection in y
    const Vec3 p(1, 1, 1);
    const Vec3 step = transform_point(m1, transform_point(m2, transform_point(m3, p)));
    // by hand: scale (2, -1, 0.5); rotate 90° about z: (1, 2, 0.5); translate: (2, 4, 3.5)
    expect_vec_near(step, Vec3(2, 4, 3.5), 1e-15);
    expect_vec_near(transform_point(m1 * m2 * m3, p), step, 1e-15);
    EXPECT_NEAR(glm::determinant(m1 * m2 * m3), -1.0, 1e-15);
    // directions ignore the translation
    expect_vec_near(transform_direction(m1 * m2, Vec3(1, 0, 0)), Vec3(0, 1, 0), 1e-15);
}

// ---- algebra -------------------------------------------------------------------------------------

TEST(QuatAlgebra, HamiltonUnits) {
    const Quat i(0, 1, 0, 0), j(0, 0, 1, 0), k(0, 0, 0, 1), one(1, 0, 0, 0);
    expect_quat_near(multiply(i, j), k, 0);
    expect_quat_near(multiply(j, k), i, 0);
    expect_quat_near(multiply(k, i), j, 0);
    expect_quat_near(multiply(j, i), Quat(0, 0, 0, -1), 0);
    expect_quat_near(multiply(i, i), Quat(-1, 0, 0, 0), 0);
    expect_quat_near(multiply(multiply(i, j), k), Quat(-1, 0, 0, 0), 0);  // ijk = −1
    expect_quat_near(multiply(one, Quat(1, 2, 3, 4)), Quat(1, 2, 3, 4), 0);
}

TEST(QuatAlgebra, ProductIsAssociativeAndNormMultiplicativeAndMatchesGlm) {
    Random rnd;
    for (int trial = 0; trial < 500; ++trial) {
        const Quat a = rnd.quat(), b = rnd.quat(), c = rnd.quat();
        expect_quat_near(multiply(multiply(a, b), c), multiply(a, multiply(b, c)), 1e-12);
        EXPECT_NEAR(norm(multiply(a, b)), norm(a) * norm(b), 1e-12 * norm(a) * norm(b));
        expect_quat_near(multiply(a, b), a * b, 1e-14);
        expect_quat_near(conjugate(multiply(a, b)), multiply(conjugate(b), conjugate(a)), 1e-14);
    }
}

TEST(QuatAlgebra, NormIsOverflowAndUnderflowSafe) {
    EXPECT_DOUBLE_EQ(norm(Quat(3e300, 4e300, 0, 0)), 5e300);
    EXPECT_DOUBLE_EQ(norm(Quat(0, 3e-300, 0, 4e-300)), 5e-300);
    EXPECT_DOUBLE_EQ(norm(Quat(1, 2, 2, 4)), 5.0);
    EXPECT_EQ(norm(Quat(0, 0, 0, 0)), 0.0);
    EXPECT_TRUE(std::isnan(norm(Quat(NAN, 0, 0, 0))));
}

TEST(QuatAlgebra, InverseAndDivide) {
    Random rnd;
    for (int trial = 0; trial < 200; ++trial) {
        const Quat a = rnd.quat(), b = rnd.quat();
        expect_quat_near(multiply(a, inverse(a)), Quat(1, 0, 0, 0), 1e-14);
        expect_quat_near(multiply(inverse(a), a), Quat(1, 0, 0, 0), 1e-14);
        expect_quat_near(multiply(divide(a, b), b), a, 1e-12);
        expect_quat_near(divide(multiply(a, b), b), a, 1e-12);
    }
    // huge and tiny quaternions invert without overflow
    expect_quat_near(multiply(Quat(1e200, 0, 0, 0), inverse(Quat(1e200, 0, 0, 0))), Quat(1, 0, 0, 0), 1e-15);
    EXPECT_DOUBLE_EQ(inverse(Quat(0, 1e-200, 0, 0)).x, -1e200);
    expect_invalid([] { inverse(Quat(0, 0, 0, 0)); }, "q: zero-length quaternion");
    expect_invalid([] { divide(Quat(1, 0, 0, 0), Quat(0, 0, 0, 0)); }, "b: zero-length quaternion");
}

TEST(QuatAlgebra, ExpLogPow) {
    Random rnd;
    for (int trial = 0; trial < 300; ++trial) {
        const Quat q = rnd.quat();
        expect_quat_near(exp(log(q)), q, 1e-12 * norm(q));
        const Quat u = rnd.unit();
        expect_quat_near(pow(u, 1.0), u, 1e-14);
        expect_quat_near(pow(u, 0.0), Quat(1, 0, 0, 0), 1e-15);
        const Quat h = pow(u, 0.5);
        expect_quat_near(multiply(h, h), u, 1e-14);
        EXPECT_NEAR(norm(pow(u, 0.3)), 1.0, 1e-14);
        // pow(q, t) turns by t times q's angle about q's axis
        Vec3 axis;
        double angle, angle_t;
        quat_to_axis_angle(u, axis, angle);
        Vec3 axis_t;
        quat_to_axis_angle(pow(u, 0.25), axis_t, angle_t);
        EXPECT_NEAR(angle_t, 0.25 * angle, 1e-13);
        expect_vec_near(axis_t, axis, 1e-12);
    }
    // pure vector of length π: e^q = −1
    expect_quat_near(exp(Quat(0, kPi, 0, 0)), Quat(-1, 0, 0, 0), 1e-15);
    expect_quat_near(exp(Quat(1, 0, 0, 0)), Quat(std::exp(1.0), 0, 0, 0), 1e-15);
}

TEST(QuatAlgebra, ExpLogSmallAngleBranches) {
    // The Taylor branch of exp and the atan2 form of log stay exact down to tiny vectors.
    for (double theta : {1e-3, 1e-4, 0.99e-4, 1e-6, 1e-9, 1e-30, 1e-300}) {
        const Quat e = exp(Quat(0, theta, 0, 0));
        EXPECT_DOUBLE_EQ(e.w, std::cos(theta));
        EXPECT_NEAR(e.x / theta, std::sin(theta) / theta, 2.5e-16) << theta;
        const Quat l = log(Quat(std::cos(theta), 0, 0, std::sin(theta)));
        EXPECT_NEAR(l.z / theta, 1.0, 1e-15) << theta;
        EXPECT_NEAR(l.w, 0.0, 3e-16);
    }
    // both sides of the branch switch agree
    const Quat below = exp(Quat(0, 0, 0.999999e-4, 0)), above = exp(Quat(0, 0, 1.000001e-4, 0));
    EXPECT_NEAR(above.y - below.y, 2e-10, 1e-18);
}

TEST(QuatAlgebra, LogOfRealQuaternions) {
    expect_quat_near(log(Quat(2, 0, 0, 0)), Quat(std::log(2.0), 0, 0, 0), 1e-16);
    expect_quat_near(log(Quat(-1, 0, 0, 0)), Quat(0, kPi, 0, 0), 1e-16);  // the x axis is chosen
    expect_quat_near(exp(log(Quat(-3, 0, 0, 0))), Quat(-3, 0, 0, 0), 1e-15);
    expect_invalid([] { log(Quat(0, 0, 0, 0)); }, "zero-length quaternion");
    expect_invalid([] { pow(Quat(0, 0, 0, 0), 2.0); }, "zero-length quaternion");
}

// ---- rotation of points --------------------------------------------------------------------------

TEST(QuatRotate, FastFormEqualsSandwichAndMatrixAndNormalizes) {
    Random rnd;
    for (int trial = 0; trial < 500; ++trial) {
        const Quat q = rnd.quat();  // not unit: rotate normalizes, the sandwich cancels the scale
        const Vec3 p = rnd.vec();
        const Vec3 fast = rotate(q, p);
        expect_vec_near(fast, rotate_sandwich(q, p), 1e-13);
        expect_vec_near(fast, quat_to_matrix(q) * p, 1e-13);
        expect_vec_near(fast, rotate(Quat(-q.w, -q.x, -q.y, -q.z), p), 1e-13);  // q ≡ −q
    }
    expect_invalid([] { rotate(Quat(0, 0, 0, 0), Vec3(1, 0, 0)); }, "zero-length quaternion");
    expect_invalid([] { rotate_sandwich(Quat(0, 0, 0, 0), Vec3(1, 0, 0)); }, "zero-length quaternion");
    expect_invalid([] { rotate(Quat(NAN, 0, 0, 1), Vec3(1, 0, 0)); }, "non-finite value nan in component w");
}

// ---- axis-angle ------------------------------------------------------------------------------------

TEST(QuatAxisAngle, RoundTripAndRanges) {
    Random rnd;
    for (int trial = 0; trial < 500; ++trial) {
        const Vec3 axis = rnd.vec();
        const double angle = rnd.uniform(0.0, 2.0 * kPi);
        const Quat q = axis_angle_to_quat(3.0 * axis, angle);  // the axis is normalized
        EXPECT_NEAR(norm(q), 1.0, 1e-15);
        Vec3 a;
        double t;
        quat_to_axis_angle(q, a, t);
        EXPECT_NEAR(t, angle, 1e-13);
        expect_vec_near(a, glm::normalize(axis), 1e-12);
        // −q is the same rotation, reported with the complementary angle about the flipped axis... or
        // equivalently angle 2π − t about −axis
        quat_to_axis_angle(Quat(-q.w, -q.x, -q.y, -q.z), a, t);
        EXPECT_NEAR(t, 2.0 * kPi - angle, 1e-13);
        expect_vec_near(a, -glm::normalize(axis), 1e-12);
    }
}

TEST(QuatAxisAngle, EdgeCases) {
    Vec3 axis;
    double angle;
    quat_to_axis_angle(Quat(1, 0, 0, 0), axis, angle);  // identity: Blender's default axis
    EXPECT_EQ(angle, 0.0);
    expect_vec_near(axis, Vec3(0, 1, 0), 0);
    quat_to_axis_angle(Quat(-2, 0, 0, 0), axis, angle);  // −identity: a full turn
    EXPECT_DOUBLE_EQ(angle, 2.0 * kPi);
    expect_vec_near(axis, Vec3(0, 1, 0), 0);
    quat_to_axis_angle(Quat(0, 0, 0, 5), axis, angle);  // half turn about z
    EXPECT_DOUBLE_EQ(angle, kPi);
    expect_vec_near(axis, Vec3(0, 0, 1), 0);
    quat_to_axis_angle(Quat(1, 1e-12, 0, 0), axis, angle);  // tiny angle: direction still exact
    EXPECT_NEAR(angle, 2e-12, 1e-27);
    expect_vec_near(axis, Vec3(1, 0, 0), 0);
    expect_quat_near(axis_angle_to_quat(Vec3(0, 0, 1), 2.0 * kPi), Quat(-1, 0, 0, 0), 1e-15);  // no wrapping
    expect_invalid([] { axis_angle_to_quat(Vec3(0, 0, 0), 1.0); }, "axis: zero-length axis");
    expect_invalid([] { axis_angle_to_quat(Vec3(0, INFINITY, 0), 1.0); }, "axis: non-finite value inf in component y");
    expect_invalid([] { axis_angle_to_quat(Vec3(0, 0, 1), NAN); }, "angle: non-finite value nan");
    expect_invalid([&] { quat_to_axis_angle(Quat(0, 0, 0, 0), axis, angle); }, "zero-length quaternion");
}

TEST(QuatAngleBetween, SignInvariantAndAccurateNearZeroAndPi) {
    Random rnd;
    for (int trial = 0; trial < 500; ++trial) {
        const Quat a = rnd.unit();
        const Vec3 u = glm::normalize(rnd.vec());
        for (double delta : {1e-12, 1e-9, 1e-6, 0.5, 3.0, kPi - 1e-9}) {
            const Quat d = axis_angle_to_quat(u, delta);
            const Quat b = multiply(a, d);
            const double tol = delta < 1.0 ? 2e-15 + 1e-7 * delta : 1e-13;
            EXPECT_NEAR(angle_between(a, b), delta, tol);
            EXPECT_NEAR(angle_between(a, Quat(-b.w, -b.x, -b.y, -b.z)), delta, tol);  // sign-invariant
            EXPECT_NEAR(angle_between(2.0 * a, 0.5 * b), delta, tol);                 // scale-invariant
            EXPECT_NEAR(angle_between(b, a), delta, tol);                              // symmetric
        }
    }
    EXPECT_EQ(angle_between(Quat(1, 0, 0, 0), Quat(1, 0, 0, 0)), 0.0);
    EXPECT_DOUBLE_EQ(angle_between(Quat(1, 0, 0, 0), Quat(0, 1, 0, 0)), kPi);
    expect_invalid([] { angle_between(Quat(0, 0, 0, 0), Quat(1, 0, 0, 0)); }, "a: zero-length quaternion");
    expect_invalid([] { angle_between(Quat(1, 0, 0, 0), Quat(0, 0, 0, 0)); }, "b: zero-length quaternion");
}

// ---- matrices --------------------------------------------------------------------------------------

TEST(QuatMatrix, RoundTripAllShepperdBranches) {
    Random rnd;
    std::vector<Quat> cases = {Quat(1, 0, 0, 0), Quat(0, 1, 0, 0), Quat(0, 0, 1, 0), Quat(0, 0, 0, 1),
                               Quat(0.1, 0.9, 0.3, 0.2), Quat(0.1, 0.2, 0.9, 0.3), Quat(0.1, 0.3, 0.2, 0.9)};
    for (int trial = 0; trial < 1000; ++trial) cases.push_back(rnd.quat());
    for (const Quat& c : cases) {
        const Quat u = normalized_rotation(c);
        const Mat3 m = quat_to_matrix(c);
        EXPECT_NEAR(glm::determinant(m), 1.0, 1e-14);
        const Quat back = matrix_to_quat(m);
        EXPECT_GE(back.w, 0.0);
        EXPECT_NEAR(norm(back), 1.0, 1e-15);
        const Quat expected = u.w < 0.0 ? Quat(-u.w, -u.x, -u.y, -u.z) : u;
        if (u.w != 0.0) expect_quat_near(back, expected, 2e-15);
        expect_same_rotation(back, u, 1e-14);
    }
    // half turns (w = 0): the first nonzero of x, y, z is made positive
    expect_quat_near(matrix_to_quat(quat_to_matrix(Quat(0, -1, 0, 0))), Quat(0, 1, 0, 0), 1e-16);
    expect_quat_near(matrix_to_quat(quat_to_matrix(Quat(0, 0, -0.6, 0.8))), Quat(0, 0, 0.6, -0.8), 1e-15);
}

TEST(QuatMatrix, RobustToScaleShearAndNoise) {
    Random rnd;
    for (int trial = 0; trial < 300; ++trial) {
        const Quat q = rnd.unit();
        const Mat3 r = quat_to_matrix(q);
        // slightly non-orthonormal: the nearest rotation is within the noise
        Mat3 noisy = r;
        for (int c = 0; c < 3; ++c)
            for (int k = 0; k < 3; ++k) noisy[c][k] += 1e-7 * rnd.normal();
        expect_same_rotation(matrix_to_quat(noisy), q, 1e-6);
        // any positive scale, before or after the rotation, and a uniform one: removed exactly
        const Mat3 s = Mat3(glm::dmat3(glm::dvec3(rnd.uniform(0.01, 100.0), 0, 0), glm::dvec3(0, rnd.uniform(0.01, 100.0), 0),
                                       glm::dvec3(0, 0, rnd.uniform(0.01, 100.0))));
        expect_same_rotation(matrix_to_quat(r * s), q, 1e-13);
        expect_same_rotation(matrix_to_quat(s * r), q, 1e-13);
        expect_same_rotation(matrix_to_quat(1e-5 * r), q, 1e-14);
        expect_same_rotation(matrix_to_quat(1e5 * r), q, 1e-14);
        // the nearest rotation is orthonormal and, for a rotation, unchanged
        const Mat3 n = nearest_rotation(noisy);
        const Mat3 ntn = glm::transpose(n) * n;
        for (int c = 0; c < 3; ++c)
            for (int k = 0; k < 3; ++k) EXPECT_NEAR(ntn[c][k], c == k ? 1.0 : 0.0, 1e-15);
        const Mat3 same = nearest_rotation(r);
        for (int c = 0; c < 3; ++c)
            for (int k = 0; k < 3; ++k) EXPECT_NEAR(same[c][k], r[c][k], 1e-15);
        // 4×4: translation ignored
        Mat4 m4 = translation_matrix(Vec3(5, 6, 7)) * rotation_matrix4(q) * scale_matrix(Vec3(2, 3, 4));
        expect_same_rotation(matrix4_to_quat(m4), q, 1e-13);
    }
}

TEST(QuatMatrix, RefusesReflectionsSingularAndNonFinite) {
    expect_invalid([] { matrix_to_quat(Mat3(glm::dvec3(-1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1))); },
                   "m: reflection (determinant < 0)");
    expect_invalid([] { matrix_to_quat(Mat3(0.0)); }, "m: singular matrix");
    expect_invalid([] { matrix_to_quat(Mat3(glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 0))); },
                   "singular matrix");
    expect_invalid([] { matrix_to_quat(Mat3(glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1e-20))); },
                   "singular matrix");
    Mat3 bad(1.0);
    bad[2][1] = NAN;  // row 1, column 2
    expect_invalid([&] { matrix_to_quat(bad); }, "non-finite value nan in entry [1][2]");
    expect_invalid([&] { nearest_rotation(bad); }, "entry [1][2]");
    EXPECT_EQ(rotation_matrix_problem(Mat3(1.0)), "");
}

TEST(QuatTransform, HomogeneousMatrices) {
    expect_vec_near(transform_point(translation_matrix(Vec3(1, -2, 3)), Vec3(1, 1, 1)), Vec3(2, -1, 4), 0);
    expect_vec_near(transform_point(scale_matrix(Vec3(-1, 2, 0)), Vec3(1, 1, 1)), Vec3(-1, 2, 0), 0);
    EXPECT_EQ(glm::determinant(scale_matrix(Vec3(-1, 1, 1))), -1.0);
    const Quat q = axis_angle_to_quat(Vec3(1, 2, 3), 0.7);
    expect_vec_near(transform_point(rotation_matrix4(q), Vec3(4, 5, 6)), rotate(q, Vec3(4, 5, 6)), 1e-14);
    // a projective matrix divides by w
    Mat4 p(1.0);
    p[3][3] = 2.0;
    expect_vec_near(transform_point(p, Vec3(2, 4, 6)), Vec3(1, 2, 3), 0);
    Mat4 z(1.0);
    z[3][3] = 0.0;
    expect_invalid([&] { transform_point(z, Vec3(1, 2, 3)); }, "maps to infinity");
    expect_invalid([] { rotation_matrix4(Quat(0, 0, 0, 0)); }, "zero-length quaternion");
}

// ---- the two matrix representations ----------------------------------------------------------------

namespace {
using C2 = std::array<std::complex<double>, 4>;
C2 mul2(const C2& a, const C2& b) {
    return {a[0] * b[0] + a[1] * b[2], a[0] * b[1] + a[1] * b[3], a[2] * b[0] + a[3] * b[2], a[2] * b[1] + a[3] * b[3]};
}
std::array<double, 16> mul4(const std::array<double, 16>& a, const std::array<double, 16>& b) {
    std::array<double, 16> c{};
    for (int r = 0; r < 4; ++r)
        for (int k = 0; k < 4; ++k)
            for (int j = 0; j < 4; ++j) c[4 * r + k] += a[4 * r + j] * b[4 * j + k];
    return c;
}
}  // namespace

TEST(QuatRepresentations, ProductsMapToProducts) {
    Random rnd;
    for (int trial = 0; trial < 300; ++trial) {
        const Quat a = rnd.quat(), b = rnd.quat();
        const C2 ca = quat_to_complex2(a), cb = quat_to_complex2(b), cab = quat_to_complex2(multiply(a, b));
        const C2 prod = mul2(ca, cb);
        for (int n = 0; n < 4; ++n) EXPECT_NEAR(std::abs(prod[n] - cab[n]), 0.0, 1e-13);
        // det C(q) = |q|², C(conj q) = C(q)^H
        const std::complex<double> det = ca[0] * ca[3] - ca[1] * ca[2];
        EXPECT_NEAR(det.real(), norm(a) * norm(a), 1e-13);
        EXPECT_NEAR(det.imag(), 0.0, 1e-13);
        const C2 cc = quat_to_complex2(conjugate(a));
        EXPECT_NEAR(std::abs(cc[1] - std::conj(ca[2])), 0.0, 0.0);

        const auto la = quat_to_real4(a), lb = quat_to_real4(b), lab = quat_to_real4(multiply(a, b));
        const auto lprod = mul4(la, lb);
        for (int n = 0; n < 16; ++n) EXPECT_NEAR(lprod[n], lab[n], 1e-13);
        // L(a)·vec(b) = vec(a·b)
        const double vb[4] = {b.w, b.x, b.y, b.z};
        double v[4] = {0, 0, 0, 0};
        for (int r = 0; r < 4; ++r)
            for (int k = 0; k < 4; ++k) v[r] += la[4 * r + k] * vb[k];
        const Quat ab = multiply(a, b);
        expect_quat_near(Quat(v[0], v[1], v[2], v[3]), ab, 1e-13);

        expect_quat_near(complex2_to_quat(ca), a, 1e-15);
        expect_quat_near(real4_to_quat(la), a, 1e-15);
    }
    EXPECT_EQ(finite_problem(C2{std::complex<double>(0, NAN), 0, 0, 0}), "non-finite value nan in the imaginary part of entry [0][0]");
}

// ---- validation --------------------------------------------------------------------------------------

TEST(QuatValidation, ProblemsNameTheComponent) {
    EXPECT_EQ(finite_problem(Quat(1, 0, 0, 0)), "");
    EXPECT_EQ(finite_problem(Quat(1, 0, INFINITY, 0)), "non-finite value inf in component y");
    EXPECT_EQ(finite_problem(Vec3(0, 0, -INFINITY)), "non-finite value -inf in component z");
    EXPECT_EQ(finite_problem(NAN), "non-finite value nan");
    EXPECT_EQ(nonzero_problem(Quat(0, 0, 0, 0)), "zero-length quaternion");
    EXPECT_EQ(nonzero_problem(Quat(0, 0, 0, 1e-301)), "zero-length quaternion");
    EXPECT_EQ(nonzero_problem(Quat(0, 0, 0, 1e-290)), "");
    EXPECT_EQ(nonzero_problem(Vec3(0, 0, 0), "axis"), "zero-length axis");
    expect_invalid([] { check_finite(Quat(0, NAN, 0, 0), "q[7]"); }, "q[7]: non-finite value nan in component x");
    expect_invalid([] { check_nonzero(Vec3(0, 0, 0), "v"); }, "v: zero-length vector");
    expect_invalid([] { normalized_rotation(Quat(0, 0, 0, 0), "keys[2]"); }, "keys[2]: zero-length quaternion");
    // tiny and huge quaternions normalize exactly
    expect_quat_near(normalized_rotation(Quat(0, 3e-250, 4e-250, 0)), Quat(0, 0.6, 0.8, 0), 1e-16);
    expect_quat_near(normalized_rotation(Quat(0, 3e250, 4e250, 0)), Quat(0, 0.6, 0.8, 0), 1e-16);
}
