#include "bo/optimizer.hpp"

#include <LBFGSB.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <random>

#include "bo/quadratic_model.hpp"
#include "gp/parallel.hpp"

namespace maptune::bo {

namespace {

std::uint64_t mix(std::uint64_t a, std::uint64_t b) {
    // splitmix64 of a combined key: independent streams per (seed, ask, purpose).
    std::uint64_t z = a + 0x9e3779b97f4a7c15ULL * (b + 1);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

const double kDuplicateTolerance = 1e-9;  // max-norm distance in GP input space
// Proposals in flight at the same time are at least this far apart (max norm, GP input space):
// two near-copies in one batch waste an evaluation, most of all inside a small trust region.
const double kPendingSeparation = 1e-3;

double normal_quantile(double p) {
    // Bisection on erfc: robust over the whole range and cheap next to the GP.
    double lo = -12.0, hi = 12.0;
    for (int i = 0; i < 64; ++i) {
        const double mid = 0.5 * (lo + hi);
        (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

// Gaussian copula: Φ⁻¹((rank + ½) / n) with ties sharing their mean rank. Monotone, so the
// order of points (and the incumbent) is unchanged.
Eigen::VectorXd copula(const Eigen::VectorXd& y) {
    const Eigen::Index n = y.size();
    std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(),
              [&](Eigen::Index a, Eigen::Index b) { return y(a) < y(b); });
    Eigen::VectorXd out(n);
    for (Eigen::Index i = 0; i < n;) {
        Eigen::Index j = i;
        while (j + 1 < n &&
               y(order[static_cast<std::size_t>(j + 1)]) == y(order[static_cast<std::size_t>(i)]))
            ++j;
        const double rank = 0.5 * static_cast<double>(i + j);
        const double z = normal_quantile((rank + 0.5) / static_cast<double>(n));
        for (Eigen::Index k = i; k <= j; ++k) out(order[static_cast<std::size_t>(k)]) = z;
        i = j + 1;
    }
    return out;
}

// Negative acquisition over u for LBFGSpp; integer coordinates are held fixed by their bounds
// and get zero gradient because the model input is piecewise constant in them.
// log P(live) = log Φ(μ / √(s0² + σ²)) of the dead-region classifier, and its gradient.
constexpr double kLiveScale2 = 0.25;  // s0²: labels ±1, so μ = ±1 means P ≈ 0.98 / 0.02
double log_live(const gp::PointPrediction& p, double prior, Eigen::VectorXd* grad) {
    const double s = std::sqrt(kLiveScale2 + std::max(0.0, p.variance));
    const double mean = p.mean + prior;
    const double t = mean / s;
    const double cdf = 0.5 * std::erfc(-t / std::sqrt(2.0));
    const double log_cdf = cdf > 1e-300 ? std::log(cdf) : -690.0;
    if (grad) {
        const double pdf = std::exp(-0.5 * t * t) / std::sqrt(2.0 * M_PI);
        const double ratio = cdf > 1e-300 ? pdf / cdf : std::max(-t, 0.0);  // Mills ratio tail
        // dt = (μ' s − μ s') / s², s' = σ²' / (2 s)
        *grad = ratio * (p.mean_gradient * s - mean * p.variance_gradient / (2.0 * s)) / (s * s);
    }
    return log_cdf;
}

// The dead-region classifier's GP: labels in their own units (no standardization: ±1 is the
// scale of s0), length scales bounded (OptimizerOptions::live_max_length_scale).
gp::GpOptions classifier_options(const OptimizerOptions& o) {
    gp::GpOptions lo = o.gp;
    lo.mean = gp::MeanKind::zero;
    lo.fit.max_length_scale = o.live_max_length_scale;
    return lo;
}

// Acquisition weighted by P(live): log-EI + log P, EI × P; UCB is left alone (not a probability
// of improvement, a weight would change its meaning).
void weigh_by_live(const AcquisitionContext& ctx, double log_p, double& value) {
    if (ctx.kind == Acquisition::log_ei) value += log_p;
    if (ctx.kind == Acquisition::ei) value *= std::exp(log_p);
}

// The acquisition averaged over models (hyperparameter draws): EI's average, so log-EI's
// log-mean-exp; UCB's plain average. weights (optional, one per value): d(average)/d(value).
double average_acquisition(Acquisition kind, const std::vector<double>& v, std::vector<double>* weights) {
    const auto m = static_cast<double>(v.size());
    if (weights) weights->assign(v.size(), 1.0 / m);
    if (kind != Acquisition::log_ei) return std::accumulate(v.begin(), v.end(), 0.0) / m;
    const double top = *std::max_element(v.begin(), v.end());
    if (!std::isfinite(top)) return top;
    double sum = 0;
    for (double x : v) sum += std::exp(x - top);
    if (weights) {
        for (std::size_t k = 0; k < v.size(); ++k) (*weights)[k] = std::exp(v[k] - top) / sum;
    }
    return top + std::log(sum / m);
}

double ensemble_value(const AcquisitionContext& ctx, const std::vector<gp::GaussianProcess>& models,
                      const Eigen::VectorXd& g, Eigen::VectorXd* grad) {
    std::vector<double> v(models.size()), w;
    std::vector<Eigen::VectorXd> gr(models.size());
    for (std::size_t k = 0; k < models.size(); ++k)
        v[k] = acquisition_value(ctx, models[k].predict_with_gradient(g), grad ? &gr[k] : nullptr);
    const double value = average_acquisition(ctx.kind, v, grad ? &w : nullptr);
    if (grad) {
        grad->setZero(g.size());
        if (std::isfinite(value)) {
            for (std::size_t k = 0; k < models.size(); ++k) *grad += w[k] * gr[k];
        }
    }
    return value;
}

struct AcquisitionObjective {
    const gp::GaussianProcess& gp;
    const SearchSpace& space;
    const AcquisitionContext& ctx;
    const gp::GaussianProcess* live = nullptr;
    double live_prior = 0.0;
    const std::vector<gp::GaussianProcess>* ensemble = nullptr;
    double best_value = -std::numeric_limits<double>::infinity();
    Eigen::VectorXd best_u;

    double operator()(const Eigen::VectorXd& u, Eigen::VectorXd& grad) {
        const Eigen::VectorXd g = space.to_model_input(u);
        Eigen::VectorXd acq_grad;
        double value = ensemble ? ensemble_value(ctx, *ensemble, g, &acq_grad)
                                : acquisition_value(ctx, gp.predict_with_gradient(g), &acq_grad);
        if (live && (ctx.kind == Acquisition::log_ei || ctx.kind == Acquisition::ei) && std::isfinite(value)) {
            Eigen::VectorXd lg;
            const double lp = log_live(live->predict_with_gradient(g), live_prior, &lg);
            if (ctx.kind == Acquisition::log_ei) {
                acq_grad += lg;
            } else {
                acq_grad = std::exp(lp) * (acq_grad + value * lg);
            }
            weigh_by_live(ctx, lp, value);
        }
        grad = -acq_grad;
        for (int j = 0; j < space.dim(); ++j) {
            if (space.specs()[static_cast<std::size_t>(j)].is_integer) grad(j) = 0.0;
        }
        if (!std::isfinite(value)) {
            grad.setZero();
            return 1e300;
        }
        if (value > best_value) {
            best_value = value;
            best_u = u;
        }
        return -value;
    }
};

}  // namespace

Optimizer::Optimizer(std::vector<ParameterSpec> specs, OptimizerOptions options)
    : space_(std::move(specs)),
      options_(options),
      design_(space_.dim(), mix(options.seed, 1)),
      hp_(gp::Hyperparameters::defaults(space_.dim())) {
}

Optimizer::Optimizer(std::vector<ParameterSpec> specs, OptimizerOptions options,
                     const std::vector<Observation>& history)
    : Optimizer(std::move(specs), options) {
    for (const Observation& o : history) add_observation(o);
    // The design continues where a run with this history would have continued.
    design_index_ = history.size();
}

int Optimizer::initial_points() const {
    return options_.initial_points > 0 ? options_.initial_points : std::max(5, space_.dim() + 1);
}

void Optimizer::add_start_point(const std::vector<double>& values) {
    start_points_.push_back(space_.canonical(values));
}

Optimizer::Point Optimizer::make_point(const Eigen::VectorXd& u) const {
    Point p;
    p.u = space_.snap(u);
    p.g = space_.to_model_input(p.u);
    return p;
}

bool Optimizer::is_taken(const Eigen::VectorXd& g) const {
    auto same = [&](const Point& p) {
        return (p.g - g).cwiseAbs().maxCoeff() < kDuplicateTolerance;
    };
    if (std::any_of(observed_points_.begin(), observed_points_.end(), same)) return true;
    return std::any_of(pending_.begin(), pending_.end(), [&](const auto& kv) {
        return (kv.second.g - g).cwiseAbs().maxCoeff() < kPendingSeparation;
    });
}

bool Optimizer::near_failure(const Eigen::VectorXd& g) const {
    const double r2 = options_.failure_radius * options_.failure_radius;
    for (std::size_t i = 0; i < observations_.size(); ++i) {
        if (observations_[i].failed && (observed_points_[i].g - g).squaredNorm() < r2) return true;
    }
    return false;
}

Eigen::VectorXd Optimizer::next_design_point() {
    Eigen::VectorXd fallback;
    for (int tries = 0; tries < 1000; ++tries) {
        const Point p = make_point(design_.point(design_index_++));
        if (!is_taken(p.g) && !near_failure(p.g)) return p.u;
        if (fallback.size() == 0 && !is_taken(p.g)) fallback = p.u;
    }
    // A tiny, exhausted integer space: give the least bad point rather than nothing.
    return fallback.size() > 0 ? fallback : make_point(design_.point(design_index_++)).u;
}

void Optimizer::model_data(Eigen::MatrixXd& x, Eigen::VectorXd& y, double& best, Eigen::VectorXd* raw,
                           Eigen::VectorXd* low_fidelity) const {
    const int d = space_.dim();
    double worst = std::numeric_limits<double>::infinity();
    best = -std::numeric_limits<double>::infinity();
    for (const Observation& o : observations_) {
        if (o.failed) continue;
        worst = std::min(worst, internal(o.value));
        best = std::max(best, internal(o.value));
    }
    // In observation order, so that the data only ever grows at the end (the cached factor
    // takes appends). Failures enter at the worst observed value so that the surrogate itself
    // steers away from their region (besides the hard exclusion radius).
    const auto n = static_cast<Eigen::Index>(observations_.size());
    x.resize(d, n);
    y.resize(n);
    for (Eigen::Index k = 0; k < n; ++k) {
        const auto i = static_cast<std::size_t>(k);
        x.col(k) = observed_points_[i].g;
        y(k) = observations_[i].failed ? worst : internal(observations_[i].value);
    }

    if (raw) *raw = y;
    if (low_fidelity) {
        low_fidelity->resize(0);
        for (Eigen::Index k = 0; k < n; ++k) {
            const Observation& o = observations_[static_cast<std::size_t>(k)];
            if (!o.low_fidelity || o.failed) continue;
            if (low_fidelity->size() == 0) *low_fidelity = Eigen::VectorXd::Zero(n);
            (*low_fidelity)(k) = 1.0;
        }
    }
    if (options_.warping == OutputWarping::copula && n > 0) {
        y = copula(y);
        best = -std::numeric_limits<double>::infinity();
        for (Eigen::Index k = 0; k < n; ++k) {
            if (!observations_[static_cast<std::size_t>(k)].failed) best = std::max(best, y(k));
        }
    }
    const double alpha = warp_alpha();
    if (alpha > 0 && n > 0) {
        const Warp w = warp_for(alpha, y);
        for (Eigen::Index i = 0; i < n; ++i) y(i) = w.apply(y(i));
        best = w.apply(best);
    }
}

std::string Optimizer::warping_in_use() const {
    if (options_.warping == OutputWarping::copula) return "copula";
    const double alpha = warp_alpha();
    if (alpha <= 0) return "none";
    char buf[48];
    std::snprintf(buf, sizeof buf, "log(c = %g range)", alpha);
    return buf;
}

std::vector<bool> Optimizer::improvements() const {
    std::vector<bool> out;
    double best = -std::numeric_limits<double>::infinity();
    for (const Observation& o : observations_) {
        const double v = o.failed ? -std::numeric_limits<double>::infinity() : internal(o.value);
        out.push_back(v > best + 1e-3 * std::fabs(best));
        if (v > best) best = v;
    }
    return out;
}

double Optimizer::trust_region_length() const {
    // TuRBO-1's defaults (Eriksson et al. 2019), q = 1.
    const double l0 = 0.8, l_max = 1.6, l_min = std::pow(0.5, 7);
    const int fail_tolerance = std::max(4, space_.dim());
    double length = l0;
    int success = 0, failure = 0;
    const std::size_t design = static_cast<std::size_t>(initial_points());
    const std::vector<bool> improved = improvements();
    for (std::size_t i = design; i < improved.size(); ++i) {  // the design only sets the incumbent
        if (improved[i]) {
            ++success;
            failure = 0;
        } else {
            ++failure;
            success = 0;
        }
        if (success >= 3) {
            length = std::min(2 * length, l_max);
            success = 0;
        } else if (failure >= fail_tolerance) {
            length /= 2;
            failure = 0;
        }
        if (length < l_min) length = l0;
    }
    return length;
}

Optimizer::Warp Optimizer::warp_for(double alpha, const Eigen::VectorXd& y) const {
    Warp w;
    if (y.size() == 0) return w;
    // Also for the identity: the warping fits take a candidate's incumbent as apply(best), which
    // must be the best value itself, not 0.
    w.best = y.maxCoeff();
    if (alpha <= 0) return w;
    w.alpha = alpha;
    const double range = w.best - y.minCoeff();
    w.c = alpha * (range > 0 ? range : 1.0);
    return w;
}

// The warping the current values are modelled in (to map predictions back to values).
Optimizer::Warp Optimizer::current_warp() const {
    const double alpha = warp_alpha();
    if (alpha <= 0) return Warp{};
    Eigen::MatrixXd x;
    Eigen::VectorXd y, raw;
    double best = 0;
    model_data(x, y, best, &raw);
    return warp_for(alpha, raw);
}

double Optimizer::warp_alpha() const {
    if (options_.warping == OutputWarping::log) return 0.1;
    return options_.warping == OutputWarping::automatic ? warp_alpha_ : 0.0;
}

gp::GpOptions Optimizer::main_gp_options(std::size_t design_outputs) const {
    gp::GpOptions o = options_.gp;
    // The prior mean is the design's average (the objective's average over the box); the
    // model's own proposals cluster where it is good (BENCHMARKS.md, "prior mean").
    o.mean_points = static_cast<Eigen::Index>(std::min(design_outputs, static_cast<std::size_t>(initial_points())));
    return o;
}

AcquisitionContext Optimizer::acquisition_context(double incumbent) const {
    AcquisitionContext ctx;
    ctx.kind = options_.acquisition;
    ctx.kappa = options_.ucb_kappa;
    ctx.incumbent = incumbent;
    if (ctx.kind == Acquisition::ucb_schedule) {
        const double t = static_cast<double>(observations_.size() + pending_.size() + 1);
        ctx.kappa = srinivas_kappa(space_.dim(), t, options_.schedule_delta, options_.schedule_scale);
    }
    return ctx;
}

void Optimizer::fit() { build_model(); }

std::vector<PosteriorPoint> Optimizer::posterior(const std::vector<std::vector<double>>& points) const {
    std::size_t ok = 0;
    for (const auto& o : observations_) ok += o.failed ? 0 : 1;
    if (ok < 2 || hp_.length_scales.size() != space_.dim()) return {};
    Eigen::MatrixXd x;
    Eigen::VectorXd y, lf;
    double best = 0;
    model_data(x, y, best, nullptr, &lf);
    gp::GaussianProcess model(space_.dim(), main_gp_options(observations_.size()));
    model.set_hyperparameters(hp_);
    if (!model.set_data(x, y, lf)) return {};
    Eigen::MatrixXd g(space_.dim(), static_cast<Eigen::Index>(points.size()));
    for (std::size_t i = 0; i < points.size(); ++i) {
        g.col(static_cast<Eigen::Index>(i)) = space_.to_model_input(space_.from_values(space_.canonical(points[i])));
    }
    Eigen::VectorXd mean, var;
    model.predict(g, mean, var);
    const Eigen::VectorXd acq = acquisition_values(acquisition_context(best), mean, var);
    const Warp w = current_warp();
    std::vector<PosteriorPoint> out(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
        const auto k = static_cast<Eigen::Index>(i);
        // A warped model's mean maps back monotonically (the median); its spread by the
        // slope there (delta method).
        const double v = w.invert(mean(k));
        const double sd = std::sqrt(std::max(0.0, var(k))) * std::exp(-w.log_slope(v));
        out[i] = {internal(v), sd, acq(k)};
    }
    return out;
}

Optimizer::Model Optimizer::build_model() {
    const int d = space_.dim();
    Eigen::MatrixXd x;
    Eigen::VectorXd y;
    double best = 0;
    Eigen::VectorXd raw, lf;
    model_data(x, y, best, &raw, &lf);
    const auto n = x.cols();
    gp::GpOptions gp_options = main_gp_options(observations_.size());
    // After the first fit the previous optimum is a good start; the fixed one only costs time.
    if (last_fit_n_ > 0) gp_options.fit.fixed_start = false;
    gp::GaussianProcess model(d, gp_options);
    const auto nu = static_cast<std::size_t>(n);
    const double grown = static_cast<double>(nu) - static_cast<double>(last_fit_n_);
    const bool refit =
        last_fit_n_ == 0 ||
        grown >= std::max(1.0, std::round(options_.refit_growth * static_cast<double>(nu)));
    if (!(refit && n >= 2) && cache_ && cache_n_ <= nu) {
        // Between refits (same hyperparameters) new observations enter the cached factor by
        // O(n²) appends; only K⁻¹y is recomputed for the outputs (the warping and the worst
        // value may have moved).
        for (Eigen::Index i = static_cast<Eigen::Index>(cache_n_); i < n; ++i)
            cache_->append(x.col(i), y(i), lf.size() > 0 && lf(i) > 0);
        cache_->set_outputs(y);
        cache_n_ = nu;
        model = *cache_;
        ++stats_.appends;
    } else {
        model.set_hyperparameters(hp_);
        model.set_data(x, y, lf);
        ++stats_.factorizations;
    }
    if (refit && n >= 2) {
        ++stats_.refits;
        if (options_.warping == OutputWarping::automatic && n <= options_.gp.fit.max_points) {
            // Each candidate warping fitted on the same data; the one under which the values
            // themselves are most probable wins: log p(v) = log p(z) + Σ log |dz/dv|, with
            // log p(z) = −(neg. log posterior of the standardized z) − n log(scale of z).
            double best_score = -std::numeric_limits<double>::infinity();
            // The offset c sets how far below the best the log compresses: with c = 0.1 × the
            // range alone, a few huge values (a quartic's corners) made every good value look
            // alike. Log-spaced c down to 0.001 range: ellipsoid9's p90 9e4 -> 139, Zakharov
            // 207 -> 128, Dixon-Price 144 -> 15 at twice the refit time (BENCHMARKS.md,
            // "Warping offsets").
            const double alphas[] = {0.0, 0.1, 0.01, 0.001};
            struct Candidate {
                double alpha;
                Warp w;
                double log_jac = 0;
                gp::GaussianProcess g;
                gp::FitResult fr;
                bool ok = false;
            };
            std::vector<Candidate> cands;
            for (const double alpha : alphas) {
                cands.push_back({alpha, warp_for(alpha, raw), 0.0, gp::GaussianProcess(d, gp_options), {}, false});
            }
            // The model of the values under a warping, warm-started from its own last fit.
            auto prepare = [&](Candidate& c) {
                Eigen::VectorXd z(n);
                for (Eigen::Index i = 0; i < n; ++i) {
                    z(i) = c.w.apply(raw(i));
                    c.log_jac += c.w.log_slope(raw(i));
                }
                const auto warm = warp_hp_.find(c.alpha);
                c.g.set_hyperparameters(warm != warp_hp_.end() ? warm->second : hp_);
                c.ok = c.g.set_data(x, z, lf);
            };
            const std::uint64_t seed = mix(options_.seed, 1000 + nu);
            auto judge = [&](Candidate& c) {
                if (!c.ok) return;
                warp_hp_[c.alpha] = c.fr.hyperparameters;
                const double score = -c.fr.neg_log_posterior -
                                     static_cast<double>(n) * std::log(c.g.output_scale()) + c.log_jac;
                if (score > best_score) {
                    best_score = score;
                    warp_alpha_ = c.alpha;
                    hp_ = c.fr.hyperparameters;
                    best = c.w.apply(c.w.best);
                    model = std::move(c.g);
                }
            };
            if (warp_hp_.size() == std::size(alphas)) {
                // Every warping starts from its own last fit: the four fits are independent,
                // and their starts share the threads (judged in the same order as below).
                std::vector<gp::GaussianProcess*> models;
                for (Candidate& c : cands) {
                    prepare(c);
                    if (c.ok) models.push_back(&c.g);
                }
                const std::vector<gp::FitResult> results =
                    gp::GaussianProcess::fit_together(models, std::vector<std::uint64_t>(models.size(), seed));
                std::size_t k = 0;
                for (Candidate& c : cands) {
                    if (c.ok) c.fr = results[k++];
                }
                for (Candidate& c : cands) judge(c);
            } else {
                // The first refit: a warping without a fit of its own starts from the previous
                // winner's, so the fits run one after the other.
                for (Candidate& c : cands) {
                    prepare(c);
                    if (!c.ok) continue;
                    c.fr = c.g.fit(seed);
                    judge(c);
                }
            }
        } else {
            hp_ = model.fit(mix(options_.seed, 1000 + nu)).hyperparameters;
        }
        last_fit_n_ = nu;
        hp_samples_.clear();
        if (options_.hyper_samples > 0 && n <= options_.gp.fit.max_points)
            hp_samples_ = model.sample_hyperparameters(options_.hyper_samples, mix(options_.seed, 5000 + nu));
    }
    if (!cache_ || cache_n_ != nu) {
        cache_ = model;
        cache_n_ = nu;
    }
    Model m{std::move(model), best, std::nullopt};
    Eigen::VectorXd labels;
    double prior = 0.0;
    if (live_labels(labels, prior)) {
        gp::GaussianProcess live(d, classifier_options(options_));
        if (live_hp_.length_scales.size() == d) live.set_hyperparameters(live_hp_);
        live.set_data(x, labels);
        if (live_fit_n_ == 0 || (refit && n >= 2)) {
            live_hp_ = live.fit(mix(options_.seed, 3000 + nu)).hyperparameters;
            live_fit_n_ = nu;
        }
        m.live = std::move(live);
        m.live_prior = prior;
    }
    // Kriging believer: pending points enter with their predicted value, which shrinks the
    // variance around them so that the next proposal goes elsewhere.
    for (const auto& [id, p] : pending_) {
        Eigen::VectorXd mean, var;
        m.gp.predict(p.g, mean, var);
        m.gp.append(p.g, mean(0));
        m.incumbent = std::max(m.incumbent, mean(0));
    }
    return m;
}

void Optimizer::add_draws(Model& model) const {
    for (const gp::Hyperparameters& h : hp_samples_) {
        gp::GaussianProcess g = model.gp;
        if (g.set_hyperparameters(h)) model.ensemble.push_back(std::move(g));
    }
}

std::optional<PredictedBest> Optimizer::predicted_best() const {
    std::vector<std::size_t> ok;
    for (std::size_t i = 0; i < observations_.size(); ++i) {
        if (!observations_[i].failed) ok.push_back(i);
    }
    if (ok.size() < 2 || hp_.length_scales.size() != space_.dim()) return std::nullopt;
    const auto n = static_cast<Eigen::Index>(ok.size());
    Eigen::MatrixXd x(space_.dim(), n);
    Eigen::VectorXd y(n), lf = Eigen::VectorXd::Zero(n);
    const Warp w = current_warp();
    for (Eigen::Index k = 0; k < n; ++k) {
        const std::size_t i = ok[static_cast<std::size_t>(k)];
        x.col(k) = observed_points_[i].g;
        y(k) = w.apply(internal(observations_[i].value));
        lf(k) = observations_[i].low_fidelity ? 1.0 : 0.0;
    }
    const auto design = static_cast<std::size_t>(initial_points());
    const auto leading = static_cast<std::size_t>(
        std::count_if(ok.begin(), ok.end(), [&](std::size_t i) { return i < design; }));
    gp::GaussianProcess model(space_.dim(), main_gp_options(leading));
    model.set_hyperparameters(hp_);
    if (!model.set_data(x, y, lf)) return std::nullopt;
    Eigen::VectorXd mean, var;
    model.predict(x, mean, var);
    // Only a set evaluated in full can be the best: an estimate never is.
    Eigen::Index best = -1;
    for (Eigen::Index k = 0; k < n; ++k) {
        if (lf(k) == 0.0 && (best < 0 || mean(k) > mean(best))) best = k;
    }
    if (best < 0) return std::nullopt;
    PredictedBest out;
    out.values = observations_[ok[static_cast<std::size_t>(best)]].values;
    const double v = w.invert(mean(best));
    out.mean = internal(v);  // internal() is its own inverse
    out.std = std::sqrt(std::max(0.0, var(best))) * std::exp(-w.log_slope(v));
    return out;
}

bool Optimizer::region_slot(std::size_t i) const {
    // Alternating: every other proposal searches the whole box (by the count so far, so a
    // resumed run alternates as the uninterrupted one).
    return options_.search == SearchRegion::trust_region || (options_.search == SearchRegion::alternate && i % 2 == 1);
}

bool Optimizer::quadratic_steps_pay() const {
    // Laplace's rule of succession for "this proposal improved the best" on the quadratic
    // steps' slots against the region's other slots, from the observations in order (so a
    // resumed run decides as the uninterrupted one). A slot lost to the acquisition keeps being
    // counted, so the quadratic gets its slots back when the region's proposals stop paying.
    int quad_tries = 0, quad_wins = 0, region_tries = 0, region_wins = 0;
    const std::vector<bool> improved = improvements();
    for (std::size_t i = static_cast<std::size_t>(initial_points()); i < improved.size(); ++i) {
        if (!region_slot(i)) continue;
        if (quadratic_slot(i)) {
            ++quad_tries;
            quad_wins += improved[i];
        } else {
            ++region_tries;
            region_wins += improved[i];
        }
    }
    return (quad_wins + 1.0) / (quad_tries + 2.0) >= (region_wins + 1.0) / (region_tries + 2.0);
}

std::optional<Eigen::VectorXd> Optimizer::quadratic_step(const Model& model, const Eigen::VectorXd& centre,
                                                         const Eigen::VectorXd& lo, const Eigen::VectorXd& hi) const {
    // All measured live values: failures and low-fidelity estimates carry no value of their own,
    // and a dead region's constant (the matcher's p = 0) is a cliff, not part of the bowl.
    std::vector<std::size_t> used;
    for (std::size_t i = 0; i < observations_.size(); ++i) {
        if (!is_dead(observations_[i]) && !observations_[i].low_fidelity) used.push_back(i);
    }
    const int d = space_.dim();
    if (used.size() < static_cast<std::size_t>(d + 2)) return std::nullopt;
    Eigen::MatrixXd u(d, static_cast<Eigen::Index>(used.size()));
    Eigen::VectorXd y(u.cols());
    for (std::size_t k = 0; k < used.size(); ++k) {
        u.col(static_cast<Eigen::Index>(k)) = observed_points_[used[k]].u;
        y(static_cast<Eigen::Index>(k)) = internal(observations_[used[k]].value);
    }
    const auto quadratic = fit_quadratic(u, y, centre);
    if (!quadratic) return std::nullopt;
    // Inside the region and the box the values span: a least-squares surface interpolates, and
    // past its data (beyond the last live point before a cliff) it only extrapolates.
    const Point point = make_point(maximize_in_box(*quadratic, lo.cwiseMax(u.rowwise().minCoeff()),
                                                   hi.cwiseMin(u.rowwise().maxCoeff())));
    if (is_taken(point.g) || near_failure(point.g)) return std::nullopt;
    // The step knows nothing of dead regions: where the classifier rates it more likely dead
    // than live, the acquisition (weighted by P(live)) proposes instead.
    if (model.live && log_live(model.live->predict_with_gradient(point.g), model.live_prior, nullptr) < std::log(0.5))
        return std::nullopt;
    return point.u;
}

Eigen::VectorXd Optimizer::maximize_acquisition(const Model& model, std::uint64_t seed, bool& quadratic) {
    quadratic = false;
    const int d = space_.dim();
    const AcquisitionContext ctx = acquisition_context(model.incumbent);

    // Candidates: a freshly scrambled Halton set plus Gaussian perturbations of the best
    // observations at several scales (exploitation needs points near the incumbent).
    std::mt19937_64 rng(seed);
    const double n_obs = static_cast<double>(observations_.size());
    const double shrink = n_obs > 300.0 ? 300.0 / n_obs : 1.0;
    const auto n_total = static_cast<Eigen::Index>(std::max(
        std::min(options_.candidates, 256), static_cast<int>(options_.candidates * shrink)));
    const auto n_local =
        static_cast<Eigen::Index>(options_.local_fraction * static_cast<double>(n_total));
    const Eigen::Index n_global = n_total - n_local;
    const ScrambledHalton halton(d, mix(seed, 2));
    Eigen::MatrixXd cand_u(d, n_total);
    cand_u.leftCols(n_global) = halton.points(0, n_global);
    // Trust region: the box around the incumbent where candidates and polishes stay.
    Eigen::VectorXd lo = Eigen::VectorXd::Zero(d), hi = Eigen::VectorXd::Ones(d);
    const std::size_t count = observations_.size() + pending_.size();
    if (region_slot(count) && has_success()) {
        std::size_t inc = 0;
        bool found = false;
        for (std::size_t i = 0; i < observations_.size(); ++i) {
            if (observations_[i].failed) continue;
            if (!found || internal(observations_[i].value) > internal(observations_[inc].value)) inc = i;
            found = true;
        }
        const Eigen::VectorXd& center = observed_points_[inc].u;
        // Side per dimension ∝ length scale, geometric mean L (TuRBO's weighting).
        Eigen::VectorXd w = Eigen::VectorXd::Ones(d);
        if (hp_.length_scales.size() == d) {
            w = hp_.length_scales.array().min(1e2).max(1e-3);
            w /= std::exp(w.array().log().mean());
        }
        const double length = trust_region_length();
        for (int j = 0; j < d; ++j) {
            const double half = 0.5 * std::min(1.0, length * w(j));
            lo(j) = std::max(0.0, center(j) - half);
            hi(j) = std::min(1.0, center(j) + half);
        }
        // Every fourth proposal (half of the region's) is the quadratic response
        // surface's maximizer in the region while such steps pay (quadratic_model.hpp; why:
        // BENCHMARKS.md, "Quadratic steps").
        if (options_.quadratic_steps && quadratic_slot(count) && quadratic_steps_pay()) {
            if (auto u = quadratic_step(model, center, lo, hi)) {
                quadratic = true;
                return *u;
            }
        }
        for (Eigen::Index i = 0; i < n_global; ++i) {
            cand_u.col(i) = lo.array() + (hi - lo).array() * cand_u.col(i).array();
        }
    }

    std::vector<std::size_t> order;
    for (std::size_t i = 0; i < observations_.size(); ++i) {
        if (!observations_[i].failed) order.push_back(i);
    }
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        return internal(observations_[a].value) > internal(observations_[b].value);
    });
    order.resize(std::min<std::size_t>(order.size(), 5));
    std::normal_distribution<double> normal;
    const double scales[3] = {0.01, 0.05, 0.15};
    for (Eigen::Index i = 0; i < n_local; ++i) {
        if (order.empty()) {
            cand_u.col(n_global + i) = halton.point(static_cast<std::uint64_t>(n_global + i));
            continue;
        }
        const Eigen::VectorXd& center =
            observed_points_[order[static_cast<std::size_t>(i) % order.size()]].u;
        const double s = scales[i % 3];
        for (int j = 0; j < d; ++j)
            cand_u(j, n_global + i) = std::clamp(center(j) + s * normal(rng), lo(j), hi(j));
    }
    Eigen::MatrixXd cand_g(d, n_total);
    for (Eigen::Index i = 0; i < n_total; ++i) {
        cand_u.col(i) = space_.snap(cand_u.col(i));
        cand_g.col(i) = space_.to_model_input(cand_u.col(i));
    }
    Eigen::VectorXd mean, var;
    model.gp.predict(cand_g, mean, var);
    Eigen::VectorXd acq = acquisition_values(ctx, mean, var);
    // Only the whole box's proposals average over the draws (the region's refine the fit's model).
    const bool use_ensemble = !model.ensemble.empty() && !(region_slot(count) && has_success());
    if (use_ensemble) {
        std::vector<Eigen::VectorXd> values;
        for (const gp::GaussianProcess& g : model.ensemble) {
            g.predict(cand_g, mean, var);
            values.push_back(acquisition_values(ctx, mean, var));
        }
        std::vector<double> at(values.size());
        for (Eigen::Index i = 0; i < n_total; ++i) {
            for (std::size_t k = 0; k < values.size(); ++k) at[k] = values[k](i);
            acq(i) = average_acquisition(ctx.kind, at, nullptr);
        }
    }
    if (model.live) {
        Eigen::VectorXd lm, lv;
        model.live->predict(cand_g, lm, lv);
        for (Eigen::Index i = 0; i < n_total; ++i) {
            gp::PointPrediction p;
            p.mean = lm(i);
            p.variance = lv(i);
            if (std::isfinite(acq(i))) weigh_by_live(ctx, log_live(p, model.live_prior, nullptr), acq(i));
        }
    }
    const double minus_inf = -std::numeric_limits<double>::infinity();
    for (Eigen::Index i = 0; i < n_total; ++i) {
        if (!std::isfinite(acq(i)) || is_taken(cand_g.col(i)) || near_failure(cand_g.col(i)))
            acq(i) = minus_inf;
    }
    std::vector<Eigen::Index> idx(static_cast<std::size_t>(n_total));
    std::iota(idx.begin(), idx.end(), 0);
    const auto n_starts = std::min<std::size_t>(
        static_cast<std::size_t>(std::max(options_.polish_starts, 1)), idx.size());
    std::partial_sort(idx.begin(), idx.begin() + static_cast<std::ptrdiff_t>(n_starts), idx.end(),
                      [&](Eigen::Index a, Eigen::Index b) { return acq(a) > acq(b); });

    Eigen::VectorXd best_u = cand_u.col(idx.front());
    double best_value = acq(idx.front());

    LBFGSpp::LBFGSBParam<double> param;
    param.max_iterations = options_.polish_iterations;
    param.epsilon = 1e-6;
    param.past = 1;
    param.delta = 1e-10;
    param.max_linesearch = 20;
    // The polishes are independent: they run side by side and are merged in start order below,
    // exactly as one after the other. Starts are sorted by value, so the finite ones lead.
    std::size_t n_polish = 0;
    while (n_polish < n_starts && std::isfinite(acq(idx[n_polish]))) ++n_polish;
    struct Polished {
        double value = -std::numeric_limits<double>::infinity();
        Eigen::VectorXd u;
    };
    std::vector<Polished> polished(n_polish);
    auto polish = [&](int s) {
        const Eigen::Index c = idx[static_cast<std::size_t>(s)];
        Eigen::VectorXd lb = lo, ub = hi;
        for (int j = 0; j < d; ++j) {
            if (space_.specs()[static_cast<std::size_t>(j)].is_integer)
                lb(j) = ub(j) = cand_u(j, c);
        }
        LBFGSpp::LBFGSBSolver<double> solver(param);
        AcquisitionObjective objective{model.gp, space_, ctx, model.live ? &*model.live : nullptr,
                                       model.live_prior, use_ensemble ? &model.ensemble : nullptr};
        Eigen::VectorXd u = cand_u.col(c);
        double fx = 0.0;
        try {
            solver.minimize(objective, u, fx, lb, ub);
        } catch (const std::exception&) {
            // Line search gave up; the best point it saw is still usable.
        }
        polished[static_cast<std::size_t>(s)] = {objective.best_value, objective.best_u};
    };
    gp::parallel_for(static_cast<int>(n_polish), gp::resolve_threads(options_.gp.threads), polish);
    for (const Polished& p : polished) {
        if (p.u.size() == 0 || p.value <= best_value) continue;
        const Point point = make_point(p.u);
        if (is_taken(point.g) || near_failure(point.g)) continue;
        best_value = p.value;
        best_u = point.u;
    }
    if (!std::isfinite(best_value)) {
        // Every candidate was taken or excluded (tiny integer space): fall back to the design.
        return next_design_point();
    }
    return best_u;
}

std::vector<Proposal> Optimizer::ask(int q) {
    std::vector<Proposal> out;
    std::optional<Model> model;
    const bool any_success = has_success();
    for (int i = 0; i < q; ++i) {
        Proposal proposal;
        Point point;
        if (!start_points_.empty()) {
            point = make_point(space_.from_values(start_points_.front()));
            start_points_.pop_front();
            proposal.origin = "start";
            if (is_taken(point.g)) {
                --i;  // already known: the next source fills this slot
                continue;
            }
        } else if (observations_.size() + pending_.size() <
                       static_cast<std::size_t>(initial_points()) ||
                   !any_success) {
            point = make_point(next_design_point());
            proposal.origin = "initial";
        } else {
            if (!model) model = build_model();
            // Seeded by the number of points so far, so a restored optimizer draws the same
            // candidates.
            const auto key = static_cast<std::uint64_t>(observations_.size() + pending_.size());
            if (model->ensemble.empty() && !region_slot(key)) add_draws(*model);
            bool quadratic = false;
            point = make_point(maximize_acquisition(*model, mix(options_.seed, 2 * key + 11), quadratic));
            proposal.origin = quadratic ? "quadratic" : "model";
        }
        if (model) {
            // Every proposal of this batch becomes a fantasy for the following ones.
            Eigen::VectorXd mean, var;
            model->gp.predict(point.g, mean, var);
            model->gp.append(point.g, mean(0));
            for (gp::GaussianProcess& g : model->ensemble) g.append(point.g, mean(0));
            model->incumbent = std::max(model->incumbent, mean(0));
        }
        proposal.id = next_id_++;
        proposal.values = space_.to_values(point.u);
        pending_.emplace(proposal.id, point);
        out.push_back(std::move(proposal));
    }
    return out;
}

bool Optimizer::resolve(std::uint64_t id, const Observation& observation) {
    const auto it = pending_.find(id);
    if (it == pending_.end()) return false;
    observed_points_.push_back(it->second);
    observations_.push_back(observation);
    pending_.erase(it);
    return true;
}

bool Optimizer::tell(std::uint64_t id, double value) {
    const auto it = pending_.find(id);
    if (it == pending_.end()) return false;
    Observation o;
    o.values = space_.to_values(it->second.u);
    if (std::isfinite(value)) {
        o.value = value;
    } else {
        o.failed = true;
        o.reason = "non-finite value";
    }
    return resolve(id, o);
}

bool Optimizer::tell_failed(std::uint64_t id, const std::string& reason) {
    const auto it = pending_.find(id);
    if (it == pending_.end()) return false;
    Observation o;
    o.values = space_.to_values(it->second.u);
    o.failed = true;
    o.reason = reason;
    return resolve(id, o);
}

bool Optimizer::cancel(std::uint64_t id) { return pending_.erase(id) > 0; }

void Optimizer::add_observation(const Observation& observation) {
    Observation o = observation;
    o.values = space_.canonical(observation.values);
    if (!o.failed && !std::isfinite(o.value)) {
        o.failed = true;
        o.reason = "non-finite value";
    }
    observed_points_.push_back(make_point(space_.from_values(o.values)));
    observations_.push_back(std::move(o));
}

bool Optimizer::live_labels(Eigen::VectorXd& labels, double& prior) const {
    if (!options_.dead_value) return false;
    const std::size_t n = observations_.size();
    const std::size_t design = std::min(n, static_cast<std::size_t>(initial_points()));
    std::size_t dead = 0, design_live = 0;
    labels.resize(static_cast<Eigen::Index>(n));
    for (std::size_t k = 0; k < n; ++k) {
        const bool d_k = is_dead(observations_[k]);
        labels(static_cast<Eigen::Index>(k)) = d_k ? -1.0 : 1.0;
        dead += d_k ? 1 : 0;
        if (k < design && !d_k) ++design_live;
    }
    if (dead == 0 || dead == n) return false;
    // Far from every label P(live) falls to the share of live results in the design (the one
    // unbiased sample of the box: model proposals crowd the live region), by Laplace's rule so
    // that an all-dead design still leaves a chance.
    const double share = (static_cast<double>(design_live) + 1.0) / (static_cast<double>(design) + 2.0);
    prior = 2.0 * share - 1.0;
    labels.array() -= prior;
    return true;
}

std::vector<double> Optimizer::live_probability(const std::vector<std::vector<double>>& points) const {
    Eigen::VectorXd labels;
    double prior = 0.0;
    if (live_fit_n_ == 0 || live_hp_.length_scales.size() != space_.dim() || !live_labels(labels, prior))
        return {};
    gp::GaussianProcess live(space_.dim(), classifier_options(options_));
    live.set_hyperparameters(live_hp_);
    Eigen::MatrixXd x(space_.dim(), labels.size());
    for (Eigen::Index k = 0; k < labels.size(); ++k) x.col(k) = observed_points_[static_cast<std::size_t>(k)].g;
    if (!live.set_data(x, labels)) return {};
    Eigen::MatrixXd g(space_.dim(), static_cast<Eigen::Index>(points.size()));
    for (std::size_t i = 0; i < points.size(); ++i)
        g.col(static_cast<Eigen::Index>(i)) = space_.to_model_input(space_.from_values(space_.canonical(points[i])));
    Eigen::VectorXd mean, var;
    live.predict(g, mean, var);
    std::vector<double> out(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
        gp::PointPrediction p;
        p.mean = mean(static_cast<Eigen::Index>(i));
        p.variance = var(static_cast<Eigen::Index>(i));
        out[i] = std::exp(log_live(p, prior, nullptr));
    }
    return out;
}

bool Optimizer::is_dead(const Observation& o) const {
    return o.failed || (options_.dead_value && internal(o.value) <= internal(*options_.dead_value));
}

bool Optimizer::has_success() const {
    return std::any_of(observations_.begin(), observations_.end(),
                       [this](const Observation& o) { return !is_dead(o); });
}

void Optimizer::replay(const std::vector<Observation>& history, const std::vector<std::string>& origins) {
    observations_.clear();
    observed_points_.clear();
    pending_.clear();
    design_index_ = 0;
    hp_ = gp::Hyperparameters::defaults(space_.dim());
    last_fit_n_ = 0;
    warp_alpha_ = 0;
    warp_hp_.clear();
    cache_.reset();
    cache_n_ = 0;
    live_hp_ = gp::Hyperparameters();
    live_fit_n_ = 0;
    hp_samples_.clear();
    for (std::size_t k = 0; k < history.size(); ++k) {
        const std::string origin = k < origins.size() ? origins[k] : "model";
        if (origin == "initial") {
            next_design_point();  // advances past what this proposal skipped, as then
        } else if (origin != "start") {
            if (has_success()) build_model();  // fits when the refit rule said so then
        }
        add_observation(history[k]);
    }
}

std::optional<Observation> Optimizer::best() const {
    std::optional<Observation> out;
    for (const Observation& o : observations_) {
        if (o.failed) continue;
        if (!out || internal(o.value) > internal(out->value)) out = o;
    }
    return out;
}

}  // namespace maptune::bo
