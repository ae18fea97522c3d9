#pragma once
// An experiment: a design space, which of its parameters are optimized (the others fixed),
// the dataset, view and reference to train on, the measure's settings, the budget and the
// optimizer's settings. Loaded from YAML (configs/experiments/, docs/experiments.md).

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "bo/optimizer.hpp"
#include "params/parameter_set.hpp"
#include "params/parameter_space.hpp"

namespace maptune::experiment {

// Dataset to generate when the directory does not exist yet (simulator presets).
struct GenerateSpec {
    std::string preset;            // lab | moon | lab-tiny | moon-tiny
    int runs = 0;                  // 0 = preset's
    int submaps = 0;               // 0 = preset's
    std::uint64_t seed = 1;
    // Simulator settings on top of the preset (`dataset generate --sim KEY=VALUE`), in order;
    // checked where the dataset is made, naming `where` (file:line: key).
    struct SimSetting {
        std::string key, value, where;
    };
    std::vector<SimSetting> sim;
};

// Reserved validation label: the column of all targets together (evaluation::add_pooled_column).
inline constexpr const char* kPooledValidationLabel = "pooled";

// A held-out dataset view the tuned sets are validated on (`validate:`, issue 11): the
// thesis's protocol is to tune on subsequent pairs and judge on complete views with gt.
struct ValidationTarget {
    std::string label;                       // default: the dataset directory's name
    std::string dataset_dir;
    std::optional<GenerateSpec> generate;
    std::string view = "complete";           // complete | subsequent
    std::string reference = "gt";            // gt | odometry
    std::optional<double> m_star;            // absolute
    std::optional<double> m_star_per_pair;   // m* = this x pairs of the view; neither: auto
};

struct Experiment {
    std::string name;
    std::string file;                        // where it was loaded from
    params::ParameterSpace space;
    std::string space_file;
    std::vector<std::string> optimize;       // names, in space order
    params::ParameterSet fixed;              // full set: defaults with the `fixed` overrides
    std::string dataset_dir;                 // absolute or relative to the working dir
    std::optional<GenerateSpec> generate;
    std::string view = "subsequent";         // complete | subsequent
    std::string reference = "gt";            // gt | odometry
    double e_star = 0.4;                     // [m]
    std::optional<double> m_star;            // absolute; neither this nor m_star_per_pair: auto
    std::optional<double> m_star_per_pair;   // m* = this x pairs of the training view
    double w_v = 0.5;
    // Run-time budget (measure.max_pair_seconds): the mean seconds per pair a set may take from
    // the raw submaps; 0 = none. The optimizer maximizes objective() (p, penalized above the
    // budget); p itself stays the thesis's.
    double max_pair_seconds = 0;
    // Multi-fidelity (`fidelity: {subset: k, z: Z}`, docs/optimizer.md): a proposal is first
    // evaluated on the fixed stratified subset "<view>/<k>" and goes on to the whole view only
    // when its bound on the whole view's p (z standard errors up) can beat the best so far.
    // 0: every proposal on the whole view.
    int fidelity_subset = 0;
    double fidelity_z = 2.0;
    bool multi_fidelity() const { return fidelity_subset > 1; }
    int max_evaluations = 30;
    double max_seconds = 0;                  // 0 = no time budget
    std::string acquisition = "log_ei";      // ucb | ucb_schedule | ei | log_ei
    double ucb_kappa = 5.0;
    int initial_points = 0;                  // 0 = optimizer default
    std::uint64_t seed = 1;
    std::vector<std::uint64_t> seeds;        // repeats (`seeds: [1, 2, 3]`); empty: just `seed`
    int batch = 0;                           // proposals in flight; 0 = one per free worker slot
    std::string warping = "automatic";       // none | log | copula | automatic (docs/optimizer.md)
    std::string search = "alternate";        // global | trust_region | alternate
    bool quadratic_steps = true;             // quadratic steps while they pay (docs/optimizer.md)
    int hyper_samples = 4;                   // hyperparameter draws for the whole box's acquisition
    std::string cholesky = "eigen";          // eigen | cholmod (the GP's factorization)
    bool dead_regions = true;                // model where p = 0 (matcher experiments only)
    std::vector<params::ParameterSet> start_points;  // full sets, e.g. the baseline
    std::vector<std::string> start_point_files;
    // matcher.id: which matcher evaluates the sets — the reference pipeline (lru_matcher), the
    // analytic test objective (analytic), or a plug-in's id (its workers are started apart:
    // `maptune run --external-workers`).
    std::string matcher_id = "lru_matcher";
    // Non-optimized matcher settings (lru_matcher only).
    int matcher_threads = 0;                 // 0 = hardware concurrency
    // Per worker: memory for computed features (matcher.feature_cache_mb); not part of the
    // matcher version. A view whose features do not fit recomputes them for every evaluation
    // (the full moon preset's 1 600 submaps do not fit in 4 GiB; 10 GiB does).
    int feature_cache_mb = 4096;
    // Per worker: memory for the pairs' descriptor neighbour lists (matcher.neighbour_cache_mb),
    // what lets a pair-stage-only change skip the descriptor GEMM; 0 disables the cache. The
    // full moon's 31 200 pairs do not fit in 1 GiB; 4 GiB does (BENCHMARKS, "Full moon scale").
    int neighbour_cache_mb = 1024;
    // matcher.settings: non-optimized matcher settings KEY: VALUE (docs/matcher.md, as
    // `--matcher KEY=VALUE`); part of the matcher version. `where` names file, line and key.
    struct MatcherSetting {
        std::string key, value, where;
    };
    std::vector<MatcherSetting> matcher_settings;
    double pair_time_limit_s = 60;
    // The matcher's own default (MatcherSettings::total_time_limit_s): it is part of the matcher
    // version, and a different default kept `maptune run` from sharing observations with
    // standalone workers, `evaluate` and `compare`.
    double total_time_limit_s = 3600;
    std::vector<ValidationTarget> validate;
    // Embedded run: worker processes/threads started by `maptune run`.
    int workers = 1;
    // A black-box experiment (`objective:`, `maptune optimize`, issue 15): a command evaluates
    // each set instead of the matcher; there is no dataset, view or measure.
    struct Objective {
        std::string command;   // run by /bin/sh -c; the set as JSON on stdin, a number on stdout
        double timeout_s = 0;  // 0: none
        int parallel = 1;      // commands at once
    };
    std::optional<Objective> objective;
    bool minimize = false;     // objective.direction: minimize (the matcher's p is maximized)
};

// Whether objective value a is better than b in the experiment's direction.
inline bool better(const Experiment& e, double a, double b) { return e.minimize ? a < b : a > b; }

// What the optimizer maximizes for a set scoring p at a mean of `pair_s` seconds per pair:
// p within the run-time budget, p·(budget / pair_s)² above it (a set twice as slow as
// allowed keeps a quarter of its p). p when there is no budget or no time (pair_s 0).
double objective(const Experiment& e, double p, double pair_s);

// Loads and checks an experiment; paths inside are relative to the file's directory.
// Throws params::ConfigError naming the file, line, key path and what was expected.
Experiment load_experiment(const std::string& file);

// The optimizer's search box for the optimized parameters (the one conversion).
std::vector<bo::ParameterSpec> search_space(const Experiment& e);
// The full parameter set for optimizer values (in `optimize` order), fixed ones filled in.
params::ParameterSet full_set(const Experiment& e, const std::vector<double>& values);
// The optimizer values (in `optimize` order) of a full set.
std::vector<double> optimizer_values(const Experiment& e, const params::ParameterSet& set);
bo::OptimizerOptions optimizer_options(const Experiment& e);

}  // namespace maptune::experiment
