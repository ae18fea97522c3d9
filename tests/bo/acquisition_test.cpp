#include "bo/acquisition.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace maptune::bo {
namespace {

gp::GaussianProcess small_gp() {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    Eigen::MatrixXd x(2, 12);
    Eigen::VectorXd y(12);
    for (int i = 0; i < 12; ++i) {
        x(0, i) = u(rng);
        x(1, i) = u(rng);
        y(i) = std::sin(5.0 * x(0, i)) * std::cos(3.0 * x(1, i));
    }
    gp::GaussianProcess model(2);
    gp::Hyperparameters hp = gp::Hyperparameters::defaults(2);
    hp.length_scales = Eigen::Vector2d(0.3, 0.4);
    model.set_hyperparameters(hp);
    model.set_data(x, y);
    return model;
}

TEST(AcquisitionTest, LogHMatchesDirectFormulaAndIsContinuous) {
    for (double z : {-11.9, -5.9, -3.0, -1.0, 0.0, 0.7, 2.5}) {
        const double phi = std::exp(-0.5 * z * z) / std::sqrt(2.0 * M_PI);
        const double cdf = 0.5 * std::erfc(-z / std::sqrt(2.0));
        EXPECT_NEAR(log_h(z), std::log(phi + z * cdf), 1e-6) << z;
    }
    EXPECT_NEAR(log_h(-12.0 - 1e-9), log_h(-12.0 + 1e-9), 1e-5);
    EXPECT_TRUE(std::isfinite(log_h(-40.0)));
    EXPECT_LT(log_h(-40.0), log_h(-39.0));
}

class AcquisitionGradientTest : public ::testing::TestWithParam<Acquisition> {};

TEST_P(AcquisitionGradientTest, MatchesFiniteDifferences) {
    const gp::GaussianProcess model = small_gp();
    AcquisitionContext ctx;
    ctx.kind = GetParam();
    ctx.kappa = 2.0;
    ctx.incumbent = 0.6;
    for (const Eigen::Vector2d& p : {Eigen::Vector2d(0.2, 0.7), Eigen::Vector2d(0.85, 0.15)}) {
        Eigen::VectorXd grad;
        const double value = acquisition_value(ctx, model.predict_with_gradient(p), &grad);
        Eigen::VectorXd m, v;
        model.predict(p, m, v);
        EXPECT_NEAR(value, acquisition_values(ctx, m, v)(0), 1e-9);
        for (int j = 0; j < 2; ++j) {
            const double h = 1e-6;
            Eigen::Vector2d pp = p, pm = p;
            pp(j) += h;
            pm(j) -= h;
            const double fd = (acquisition_value(ctx, model.predict_with_gradient(pp), nullptr) -
                               acquisition_value(ctx, model.predict_with_gradient(pm), nullptr)) /
                              (2 * h);
            EXPECT_NEAR(grad(j), fd, 1e-4 * std::max(1.0, std::abs(fd))) << to_string(ctx.kind);
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Kinds, AcquisitionGradientTest,
                         ::testing::Values(Acquisition::ucb, Acquisition::ucb_schedule,
                                           Acquisition::ei, Acquisition::log_ei),
                         [](const auto& tpi) { return to_string(tpi.param); });

TEST(AcquisitionTest, SrinivasScheduleGrowsSlowly) {
    const double k10 = srinivas_kappa(6, 10, 0.1, 0.2);
    const double k100 = srinivas_kappa(6, 100, 0.1, 0.2);
    EXPECT_GT(k100, k10);
    EXPECT_LT(k100, 3.0);
    EXPECT_EQ(acquisition_from_string("log_ei"), Acquisition::log_ei);
    EXPECT_FALSE(acquisition_from_string("nope").has_value());
}

}  // namespace
}  // namespace maptune::bo
