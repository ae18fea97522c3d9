#include "gp/gaussian_process.hpp"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace maptune::gp {
namespace {

Eigen::MatrixXd uniform_points(int dim, Eigen::Index n, std::mt19937_64& rng) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    Eigen::MatrixXd x(dim, n);
    for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] = u(rng);
    return x;
}

double hartmann6(const Eigen::VectorXd& x) {
    static const double alpha[4] = {1.0, 1.2, 3.0, 3.2};
    static const double a[4][6] = {{10, 3, 17, 3.5, 1.7, 8},
                                   {0.05, 10, 17, 0.1, 8, 14},
                                   {3, 3.5, 1.7, 10, 17, 8},
                                   {17, 8, 0.05, 10, 0.1, 14}};
    static const double p[4][6] = {{0.1312, 0.1696, 0.5569, 0.0124, 0.8283, 0.5886},
                                   {0.2329, 0.4135, 0.8307, 0.3736, 0.1004, 0.9991},
                                   {0.2348, 0.1451, 0.3522, 0.2883, 0.3047, 0.6650},
                                   {0.4047, 0.8828, 0.8732, 0.5743, 0.1091, 0.0381}};
    double f = 0.0;
    for (int i = 0; i < 4; ++i) {
        double s = 0.0;
        for (int j = 0; j < 6; ++j) s += a[i][j] * (x(j) - p[i][j]) * (x(j) - p[i][j]);
        f -= alpha[i] * std::exp(-s);
    }
    return f;
}

// log(1 + Rosenbrock) on [-2, 2]^d mapped from the unit cube: curved valley, 9-D.
double log_rosenbrock(const Eigen::VectorXd& u) {
    double f = 0.0;
    for (Eigen::Index j = 0; j + 1 < u.size(); ++j) {
        const double a = 4.0 * u(j) - 2.0;
        const double b = 4.0 * u(j + 1) - 2.0;
        f += 100.0 * (b - a * a) * (b - a * a) + (1.0 - a) * (1.0 - a);
    }
    return std::log1p(f);
}

GaussianProcess make_gp(int dim, const Hyperparameters& hp, const Eigen::MatrixXd& x,
                        const Eigen::VectorXd& y,
                        CholeskyBackend backend = CholeskyBackend::eigen) {
    GpOptions options;
    options.backend = backend;
    GaussianProcess gp(dim, options);
    gp.set_data(x, y);
    gp.set_hyperparameters(hp);
    return gp;
}

Hyperparameters some_hyperparameters() {
    Hyperparameters hp;
    hp.length_scales = Eigen::Vector3d(0.3, 0.5, 0.8);
    hp.signal_variance = 1.3;
    hp.noise_variance = 1e-3;
    return hp;
}

TEST(GaussianProcessTest, PosteriorMatchesDenseSolve) {
    std::mt19937_64 rng(7);
    const Eigen::MatrixXd x = uniform_points(3, 30, rng);
    const Eigen::VectorXd y =
        Eigen::VectorXd::Random(30) * 4.0 + Eigen::VectorXd::Constant(30, 2.0);
    const Eigen::MatrixXd xs = uniform_points(3, 17, rng);
    const Hyperparameters hp = some_hyperparameters();
    for (auto backend : {CholeskyBackend::eigen, CholeskyBackend::cholmod}) {
        if (backend == CholeskyBackend::cholmod && !cholmod_available()) continue;
        const GaussianProcess gp = make_gp(3, hp, x, y, backend);
        Eigen::VectorXd mean, var;
        gp.predict(xs, mean, var);

        // Oracle in standardized units with an explicit inverse.
        const double off = gp.output_offset();
        const double sc = gp.output_scale();
        Eigen::MatrixXd k = matern52(x, x, hp);
        k.diagonal().array() += hp.noise_variance;
        const Eigen::MatrixXd kinv = k.fullPivLu().inverse();
        const Eigen::MatrixXd ks = matern52(x, xs, hp);
        const Eigen::VectorXd ys = (y.array() - off) / sc;
        const Eigen::VectorXd mean_ref = (ks.transpose() * kinv * ys).array() * sc + off;
        const Eigen::VectorXd var_ref =
            (hp.signal_variance - (ks.transpose() * kinv * ks).diagonal().array()) * sc * sc;
        EXPECT_LT((mean - mean_ref).cwiseAbs().maxCoeff(), 1e-8) << to_string(backend);
        EXPECT_LT((var - var_ref).cwiseAbs().maxCoeff(), 1e-8) << to_string(backend);
    }
}

