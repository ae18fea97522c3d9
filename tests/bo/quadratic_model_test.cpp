#include "bo/quadratic_model.hpp"

#include <gtest/gtest.h>

#include <Eigen/QR>
#include <cmath>
#include <limits>
#include <random>

namespace maptune::bo {
namespace {

Eigen::MatrixXd random_points(int d, int n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    Eigen::MatrixXd u(d, n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < d; ++j) u(j, i) = uni(rng);
    return u;
}

// A concave separable bowl with axis scales 1 .. 100 and its peak inside the unit cube.
double bowl(const Eigen::VectorXd& u) {
    double v = 2.0;
    for (Eigen::Index j = 0; j < u.size(); ++j) {
        const double peak = 0.2 + 0.6 * static_cast<double>(j) / static_cast<double>(u.size());
        v -= std::pow(10.0, 2.0 * static_cast<double>(j) / static_cast<double>(u.size() - 1)) *
             (u(j) - peak) * (u(j) - peak);
    }
    return v;
}

TEST(QuadraticModelTest, RecoversASeparableBowlAndItsPeak) {
    const int d = 6;
    const Eigen::MatrixXd u = random_points(d, 30, 1);
    Eigen::VectorXd y(u.cols());
    for (Eigen::Index i = 0; i < u.cols(); ++i) y(i) = bowl(u.col(i));
    const Eigen::VectorXd centre = Eigen::VectorXd::Constant(d, 0.9);
    const auto model = fit_quadratic(u, y, centre, 0.0);
    ASSERT_TRUE(model.has_value());
    for (Eigen::Index i = 0; i < u.cols(); ++i) EXPECT_NEAR(model->value(u.col(i)), y(i), 1e-5);
    const Eigen::VectorXd best =
        maximize_in_box(*model, Eigen::VectorXd::Zero(d), Eigen::VectorXd::Ones(d));
    for (int j = 0; j < d; ++j) EXPECT_NEAR(best(j), 0.2 + 0.6 * j / d, 1e-4) << "dimension " << j;
}

TEST(QuadraticModelTest, SmoothsRipplesIntoTheirBowl) {
    // Rastrigin-like: a bowl with ripples of comparable height. The least-squares model over
    // the whole box finds the bowl's centre, which the ripples hide from local search.
    const int d = 5;
    const Eigen::MatrixXd u = random_points(d, 200, 2);
    Eigen::VectorXd y(u.cols());
    for (Eigen::Index i = 0; i < u.cols(); ++i) {
        double v = 0.0;
        for (int j = 0; j < d; ++j) {
            const double z = 10.0 * (u(j, i) - 0.35);
            v -= z * z - 10.0 * std::cos(2.0 * M_PI * z);
        }
        y(i) = v;
    }
    const auto model = fit_quadratic(u, y, Eigen::VectorXd::Constant(d, 0.5));
    ASSERT_TRUE(model.has_value());
    const Eigen::VectorXd best =
        maximize_in_box(*model, Eigen::VectorXd::Zero(d), Eigen::VectorXd::Ones(d));
    for (int j = 0; j < d; ++j) EXPECT_NEAR(best(j), 0.35, 0.05) << "dimension " << j;
}

TEST(QuadraticModelTest, StaysInTheBoxAndClimbsConvexDimensionsToAFace) {
    const int d = 3;
    const Eigen::MatrixXd u = random_points(d, 20, 3);
    Eigen::VectorXd y(u.cols());
    // Dimension 0 concave with its peak below the box, 1 convex (upward), 2 flat.
    for (Eigen::Index i = 0; i < u.cols(); ++i) {
        y(i) = -(u(0, i) - 0.1) * (u(0, i) - 0.1) + (u(1, i) - 0.3) * (u(1, i) - 0.3) + 1.0;
    }
    const Eigen::VectorXd centre = Eigen::VectorXd::Constant(d, 0.5);
    const auto model = fit_quadratic(u, y, centre, 0.0);
    ASSERT_TRUE(model.has_value());
    const Eigen::VectorXd lo = Eigen::VectorXd::Constant(d, 0.4),
                          hi = Eigen::VectorXd::Constant(d, 0.6);
    const Eigen::VectorXd best = maximize_in_box(*model, lo, hi);
    EXPECT_NEAR(best(0), 0.4, 1e-9);  // the concave peak, clamped to the box
    EXPECT_NEAR(best(1), 0.6, 1e-9);  // up the slope at the centre (0.5 > 0.3), to the face
    EXPECT_NEAR(best(2), 0.5, 1e-3);  // no slope (rounding only): stays
}

// A concave bowl along rotated axes: its valley runs diagonally, so no separable surface points
// along it.
double rotated_bowl(const Eigen::VectorXd& u, const Eigen::MatrixXd& rotation,
                    const Eigen::VectorXd& peak) {
    const Eigen::VectorXd z = rotation * (u - peak);
    double v = 1.0;
    for (Eigen::Index j = 0; j < z.size(); ++j)
        v -= std::pow(10.0, 2.0 * static_cast<double>(j) / static_cast<double>(z.size() - 1)) *
             z(j) * z(j);
    return v;
}

Eigen::MatrixXd random_rotation(int d, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> normal;
    Eigen::MatrixXd m(d, d);
    for (int i = 0; i < d; ++i)
        for (int j = 0; j < d; ++j) m(i, j) = normal(rng);
    return Eigen::HouseholderQR<Eigen::MatrixXd>(m).householderQ();
}

TEST(QuadraticModelTest, RecoversARotatedBowlWhereTheDataSupportCrossTerms) {
    const int d = 5;
    const Eigen::MatrixXd rotation = random_rotation(d, 7);
    const Eigen::VectorXd peak = Eigen::VectorXd::LinSpaced(d, 0.3, 0.7);
    const Eigen::MatrixXd u = random_points(d, 60, 8);  // 21 coefficients: well determined
    Eigen::VectorXd y(u.cols());
    for (Eigen::Index i = 0; i < u.cols(); ++i) y(i) = rotated_bowl(u.col(i), rotation, peak);
    const auto model = fit_quadratic(u, y, Eigen::VectorXd::Constant(d, 0.5));
    ASSERT_TRUE(model.has_value());
    EXPECT_FALSE(model->separable());
    const Eigen::VectorXd best =
        maximize_in_box(*model, Eigen::VectorXd::Zero(d), Eigen::VectorXd::Ones(d));
    EXPECT_LT((best - peak).norm(), 0.02) << best.transpose();
    // The separable surface on the same data misses the peak by far more.
    const auto axes = fit_quadratic(u, y, Eigen::VectorXd::Constant(d, 0.5), 1e-6, false);
    ASSERT_TRUE(axes.has_value());
    EXPECT_TRUE(axes->separable());
    EXPECT_GT(
        (maximize_in_box(*axes, Eigen::VectorXd::Zero(d), Eigen::VectorXd::Ones(d)) - peak).norm(),
        0.1);
}

TEST(QuadraticModelTest, KeepsTheSeparableSurfaceWhenCrossTermsOnlyFitNoise) {
    // Ripples on a separable bowl, few points: cross terms would only chase the ripples.
    const int d = 6;
    const Eigen::MatrixXd u = random_points(d, 25, 9);
    Eigen::VectorXd y(u.cols());
    for (Eigen::Index i = 0; i < u.cols(); ++i)
        y(i) = bowl(u.col(i)) + 3.0 * std::cos(20.0 * u.col(i).sum());
    const auto model = fit_quadratic(u, y, Eigen::VectorXd::Constant(d, 0.5));
    ASSERT_TRUE(model.has_value());
    EXPECT_TRUE(model->separable());
}

TEST(QuadraticModelTest, BoxMaximizerOfAnObliqueModelMatchesAGridSearch) {
    // A concave model whose peak lies outside the box: the maximizer sits on faces, where a
    // per-coordinate clamp of the unconstrained peak would be wrong.
    QuadraticModel m;
    m.centre = Eigen::Vector2d(0.5, 0.5);
    m.c = 0.0;
    m.g = Eigen::Vector2d(3.0, -1.0);
    m.A.resize(2, 2);
    m.A << -2.0, 1.8, 1.8, -2.0;
    const Eigen::Vector2d lo(0.2, 0.3), hi(0.8, 0.9);
    const Eigen::VectorXd best = maximize_in_box(m, lo, hi);
    Eigen::Vector2d grid_best = lo;
    for (int i = 0; i <= 600; ++i)
        for (int j = 0; j <= 600; ++j) {
            const Eigen::Vector2d p(lo(0) + 0.001 * i, lo(1) + 0.001 * j);
            if (m.value(p) > m.value(grid_best)) grid_best = p;
        }
    EXPECT_GE(m.value(best), m.value(grid_best) - 1e-9);
    EXPECT_TRUE((best.array() >= lo.array()).all() && (best.array() <= hi.array()).all());
}

TEST(QuadraticModelTest, RejectsTooFewOrNonFinitePoints) {
    const Eigen::MatrixXd u = random_points(3, 3, 4);
    EXPECT_FALSE(fit_quadratic(u, Eigen::Vector3d(1, 2, 3), Eigen::Vector3d::Zero()).has_value());
    const Eigen::MatrixXd v = random_points(3, 6, 5);
    Eigen::VectorXd y = Eigen::VectorXd::Ones(6);
    y(2) = std::numeric_limits<double>::quiet_NaN();
    EXPECT_FALSE(fit_quadratic(v, y, Eigen::Vector3d::Zero()).has_value());
}

}  // namespace
}  // namespace maptune::bo
