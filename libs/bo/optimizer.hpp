#pragma once
// Bayesian optimizer in ask/tell form (SPEC §6). It never calls the objective: a caller asks
// for q parameter sets, evaluates them wherever and whenever it likes, and tells the values
// (or the failures) back by id. Everything is deterministic given the seed and the order of
// calls; the state can be rebuilt from the list of observations after a restart.

#include <cmath>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "bo/acquisition.hpp"
#include "bo/quasi_random.hpp"
#include "bo/space.hpp"
#include "gp/gaussian_process.hpp"

namespace maptune::bo {

enum class Direction { minimize, maximize };

enum class OutputWarping {
    none,    // the GP models the objective values themselves
    copula,  // the GP models Φ⁻¹ of their ranks (Gaussian copula); robust to rare deep optima
    log,     // the GP models −log(best − v + c), c = 0.1 × range: values over orders of magnitude
    // At every refit (up to FitOptions::max_points observations) the warping with the highest
    // marginal likelihood of the values themselves (Jacobian included): none or −log(best −
    // v + c) with c = 0.1, 0.01 or 0.001 × the range of values; above max_points the last
    // choice stays.
    automatic,
};

// Where the acquisition is maximized.
enum class SearchRegion {
    global,        // the whole box
    trust_region,  // a box around the best observation (TuRBO-1, Eriksson et al. 2019)
    alternate,     // every other proposal in the trust region, the others in the whole box
};

struct OptimizerOptions {
    Direction direction = Direction::maximize;  // the matcher's score p: larger is better
    // Default chosen from the regret benchmarks (docs/optimizer.md, BENCHMARKS.md).
    Acquisition acquisition = Acquisition::log_ei;
    // Chosen by marginal likelihood at each refit (issue 15): on 9-D functions over orders of
    // magnitude the log warp wins by orders of magnitude, elsewhere it stays the identity
    // (BENCHMARKS.md, "Optimizer beyond the peers"). The copula lost to raw values on Branin
    // and Hartmann-6: ranks hide the small differences that local refinement needs.
    OutputWarping warping = OutputWarping::automatic;
    double ucb_kappa = 5.0;       // fixed UCB weight; the thesis used 5
    double schedule_delta = 0.1;  // Srinivas δ
    double schedule_scale = 0.2;  // Srinivas et al. scale β_t down by 5 in their experiments
    // Quasi-random design size; 0 = max(5, d + 1): measured better than 2d on every 9-D
    // benchmark function (BENCHMARKS.md, issue 15) — more of the budget goes to the model.
    int initial_points = 0;
    // Quasi-random acquisition candidates per proposal; above 300 observations scaled by
    // 300/n (at least 256) because each costs O(n²) for its variance.
    int candidates = 2000;
    double local_fraction = 0.25;  // share of candidates drawn around the best observations
    int polish_starts = 5;         // L-BFGS-B polishes from the best candidates
    int polish_iterations = 30;
    double failure_radius = 0.05;  // no proposals this close (unit cube, Euclidean) to a failure
    // Hyperparameters are refitted when the observations grew by this fraction since the last
    // fit (at least one new observation): every tell below 20, every 5th at 100, every 50th at
    // 1000. In between, new points enter the cached factorization by O(n²) appends.
    double refit_growth = 0.05;
    // The trust region (TuRBO-1): a box around the best observation, side L in the unit cube
    // per dimension scaled by the GP's length scales; L doubles after 3 improvements in a row,
    // halves after max(4, d) proposals without one, and starts again at 0.8 below 2⁻⁷.
    // Derived from the observations in order, so a resumed run has the same region. Alternating
    // with whole-box proposals measured best on the 9-D benchmark functions (BENCHMARKS.md):
    // the region alone parks multi-modal Levy in a side basin, the whole box alone lets the
    // model park "unimportant" dimensions on the boundary (ellipsoid, Styblinski-Tang).
    SearchRegion search = SearchRegion::alternate;
    // Every fourth proposal (half of the region's, with `alternate`) is the maximizer inside the
    // trust region of a quadratic fitted by least squares to all live values, with cross
    // curvatures where leave-one-out error supports them (quadratic_model.hpp), instead of the
    // acquisition's, while such steps improve the best at least as often as the region's others
    // (Laplace's rule): much better median regret@100 on multi-modal bowls (Levy 2.9 → 0.25,
    // Griewank 0.85 → 0.24, Rastrigin 77 → 55) and, with the cross curvatures, on oblique valleys
    // (rotated ellipsoid 1 980 → 37, Trid 2.45 → 0.05); worse on Schwefel (BENCHMARKS.md,
    // "Quadratic steps", "Cross curvatures").
    // No effect with SearchRegion::global.
    bool quadratic_steps = true;
    // Dead regions (issue 15): observations at or worse than this value (the matcher's p = 0:
    // no match at all) and failures are "dead". Once both kinds exist, a second GP on the
    // labels (+1 live, −1 dead; least-squares classification) gives P(live) = Φ(μ / √(0.25 +
    // σ²)), and EI / log-EI are weighted by it (as constrained BO weighs by the probability of
    // feasibility), so whole dead regions stop attracting proposals. Empty: off.
    std::optional<double> dead_value;
    // Longest length scale (unit cube) the classifier may fit. Fitted freely, it called every
    // dimension its few labels never showed varying irrelevant and rated proposals far along
    // it as surely live as the live cluster itself (BENCHMARKS.md, "Dead regions").
    double live_max_length_scale = 1.0;
    gp::GpOptions gp;
    std::uint64_t seed = 0;
    // The whole box's acquisition is averaged over this many draws of the GP's hyperparameters
    // (Laplace's approximation of their posterior at each refit; EI averaged, as Snoek et al.'s
    // integrated acquisition) instead of taken under the fitted ones alone, which with few
    // points can call a dimension irrelevant and stop exploring it. Up to fit.max_points
    // observations (the posterior is sharp beyond, and each draw costs a factorization per ask).
    // 0 = the fitted hyperparameters alone. Why 4: BENCHMARKS.md, "Hyperparameter draws".
    int hyper_samples = 4;
};

// The model's belief about the best observed location (what a user deploying today should
// pick when observations are noisy): the successful observation with the highest posterior
// mean under the current hyperparameters.
struct PredictedBest {
    std::vector<double> values;
    double mean = 0.0;  // posterior mean of the objective there (caller's units)
    double std = 0.0;   // posterior standard deviation of the latent objective
};

// The model at one parameter set, in the caller's units (report figures: slices, grids).
struct PosteriorPoint {
    double mean = 0.0;
    double std = 0.0;          // of the latent objective
    double acquisition = 0.0;  // the optimizer's acquisition there (log EI: its log)
};

struct Proposal {
    std::uint64_t id = 0;
    std::vector<double> values;  // one per parameter, integers exact
    std::string origin;          // "start", "initial", "model", "quadratic" (a quadratic step)
};

struct Observation {
    std::vector<double> values;
    double value = 0.0;  // objective value (ignored when failed)
    bool failed = false;
    std::string reason;  // why it failed (crash, timeout, ...)
    // An estimate, not a measurement of the objective (multi-fidelity: a proposal stopped on a
    // subset of the pairs): the GP gives such values a noise of their own, learnt with its
    // other hyperparameters, and never predicts one as the best.
    bool low_fidelity = false;
};

class Optimizer {
  public:
    Optimizer(std::vector<ParameterSpec> specs, OptimizerOptions options = {});
    // Rebuilds the state from earlier observations (resume after a restart).
    Optimizer(std::vector<ParameterSpec> specs, OptimizerOptions options,
              const std::vector<Observation>& history);

