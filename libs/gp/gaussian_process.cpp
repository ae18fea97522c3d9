#include "gp/gaussian_process.hpp"

#include <LBFGSB.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include "gp/parallel.hpp"
#include "gp/simd_kernels.hpp"

namespace maptune::gp {

namespace {

const double kLog2Pi = std::log(2.0 * M_PI);

// Priors in log space: mean and standard deviation of a normal on log(value).
const double kSignalPriorMean = 0.0;  // standardized outputs: signal variance near 1
const double kSignalPriorSd = 1.5;
const double kNoisePriorMean = std::log(1e-4);  // near-deterministic objectives are common
const double kNoisePriorSd = 3.0;
// Low-fidelity extra noise: a subset's estimate may stray by a good part of the outputs' spread.
const double kLowFidelityPriorMean = std::log(0.05);
const double kLowFidelityPriorSd = 3.0;
const double kMaxLowFidelityNoise = 10.0;

const double kMaxJitter = 1e-2;

struct Bounds {
    Eigen::VectorXd lower, upper;
};

// With low_fidelity, one more entry: log of Hyperparameters::low_fidelity_noise.
Bounds log_bounds(int dim, const FitOptions& o, bool low_fidelity) {
    const int size = dim + (low_fidelity ? 3 : 2);
    Bounds b{Eigen::VectorXd(size), Eigen::VectorXd(size)};
    if (low_fidelity) {
        b.lower(dim + 2) = std::log(o.min_noise_variance);
        b.upper(dim + 2) = std::log(kMaxLowFidelityNoise);
    }
    b.lower.head(dim).setConstant(std::log(o.min_length_scale));
    b.upper.head(dim).setConstant(std::log(o.max_length_scale));
    b.lower(dim) = std::log(o.min_signal_variance);
    b.upper(dim) = std::log(o.max_signal_variance);
    b.lower(dim + 1) = std::log(o.min_noise_variance);
    b.upper(dim + 1) = std::log(o.max_noise_variance);
    return b;
}

double add_prior(const Eigen::VectorXd& theta, int dim, const FitOptions& o,
                 Eigen::VectorXd* grad) {
    double nlp = 0.0;
    auto term = [&](Eigen::Index i, double mean, double sd) {
        const double z = (theta(i) - mean) / sd;
        nlp += 0.5 * z * z;
        if (grad != nullptr) (*grad)(i) += z / sd;
    };
    const double ls_mean = std::isnan(o.length_scale_prior_mean) ? length_scale_prior_mean(dim)
                                                                 : o.length_scale_prior_mean;
    for (int j = 0; j < dim; ++j) term(j, ls_mean, o.length_scale_prior_sd);
    term(dim, kSignalPriorMean, kSignalPriorSd);
    term(dim + 1, kNoisePriorMean, kNoisePriorSd);
    if (theta.size() > dim + 2) term(dim + 2, kLowFidelityPriorMean, kLowFidelityPriorSd);
    return nlp;
}

// Buffers of one fit start, reused by all its evaluations: fresh n×n temporaries (320 KB each
// at n = 200) cost page faults on every evaluation, ~20 % of the fit at n = 100.
struct NlpWorkspace {
    Eigen::MatrixXd z, r2, kf, q, k, linv, w;
    int threads = 1;  // inside one evaluation (the full-data refinement; the starts are parallel)
};

// low_fidelity (null or one 0/1 entry per point): theta has one more entry, the log of the
// extra noise on the flagged points.
double neg_log_posterior(const Eigen::MatrixXd& x, const Eigen::VectorXd& y,
                         const Eigen::VectorXd& theta, const FitOptions& options,
                         Eigen::VectorXd* grad, CholeskyBackend backend, NlpWorkspace& ws,
                         const Eigen::VectorXd* low_fidelity = nullptr) {
    const auto dim = static_cast<int>(x.rows());
    const Eigen::Index n = x.cols();
    const Hyperparameters hp = Hyperparameters::from_log(theta.head(dim + 2));
    const double lf_noise = low_fidelity ? std::exp(theta(dim + 2)) : 0.0;
    if (grad != nullptr) grad->setZero(theta.size());

    const Eigen::ArrayXd inv_l = hp.length_scales.array().inverse();
    // Scaled inputs, point-major (n×d): the O(n²d) kernels run along the points.
    ws.z = (x.array().colwise() * inv_l).matrix().transpose();
    // The O(n²) work in slabs of kSlab columns, one task each: every element and every partial
    // sum is computed the same way for any thread count (the slabs depend on n only).
    constexpr Eigen::Index kSlab = 128;
    const auto slabs = static_cast<int>((n + kSlab - 1) / kSlab);
    const int threads = n <= kSmallDense ? 1 : ws.threads;
    auto slab = [&](int b) { return std::make_pair(b * kSlab, std::min(kSlab, n - b * kSlab)); };
    ws.r2.resize(n, n);
    ws.kf.resize(n, n);
    ws.q.resize(n, n);
    ws.k.resize(n, n);
    // kf = K without noise; q = s² (5/3)(1 + √5 r) e^{−√5 r} for the length-scale gradient.
    parallel_for(slabs, threads, [&](int b) {
        const auto [c0, w] = slab(b);
        auto r2 = ws.r2.middleCols(c0, w);
        detail::scaled_sq_dist_columns(ws.z.data(), n, dim, c0, w, r2.data(), n);
        detail::matern52_from_sq_dist(r2.data(), n * w, hp.signal_variance,
                                      ws.kf.middleCols(c0, w).data(),
                                      grad != nullptr ? ws.q.middleCols(c0, w).data() : nullptr);
        ws.k.middleCols(c0, w) = ws.kf.middleCols(c0, w);
        for (Eigen::Index j = 0; j < w; ++j) ws.k(c0 + j, c0 + j) += hp.noise_variance;
        if (low_fidelity) {
            for (Eigen::Index j = 0; j < w; ++j) ws.k(c0 + j, c0 + j) += lf_noise * (*low_fidelity)(c0 + j);
        }
    });

    double log_det = 0.0;
    Eigen::VectorXd alpha;
    std::unique_ptr<Cholesky> chol;
    if (backend == CholeskyBackend::eigen) {
        // In place: L overwrites the lower triangle of ws.k.
        if (!factorize_lower(ws.k, threads)) return 1e25;  // a wall the line search backs away from
        log_det = 2.0 * ws.k.diagonal().array().log().sum();
        alpha = ws.k.triangularView<Eigen::Lower>().solve(y);
        ws.k.triangularView<Eigen::Lower>().transpose().solveInPlace(alpha);
    } else {
        chol = make_cholesky(backend);
        if (!chol->compute(ws.k)) return 1e25;
        log_det = chol->log_det();
        alpha = chol->solve(y);
    }
    double value = 0.5 * y.dot(alpha) + 0.5 * log_det + 0.5 * static_cast<double>(n) * kLog2Pi;

    if (grad != nullptr) {
        // d log p / dθ = ½ tr((ααᵀ − K⁻¹) dK/dθ); W = ααᵀ − K⁻¹.
        if (chol) {
            ws.w = chol->inverse();
        } else {
            inverse_from_lower(ws.k, ws.linv, ws.w, threads);
        }
        // Per slab: W, Σ W∘kf (dK/dlog s² = kf), tr W, and for the length scales
        // dK/dlog l_j = Q ∘ D_j with D_j = (z_j,a − z_j,b)²: ½ Σ (W ∘ Q) ∘ D_j.
        Eigen::VectorXd signal_part(slabs), trace_part(slabs), lf_part = Eigen::VectorXd::Zero(slabs);
        Eigen::MatrixXd ls_part = Eigen::MatrixXd::Zero(dim, slabs);
        parallel_for(slabs, threads, [&](int b) {
            const auto [c0, w] = slab(b);
            auto wb = ws.w.middleCols(c0, w);
            wb *= -1.0;
            wb.noalias() += alpha * alpha.segment(c0, w).transpose();
            signal_part(b) = (wb.array() * ws.kf.middleCols(c0, w).array()).sum();
            trace_part(b) = wb.middleRows(c0, w).trace();
            if (low_fidelity) {
                for (Eigen::Index j = 0; j < w; ++j) lf_part(b) += (*low_fidelity)(c0 + j) * wb(c0 + j, j);
            }
            auto mb = ws.q.middleCols(c0, w);
            mb.array() *= wb.array();
            detail::weighted_sq_dist_sums(ws.z.data(), n, dim, c0, w, mb.data(), n, ls_part.col(b).data());
        });
        (*grad)(dim) = -0.5 * signal_part.sum();
        (*grad)(dim + 1) = -0.5 * hp.noise_variance * trace_part.sum();
        if (low_fidelity) (*grad)(dim + 2) = -0.5 * lf_noise * lf_part.sum();
        for (int j = 0; j < dim; ++j) (*grad)(j) = -0.5 * ls_part.row(j).sum();
    }
    if (options.use_priors) value += add_prior(theta, dim, options, grad);
    return value;
}

// Wraps the objective for LBFGSpp and remembers the best point seen, because the line search
// may throw after having evaluated good points.
struct Objective {
    const Eigen::MatrixXd& x;
    const Eigen::VectorXd& y;
    const FitOptions& options;
    CholeskyBackend backend;
    const Eigen::VectorXd* low_fidelity = nullptr;
    NlpWorkspace workspace;
    int evaluations = 0;
    double best_value = std::numeric_limits<double>::infinity();
    Eigen::VectorXd best_theta;