// The prior mean from the leading outputs only: far from the data the prediction returns to
// their average, not to the average of the later ones (clustered where the objective is good).
TEST(GaussianProcessTest, PriorMeanFromLeadingOutputs) {
    std::mt19937_64 rng(9);
    Eigen::MatrixXd x = uniform_points(3, 12, rng) * 0.2;  // all in a corner
    Eigen::VectorXd y(12);
    y.head(4).setConstant(1.0);
    y.tail(8).setConstant(5.0);
    y += Eigen::VectorXd::Random(12) * 0.1;
    Hyperparameters hp = some_hyperparameters();
    hp.length_scales.setConstant(0.1);
    const Eigen::MatrixXd far = Eigen::Vector3d(0.95, 0.95, 0.95);
    for (const Eigen::Index leading : {Eigen::Index{0}, Eigen::Index{4}}) {
        GpOptions options;
        options.mean_points = leading;
        GaussianProcess gp(3, options);
        gp.set_hyperparameters(hp);
        gp.set_data(x, y);
        Eigen::VectorXd mean, var;
        gp.predict(far, mean, var);
        const double expected = leading == 0 ? y.mean() : y.head(4).mean();
        EXPECT_NEAR(mean(0), expected, 1e-6) << "mean_points " << leading;
        // Appends standardize with the same offset.
        gp.append(Eigen::Vector3d(0.1, 0.1, 0.1), 5.0);
        gp.predict(far, mean, var);
        EXPECT_NEAR(mean(0), expected, 1e-6) << "mean_points " << leading << " after append";
    }
}

