// reduce_impl::chebyshev_may_meet: the Remez exchange that rejects a one-channel segment fit before
// its reweighting rounds. It must never reject a problem whose minimax is within the cap (the reducer
// would lose a segment it can fit), and it should reject those clearly above it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include "reduce_impl.hpp"

using quatcurve::reduce_impl::chebyshev_may_meet;
using quatcurve::reduce_impl::ChebyshevRow;

namespace {

struct Problem {
    std::vector<ChebyshevRow> rows;
};

// Rows at increasing parameters u in (0, 1): the Bezier basis of the inner control values, a random
// target and weight.
Problem random_problem(std::mt19937& rng, int n) {
    std::uniform_real_distribution<double> unit(0.02, 0.98), target(-1.0, 1.0), weight(0.3, 5.0);
    std::vector<double> u(n);
    for (double& x : u) x = unit(rng);
    std::sort(u.begin(), u.end());
    Problem p;
    for (double x : u) p.rows.push_back({3.0 * x * (1.0 - x) * (1.0 - x), 3.0 * x * x * (1.0 - x), target(rng), weight(rng)});
    return p;
}

// The levelled error |h| of rows a < b < c (residuals +h, −h, +h), by Gaussian elimination with
// partial pivoting (not the exchange's Cramer's rule).
double levelled(const Problem& p, int a, int b, int c) {
    double M[3][4];
    const int idx[3] = {a, b, c};
    for (int r = 0; r < 3; ++r) {
        const ChebyshevRow& row = p.rows[idx[r]];
        M[r][0] = row.g1;
        M[r][1] = row.g2;
        M[r][2] = (r == 1 ? 1.0 : -1.0) / row.w;
        M[r][3] = row.t;
    }
    for (int col = 0; col < 3; ++col) {
        int piv = col;
        for (int r = col + 1; r < 3; ++r)
            if (std::fabs(M[r][col]) > std::fabs(M[piv][col])) piv = r;
        for (int k = 0; k < 4; ++k) std::swap(M[col][k], M[piv][k]);
        for (int r = col + 1; r < 3; ++r) {
            const double f = M[r][col] / M[col][col];
            for (int k = col; k < 4; ++k) M[r][k] -= f * M[col][k];
        }
    }
    return std::fabs(M[2][3] / M[2][2]);
}

// The minimax of the problem: over a Haar system the largest levelled error of all references.
double minimax(const Problem& p) {
    const int n = static_cast<int>(p.rows.size());
    double best = 0.0;
    for (int a = 0; a < n; ++a)
        for (int b = a + 1; b < n; ++b)
            for (int c = b + 1; c < n; ++c) best = std::max(best, levelled(p, a, b, c));
    return best;
}

bool may_meet(const Problem& p, double cap, std::size_t start[3]) {
    return chebyshev_may_meet(
        p.rows.size(), [&p](std::size_t r, ChebyshevRow& out) { out = p.rows[r]; }, start, cap);
}

}  // namespace

TEST(ChebyshevMayMeet, NeverRejectsAProblemWithinTheCapAndRejectsThoseAboveIt) {
    std::mt19937 rng(7);
    for (int trial = 0; trial < 400; ++trial) {
        const int n = 3 + trial % 14;
        const Problem p = random_problem(rng, n);
        const double s = minimax(p);
        ASSERT_GT(s, 0.0);
        for (double factor : {1.0 + 1e-9, 1.01, 2.0}) {
            std::size_t start[3] = {0, static_cast<std::size_t>(n / 2), static_cast<std::size_t>(n - 1)};
            EXPECT_TRUE(may_meet(p, factor * s, start)) << "trial " << trial << ", cap " << factor << " x the minimax";
        }
        // A cap clearly below the minimax: rejected (the exchange converges well within its rounds
        // on problems of this size), from the default start and from another one.
        std::size_t start[3] = {0, static_cast<std::size_t>(n / 2), static_cast<std::size_t>(n - 1)};
        EXPECT_FALSE(may_meet(p, 0.99 * s, start)) << "trial " << trial;
        if (n >= 5) {
            std::size_t other[3] = {1, 2, static_cast<std::size_t>(n - 2)};
            EXPECT_FALSE(may_meet(p, 0.99 * s, other)) << "trial " << trial;
        }
    }
}

TEST(ChebyshevMayMeet, UndecidedCasesPass) {
    std::mt19937 rng(11);
    Problem p = random_problem(rng, 6);
    const double s = minimax(p);
    // A start that is not three increasing rows inside the problem: undecided.
    std::size_t bad[3] = {2, 2, 5};
    EXPECT_TRUE(may_meet(p, 0.5 * s, bad));
    std::size_t outside[3] = {0, 3, 6};
    EXPECT_TRUE(may_meet(p, 0.5 * s, outside));
    // A reference row of weight 0 (a sample the channel hardly moves): undecided.
    p.rows[0].w = 0.0;
    std::size_t start[3] = {0, 3, 5};
    EXPECT_TRUE(may_meet(p, 1e-3 * s, start));
    // Fewer than three rows: undecided.
    Problem two = random_problem(rng, 2);
    std::size_t first[3] = {0, 1, 2};
    EXPECT_TRUE(may_meet(two, 1e-9, first));
}