    double operator()(const Eigen::VectorXd& theta, Eigen::VectorXd& grad) {
        ++evaluations;
        const double value = neg_log_posterior(x, y, theta, options, &grad, backend, workspace, low_fidelity);
        if (value < best_value) {
            best_value = value;
            best_theta = theta;
        }
        return value;
    }
};

}  // namespace

const char* kernel_instruction_set() { return detail::instruction_set(); }

double length_scale_prior_mean(int dim) {
    return std::sqrt(2.0) + 0.5 * std::log(static_cast<double>(dim));
}

double neg_log_posterior(const Eigen::MatrixXd& x, const Eigen::VectorXd& y,
                         const Eigen::VectorXd& theta, const FitOptions& options,
                         Eigen::VectorXd* grad, CholeskyBackend backend, const Eigen::VectorXd* low_fidelity) {
    NlpWorkspace ws;
    return neg_log_posterior(x, y, theta, options, grad, backend, ws, low_fidelity);
}

GaussianProcess::GaussianProcess(int dim, GpOptions options)
    : dim_(dim),
      options_(options),
      hp_(Hyperparameters::defaults(dim)),
      x_(dim, 0),
      chol_(make_cholesky(options.backend)) {}

GaussianProcess::GaussianProcess(const GaussianProcess& other)
    : dim_(other.dim_),
      options_(other.options_),
      hp_(other.hp_),
      x_(other.x_),
      y_(other.y_),
      alpha_(other.alpha_),
      low_fidelity_(other.low_fidelity_),
      y_offset_(other.y_offset_),
      y_scale_(other.y_scale_),
      jitter_(other.jitter_),
      chol_(other.chol_->clone()) {}

GaussianProcess& GaussianProcess::operator=(const GaussianProcess& other) {
    if (this != &other) *this = GaussianProcess(other);
    return *this;
}

bool GaussianProcess::set_data(const Eigen::MatrixXd& x, const Eigen::VectorXd& y,
                               const Eigen::VectorXd& low_fidelity) {
    if (x.rows() != dim_ || x.cols() != y.size() ||
        (low_fidelity.size() != 0 && low_fidelity.size() != y.size())) {
        throw std::invalid_argument("GaussianProcess::set_data: shape mismatch");
    }
    x_ = x;
    // Without a flagged point the model is exactly the plain one (no extra hyperparameter).
    if (low_fidelity.size() > 0 && (low_fidelity.array() != 0.0).any()) {
        low_fidelity_ = (low_fidelity.array() != 0.0).cast<double>().matrix();
    } else {
        low_fidelity_.resize(0);
    }
    standardize(y);
    return refactorize();
}

bool GaussianProcess::set_outputs(const Eigen::VectorXd& y) {
    if (y.size() != x_.cols()) throw std::invalid_argument("GaussianProcess::set_outputs: shape mismatch");
    standardize(y);
    if (x_.cols() > 0) update_alpha();  // K, and so its factor, does not depend on the outputs
    return true;
}

void GaussianProcess::standardize(const Eigen::VectorXd& y) {
    const Eigen::Index n = y.size();
    if (options_.mean == MeanKind::constant) {
        y_offset_ = n > 0 ? y.mean() : 0.0;
        const double var =
            n > 1 ? (y.array() - y_offset_).square().sum() / static_cast<double>(n - 1) : 0.0;
        y_scale_ = var > 1e-24 ? std::sqrt(var) : 1.0;
        if (options_.mean_points > 0 && n > options_.mean_points) y_offset_ = y.head(options_.mean_points).mean();
    } else {
        y_offset_ = 0.0;
        const double ms = n > 0 ? y.squaredNorm() / static_cast<double>(n) : 0.0;
        y_scale_ = ms > 1e-24 ? std::sqrt(ms) : 1.0;
    }
    y_ = (y.array() - y_offset_) / y_scale_;
}

bool GaussianProcess::set_hyperparameters(const Hyperparameters& hp) {
    if (hp.length_scales.size() != dim_) {
        throw std::invalid_argument("GaussianProcess::set_hyperparameters: wrong dimension");
    }
    hp_ = hp;
    return refactorize();
}

bool GaussianProcess::refactorize() {
    jitter_ = 0.0;
    const Eigen::Index n = x_.cols();
    if (n == 0) {
        chol_->truncate(0);
        alpha_.resize(0);
        return true;
    }
    Eigen::MatrixXd k = matern52(x_, x_, hp_);
    k.diagonal().array() += hp_.noise_variance;
    if (has_low_fidelity()) k.diagonal() += hp_.low_fidelity_noise * low_fidelity_;
    double jitter = 1e-10 * hp_.signal_variance;
    while (!chol_->compute(k)) {
        if (jitter > kMaxJitter * hp_.signal_variance) return false;
        k.diagonal().array() += jitter - jitter_;
        jitter_ = jitter;
        jitter *= 10.0;
    }
    update_alpha();
    return true;
}

void GaussianProcess::update_alpha() { alpha_ = chol_->solve(y_); }

bool GaussianProcess::append(const Eigen::VectorXd& x, double y, bool low_fidelity) {
    const Eigen::Index n = x_.cols();
    const Eigen::VectorXd cross = matern52(x_, x, hp_).col(0);
    const double diag = hp_.signal_variance + hp_.noise_variance + jitter_ +
                        (low_fidelity ? hp_.low_fidelity_noise : 0.0);
    if (low_fidelity || has_low_fidelity()) {
        if (!has_low_fidelity()) low_fidelity_ = Eigen::VectorXd::Zero(n);
        low_fidelity_.conservativeResize(n + 1);
        low_fidelity_(n) = low_fidelity ? 1.0 : 0.0;
    }
    x_.conservativeResize(Eigen::NoChange, n + 1);
    x_.col(n) = x;
    y_.conservativeResize(n + 1);
    y_(n) = (y - y_offset_) / y_scale_;
    if (!chol_->append(cross, diag)) return refactorize();
    update_alpha();
    return true;
}

void GaussianProcess::truncate(Eigen::Index n) {
    if (n >= x_.cols()) return;
    x_.conservativeResize(Eigen::NoChange, n);
    y_.conservativeResize(n);
    if (has_low_fidelity()) low_fidelity_.conservativeResize(n);
    chol_->truncate(n);
    update_alpha();
}

// One model's fit, split so that the starts of several fits can share one pool of threads
// (GaussianProcess::fit_together): the subset and the starts, then each start's L-BFGS-B run,
// then the best start (and the full-data refinement).
struct GaussianProcess::FitPlan {
    Eigen::MatrixXd xs;
    Eigen::VectorXd ys, lfs;
    bool lf = false;
    Bounds bounds;
    std::vector<Eigen::VectorXd> starts;
    struct StartResult {
        double value = std::numeric_limits<double>::infinity();
        Eigen::VectorXd theta;
        int evaluations = 0;
    };
    std::vector<StartResult> runs;
};

namespace {

LBFGSpp::LBFGSBParam<double> fit_param(const FitOptions& o) {
    LBFGSpp::LBFGSBParam<double> param;
    param.max_iterations = o.max_iterations;
    // Hyperparameters within ~1e-3 nats of the optimum predict the same; tighter tolerances
    // only add evaluations.
    param.epsilon = 1e-3;
    param.past = 1;
    param.delta = 1e-5;
    param.max_linesearch = 30;
    return param;
}

}  // namespace

GaussianProcess::FitPlan GaussianProcess::plan_fit(std::uint64_t seed) const {
    const FitOptions& o = options_.fit;
    const Eigen::Index n = x_.cols();
    FitPlan plan;
    std::mt19937_64 rng(seed);
    // Above max_points each step is O(n³): a random subset estimates the hyperparameters well
    // at a fraction of the cost; the final model still conditions on all points.
    plan.lf = has_low_fidelity();
    const bool lf = plan.lf;
    if (n > o.max_points) {
        std::vector<Eigen::Index> idx(static_cast<std::size_t>(n));
        std::iota(idx.begin(), idx.end(), 0);
        for (Eigen::Index i = 0; i < o.max_points; ++i) {
            std::uniform_int_distribution<Eigen::Index> pick(i, n - 1);
            std::swap(idx[static_cast<std::size_t>(i)], idx[static_cast<std::size_t>(pick(rng))]);
        }
        plan.xs.resize(dim_, o.max_points);
        plan.ys.resize(o.max_points);
        if (lf) plan.lfs.resize(o.max_points);
        for (Eigen::Index i = 0; i < o.max_points; ++i) {
            plan.xs.col(i) = x_.col(idx[static_cast<std::size_t>(i)]);
            plan.ys(i) = y_(idx[static_cast<std::size_t>(i)]);
            if (lf) plan.lfs(i) = low_fidelity_(idx[static_cast<std::size_t>(i)]);
        }
    } else {
        plan.xs = x_;
        plan.ys = y_;
        plan.lfs = low_fidelity_;
    }

    plan.bounds = log_bounds(dim_, o, lf);
    // With low-fidelity points every start carries the log of their extra noise too.
    const double lf_start = std::log(hp_.low_fidelity_noise > 0 ? hp_.low_fidelity_noise : 0.05);
    auto with_lf = [&](Eigen::VectorXd t, double log_lf) {
        if (!lf) return t;
        t.conservativeResize(dim_ + 3);
        t(dim_ + 2) = log_lf;
        return t;
    };
    std::vector<Eigen::VectorXd>& starts = plan.starts;
    starts.push_back(with_lf(hp_.to_log(), lf_start));  // warm start: the previous optimum
    if (o.fixed_start) {
        // A fixed, moderately smooth start independent of history.
        Hyperparameters h = Hyperparameters::defaults(dim_);
        h.length_scales.setConstant(0.3 * std::sqrt(static_cast<double>(dim_)));
        h.noise_variance = 1e-3;
        starts.push_back(with_lf(h.to_log(), std::log(0.05)));
    }
    std::normal_distribution<double> normal(0.0, 1.0);
    for (int s = 0; s < o.random_starts; ++s) {
        Eigen::VectorXd t(dim_ + 2);
        for (int j = 0; j < dim_; ++j) {
            // Narrower than the prior so that starts land where the data can speak.
            t(j) = std::log(0.4) + 0.75 * normal(rng);
        }
        t(dim_) = kSignalPriorMean + 0.5 * normal(rng);
        t(dim_ + 1) = std::log(1e-3) + 1.0 * normal(rng);
        // Drawn only with low-fidelity points: a plain fit's random starts stay as they were.
        starts.push_back(lf ? with_lf(t, std::log(0.05) + 1.0 * normal(rng)) : t);
    }
    plan.runs.resize(starts.size());
    return plan;
}

void GaussianProcess::run_start(FitPlan& plan, std::size_t s) const {
    const LBFGSpp::LBFGSBParam<double> param = fit_param(options_.fit);  // the solver keeps a reference
    LBFGSpp::LBFGSBSolver<double> solver(param);
    Eigen::VectorXd theta = plan.starts[s].cwiseMax(plan.bounds.lower).cwiseMin(plan.bounds.upper);
    Objective objective{plan.xs, plan.ys, options_.fit, options_.backend, plan.lf ? &plan.lfs : nullptr};
    double fx = 0.0;
    try {
        solver.minimize(objective, theta, fx, plan.bounds.lower, plan.bounds.upper);
    } catch (const std::exception&) {
        // Line-search failures near a flat optimum are common; the best point seen stands.
    }
    plan.runs[s] = {objective.best_value, objective.best_theta, objective.evaluations};
}

FitResult GaussianProcess::finish_fit(const FitPlan& plan) {
    const FitOptions& o = options_.fit;
    const Eigen::Index n = x_.cols();
    FitResult result;
    result.points_used = plan.xs.cols();
    // The best is picked in start order (ties to the earlier start), as a sequential loop would.
    double best = std::numeric_limits<double>::infinity();
    Eigen::VectorXd best_theta = plan.starts.front();
    for (const FitPlan::StartResult& run : plan.runs) {
        result.evaluations += run.evaluations;
        ++result.starts;
        if (run.value < best) {
            best = run.value;
            best_theta = run.theta;
        }
    }
    const bool lf = plan.lf;
    if (n > o.max_points && o.full_data_refine) {
        // One warm run on all points from the subset's optimum: the subset finds the basin at
        // a fraction of the cost, the full data sets where in it the optimum lies.
        LBFGSpp::LBFGSBParam<double> refine = fit_param(o);
        refine.max_iterations = o.refine_iterations;
        LBFGSpp::LBFGSBSolver<double> solver(refine);
        Eigen::VectorXd theta = best_theta;
        Objective objective{x_, y_, o, options_.backend, lf ? &low_fidelity_ : nullptr};
        objective.workspace.threads = resolve_threads(options_.threads);
        double fx = 0.0;
        try {
            solver.minimize(objective, theta, fx, plan.bounds.lower, plan.bounds.upper);
        } catch (const std::exception&) {
        }
        result.evaluations += objective.evaluations;
        ++result.starts;
        best = objective.best_value;
        best_theta = objective.best_theta;
        result.points_used = n;
    }
    result.neg_log_posterior = best;
    result.hyperparameters = Hyperparameters::from_log(best_theta.head(dim_ + 2));
    result.hyperparameters.low_fidelity_noise = lf ? std::exp(best_theta(dim_ + 2)) : hp_.low_fidelity_noise;
    if (!set_hyperparameters(result.hyperparameters)) set_hyperparameters(hp_);
    return result;
}

std::vector<Hyperparameters> GaussianProcess::sample_hyperparameters(int count, std::uint64_t seed) const {
    std::vector<Hyperparameters> out;
    if (count <= 0 || x_.cols() < 2) return out;
    const bool lf = has_low_fidelity();
    const Bounds b = log_bounds(dim_, options_.fit, lf);
    const Eigen::Index k = dim_ + 2;  // the low-fidelity noise stays fixed
    Eigen::VectorXd theta(b.lower.size());
    theta.head(k) = hp_.to_log();
    if (lf) theta(k) = std::log(std::max(hp_.low_fidelity_noise, options_.fit.min_noise_variance));
    theta = theta.cwiseMax(b.lower).cwiseMin(b.upper);
    // Laplace's approximation: the Hessian of the negative log posterior at the fit, by central
    // differences of its analytic gradient (2k gradients; a sampler would need hundreds of
    // evaluations, BENCHMARKS.md).
    NlpWorkspace ws;
    const Eigen::VectorXd* lfp = lf ? &low_fidelity_ : nullptr;
    const double h = 1e-3;
    Eigen::MatrixXd hess(k, k);
    Eigen::VectorXd gp_plus, gp_minus;
    for (Eigen::Index i = 0; i < k; ++i) {
        Eigen::VectorXd t = theta;
        t(i) = theta(i) + h;
        neg_log_posterior(x_, y_, t, options_.fit, &gp_plus, options_.backend, ws, lfp);
        t(i) = theta(i) - h;
        neg_log_posterior(x_, y_, t, options_.fit, &gp_minus, options_.backend, ws, lfp);
        hess.col(i) = (gp_plus.head(k) - gp_minus.head(k)) / (2.0 * h);
    }
    if (!hess.allFinite()) return out;
    hess = 0.5 * (hess + hess.transpose());
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(hess);
    // Curvature at least the length-scale prior's: at a bound or a saddle the fit's curvature
    // says nothing, and the prior alone bounds how far a draw may stray.
    const double min_precision = 1.0 / (options_.fit.length_scale_prior_sd * options_.fit.length_scale_prior_sd);
    const Eigen::VectorXd sd = eig.eigenvalues().cwiseMax(min_precision).cwiseInverse().cwiseSqrt();
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> normal;
    for (int c = 0; c < count; ++c) {
        Eigen::VectorXd z(k);
        for (Eigen::Index i = 0; i < k; ++i) z(i) = sd(i) * normal(rng);
        const Eigen::VectorXd t =
            (theta.head(k) + eig.eigenvectors() * z).cwiseMax(b.lower.head(k)).cwiseMin(b.upper.head(k));
        Hyperparameters draw = Hyperparameters::from_log(t);
        draw.low_fidelity_noise = hp_.low_fidelity_noise;
        out.push_back(draw);
    }
    return out;
}

FitResult GaussianProcess::fit(std::uint64_t seed) { return fit_together({this}, {seed}).front(); }

std::vector<FitResult> GaussianProcess::fit_together(const std::vector<GaussianProcess*>& models,
                                                     const std::vector<std::uint64_t>& seeds) {
    if (models.size() != seeds.size()) throw std::invalid_argument("fit_together: one seed per model");
    std::vector<std::optional<FitPlan>> plans(models.size());
    std::vector<std::pair<std::size_t, std::size_t>> tasks;  // (model, start)
    int threads = 1;
    for (std::size_t m = 0; m < models.size(); ++m) {
        if (models[m]->size() < 2) continue;
        plans[m] = models[m]->plan_fit(seeds[m]);
        for (std::size_t s = 0; s < plans[m]->starts.size(); ++s) tasks.emplace_back(m, s);
        threads = std::max(threads, resolve_threads(models[m]->options_.threads));
    }
    // Random starts (last in each plan) usually take the most iterations, the warm start the
    // fewest: longest first leaves the least idle time at the end (the order changes no result).
    std::stable_sort(tasks.begin(), tasks.end(),
                     [](const auto& a, const auto& b) { return a.second > b.second; });
    // The starts are independent: all of them, of every model, run side by side.
    parallel_for(static_cast<int>(tasks.size()), threads, [&](int t) {
        const auto [m, s] = tasks[static_cast<std::size_t>(t)];
        models[m]->run_start(*plans[m], s);
    });
    std::vector<FitResult> results(models.size());
    for (std::size_t m = 0; m < models.size(); ++m) {
        if (plans[m]) {
            results[m] = models[m]->finish_fit(*plans[m]);
        } else {
            results[m].hyperparameters = models[m]->hp_;
        }
    }
    return results;
}

void GaussianProcess::predict(const Eigen::MatrixXd& xs, Eigen::VectorXd& mean,
                              Eigen::VectorXd& variance) const {
    const Eigen::Index m = xs.cols();
    const Eigen::Index n = x_.cols();
    mean.resize(m);
    variance.resize(m);
    if (n == 0) {
        mean.setConstant(y_offset_);
        variance.setConstant(hp_.signal_variance * y_scale_ * y_scale_);
        return;
    }
    const std::optional<Cholesky::DenseLower> lower = chol_->dense_lower();
    if (!lower) {
        predict_generic(xs, mean, variance);
        return;
    }
    // O(n d + n²) preparation next to the O(n² m) solve: scaled inputs and the packed factor.
    const Eigen::ArrayXd inv_l = hp_.length_scales.array().inverse();
    const Eigen::MatrixXd z = (x_.array().colwise() * inv_l).matrix();
    const Eigen::MatrixXd zs = (xs.array().colwise() * inv_l).matrix();
    std::vector<double> packed(static_cast<std::size_t>(detail::packed_lower_size(n)));
    detail::pack_lower(lower->data(), lower->outerStride(), n, packed.data());
    detail::PredictProblem problem;
    problem.n = n;
    problem.dim = dim_;
    problem.z = z.data();
    problem.alpha = alpha_.data();
    problem.packed_l = packed.data();
    problem.signal_variance = hp_.signal_variance;

    const Eigen::Index width = detail::strip_width();
    const Eigen::Index total_strips = (m + width - 1) / width;
    // About 1 MB of K* per chunk, so that a chunk stays in L2 while L streams past it.
    const Eigen::Index chunk_strips =
        std::max<Eigen::Index>(1, (Eigen::Index{1} << 20) / (8 * width * (n + 4)));
    // A thread costs tens of µs to start: only batches above ~0.1 ms of work are split.
    const double work = static_cast<double>(n) * static_cast<double>(n) * static_cast<double>(m);
    int threads = 1;
    if (work >= 4e6) {
        threads = static_cast<int>(
            std::min<Eigen::Index>(resolve_threads(options_.threads), total_strips));
    }
    parallel_for(threads, threads, [&](int t) {
        // Contiguous whole strips per thread.
        const Eigen::Index s0 = total_strips * t / threads;
        const Eigen::Index s1 = total_strips * (t + 1) / threads;
        const Eigen::Index first = s0 * width;
        const Eigen::Index last = std::min(m, s1 * width);
        if (first >= last) return;
        const Eigen::Index strips = std::min(chunk_strips, s1 - s0);
        std::vector<double> buffer(static_cast<std::size_t>(detail::work_size(n, dim_, strips)));
        detail::predict_range(problem, zs.data(), first, last - first, strips, buffer.data(),
                              mean.data() + first, variance.data() + first);
    });
    mean = (mean.array() * y_scale_ + y_offset_).matrix();
    variance = variance.cwiseMax(1e-12 * hp_.signal_variance) * (y_scale_ * y_scale_);
}

void GaussianProcess::predict_generic(const Eigen::MatrixXd& xs, Eigen::VectorXd& mean,
                                      Eigen::VectorXd& variance) const {
    const Eigen::Index m = xs.cols();
    // Blocks keep the n×block cross-covariance in cache-friendly sizes.
    const Eigen::Index block = 1024;
    for (Eigen::Index start = 0; start < m; start += block) {
        const Eigen::Index len = std::min(block, m - start);
        const Eigen::MatrixXd kc = matern52(x_, xs.middleCols(start, len), hp_);  // n×len
        mean.segment(start, len) = kc.transpose() * alpha_;
        const Eigen::MatrixXd v = chol_->solve_lower(kc);
        variance.segment(start, len) = (hp_.signal_variance - v.colwise().squaredNorm().array())
                                           .max(1e-12 * hp_.signal_variance);
    }
    mean = (mean.array() * y_scale_ + y_offset_).matrix();
    variance *= y_scale_ * y_scale_;
}

PointPrediction GaussianProcess::predict_with_gradient(const Eigen::VectorXd& x) const {
    PointPrediction p;
    const double s2 = y_scale_ * y_scale_;
    if (x_.cols() == 0) {
        p.mean = y_offset_;
        p.variance = hp_.signal_variance * s2;
        p.mean_gradient = Eigen::VectorXd::Zero(dim_);
        p.variance_gradient = Eigen::VectorXd::Zero(dim_);
        return p;
    }
    const Eigen::VectorXd k = matern52(x_, x, hp_).col(0);
    const Eigen::MatrixXd jac = matern52_input_gradient(x, x_, hp_);  // d×n
    const Eigen::VectorXd v = chol_->solve_lower(k);
    // K⁻¹k = L⁻ᵀv: with a dense factor one triangular solve instead of solve(k)'s two (the same
    // operations on the same matrix type as EigenCholesky::solve, so the same result).
    Eigen::MatrixXd kinv_k = v;
    if (const std::optional<Cholesky::DenseLower> lower = chol_->dense_lower()) {
        lower->transpose().triangularView<Eigen::Upper>().solveInPlace(kinv_k);
    } else {
        kinv_k = chol_->solve(k);
    }
    const Eigen::VectorXd w = kinv_k.col(0);
    p.mean = k.dot(alpha_) * y_scale_ + y_offset_;
    p.mean_gradient = jac * alpha_ * y_scale_;
    p.variance = std::max(hp_.signal_variance - v.squaredNorm(), 1e-12 * hp_.signal_variance) * s2;
    p.variance_gradient = -2.0 * (jac * w) * s2;
    return p;
}

}  // namespace maptune::gp