TEST(GaussianProcessTest, AppendAndTruncateMatchFreshModel) {
    std::mt19937_64 rng(8);
    const Eigen::MatrixXd x = uniform_points(3, 40, rng);
    const Eigen::VectorXd y = Eigen::VectorXd::Random(40);
    const Hyperparameters hp = some_hyperparameters();
    GaussianProcess inc = make_gp(3, hp, x.leftCols(25), y.head(25));
    for (Eigen::Index i = 25; i < 40; ++i) ASSERT_TRUE(inc.append(x.col(i), y(i)));

    // The fresh model must share the incremental one's standardization to be comparable.
    GaussianProcess fresh = make_gp(3, hp, x.leftCols(25), y.head(25));
    const Eigen::MatrixXd xs = uniform_points(3, 10, rng);
    {
        Eigen::MatrixXd k = matern52(x, x, hp);
        k.diagonal().array() += hp.noise_variance;
        const Eigen::VectorXd ys = (y.array() - inc.output_offset()) / inc.output_scale();
        const Eigen::MatrixXd ks = matern52(x, xs, hp);
        const Eigen::VectorXd mean_ref =
            (ks.transpose() * k.llt().solve(ys)).array() * inc.output_scale() + inc.output_offset();
        Eigen::VectorXd mean, var;
        inc.predict(xs, mean, var);
        EXPECT_LT((mean - mean_ref).cwiseAbs().maxCoeff(), 1e-9);
    }
    inc.truncate(25);
    Eigen::VectorXd m1, v1, m2, v2;
    inc.predict(xs, m1, v1);
    fresh.predict(xs, m2, v2);
    EXPECT_LT((m1 - m2).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((v1 - v2).cwiseAbs().maxCoeff(), 1e-9);
}

// Issue 15: between refits the optimizer appends points and replaces all outputs (a warping or
// the worst value moved); the result equals a fresh model of the same data.
TEST(GaussianProcessTest, AppendThenSetOutputsMatchesFreshModel) {
    std::mt19937_64 rng(9);
    const Eigen::MatrixXd x = uniform_points(3, 60, rng);
    const Eigen::VectorXd y0 = Eigen::VectorXd::Random(60);
    const Eigen::VectorXd y1 = 5.0 + 3.0 * Eigen::VectorXd::Random(60).array();  // other outputs
    const Hyperparameters hp = some_hyperparameters();
    GaussianProcess inc = make_gp(3, hp, x.leftCols(40), y0.head(40));
    for (Eigen::Index i = 40; i < 60; ++i) ASSERT_TRUE(inc.append(x.col(i), y0(i)));
    ASSERT_TRUE(inc.set_outputs(y1));
    const GaussianProcess fresh = make_gp(3, hp, x, y1);
    EXPECT_NEAR(inc.output_offset(), fresh.output_offset(), 1e-12);
    EXPECT_NEAR(inc.output_scale(), fresh.output_scale(), 1e-12);
    const Eigen::MatrixXd xs = uniform_points(3, 20, rng);
    Eigen::VectorXd m1, v1, m2, v2;
    inc.predict(xs, m1, v1);
    fresh.predict(xs, m2, v2);
    EXPECT_LT((m1 - m2).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((v1 - v2).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_THROW(inc.set_outputs(Eigen::VectorXd::Zero(3)), std::invalid_argument);
}

// Realistic optimizer data in 9-D: a spread-out design plus clusters of near-duplicates
// around a few centres (local refinement), with a fitted-looking model and tiny noise, so that
// K is ill-conditioned as in a long run.
struct ClusteredData {
    Eigen::MatrixXd x;
    Eigen::VectorXd y;
    Eigen::MatrixXd queries;  // uniform, at observations, and 1e-2 … 1e-8 away from them
};

ClusteredData clustered_data(Eigen::Index n, Eigen::Index m, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::normal_distribution<double> normal;
    const int dim = 9;
    ClusteredData data;
    data.x = uniform_points(dim, n, rng);
    for (Eigen::Index i = n / 2; i < n; ++i) {
        const Eigen::Index centre = i % 10;
        const double scale = std::pow(10.0, -1.0 - 4.0 * u(rng));
        for (int j = 0; j < dim; ++j) {
            data.x(j, i) = std::clamp(data.x(j, centre) + scale * normal(rng), 0.0, 1.0);
        }
    }
    data.y.resize(n);
    for (Eigen::Index i = 0; i < n; ++i) data.y(i) = 3.0 + 2.0 * log_rosenbrock(data.x.col(i));
    data.queries = uniform_points(dim, m, rng);
    for (Eigen::Index q = 0; q < m; q += 2) {
        const auto i = static_cast<Eigen::Index>(u(rng) * static_cast<double>(n)) % n;
        const double scale = q % 6 == 0 ? 0.0 : std::pow(10.0, -2.0 - 6.0 * u(rng));
        for (int j = 0; j < dim; ++j) {
            data.queries(j, q) = std::clamp(data.x(j, i) + scale * normal(rng), 0.0, 1.0);
        }
    }
    return data;
}

Hyperparameters fitted_like_9d() {
    Hyperparameters hp;
    hp.length_scales.resize(9);
    hp.length_scales << 1.4, 1.55, 1.48, 1.07, 1.25, 1.19, 0.98, 1.27, 2.95;
    hp.signal_variance = 5.5;
    hp.noise_variance = 1e-6;  // the lower bound: the worst conditioning a fit can produce
    return hp;
}

class FastPredictTest : public ::testing::TestWithParam<Eigen::Index> {};

// The blocked (and, when built so, AVX2) prediction against a direct dense solve with K⁻¹ from
// Eigen's LLT, both in double. Measured differences (SSE2, AVX2 and AVX-512 builds): |Δvar|
// ≤ 2e-13 of the prior variance, relative ≤ 2e-9, |Δmean| ≤ 3.4e-11 of the output scale; the
// tolerances leave 30–500×.
TEST_P(FastPredictTest, MatchesDenseDoubleSolve) {
    const Eigen::Index n = GetParam();
    const Eigen::Index m = n >= 1000 ? 300 : 1000;
    const ClusteredData data = clustered_data(n, m, 20 + static_cast<std::uint64_t>(n));
    const Hyperparameters hp = fitted_like_9d();
    const GaussianProcess gp = make_gp(9, hp, data.x, data.y);
    Eigen::VectorXd mean, var;
    gp.predict(data.queries, mean, var);

    // Oracle in standardized units, then the same output scaling as the GP.
    const double off = gp.output_offset();
    const double sc = gp.output_scale();
    Eigen::MatrixXd k = matern52(data.x, data.x, hp);
    k.diagonal().array() += hp.noise_variance + gp.jitter();
    const Eigen::LLT<Eigen::MatrixXd> llt(k);
    ASSERT_EQ(llt.info(), Eigen::Success);
    const Eigen::MatrixXd ks = matern52(data.x, data.queries, hp);
    const Eigen::VectorXd ys = (data.y.array() - off) / sc;
    const Eigen::VectorXd mean_ref = (ks.transpose() * llt.solve(ys)).array() * sc + off;
    const Eigen::ArrayXd var_std =
        hp.signal_variance - (ks.array() * llt.solve(ks).array()).colwise().sum().transpose();
    const Eigen::ArrayXd var_ref = var_std.max(1e-12 * hp.signal_variance) * sc * sc;

    const double prior = hp.signal_variance * sc * sc;
    double worst_abs = 0.0, worst_rel = 0.0;
    Eigen::Index tiny = 0;  // queries whose variance is below 1e-4 of the prior
    for (Eigen::Index q = 0; q < m; ++q) {
        const double d = std::abs(var(q) - var_ref(q));
        worst_abs = std::max(worst_abs, d / prior);
        if (var_ref(q) > 1e-6 * prior) worst_rel = std::max(worst_rel, d / var_ref(q));
        if (var_ref(q) < 1e-4 * prior) ++tiny;
        EXPECT_NEAR(mean(q), mean_ref(q), 1e-9 * sc) << "query " << q;
    }
    EXPECT_LT(worst_abs, 1e-11) << "max |Δvar| / prior variance";
    EXPECT_LT(worst_rel, 1e-6) << "max relative |Δvar| where var > 1e-6 prior";
    EXPECT_GT(tiny, m / 10) << "the data should put queries where cancellation matters";
}

INSTANTIATE_TEST_SUITE_P(Sizes, FastPredictTest, ::testing::Values(50, 1000));

TEST(GaussianProcessTest, PredictionDoesNotDependOnThreadsOrBatch) {
    const ClusteredData data = clustered_data(300, 777, 31);
    const Hyperparameters hp = fitted_like_9d();
    Eigen::VectorXd mean1, var1;
    {
        GpOptions options;
        options.threads = 1;
        GaussianProcess gp(9, options);
        gp.set_data(data.x, data.y);
        gp.set_hyperparameters(hp);
        gp.predict(data.queries, mean1, var1);
    }
    for (int threads : {2, 3, 0}) {
        GpOptions options;
        options.threads = threads;
        GaussianProcess gp(9, options);
        gp.set_data(data.x, data.y);
        gp.set_hyperparameters(hp);
        Eigen::VectorXd mean, var;
        gp.predict(data.queries, mean, var);
        // Bitwise: the threads split the queries, never a sum.
        for (Eigen::Index q = 0; q < data.queries.cols(); ++q) {
            ASSERT_EQ(mean(q), mean1(q)) << threads << " threads, query " << q;
            ASSERT_EQ(var(q), var1(q)) << threads << " threads, query " << q;
        }
        // A point's result does not depend on its batch or position either.
        const Eigen::Index first = 101, count = 5;
        gp.predict(data.queries.middleCols(first, count), mean, var);
        for (Eigen::Index q = 0; q < count; ++q) {
            ASSERT_EQ(mean(q), mean1(first + q));
            ASSERT_EQ(var(q), var1(first + q));
        }
    }
}

TEST(GaussianProcessTest, FitDoesNotDependOnThreads) {
    std::mt19937_64 rng(13);
    const Eigen::MatrixXd x = uniform_points(6, 60, rng);
    Eigen::VectorXd y(60);
    for (Eigen::Index i = 0; i < 60; ++i) y(i) = hartmann6(x.col(i));
    FitResult results[2];
    for (int t = 0; t < 2; ++t) {
        GpOptions options;
        options.threads = t + 1;
        GaussianProcess gp(6, options);
        gp.set_data(x, y);
        results[t] = gp.fit(5);
    }
    EXPECT_EQ(results[0].neg_log_posterior, results[1].neg_log_posterior);
    EXPECT_EQ(results[0].evaluations, results[1].evaluations);
    EXPECT_EQ(results[0].hyperparameters.to_log(), results[1].hyperparameters.to_log());
}

// Several models fitted together (their starts sharing the threads) get exactly the fits they
// would get one by one.
TEST(GaussianProcessTest, FitTogetherEqualsSeparateFits) {
    std::mt19937_64 rng(17);
    const Eigen::MatrixXd x = uniform_points(6, 50, rng);
    Eigen::VectorXd y(50);
    for (Eigen::Index i = 0; i < 50; ++i) y(i) = hartmann6(x.col(i));
    const Eigen::VectorXd outputs[3] = {y, y.array().exp().matrix(), (y.array() + 4.0).log().matrix()};
    std::vector<GaussianProcess> together, alone;
    for (const Eigen::VectorXd& out : outputs) {
        together.emplace_back(6);
        together.back().set_data(x, out);
    }
    alone = together;
    std::vector<GaussianProcess*> models;
    for (GaussianProcess& g : together) models.push_back(&g);
    const std::vector<FitResult> results = GaussianProcess::fit_together(models, {3, 4, 5});
    ASSERT_EQ(results.size(), 3u);
    for (std::size_t m = 0; m < 3; ++m) {
        const FitResult own = alone[m].fit(3 + m);
        EXPECT_EQ(results[m].neg_log_posterior, own.neg_log_posterior) << "model " << m;
        EXPECT_EQ(results[m].evaluations, own.evaluations) << "model " << m;
        EXPECT_EQ(results[m].hyperparameters.to_log(), own.hyperparameters.to_log()) << "model " << m;
        EXPECT_EQ(together[m].hyperparameters().to_log(), alone[m].hyperparameters().to_log());
    }
}

// The analytic gradient of neg_log_posterior against central differences.
void expect_gradient_matches_finite_differences(const Eigen::MatrixXd& x, const Eigen::VectorXd& y,
                                                const Eigen::VectorXd& theta, const FitOptions& options) {
    Eigen::VectorXd grad;
    neg_log_posterior(x, y, theta, options, &grad);
    for (Eigen::Index i = 0; i < theta.size(); ++i) {
        const double h = 1e-5;
        Eigen::VectorXd tp = theta, tm = theta;
        tp(i) += h;
        tm(i) -= h;
        const double fd = (neg_log_posterior(x, y, tp, options, nullptr) -
                           neg_log_posterior(x, y, tm, options, nullptr)) /
                          (2.0 * h);
        EXPECT_NEAR(grad(i), fd, 1e-5 * std::max(1.0, std::abs(fd))) << "component " << i;
    }
}

class GradientTest : public ::testing::TestWithParam<bool> {};

TEST_P(GradientTest, LogPosteriorGradientMatchesFiniteDifferences) {
    std::mt19937_64 rng(9);
    const Eigen::MatrixXd x = uniform_points(4, 35, rng);
    Eigen::VectorXd y(35);
    for (Eigen::Index i = 0; i < 35; ++i) y(i) = std::sin(4.0 * x(0, i)) + x(1, i) * x(2, i);
    y = (y.array() - y.mean()) / std::sqrt((y.array() - y.mean()).square().mean());
    FitOptions options;
    options.use_priors = GetParam();
    Eigen::VectorXd theta(6);
    theta << std::log(0.3), std::log(0.7), std::log(1.5), std::log(0.2), std::log(0.9),
        std::log(1e-3);
    expect_gradient_matches_finite_differences(x, y, theta, options);
}

INSTANTIATE_TEST_SUITE_P(Priors, GradientTest, ::testing::Bool());

// Above 128 points the O(n²) terms run in column slabs (and above 256 the factor and inverse in
// blocks): the gradient must not change at the seams.
TEST(GaussianProcessTest, GradientMatchesFiniteDifferencesAcrossSlabs) {
    std::mt19937_64 rng(21);
    const Eigen::Index n = 300;
    const Eigen::MatrixXd x = uniform_points(3, n, rng);
    Eigen::VectorXd y(n);
    for (Eigen::Index i = 0; i < n; ++i) y(i) = std::sin(4.0 * x(0, i)) + x(1, i) * x(2, i);
    y = (y.array() - y.mean()) / std::sqrt((y.array() - y.mean()).square().mean());
    FitOptions options;
    Eigen::VectorXd theta(5);
    theta << std::log(0.3), std::log(0.7), std::log(1.5), std::log(0.9), std::log(1e-2);
    expect_gradient_matches_finite_differences(x, y, theta, options);
}

// The extra noise of low-fidelity points: its gradient component too.
TEST(GaussianProcessTest, LowFidelityNoiseGradientMatchesFiniteDifferences) {
    std::mt19937_64 rng(19);
    const Eigen::MatrixXd x = uniform_points(3, 30, rng);
    Eigen::VectorXd y(30), lf = Eigen::VectorXd::Zero(30);
    for (Eigen::Index i = 0; i < 30; ++i) {
        y(i) = std::sin(4.0 * x(0, i)) + x(1, i);
        if (i % 3 == 0) lf(i) = 1.0;
    }
    y = (y.array() - y.mean()) / std::sqrt((y.array() - y.mean()).square().mean());
    FitOptions options;
    Eigen::VectorXd theta(6);
    theta << std::log(0.3), std::log(0.7), std::log(1.5), std::log(0.9), std::log(1e-3), std::log(0.04);
    Eigen::VectorXd grad;
    neg_log_posterior(x, y, theta, options, &grad, CholeskyBackend::eigen, &lf);
    ASSERT_EQ(grad.size(), 6);
    EXPECT_NE(grad(5), 0.0);
    for (Eigen::Index i = 0; i < theta.size(); ++i) {
        const double h = 1e-5;
        Eigen::VectorXd tp = theta, tm = theta;
        tp(i) += h;
        tm(i) -= h;
        const double fd = (neg_log_posterior(x, y, tp, options, nullptr, CholeskyBackend::eigen, &lf) -
                           neg_log_posterior(x, y, tm, options, nullptr, CholeskyBackend::eigen, &lf)) /
                          (2.0 * h);
        EXPECT_NEAR(grad(i), fd, 1e-5 * std::max(1.0, std::abs(fd))) << "component " << i;
    }
}

// Multi-fidelity (issue 16): estimates from a subset of the pairs stray from the objective.
// Marked low-fidelity, they get a noise of their own, learnt by the fit, and the model follows
// the exact points; unmarked, the same data make the model worse where it matters.
TEST(GaussianProcessTest, LowFidelityPointsGetANoiseOfTheirOwn) {
    std::mt19937_64 rng(23);
    auto f = [](const Eigen::VectorXd& p) { return std::sin(5.0 * p(0)) + 0.5 * std::cos(3.0 * p(1)); };
    const Eigen::MatrixXd x = uniform_points(2, 60, rng);
    std::normal_distribution<double> noise(0.0, 0.4);
    Eigen::VectorXd y(60), lf = Eigen::VectorXd::Zero(60);
    for (Eigen::Index i = 0; i < 60; ++i) {
        y(i) = f(x.col(i));
        if (i >= 20) {  // 40 estimates around 20 exact values
            lf(i) = 1.0;
            y(i) += noise(rng);
        }
    }
    const Eigen::MatrixXd xs = uniform_points(2, 200, rng);
    auto rmse = [&](const GaussianProcess& gp) {
        Eigen::VectorXd mean, var;
        gp.predict(xs, mean, var);
        double s = 0;
        for (Eigen::Index i = 0; i < xs.cols(); ++i) s += std::pow(mean(i) - f(xs.col(i)), 2);
        return std::sqrt(s / static_cast<double>(xs.cols()));
    };
    GaussianProcess marked(2), plain(2);
    marked.set_data(x, y, lf);
    plain.set_data(x, y);
    EXPECT_TRUE(marked.has_low_fidelity());
    EXPECT_FALSE(plain.has_low_fidelity());
    marked.fit(3);
    plain.fit(3);
    const Hyperparameters& hp = marked.hyperparameters();
    // 0.4² in the outputs' units, standardized by their spread (~0.8): ~0.25.
    EXPECT_GT(hp.low_fidelity_noise, 0.05);
    EXPECT_LT(hp.low_fidelity_noise, 1.0);
    EXPECT_GT(hp.low_fidelity_noise, 20.0 * hp.noise_variance);
    // At the exact points the marked model stays close to the values.
    Eigen::VectorXd mean, var;
    marked.predict(x.leftCols(20), mean, var);
    EXPECT_LT((mean - y.head(20)).cwiseAbs().maxCoeff(), 0.1);
    EXPECT_LT(rmse(marked), rmse(plain));

    // Appending a marked point equals a fresh model with the same marks.
    GaussianProcess inc(2), fresh(2);
    inc.set_hyperparameters(hp);
    fresh.set_hyperparameters(hp);
    inc.set_data(x.leftCols(20), y.head(20));
    for (Eigen::Index i = 20; i < 60; ++i) inc.append(x.col(i), y(i), true);
    inc.set_outputs(y);  // the standardization of all 60, as the fresh model's
    fresh.set_data(x, y, lf);
    Eigen::VectorXd m1, v1, m2, v2;
    inc.predict(xs, m1, v1);
    fresh.predict(xs, m2, v2);
    EXPECT_LT((m1 - m2).cwiseAbs().maxCoeff(), 1e-8);
    EXPECT_LT((v1 - v2).cwiseAbs().maxCoeff(), 1e-8);

    // No marked point: exactly the plain model and fit.
    GaussianProcess zeros(2);
    zeros.set_data(x, y, Eigen::VectorXd::Zero(60));
    EXPECT_FALSE(zeros.has_low_fidelity());
    GaussianProcess again(2);
    again.set_data(x, y);
    EXPECT_EQ(zeros.fit(3).neg_log_posterior, again.fit(3).neg_log_posterior);
}

TEST(GaussianProcessTest, InputGradientsMatchFiniteDifferences) {
    std::mt19937_64 rng(10);
    const Eigen::MatrixXd x = uniform_points(3, 20, rng);
    const Eigen::VectorXd y = Eigen::VectorXd::Random(20);
    const GaussianProcess gp = make_gp(3, some_hyperparameters(), x, y);
    const Eigen::Vector3d p(0.4, 0.55, 0.2);
    const PointPrediction pred = gp.predict_with_gradient(p);
    Eigen::VectorXd m, v;
    gp.predict(p, m, v);
    EXPECT_NEAR(pred.mean, m(0), 1e-10);
    EXPECT_NEAR(pred.variance, v(0), 1e-10);
    for (int j = 0; j < 3; ++j) {
        const double h = 1e-6;
        Eigen::VectorXd pp = p, pm = p;
        pp(j) += h;
        pm(j) -= h;
        Eigen::VectorXd mp, vp, mm, vm;
        gp.predict(pp, mp, vp);
        gp.predict(pm, mm, vm);
        EXPECT_NEAR(pred.mean_gradient(j), (mp(0) - mm(0)) / (2 * h), 1e-5);
        EXPECT_NEAR(pred.variance_gradient(j), (vp(0) - vm(0)) / (2 * h), 1e-5);
    }
}

TEST(GaussianProcessTest, RecoversHyperparametersOfKnownGp) {
    std::mt19937_64 rng(11);
    const Eigen::Index n = 250;
    const Eigen::MatrixXd x = uniform_points(2, n, rng);
    Hyperparameters truth;
    truth.length_scales = Eigen::Vector2d(0.15, 0.6);
    truth.signal_variance = 1.0;
    truth.noise_variance = 1e-2;
    Eigen::MatrixXd k = matern52(x, x, truth);
    k.diagonal().array() += truth.noise_variance;
    const Eigen::MatrixXd l = k.llt().matrixL();
    std::normal_distribution<double> normal;
    Eigen::VectorXd z(n);
    for (Eigen::Index i = 0; i < n; ++i) z(i) = normal(rng);
    const Eigen::VectorXd y = 3.0 + 2.0 * (l * z).array();  // arbitrary units

    GpOptions options;
    options.fit.use_priors = false;  // plain maximum likelihood should find the truth
    GaussianProcess gp(2, options);
    gp.set_data(x, y);
    const FitResult fit = gp.fit(1);
    const Hyperparameters& hp = fit.hyperparameters;
    // Standardization rescales the variances by the sample variance; length scales are exact.
    EXPECT_NEAR(std::log(hp.length_scales(0)), std::log(0.15), std::log(1.5));
    EXPECT_NEAR(std::log(hp.length_scales(1)), std::log(0.6), std::log(1.6));
    const double scale2 = gp.output_scale() * gp.output_scale() / 4.0;
    EXPECT_NEAR(std::log(hp.noise_variance * scale2), std::log(1e-2), std::log(2.0));
}

// Held-out coefficient of determination of a fitted GP.
double holdout_r2(const GaussianProcess& gp, const Eigen::MatrixXd& xt, const Eigen::VectorXd& yt) {
    Eigen::VectorXd mean, var;
    gp.predict(xt, mean, var);
    return 1.0 - (mean - yt).squaredNorm() / (yt.array() - yt.mean()).square().sum();
}

struct CollapseCase {
    const char* name;
    int dim;
    Eigen::Index n;
    double (*f)(const Eigen::VectorXd&);
    double min_r2;
};

class NoCollapseTest : public ::testing::TestWithParam<CollapseCase> {};

// scikit-learn's fit collapses to the length-scale bound (white noise) or stays at its start
// on these functions; ours must land inside the bounds and predict held-out points.
TEST_P(NoCollapseTest, FitStaysInsideBoundsAndPredicts) {
    const CollapseCase c = GetParam();
    std::mt19937_64 rng(12);
    const Eigen::MatrixXd x = uniform_points(c.dim, c.n, rng);
    const Eigen::MatrixXd xt = uniform_points(c.dim, 500, rng);
    Eigen::VectorXd y(c.n), yt(500);
    for (Eigen::Index i = 0; i < c.n; ++i) y(i) = c.f(x.col(i));
    for (Eigen::Index i = 0; i < 500; ++i) yt(i) = c.f(xt.col(i));
    GaussianProcess gp(c.dim);
    gp.set_data(x, y);
    const double start_nlp =
        neg_log_posterior(x, (y.array() - gp.output_offset()) / gp.output_scale(),
                          gp.hyperparameters().to_log(), gp.options().fit, nullptr);
    const FitResult fit = gp.fit(3);
    const Hyperparameters& hp = fit.hyperparameters;
    const FitOptions& o = gp.options().fit;
    EXPECT_LT(fit.neg_log_posterior, start_nlp - 1.0) << "stalled at the start point";
    EXPECT_GT(hp.length_scales.minCoeff(), 2.0 * o.min_length_scale)
        << hp.length_scales.transpose();
    EXPECT_LT(hp.noise_variance, 0.1) << "white-noise model";
    EXPECT_GT(holdout_r2(gp, xt, yt), c.min_r2)
        << "l = " << hp.length_scales.transpose() << " s2 = " << hp.signal_variance
        << " noise = " << hp.noise_variance;
}

INSTANTIATE_TEST_SUITE_P(Functions, NoCollapseTest,
                         ::testing::Values(CollapseCase{"hartmann6", 6, 100, hartmann6, 0.5},
                                           CollapseCase{"log_rosenbrock9", 9, 150, log_rosenbrock,
                                                        0.5}),
                         [](const auto& tpi) { return std::string(tpi.param.name); });

// Draws for marginalizing the hyperparameters (bo::OptimizerOptions::hyper_samples) come from
// Laplace's approximation: centred on the fit, with the inverse curvature of the negative log
// posterior there as covariance (checked against second differences of its values, not of the
// gradient the draws use), inside the fit's bounds, the same for the same seed.
TEST(GaussianProcessTest, HyperparameterDrawsFollowTheCurvatureOfThePosterior) {
    std::mt19937_64 rng(5);
    const Eigen::Index n = 40;
    const Eigen::MatrixXd x = uniform_points(1, n, rng);
    Eigen::VectorXd y(n);
    std::normal_distribution<double> noise(0.0, 0.1);  // a noise the fit must find, not a bound
    for (Eigen::Index i = 0; i < n; ++i) y(i) = std::sin(6.0 * x(0, i)) + noise(rng);
    GaussianProcess gp(1);
    gp.set_data(x, y);
    gp.fit(3);
    const int count = 4000;
    const std::vector<Hyperparameters> draws = gp.sample_hyperparameters(count, 17);
    ASSERT_EQ(draws.size(), static_cast<std::size_t>(count));
    EXPECT_EQ(gp.sample_hyperparameters(3, 17)[2].length_scales(0), draws[2].length_scales(0));

    const Eigen::VectorXd z = (y.array() - gp.output_offset()) / gp.output_scale();
    const Eigen::VectorXd theta = gp.hyperparameters().to_log();
    const FitOptions fit_options;
    auto nlp = [&](const Eigen::VectorXd& t) { return neg_log_posterior(x, z, t, fit_options, nullptr); };
    const double h = 1e-2;
    Eigen::Matrix3d hess;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            Eigen::VectorXd pp = theta, pm = theta, mp = theta, mm = theta;
            pp(i) += h, pp(j) += h;
            pm(i) += h, pm(j) -= h;
            mp(i) -= h, mp(j) += h;
            mm(i) -= h, mm(j) -= h;
            hess(i, j) = (nlp(pp) - nlp(pm) - nlp(mp) + nlp(mm)) / (4.0 * h * h);
        }
    }
    ASSERT_EQ(hess.llt().info(), Eigen::Success);  // a maximum of the posterior
    const Eigen::Matrix3d cov = hess.inverse();
    Eigen::MatrixXd t(3, count);
    for (int c = 0; c < count; ++c) t.col(c) = draws[static_cast<std::size_t>(c)].to_log();
    const Eigen::Vector3d mean = t.rowwise().mean();
    const Eigen::MatrixXd centred = t.colwise() - mean;
    const Eigen::Matrix3d sample_cov = centred * centred.transpose() / (count - 1.0);
    for (int i = 0; i < 3; ++i) {
        SCOPED_TRACE(i);
        EXPECT_NEAR(mean(i), theta(i), 0.1 * std::sqrt(cov(i, i)) + 1e-3);
        EXPECT_NEAR(std::sqrt(sample_cov(i, i)), std::sqrt(cov(i, i)), 0.1 * std::sqrt(cov(i, i)));
    }

    // Inside the fit's bounds.
    const FitOptions& bounds = gp.options().fit;
    for (const Hyperparameters& draw : draws) {
        EXPECT_GE(draw.length_scales(0), bounds.min_length_scale);
        EXPECT_LE(draw.length_scales(0), bounds.max_length_scale);
        EXPECT_GE(draw.noise_variance, bounds.min_noise_variance);
        EXPECT_LE(draw.noise_variance, bounds.max_noise_variance);
    }
}

}  // namespace
}  // namespace maptune::gp
