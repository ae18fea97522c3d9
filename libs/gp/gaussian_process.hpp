#pragma once
// Gaussian-process regression on the unit cube with a Matern-5/2 ARD kernel.
//
// Inputs: columns of a d×n matrix in [0, 1]^d (the caller normalizes). Outputs are
// standardized internally; every prediction is returned in the caller's units. The
// predictive variance is that of the latent function (observation noise excluded).

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "gp/cholesky.hpp"
#include "gp/kernel.hpp"

namespace maptune::gp {

enum class MeanKind {
    zero,      // prior mean 0 in the caller's units; outputs only scaled
    constant,  // prior mean = sample mean of the outputs (standardization)
};

// Hyperparameter fitting: maximum a posteriori in log space by L-BFGS-B, several starts.
struct FitOptions {
    int random_starts = 2;          // random starts, in addition to the warm start and a fixed one
    int max_iterations = 50;        // L-BFGS-B iterations per start
    Eigen::Index max_points = 200;  // multi-start on a seeded random subset above this (O(n³) per step)
    // Above max_points, the subset's optimum is then refined by one L-BFGS-B run on all points
    // (at most refine_iterations): the fit maximizes the full data's posterior (issue 15).
    // false: the subset's optimum as is (faster; its accuracy cost is in BENCHMARKS.md).
    bool full_data_refine = true;
    int refine_iterations = 15;
    bool use_priors = true;  // log-normal priors; false gives plain type-II maximum likelihood
    // Log-normal length-scale prior: log l ~ N(mean, sd²). A NaN mean selects the
    // dimension-scaled centre length_scale_prior_mean(d).
    double length_scale_prior_mean = std::numeric_limits<double>::quiet_NaN();
    double length_scale_prior_sd = 1.7320508075688772;  // √3
    bool fixed_start = true;  // also start from a fixed moderate point (off for warm refits)
    // Bounds, in unit-cube units for length scales and standardized units for variances.
    double min_length_scale = 1e-2;
    double max_length_scale = 1e2;
    double min_signal_variance = 1e-2;
    double max_signal_variance = 1e2;
    double min_noise_variance = 1e-6;
    double max_noise_variance = 1.0;
};

struct GpOptions {
    MeanKind mean = MeanKind::constant;
    // MeanKind::constant: the prior mean is the average of the first mean_points outputs only
    // (0 or fewer outputs: all). An optimizer passes its space-filling design here: the later
    // points cluster where the objective is good, and their average would make every unexplored
    // region look that good.
    Eigen::Index mean_points = 0;
    CholeskyBackend backend = CholeskyBackend::eigen;
    FitOptions fit;
    // Threads inside predict (large batches only) and across the starts of fit (libs/bo also
    // uses it for the acquisition polishes): 0 = the hardware's, at most kMaxAutoThreads
    // (gp/parallel.hpp); 1 = the calling thread only. Results are identical for every value.
    int threads = 0;
};

struct FitResult {
    Hyperparameters hyperparameters;
    double neg_log_posterior = 0.0;  // of the (sub)set used for fitting
    int starts = 0;
    int evaluations = 0;  // objective+gradient evaluations over all starts
    Eigen::Index points_used = 0;
};

struct PointPrediction {
    double mean = 0.0;
    double variance = 0.0;
    Eigen::VectorXd mean_gradient;      // d/dx in unit-cube coordinates
    Eigen::VectorXd variance_gradient;  // d/dx in unit-cube coordinates
};

// Negative log marginal likelihood (plus negative log prior when options.use_priors) of
// standardized outputs y at inputs x (d×n) for log-space hyperparameters theta, with its
// analytic gradient when grad is not null. Exposed for tests and benchmarks. With
// low_fidelity (one 0/1 entry per point), theta has one more entry: log low_fidelity_noise.
double neg_log_posterior(const Eigen::MatrixXd& x, const Eigen::VectorXd& y,
                         const Eigen::VectorXd& theta, const FitOptions& options,
                         Eigen::VectorXd* grad, CholeskyBackend backend = CholeskyBackend::eigen,
                         const Eigen::VectorXd* low_fidelity = nullptr);

// Instruction set the batched kernels (simd_kernels.cpp) were built for: "avx512", "avx2",
// "sse2" or "generic" (CMake options MAPTUNE_GP_AVX2, MAPTUNE_GP_AVX512).
const char* kernel_instruction_set();

// Log-normal prior on length scales, centred at √2 + ½ log d with scale √3 (Hvarfner et al.,
// "Vanilla Bayesian optimization performs great in high dimensions", 2024).
double length_scale_prior_mean(int dim);

class GaussianProcess {
  public:
    explicit GaussianProcess(int dim, GpOptions options = {});
    GaussianProcess(const GaussianProcess& other);
    GaussianProcess& operator=(const GaussianProcess& other);
    GaussianProcess(GaussianProcess&&) noexcept = default;
    GaussianProcess& operator=(GaussianProcess&&) noexcept = default;
    ~GaussianProcess() = default;