    // Queues a parameter set (e.g. the hand-tuned baseline) to be proposed before the design.
    void add_start_point(const std::vector<double>& values);
    // q proposals, none equal to an observed, pending or other proposed point.
    std::vector<Proposal> ask(int q = 1);
    // False if id is not pending (unknown or already told).
    bool tell(std::uint64_t id, double value);
    bool tell_failed(std::uint64_t id, const std::string& reason);
    // Withdraws a pending proposal without a result (its worker vanished before evaluating;
    // a timeout is a failure and goes to tell_failed instead).
    bool cancel(std::uint64_t id);
    // An observation made elsewhere (the sample database already had it).
    void add_observation(const Observation& observation);
    // Rebuilds, from a run's observations in order and where each proposal came from
    // ("start", "initial", "model", "quadratic"; anything else counts as "model"), the state that run had
    // when it proposed one set at a time: the design sequence's position and the warm-started
    // hyperparameter fits at the same sizes. A restarted sequential run then proposes exactly
    // what the uninterrupted one would have (with several proposals in flight it is close).
    // Replaces the observations; start points added before are kept.
    void replay(const std::vector<Observation>& history, const std::vector<std::string>& origins);

    const SearchSpace& space() const { return space_; }
    const OptimizerOptions& options() const { return options_; }
    const std::vector<Observation>& observations() const { return observations_; }
    std::size_t pending() const { return pending_.size(); }
    std::optional<Observation> best() const;
    // Empty until two successful observations exist. Uses the hyperparameters of the last fit.
    std::optional<PredictedBest> predicted_best() const;
    const gp::Hyperparameters& hyperparameters() const { return hp_; }
    // Fits the hyperparameters to the observations now, as the next ask() would (e.g. after
    // rebuilding from a run's history, to draw the model it ended with).
    void fit();
    // The posterior and acquisition at `points` (values, one per parameter) under the last
    // fit, with every observation in the model as when proposing (failures at the worst
    // value; no pending points). Empty until two successful observations exist.
    std::vector<PosteriorPoint> posterior(const std::vector<std::vector<double>>& points) const;
    // The dead-region classifier's P(live) at `points` under its last fit (what weighs the
    // acquisition). Empty while it is not in use (no dead_value, or not both kinds observed).
    std::vector<double> live_probability(const std::vector<std::vector<double>>& points) const;
    int initial_points() const;
    // The output warping in use since the last refit: "none", "log(c = 0.1 range)", "copula".
    std::string warping_in_use() const;
    // How the model builds went: hyperparameter refits, full factorizations, and builds that
    // appended new observations to the cached factor instead (O(n²)).
    struct ModelStats {
        std::size_t refits = 0, factorizations = 0, appends = 0;
    };
    const ModelStats& model_stats() const { return stats_; }
    // The trust region's side length (unit cube) the next region proposal uses.
    double trust_region_side() const { return trust_region_length(); }

