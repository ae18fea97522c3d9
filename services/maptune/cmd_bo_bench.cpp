// maptune bo-bench: regret and timing benchmarks of the Bayesian optimizer (issue 5).
// Built into the maptune CLI when libs/bo is present, and into bench/bo's standalone
// bo_bench executable.
#ifdef MAPTUNE_HAVE_BO

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <iterator>
#include <memory>
#include <sstream>

#include "bo/benchmark.hpp"
#include "commands.hpp"
#include "table.hpp"
#include "params/cli_range.hpp"

namespace maptune::cli {
namespace {

struct BoBenchOptions {
    std::vector<std::string> functions{"branin", "hartmann6"};
    std::vector<std::string> acquisitions{"log_ei"};
    std::vector<int> q{1};
    int seeds = 10;
    int budget = 100;
    int first_seed = 0;
    double kappa = 5.0;
    int candidates = 2000;
    double refit_growth = 0.05;
    int fit_random_starts = 2;
    std::string warping = "automatic";
    std::string search = "alternate";
    bool quadratic_steps = true;
    int hyper_samples = 4;
    int initial_points = 0;
    int threads = 0;
    bool timing = false;
    int timing_seeds = 1;
    bool no_regret = false;
    std::string json;
    std::string csv;
    std::string curves_csv;
    std::string eval;         // evaluate this function at the JSON set on stdin (an objective command)
    std::string write_space;  // write this function's design space YAML
};

std::string fmt(double v, const char* spec = "%.3g") {
    if (std::isnan(v)) return "-";  // checkpoint beyond the budget
    char buf[64];
    std::snprintf(buf, sizeof(buf), spec, v);
    return buf;
}

// `maptune bo-bench --eval F`: the test function as an objective command for `maptune optimize`
// and for other optimizers driven through the same command (bench/optimize/compare.py).
int eval_function(const std::string& name) {
    const auto fn = bo::test_function(name);
    std::string text((std::istreambuf_iterator<char>(std::cin)), std::istreambuf_iterator<char>());
    const auto j = nlohmann::json::parse(text, nullptr, false);
    if (j.is_discarded() || !j.is_object()) {
        std::cerr << "bo-bench --eval " << name << ": standard input is not a JSON object\n";
        return 2;
    }
    std::vector<double> x;
    for (const auto& s : fn->space) {
        const auto it = j.find(s.name);
        if (it == j.end() || !it->is_number()) {
            std::cerr << "bo-bench --eval " << name << ": no number '" << s.name << "' in the input\n";
            return 2;
        }
        x.push_back(it->get<double>());
    }
    std::printf("%.17g\n", fn->f(x));
    return 0;
}

// The function's box as a design space YAML on stdout (6 decimals: the functions are continuous).
int write_function_space(const std::string& name) {
    const auto fn = bo::test_function(name);
    std::ostream& out = std::cout;
    out << "# " << name << " (maptune bo-bench --write-space); minimum " << fmt(fn->minimum, "%.17g") << "\n"
        << "name: " << name << "\nparameters:\n";
    for (const auto& s : fn->space) {
        out << "  " << s.name << ": {type: " << (s.is_integer ? "int" : "float") << ", low: " << fmt(s.low, "%.17g")
            << ", high: " << fmt(s.high, "%.17g") << ", default: " << fmt(s.is_integer ? std::round((s.low + s.high) / 2) : (s.low + s.high) / 2, "%.17g")
            << (s.is_integer ? "" : ", decimals: 6") << "}\n";
    }
    return out ? 0 : 1;
}


int run_bo_bench(const BoBenchOptions& o) {
    if (!o.eval.empty()) return eval_function(o.eval);
    if (!o.write_space.empty()) return write_function_space(o.write_space);
    nlohmann::json report;
    report["regret"] = nlohmann::json::array();
    report["timing"] = nlohmann::json::array();
    Table regret_table{{"function", "acquisition", "q", "seeds", "regret@25", "regret@50",
                        "regret@100", "final_p90", "final_max", "ask_ms_median", "ask_ms_max"},
                       {},
                       {false, false, true, true, true, true, true, true, true, true, true}};
    Table curves{{"function", "acquisition", "q", "evaluation", "median_regret"},
                 {},
                 {false, false, true, true, true}};
    const std::vector<int> checkpoints{25, 50, 100};
    if (!o.no_regret) {
        for (const std::string& name : o.functions) {
            const auto fn = bo::test_function(name);
            for (const std::string& acq_name : o.acquisitions) {
                const auto acq = bo::acquisition_from_string(acq_name);
                for (int q : o.q) {
                    bo::OptimizerOptions options;
                    options.acquisition = *acq;
                    options.ucb_kappa = o.kappa;
                    options.candidates = o.candidates;
                    options.refit_growth = o.refit_growth;
                    options.warping = o.warping == "copula"      ? bo::OutputWarping::copula
                                      : o.warping == "log"       ? bo::OutputWarping::log
                                      : o.warping == "automatic" ? bo::OutputWarping::automatic
                                                                 : bo::OutputWarping::none;
                    options.gp.fit.random_starts = o.fit_random_starts;
                    options.initial_points = o.initial_points;
                    options.search = o.search == "global"         ? bo::SearchRegion::global
                                     : o.search == "trust_region" ? bo::SearchRegion::trust_region
                                                                  : bo::SearchRegion::alternate;
                    options.quadratic_steps = o.quadratic_steps;
                    options.hyper_samples = o.hyper_samples;
                    options.gp.threads = o.threads;
                    std::vector<bo::RegretRun> runs;
                    for (int s = 0; s < o.seeds; ++s) {
                        runs.push_back(
                            bo::run_regret(*fn, o.budget, q, options,
                                           static_cast<std::uint64_t>(o.first_seed + s)));
                        std::cerr << "\r" << name << " " << acq_name << " q=" << q << " seed "
                                  << s + 1 << "/" << o.seeds << std::flush;
                    }
                    std::cerr << "\n";
                    const bo::RegretSummary sm =
                        bo::summarize(name, acq_name, q, runs, checkpoints);
                    std::vector<std::string> row{name, acq_name, std::to_string(q),
                                                 std::to_string(o.seeds)};
                    for (double r : sm.median_regret) row.push_back(fmt(r, "%.3g"));
                    row.push_back(fmt(sm.final_p90, "%.3g"));
                    row.push_back(fmt(sm.final_max, "%.3g"));
                    row.push_back(fmt(sm.median_ask_ms, "%.1f"));
                    row.push_back(fmt(sm.max_ask_ms, "%.1f"));
                    regret_table.rows.push_back(row);
                    for (std::size_t e = 0; e < sm.median_curve.size(); ++e) {
                        curves.rows.push_back({name, acq_name, std::to_string(q),
                                               std::to_string(e + 1),
                                               fmt(sm.median_curve[e], "%.6g")});
                    }
                    report["regret"].push_back({{"function", name},
                                                {"acquisition", acq_name},
                                                {"q", q},
                                                {"seeds", o.seeds},
                                                {"budget", o.budget},
                                                {"checkpoints", checkpoints},
                                                {"median_regret", sm.median_regret},
                                                {"median_curve", sm.median_curve},
                                                {"final_regret_p90", sm.final_p90},
                                                {"final_regret_max", sm.final_max},
                                                {"final_regrets", sm.finals},
                                                {"ask_ms_median", sm.median_ask_ms},
                                                {"ask_ms_max", sm.max_ask_ms}});
                }
            }
        }
        write_table(std::cout, regret_table, TableFormat::kTable);
    }
    if (o.timing) {
        // cpu_seconds: CPU time of all threads of the process (std::clock), where measured; on
        // a shared machine it shows the work done, wall seconds what a caller waits.
        Table timing{{"measurement", "n", "d", "seconds", "cpu_seconds", "target_seconds"},
                     {},
                     {false, true, true, true, true, true}};
        auto add = [&](const std::string& what, int n, int d, double seconds, double target,
                       double cpu = -1.0) {
            timing.rows.push_back({what, std::to_string(n), std::to_string(d), fmt(seconds, "%.4f"),
                                   cpu >= 0 ? fmt(cpu, "%.4f") : "-",
                                   target > 0 ? fmt(target, "%.2f") : "-"});
            report["timing"].push_back({{"measurement", what},
                                        {"n", n},
                                        {"d", d},
                                        {"seconds", seconds},
                                        {"cpu_seconds", cpu},
                                        {"target_seconds", target}});
        };
        bo::OptimizerOptions options;
        options.candidates = o.candidates;
        options.gp.threads = o.threads;
        options.hyper_samples = o.hyper_samples;
        for (int n : {100, 1000}) {
            std::cerr << "ask timing n=" << n << "\n";
            // Seed 0's rows as always; with --timing-seeds, the spread over other histories and
            // optimizer seeds (one machine hiccup moves a single max).
            std::vector<double> refit_asks, cold_asks;
            for (int seed = 1; seed < o.timing_seeds; ++seed) {
                bo::OptimizerOptions seeded = options;
                seeded.seed = static_cast<std::uint64_t>(seed);
                const bo::AskTiming ts = bo::time_ask(n, 9, 10, seeded);
                refit_asks.push_back(ts.running_max_seconds);
                cold_asks.push_back(ts.first_ask_seconds);
            }
            const bo::AskTiming t = bo::time_ask(n, 9, 10, options);
            refit_asks.push_back(t.running_max_seconds);
            cold_asks.push_back(t.first_ask_seconds);
            const double target = n <= 100 ? 0.05 : 1.0;
            add("ask, restored state (cold hyperparameter fit)", n, 9, t.first_ask_seconds, target,
                t.first_ask_cpu_seconds);
            add("ask, no refit (median of 10)", n, 9, t.median_ask_seconds, target);
            add("ask, running: median of 10 ask/tell rounds", n, 9, t.running_median_seconds,
                target);
            add("ask, running: max of 10 (includes warm refits)", n, 9, t.running_max_seconds,
                target, t.running_max_cpu_seconds);
            if (o.timing_seeds > 1) {
                const std::string over = " over " + std::to_string(o.timing_seeds) + " seeds";
                add("ask, running: max of 10, median" + over, n, 9, bo::median(refit_asks), target);
                add("ask, running: max of 10, worst" + over, n, 9,
                    *std::max_element(refit_asks.begin(), refit_asks.end()), target);
                add("ask, restored state, median" + over, n, 9, bo::median(cold_asks), target);
            }
        }
        std::vector<gp::CholeskyBackend> backends{gp::CholeskyBackend::eigen};
        if (gp::cholmod_available()) backends.push_back(gp::CholeskyBackend::cholmod);
        for (auto backend : backends) {
            for (int n : {100, 300, 1000}) {
                std::cerr << "gp timing " << gp::to_string(backend) << " n=" << n << "\n";
                const bool full = n == 1000 && backend == gp::CholeskyBackend::eigen;
                const bo::GpTiming t = bo::time_gp(n, 9, 10000, backend, full, o.threads);
                const std::string b = " [" + t.backend + "]";
                add("gp factorize" + b, n, 9, t.factorize_seconds, 0);
                add("gp append one point" + b, n, 9, t.append_seconds, 0);
                add("gp fit (default: subset of 200 + full-data refinement)" + b, n, 9, t.fit_seconds,
                    n == 1000 ? 0.8 : 0, t.fit_cpu_seconds);
                if (full) {
                    add("gp fit (subset of 200 only)" + b, n, 9, t.fit_subset_seconds, 0);
                    add("gp fit (multi-start on all n points)" + b, n, 9, t.fit_full_seconds, 0);
                    // Accuracy: the full data's negative log posterior at each fit's optimum.
                    std::cout << "full-data neg. log posterior at n = " << n << " [" << t.backend
                              << "]: default " << fmt(t.fit_nlp, "%.2f") << ", subset only "
                              << fmt(t.fit_subset_nlp, "%.2f") << ", multi-start on all "
                              << fmt(t.fit_full_nlp, "%.2f") << "\n";
                }
                add("gp mean+variance at 10000 points" + b, n, 9, t.predict_seconds,
                    n == 1000 ? 0.1 : 0, t.predict_cpu_seconds);
            }
        }
        std::cout << "\nGP batched kernels built for: " << gp::kernel_instruction_set() << "\n";
        write_table(std::cout, timing, TableFormat::kTable);
        report["gp_kernel_instruction_set"] = gp::kernel_instruction_set();
    }
    if (!o.json.empty()) {
        std::ofstream f(o.json);
        if (!f) {
            std::cerr << "bo-bench: cannot write " << o.json << "\n";
            return 1;
        }
        f << report.dump(2) << "\n";
    }
    auto write_csv = [](const std::string& path, const Table& t) {
        if (path.empty()) return true;
        std::ofstream f(path);
        if (!f) {
            std::cerr << "bo-bench: cannot write " << path << "\n";
            return false;
        }
        write_table(f, t, TableFormat::kCsv);
        return true;
    };
    if (!write_csv(o.csv, regret_table) || !write_csv(o.curves_csv, curves)) return 1;
    return 0;
}

}  // namespace

void add_bo_bench_command(CLI::App& app, int& exit_code) {
    auto opt = std::make_shared<BoBenchOptions>();
    CLI::App* cmd = app.add_subcommand(
        "bo-bench",
        "Optimizer benchmarks: median simple regret at 25/50/100 evaluations over seeds on test "
        "functions, time per ask, GP fit/prediction times");
    std::vector<std::string> fn_names = bo::test_function_names();
    cmd->add_option("--functions", opt->functions,
                    "test functions, any of branin | hartmann6 | branin_integer | log_rosenbrock9 "
                    "(default: branin hartmann6)")
        ->check(CLI::IsMember(fn_names));
    cmd->add_option("--acquisitions", opt->acquisitions,
                    "acquisitions, any of ucb | ucb_schedule | ei | log_ei (default: log_ei)")
        ->check(CLI::IsMember({"ucb", "ucb_schedule", "ei", "log_ei"}));
    cmd->add_option("--q", opt->q, "proposals per round, each in 1..64 (default: 1)")
        ->check(CLI::Range(1, 64));
    cmd->add_option("--seeds", opt->seeds, "seeds per configuration, 1..1000 (default: 10)")
        ->check(CLI::Range(1, 1000));
    cmd->add_option("--first-seed", opt->first_seed, "first seed, 0..1000000 (default: 0)")
        ->check(CLI::Range(0, 1000000));
    cmd->add_option("--budget", opt->budget, "evaluations per run, 1..2000 (default: 100)")
        ->check(CLI::Range(1, 2000));
    cmd->add_option("--kappa", opt->kappa,
                    "UCB weight for --acquisitions ucb, 0..100 (default: 5, the thesis)")
        ->check(maptune::params::finite_range(0.0, 100.0));
    cmd->add_option("--candidates", opt->candidates,
                    "quasi-random acquisition candidates per proposal, 10..100000 (default: 2000)")
        ->check(CLI::Range(10, 100000));
    cmd->add_option(
           "--refit-growth", opt->refit_growth,
           "refit GP hyperparameters when the observations grew by this fraction, 0..1; 0 = "
           "every tell (default: 0.05)")
        ->check(maptune::params::finite_range(0.0, 1.0));
    cmd->add_option("--fit-random-starts", opt->fit_random_starts,
                    "random L-BFGS-B starts of each hyperparameter fit, 0..20 (default: 2)")
        ->check(CLI::Range(0, 20));
    cmd->add_option("--warping", opt->warping,
                    "output warping before the GP: none | copula | log | automatic (default: automatic)")
        ->check(CLI::IsMember({"none", "copula", "log", "automatic"}));
    cmd->add_option("--initial-points", opt->initial_points,
                    "quasi-random design size, 0..1000; 0 = max(5, d + 1) (default: 0)")
        ->check(CLI::Range(0, 1000));
    cmd->add_option("--search", opt->search,
                    "where proposals are searched: global | trust_region | alternate (default: alternate)")
        ->check(CLI::IsMember({"global", "trust_region", "alternate"}));
    cmd->add_option("--quadratic-steps", opt->quadratic_steps,
                    "every 4th proposal, while such steps improve the best as often as the trust region's others, the "
                    "maximizer there of a quadratic fitted to all live values: true | false (default: true)");
    cmd->add_option("--hyper-samples", opt->hyper_samples,
                    "hyperparameter draws (Laplace's approximation) over which the whole box's acquisition is averaged, 0..64; 0 = the fitted ones alone (default: 4)")
        ->check(CLI::Range(0, 64));
    cmd->add_option("--threads", opt->threads,
                    "threads inside the GP's batched prediction and fit and the acquisition "
                    "polish, 0..64; 0 = the hardware's, at most 4 (default: 0)")
        ->check(CLI::Range(0, 64));
    cmd->add_flag("--timing", opt->timing,
                  "also time ask at n = 100 and 1000 (9-D) and the GP (fit, append, mean+variance "
                  "at 10000 points) for both Cholesky backends (default: off)");
    cmd->add_option("--timing-seeds", opt->timing_seeds,
                    "with --timing: also time the asks for this many optimizer seeds (other "
                    "histories) and report their median and worst, 1..100 (default: 1)")
        ->check(CLI::Range(1, 100));
    cmd->add_flag("--no-regret", opt->no_regret, "skip the regret runs (default: off)");
    cmd->add_option(
        "--json", opt->json,
        "write all results, with median regret curves, as JSON to this file (default: none)");
    cmd->add_option("--csv", opt->csv,
                    "write the regret summary as CSV to this file (default: none)");
    cmd->add_option(
        "--curves-csv", opt->curves_csv,
        "write the median regret after every evaluation as CSV to this file (default: none)");
    cmd->add_option("--eval", opt->eval,
                    "evaluate FUNCTION at the JSON object {x1: .., x2: ..} on standard input and print its value "
                    "(an objective command for `maptune optimize` and other optimizers)")
        ->check(CLI::IsMember(fn_names));
    cmd->add_option("--write-space", opt->write_space, "print FUNCTION's box as a design space YAML")
        ->check(CLI::IsMember(fn_names));
    cmd->callback([opt, &exit_code] { exit_code = run_bo_bench(*opt); });
}

}  // namespace maptune::cli

#endif  // MAPTUNE_HAVE_BO
