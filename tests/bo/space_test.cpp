#include "bo/space.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "bo/quasi_random.hpp"

namespace maptune::bo {
namespace {

TEST(SearchSpaceTest, ContinuousAndLogRoundTrip) {
    const SearchSpace space({{"a", -1.0, 3.0}, {"b", 0.01, 100.0, false, true}});
    const std::vector<double> v = space.to_values(Eigen::Vector2d(0.25, 0.5));
    EXPECT_NEAR(v[0], 0.0, 1e-12);
    EXPECT_NEAR(v[1], 1.0, 1e-12);  // geometric midpoint of [0.01, 100]
    const Eigen::VectorXd u = space.from_values(v);
    EXPECT_NEAR(u(0), 0.25, 1e-12);
    EXPECT_NEAR(u(1), 0.5, 1e-12);
    EXPECT_EQ(space.to_model_input(u), u);
}

TEST(SearchSpaceTest, IntegersAreRoundedInsideTheModelInput) {
    const SearchSpace space({{"n", 1.0, 10.0, true}});
    std::set<double> seen;
    std::vector<int> counts(11, 0);
    for (int i = 0; i < 1000; ++i) {
        const double u = (i + 0.5) / 1000.0;
        const double x = space.to_values(Eigen::VectorXd::Constant(1, u))[0];
        EXPECT_EQ(x, std::round(x));
        ++counts[static_cast<std::size_t>(x)];
        // The GP sees the normalized integer, identical across the whole bin.
        const double g = space.to_model_input(Eigen::VectorXd::Constant(1, u))(0);
        EXPECT_NEAR(g, (x - 1.0) / 9.0, 1e-12);
    }
    for (int x = 1; x <= 10; ++x) EXPECT_EQ(counts[static_cast<std::size_t>(x)], 100) << x;
    const Eigen::VectorXd snapped = space.snap(Eigen::VectorXd::Constant(1, 0.03));
    EXPECT_NEAR(snapped(0), 0.05, 1e-12);  // centre of the first bin
}

TEST(SearchSpaceTest, LogScaledIntegersCoverAllValues) {
    const SearchSpace space({{"n", 3.0, 300.0, true, true}});
    std::set<double> seen;
    for (int i = 0; i < 20000; ++i) {
        seen.insert(space.to_values(Eigen::VectorXd::Constant(1, (i + 0.5) / 20000.0))[0]);
    }
    EXPECT_EQ(seen.size(), 298u);
    EXPECT_EQ(*seen.begin(), 3.0);
    EXPECT_EQ(*seen.rbegin(), 300.0);
    EXPECT_EQ(space.canonical({41.7})[0], 42.0);
}

// A float with a step is proposed on its grid only: what the objective evaluates after
// rounding to `decimals`, so two proposals are never one evaluation under two names.
TEST(SearchSpaceTest, SteppedFloatsLieOnTheirGridInsideTheBounds) {
    const SearchSpace space({{"x", 0.105, 2.0, false, false, 0.01}, {"y", 0.1, 10.0, false, true, 0.1}});
    EXPECT_TRUE(space.has_grid());
    for (int i = 0; i <= 1000; ++i) {
        const double u = i / 1000.0;
        const auto v = space.to_values(Eigen::VectorXd::Constant(2, u));
        EXPECT_NEAR(v[0] * 100, std::round(v[0] * 100), 1e-9) << u;
        EXPECT_NEAR(v[1] * 10, std::round(v[1] * 10), 1e-9) << u;
        EXPECT_GE(v[0], 0.105);  // 0.10 is below the bound: the first grid value is 0.11
        EXPECT_LE(v[1], 10.0 + 1e-12);
        // snap() gives the canonical u of those values, which maps back to them.
        const auto again = space.to_values(space.snap(Eigen::VectorXd::Constant(2, u)));
        EXPECT_NEAR(again[0], v[0], 1e-12);
        EXPECT_NEAR(again[1], v[1], 1e-12);
    }
    EXPECT_NEAR(space.canonical({0.1234, 3.33})[0], 0.12, 1e-12);
    EXPECT_NEAR(space.canonical({0.1234, 3.33})[1], 3.3, 1e-12);
    EXPECT_FALSE(SearchSpace({{"x", 0.0, 1.0}}).has_grid());
}

TEST(SearchSpaceTest, RejectsBadBounds) {
    EXPECT_THROW(SearchSpace({{"a", 1.0, 0.0}}), std::invalid_argument);
    EXPECT_THROW(SearchSpace({{"a", 0.0, 1.0, false, true}}), std::invalid_argument);
    EXPECT_THROW(SearchSpace(std::vector<ParameterSpec>{}), std::invalid_argument);
}

TEST(ScrambledHaltonTest, DeterministicUniformAndDistinct) {
    const ScrambledHalton a(5, 42), b(5, 42), c(5, 43);
    const Eigen::MatrixXd pa = a.points(0, 512);
    EXPECT_EQ(pa, b.points(0, 512));
    EXPECT_NE(pa, c.points(0, 512));
    EXPECT_GE(pa.minCoeff(), 0.0);
    EXPECT_LT(pa.maxCoeff(), 1.0);
    // Low discrepancy: every dimension's mean and every half-cube count close to uniform.
    for (int j = 0; j < 5; ++j) {
        EXPECT_NEAR(pa.row(j).mean(), 0.5, 0.01);
        EXPECT_NEAR((pa.row(j).array() < 0.5).count(), 256, 8);
    }
}

}  // namespace
}  // namespace maptune::bo