  private:
    struct Point {
        Eigen::VectorXd u;  // unit cube, integers snapped
        Eigen::VectorXd g;  // GP input
    };
    struct Model {
        gp::GaussianProcess gp;
        double incumbent;  // best internal value incl. fantasies
        std::optional<gp::GaussianProcess> live;  // the dead-region classifier, when in use
        std::vector<gp::GaussianProcess> ensemble;  // the model under hyperparameter draws
        double live_prior = 0.0;  // its prior mean (label units), added to its predictions
    };
    bool is_dead(const Observation& o) const;
    // The classifier's training labels (+1 live, −1 dead, minus the prior) and its prior mean;
    // false while it is not in use.
    bool live_labels(Eigen::VectorXd& labels, double& prior) const;

    // A monotone map of internal values (larger is better) that the GP models: identity, or
    // z = −log(best − v + c) with c = alpha × (best − worst).
    struct Warp {
        double alpha = 0;  // 0: identity
        double best = 0, c = 1;
        double apply(double v) const { return alpha > 0 ? -std::log(best - v + c) : v; }
        double invert(double z) const { return alpha > 0 ? best + c - std::exp(-z) : z; }
        double log_slope(double v) const { return alpha > 0 ? -std::log(best - v + c) : 0.0; }
    };
    // The warping's numbers for the current values (best, range), of the chosen kind.
    Warp warp_for(double alpha, const Eigen::VectorXd& y) const;

