// Cholesky backends (Eigen vs CHOLMOD) on GP covariance matrices across n, plus the GP fit, its
// objective, and batched prediction by thread count. Run: gp_bench --benchmark_min_time=0.2
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "gp/gaussian_process.hpp"

namespace {

using maptune::gp::CholeskyBackend;

Eigen::MatrixXd points(int dim, Eigen::Index n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    Eigen::MatrixXd x(dim, n);
    for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] = u(rng);
    return x;
}

Eigen::MatrixXd covariance(Eigen::Index n) {
    maptune::gp::Hyperparameters hp = maptune::gp::Hyperparameters::defaults(9);
    Eigen::MatrixXd k = maptune::gp::matern52(points(9, n, 1), points(9, n, 1), hp);
    k.diagonal().array() += 1e-4;
    return k;
}

void BM_Factorize(benchmark::State& state, CholeskyBackend backend) {
    if (backend == CholeskyBackend::cholmod && !maptune::gp::cholmod_available()) {
        state.SkipWithError("built without CHOLMOD");
        return;
    }
    const Eigen::MatrixXd k = covariance(state.range(0));
    auto chol = maptune::gp::make_cholesky(backend);
    for (auto _ : state) benchmark::DoNotOptimize(chol->compute(k));
}

void BM_Append(benchmark::State& state, CholeskyBackend backend) {
    if (backend == CholeskyBackend::cholmod && !maptune::gp::cholmod_available()) {
        state.SkipWithError("built without CHOLMOD");
        return;
    }
    const Eigen::Index n = state.range(0);
    const Eigen::MatrixXd k = covariance(n + 1);
    auto chol = maptune::gp::make_cholesky(backend);
    chol->compute(k.topLeftCorner(n, n));
    for (auto _ : state) {
        chol->append(k.col(n).head(n), k(n, n));
        chol->truncate(n);
    }
}

void BM_SolveLower1024(benchmark::State& state, CholeskyBackend backend) {
    if (backend == CholeskyBackend::cholmod && !maptune::gp::cholmod_available()) {
        state.SkipWithError("built without CHOLMOD");
        return;
    }
    const Eigen::Index n = state.range(0);
    auto chol = maptune::gp::make_cholesky(backend);
    chol->compute(covariance(n));
    const Eigen::MatrixXd b = Eigen::MatrixXd::Random(n, 1024);
    for (auto _ : state) benchmark::DoNotOptimize(chol->solve_lower(b));
}

void BM_Inverse(benchmark::State& state) {
    const Eigen::Index n = state.range(0);
    maptune::gp::EigenCholesky chol;
    chol.compute(covariance(n));
    for (auto _ : state) benchmark::DoNotOptimize(chol.inverse());
}

// One evaluation of the fit's objective with its gradient (the fit makes ~30 per start).
void BM_NegLogPosterior(benchmark::State& state) {
    const auto n = state.range(0);
    const Eigen::MatrixXd x = points(9, n, 2);
    Eigen::VectorXd y(n);
    for (Eigen::Index i = 0; i < n; ++i)
        y(i) = std::sin(3.0 * x(0, i)) + x(1, i) * x(2, i) - x(3, i);
    y = (y.array() - y.mean()) / std::sqrt((y.array() - y.mean()).square().mean());
    const Eigen::VectorXd theta = maptune::gp::Hyperparameters::defaults(9).to_log();
    const maptune::gp::FitOptions options;
    Eigen::VectorXd grad;
    for (auto _ : state) {
        benchmark::DoNotOptimize(maptune::gp::neg_log_posterior(x, y, theta, options, &grad));
    }
}

void BM_Fit(benchmark::State& state) {
    const auto n = state.range(0);
    const Eigen::MatrixXd x = points(9, n, 2);
    Eigen::VectorXd y(n);
    for (Eigen::Index i = 0; i < n; ++i)
        y(i) = std::sin(3.0 * x(0, i)) + x(1, i) * x(2, i) - x(3, i);
    for (auto _ : state) {
        maptune::gp::GaussianProcess gp(9);
        gp.set_data(x, y);
        benchmark::DoNotOptimize(gp.fit(1));
    }
}

// The blocked factorization and K⁻¹ of the fit's objective; range(1) = threads (real time).
void BM_FactorizeLower(benchmark::State& state) {
    const Eigen::MatrixXd k = covariance(state.range(0));
    Eigen::MatrixXd f;
    for (auto _ : state) {
        f = k;
        benchmark::DoNotOptimize(maptune::gp::factorize_lower(f, static_cast<int>(state.range(1))));
    }
}

void BM_InverseFromLower(benchmark::State& state) {
    Eigen::MatrixXd l = covariance(state.range(0));
    maptune::gp::factorize_lower(l);
    Eigen::MatrixXd work, inverse;
    for (auto _ : state) {
        maptune::gp::inverse_from_lower(l, work, inverse, static_cast<int>(state.range(1)));
    }
}

// Mean and variance at 10 000 points; range(1) = GpOptions::threads. Wall time matters here
// (the benchmark uses real time), CPU time is reported for the calling thread only.
void BM_Predict10000(benchmark::State& state) {
    const auto n = state.range(0);
    const Eigen::MatrixXd x = points(9, n, 3);
    const Eigen::VectorXd y = x.row(0).transpose();
    maptune::gp::GpOptions options;
    options.threads = static_cast<int>(state.range(1));
    maptune::gp::GaussianProcess gp(9, options);
    gp.set_data(x, y);
    const Eigen::MatrixXd xs = points(9, 10000, 4);
    Eigen::VectorXd mean, var;
    for (auto _ : state) gp.predict(xs, mean, var);
}

}  // namespace

BENCHMARK_CAPTURE(BM_Factorize, eigen, CholeskyBackend::eigen)
    ->Arg(100)
    ->Arg(300)
    ->Arg(1000)
    ->Arg(2000)
    ->Arg(3000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Factorize, cholmod, CholeskyBackend::cholmod)
    ->Arg(100)
    ->Arg(300)
    ->Arg(1000)
    ->Arg(2000)
    ->Arg(3000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Append, eigen, CholeskyBackend::eigen)
    ->Arg(100)
    ->Arg(300)
    ->Arg(1000)
    ->Arg(2000)
    ->Arg(3000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Append, cholmod, CholeskyBackend::cholmod)
    ->Arg(100)
    ->Arg(300)
    ->Arg(1000)
    ->Arg(2000)
    ->Arg(3000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_SolveLower1024, eigen, CholeskyBackend::eigen)
    ->Arg(100)
    ->Arg(300)
    ->Arg(1000)
    ->Arg(3000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_SolveLower1024, cholmod, CholeskyBackend::cholmod)
    ->Arg(100)
    ->Arg(300)
    ->Arg(1000)
    ->Arg(3000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FactorizeLower)
    ->ArgsProduct({{100, 1000, 2000}, {1, 2}})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_InverseFromLower)
    ->ArgsProduct({{100, 1000, 2000}, {1, 2}})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Inverse)->Arg(100)->Arg(200)->Arg(1000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_NegLogPosterior)->Arg(100)->Arg(200)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Fit)->Arg(100)->Arg(200)->Arg(1000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Predict10000)
    ->ArgsProduct({{100, 300, 1000}, {1, 2}})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