    int dim() const { return dim_; }
    Eigen::Index size() const { return x_.cols(); }
    const Hyperparameters& hyperparameters() const { return hp_; }
    const GpOptions& options() const { return options_; }
    double output_offset() const { return y_offset_; }
    double output_scale() const { return y_scale_; }
    double jitter() const { return jitter_; }

    // Replaces the data (x: d×n in the unit cube), recomputes the output standardization and
    // factorizes. False if the covariance could not be factorized even with jitter.
    // low_fidelity (empty, or one entry per point, 1 = low fidelity): those points carry the
    // extra noise Hyperparameters::low_fidelity_noise, which fit() then learns.
    bool set_data(const Eigen::MatrixXd& x, const Eigen::VectorXd& y,
                  const Eigen::VectorXd& low_fidelity = Eigen::VectorXd());
    // Replaces the outputs only (same inputs, in order): new standardization and K⁻¹y in O(n²)
    // with the existing factor, which depends on the inputs and hyperparameters alone.
    bool set_outputs(const Eigen::VectorXd& y);
    bool set_hyperparameters(const Hyperparameters& hp);
    // Adds one observation in O(n²), keeping hyperparameters and standardization (used for
    // fantasized pending points and between refits).
    bool append(const Eigen::VectorXd& x, double y, bool low_fidelity = false);
    bool has_low_fidelity() const { return low_fidelity_.size() > 0; }
    // Drops trailing observations in O(n²) (solve only): the factor's leading block is kept.
    void truncate(Eigen::Index n);

    // Fits the hyperparameters (warm-started from the current ones) and refactorizes.
    FitResult fit(std::uint64_t seed);
    // models[i]->fit(seeds[i]) for every i, with the L-BFGS-B starts of all models sharing one
    // pool of threads (three starts on two cores leave one idle half the time). Each result
    // equals the model's own fit.
    static std::vector<FitResult> fit_together(const std::vector<GaussianProcess*>& models,
                                               const std::vector<std::uint64_t>& seeds);
    // `count` draws from Laplace's approximation of the hyperparameters' posterior (log space)
    // around the current hyperparameters, which should be the fit's; the low-fidelity noise
    // stays fixed. Empty with fewer than two points or a non-finite curvature.
    std::vector<Hyperparameters> sample_hyperparameters(int count, std::uint64_t seed) const;

    // Posterior mean and latent variance at the columns of xs (d×m), in the caller's units.
    // With a dense factor (Eigen backend) each point's result depends only on that point (not
    // on m, its position or threads).
    void predict(const Eigen::MatrixXd& xs, Eigen::VectorXd& mean, Eigen::VectorXd& variance) const;
    PointPrediction predict_with_gradient(const Eigen::VectorXd& x) const;

  private:
    struct FitPlan;
    FitPlan plan_fit(std::uint64_t seed) const;
    void run_start(FitPlan& plan, std::size_t start) const;
    FitResult finish_fit(const FitPlan& plan);
    bool refactorize();
    void standardize(const Eigen::VectorXd& y);  // y_offset_, y_scale_, y_
    // predict through Cholesky::solve_lower, for backends without a dense factor.
    void predict_generic(const Eigen::MatrixXd& xs, Eigen::VectorXd& mean,
                         Eigen::VectorXd& variance) const;
    void update_alpha();

    int dim_;
    GpOptions options_;
    Hyperparameters hp_;
    Eigen::MatrixXd x_;      // d×n inputs
    Eigen::VectorXd y_;      // standardized outputs
    Eigen::VectorXd alpha_;  // K⁻¹ y
    Eigen::VectorXd low_fidelity_;  // empty, or 1 per low-fidelity point (0 otherwise)
    double y_offset_ = 0.0;
    double y_scale_ = 1.0;
    double jitter_ = 0.0;  // added to the diagonal when K is numerically singular
    std::unique_ptr<Cholesky> chol_;
};

}  // namespace maptune::gp
