// Tests of the private kernels' stated preconditions (native/src/curve_math.hpp): the sanitizer
// build (QUATCURVE_ASSERTS) checks them, and these tests check the checks.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "../../native/src/curve_impl.hpp"

using namespace quatcurve;
using namespace quatcurve::detail;

TEST(CurveMath, KernelsInsideTheirPreconditions) {
    double c, k;
    exp_coeffs(0.25, c, k);
    EXPECT_NEAR(c, std::cos(0.25), 1e-15);
    EXPECT_NEAR(atan2_over_n(0.6, 0.8), std::atan2(0.6, 0.8) / 0.6, 1e-15);
    const Vec3 rho(1.0, 2.0, 2.0);  // |ρ| = 3 < 2π
    const Vec3 v(0.3, -0.2, 0.1);
    const Vec3 back = jl_inv_apply(rho, jl_apply(rho, v));
    EXPECT_LE(glm::length(back - v), 1e-14);
    const double knots[] = {0.0, 1.0, 2.0};
    std::size_t hint = 0;
    EXPECT_EQ(locate(knots, 2, 1.5, hint), 1u);
}

#ifdef QUATCURVE_ASSERTS
TEST(CurveMathDeathTest, BrokenPreconditionsAbortWithTheirStatement) {
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    double c, k;
    EXPECT_DEATH(exp_coeffs(-1.0, c, k), "precondition failed: exp_coeffs");
    EXPECT_DEATH(atan2_over_n(0.6, -0.8), "precondition failed: atan2_over_n");
    EXPECT_DEATH(atan2_over_n(2.0, 2.0), "precondition failed: atan2_over_n");
    EXPECT_DEATH(jl_inv_apply(Vec3(7.0, 0.0, 0.0), Vec3(1.0)), "precondition failed: jl_inv_apply");
    EXPECT_DEATH(jr_inv_matrix(Vec3(0.0, 6.5, 0.0)), "precondition failed: jr_inv_matrix");
    const double knots[] = {0.0, 1.0, 2.0};
    std::size_t hint = 0;
    EXPECT_DEATH(locate(knots, 2, 2.5, hint), "precondition failed: locate");
}
#else
TEST(CurveMathDeathTest, BrokenPreconditionsAbortWithTheirStatement) {
    GTEST_SKIP() << "preconditions are checked in the sanitizer build (cpp.sanitize, QUATCURVE_ASSERTS)";
}
#endif