    Point make_point(const Eigen::VectorXd& u) const;
    double internal(double value) const {
        return options_.direction == Direction::maximize ? value : -value;
    }
    bool is_taken(const Eigen::VectorXd& g) const;
    bool near_failure(const Eigen::VectorXd& g) const;
    Eigen::VectorXd next_design_point();
    // Some observation is live (neither failed nor at the dead value): until then every
    // value is the same to a model, and the quasi-random design goes on.
    bool has_success() const;
    Model build_model();
    // The model under each hyperparameter draw (hyper_samples), fantasies included; built only
    // for a whole-box proposal, the one place that uses it.
    void add_draws(Model& model) const;
    // Model inputs and internal values of every observation (failures at the worst value)
    // and the best internal value.
    // `raw` (when given) receives the values before any warping.
    // `low_fidelity` (when given) receives 1 for low-fidelity observations, or stays empty if none.
    void model_data(Eigen::MatrixXd& x, Eigen::VectorXd& y, double& best, Eigen::VectorXd* raw = nullptr,
                    Eigen::VectorXd* low_fidelity = nullptr) const;
    Warp current_warp() const;
    // The offset factor of the log warping in use (0: identity): fixed, or the last choice.
    double warp_alpha() const;
    // The trust region's side length now (from the observations in order).
    double trust_region_length() const;
    AcquisitionContext acquisition_context(double incumbent) const;
    // The main GP's options: the prior mean from the first design_outputs outputs (the design).
    gp::GpOptions main_gp_options(std::size_t design_outputs) const;
    // quadratic: set when the proposal is a quadratic step's (OptimizerOptions::quadratic_steps).
    Eigen::VectorXd maximize_acquisition(const Model& model, std::uint64_t seed, bool& quadratic);
    // Whether proposal number i (observations and pending before it) searches the trust region
    // rather than the whole box, and whether it is a quadratic step's slot (every fourth: half
    // of the region's with `alternate`).
    bool region_slot(std::size_t i) const;
    static bool quadratic_slot(std::size_t i) { return i % 4 == 3; }
    // Whether the next quadratic slot goes to the quadratic: its slots have improved the best at
    // least as often as the region's other proposals (OptimizerOptions::quadratic_steps).
    bool quadratic_steps_pay() const;
    // Per observation in order: whether it improved the best before it by more than 1e-3 of
    // its magnitude (the trust region's and the quadratic steps' notion of success).
    std::vector<bool> improvements() const;
    // The quadratic model's maximizer in [lo, hi], if it fits, is not taken and is more
    // likely live than dead.
    std::optional<Eigen::VectorXd> quadratic_step(const Model& model, const Eigen::VectorXd& centre,
                                                  const Eigen::VectorXd& lo, const Eigen::VectorXd& hi) const;
    bool resolve(std::uint64_t id, const Observation& observation);

    SearchSpace space_;
    OptimizerOptions options_;
    ScrambledHalton design_;
    std::uint64_t design_index_ = 0;
    std::deque<std::vector<double>> start_points_;
    std::vector<Observation> observations_;
    std::vector<Point> observed_points_;  // parallel to observations_
    std::map<std::uint64_t, Point> pending_;
    std::uint64_t next_id_ = 1;
    gp::Hyperparameters hp_;
    std::vector<gp::Hyperparameters> hp_samples_;  // OptimizerOptions::hyper_samples draws
    std::size_t last_fit_n_ = 0;
    double warp_alpha_ = 0;  // the warping chosen at the last refit (0: identity)
    // The model of the last build (its first cache_n_ observations, no fantasies): the next
    // build appends to its factor unless the hyperparameters were refitted.
    std::optional<gp::GaussianProcess> cache_;
    std::size_t cache_n_ = 0;
    ModelStats stats_;
    gp::Hyperparameters live_hp_;  // the classifier's, refitted with the main model
    std::size_t live_fit_n_ = 0;
    std::map<double, gp::Hyperparameters> warp_hp_;  // per candidate warping: warm starts
};

}  // namespace maptune::bo
