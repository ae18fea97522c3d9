#pragma once
// Regret and timing benchmarks of the optimizer (the only place in bo that reads a clock).
// Wall times are what a caller waits; CPU times (std::clock: all threads of the process) are
// the work done, which is what stays comparable on a machine shared with other jobs.

#include <cstdint>
#include <string>
#include <vector>

#include "bo/optimizer.hpp"
#include "bo/test_functions.hpp"

namespace maptune::bo {

struct RegretRun {
    std::vector<double> regret;         // simple regret after each evaluation (size = budget)
    std::vector<double> ask_seconds;    // wall time of each ask(q) call
    std::vector<int> ask_observations;  // observations told before each ask
};

// Minimizes fn with `budget` evaluations in rounds of ask(q) / tell, seed-specific options.
RegretRun run_regret(const TestFunction& fn, int budget, int q, OptimizerOptions options,
                     std::uint64_t seed);

struct RegretSummary {
    std::string function;
    std::string acquisition;
    int q = 1;
    int seeds = 0;
    std::vector<int> checkpoints;
    std::vector<double> median_regret;  // at each checkpoint, median over seeds
    std::vector<double> median_curve;   // median regret after each evaluation
    double final_p90 = 0.0;             // 90th percentile over seeds of the final regret
    double final_max = 0.0;             // worst seed's final regret
    std::vector<double> finals;         // final regret of each seed, in seed order
    double median_ask_ms = 0.0;         // over all asks of all seeds
    double max_ask_ms = 0.0;
    double total_seconds = 0.0;
};

RegretSummary summarize(const std::string& function, const std::string& acquisition, int q,
                        const std::vector<RegretRun>& runs, const std::vector<int>& checkpoints);

// Wall time of ask(1) on an optimizer restored from n random observations of
// log-Rosenbrock in `dim` dimensions: the first ask refits the hyperparameters, the later
// ones reuse them (as between refits in a long run).
struct AskTiming {
    int n = 0;
    int dim = 0;
    double first_ask_seconds = 0.0;  // includes the hyperparameter fit
    double first_ask_cpu_seconds = 0.0;
    double median_ask_seconds = 0.0;  // without refit (median of `repeats`)
    // A running optimizer from there: `repeats` consecutive ask/tell rounds with real values,
    // so the periodic warm refits are included.
    double running_median_seconds = 0.0;
    double running_max_seconds = 0.0;
    double running_max_cpu_seconds = 0.0;  // CPU time of the round with the longest wall time
};
AskTiming time_ask(int n, int dim, int repeats, OptimizerOptions options);

// GP-level timings at n observations in dim dimensions.
struct GpTiming {
    int n = 0;
    int dim = 0;
    std::string backend;
    double factorize_seconds = 0.0;  // kernel matrix + Cholesky
    double append_seconds = 0.0;     // one O(n²) append (median)
    double fit_seconds = 0.0;        // hyperparameter fit (default options)
    double fit_cpu_seconds = 0.0;
    double fit_full_seconds = 0.0;  // fit on all n points (no subset), 0 if skipped
    int fit_evaluations = 0;
    // Accuracy of the fits: the full data's negative log posterior at each fit's optimum
    // (standardized outputs; lower is better), when full_fit.
    double fit_nlp = 0.0;               // default: subset multi-start + full-data refinement
    double fit_subset_seconds = 0.0;    // subset only (full_data_refine = false)
    double fit_subset_nlp = 0.0;
    double fit_full_nlp = 0.0;          // multi-start on all n points
    double predict_seconds = 0.0;  // mean + variance at predict_points
    double predict_cpu_seconds = 0.0;
    int predict_points = 0;
};
// threads: gp::GpOptions::threads of the model timed.
GpTiming time_gp(int n, int dim, int predict_points, gp::CholeskyBackend backend, bool full_fit,
                 int threads = 0);

double median(std::vector<double> v);

}  // namespace maptune::bo
