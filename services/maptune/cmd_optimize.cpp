// maptune optimize: the tuner for any component (issue 15) — a command evaluates each set.
#ifdef MAPTUNE_HAVE_TUNING
#include <signal.h>

#include <atomic>
#include <iostream>
#include <memory>

#include "commands.hpp"
#include "experiment/experiment.hpp"
#include "params/yaml_util.hpp"
#include "tuning/black_box.hpp"
#include "tuning/run_directory.hpp"
#include "params/cli_range.hpp"

namespace maptune::cli {
namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_optimize_signal(int) { g_stop.store(true); }

struct OptimizeOptions {
    std::string experiment;
    tuning::BlackBoxSpec spec;
    std::string run_dir;
};

int run_optimize(OptimizeOptions o) {
    std::string file = o.experiment;
    std::filesystem::path run_dir = o.run_dir;
    if (file.empty()) {
        if (o.spec.space_file.empty() || o.spec.command.empty()) {
            std::cerr << "maptune optimize: give --experiment FILE, or --space and --objective-cmd\n";
            return 2;
        }
        if (run_dir.empty()) run_dir = "runs/" + o.spec.name + "-" + tuning::utc_now("%Y%m%dT%H%M%SZ");
        file = tuning::write_black_box_experiment(run_dir, o.spec);
    }
    const experiment::Experiment e = experiment::load_experiment(file);
    if (!e.objective) {
        std::cerr << "maptune optimize: " << file << ": no 'objective' section (a matcher experiment runs with "
                  << "`maptune run`)\n";
        return 2;
    }
    if (run_dir.empty()) run_dir = "runs/" + e.name + "-" + tuning::utc_now("%Y%m%dT%H%M%SZ");
    struct sigaction sa {};
    sa.sa_handler = on_optimize_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    std::cout << "maptune optimize: " << e.name << ", " << e.optimize.size() << " parameters, budget "
              << e.max_evaluations << ", " << (e.minimize ? "minimizing" : "maximizing") << " `"
              << e.objective->command << "` (" << e.objective->parallel << " at once); run directory "
              << run_dir.string() << "\n";
    const auto summary = tuning::run_black_box(e, run_dir, std::cout, [] { return g_stop.load(); });
    std::cout << "\nstopped: " << summary.stop_reason << "; " << summary.evaluations.size() << " evaluations\n";
    if (summary.best >= 0) {
        const auto& b = summary.evaluations[static_cast<std::size_t>(summary.best)];
        std::cout << "best: value " << params::format_double(b.p) << " at evaluation " << b.number << " -> "
                  << (run_dir / "best_params.yaml").string() << "\n";
    } else {
        std::cout << "no successful evaluation\n";
    }
    return g_stop.load() ? 130 : (summary.best >= 0 ? 0 : 1);
}

}  // namespace

void add_optimize_command(CLI::App& app, int& exit_code) {
    auto o = std::make_shared<OptimizeOptions>();
    auto* cmd = app.add_subcommand(
        "optimize",
        "Tune any component: run a command once per proposed parameter set (the set as JSON on its "
        "standard input; it prints a number, or {\"value\": x, \"failed\": false, \"reason\": \"...\"}) and "
        "write a run directory like a matcher run (trials.csv, best_params.yaml, run.yaml).");
    cmd->add_option("--experiment", o->experiment,
                    "black-box experiment YAML (with an 'objective' section, docs/optimizer.md); instead of "
                    "--space/--objective-cmd")
        ->check(CLI::ExistingFile);
    cmd->add_option("--space", o->spec.space_file, "design space YAML (as configs/spaces/)")->check(CLI::ExistingFile);
    cmd->add_option("--objective-cmd", o->spec.command,
                    "shell command run once per set; non-zero exit, timeout or unreadable output = failed evaluation");
    cmd->add_option("--budget", o->spec.budget, "evaluations, 1..100000")->check(CLI::Range(1, 100000));
    cmd->add_option("--seed", o->spec.seed, "optimizer seed");
    cmd->add_flag("--minimize", o->spec.minimize, "minimize the value (default: maximize)");
    cmd->add_option("--parallel", o->spec.parallel, "commands at once, 1..256")->check(CLI::Range(1, 256));
    cmd->add_option("--timeout", o->spec.timeout_s, "seconds per command before it is stopped and failed (0: none)")
        ->check(maptune::params::finite_range(0.0, 1e7));
    cmd->add_option("--time-budget", o->spec.seconds, "seconds for the whole run (0: none)")->check(maptune::params::finite_range(0.0, 1e9));
    cmd->add_option("--optimize", o->spec.optimize, "parameters to optimize (default: all; the others keep their default)")
        ->delimiter(',');
    cmd->add_option("--acquisition", o->spec.acquisition, "log_ei | ei | ucb | ucb_schedule")
        ->check(CLI::IsMember({"log_ei", "ei", "ucb", "ucb_schedule"}));
    cmd->add_option("--warping", o->spec.warping, "output warping: automatic | none | log | copula")
        ->check(CLI::IsMember({"automatic", "none", "log", "copula"}));
    cmd->add_option("--search", o->spec.search, "proposal search: alternate | trust_region | global")
        ->check(CLI::IsMember({"alternate", "trust_region", "global"}));
    cmd->add_option("--quadratic-steps", o->spec.quadratic_steps,
                    "every 4th proposal, while such steps improve the best as often as the trust region's others, the "
                    "maximizer there of a quadratic fitted to all live values: true | false (default: true)");
    cmd->add_option("--hyper-samples", o->spec.hyper_samples,
                    "hyperparameter draws (Laplace's approximation) over which the whole box's acquisition is averaged, 0..64; 0 = the fitted ones alone (default: 4)")
        ->check(CLI::Range(0, 64));
    cmd->add_option("--cholesky", o->spec.cholesky, "GP factorization: eigen | cholmod")
        ->check(CLI::IsMember({"eigen", "cholmod"}));
    cmd->add_option("--initial-points", o->spec.initial_points, "quasi-random design size (0: max(5, d + 1))")
        ->check(CLI::Range(0, 10000));
    cmd->add_option("--start", o->spec.start_points, "parameter set YAML evaluated first (repeatable)")
        ->check(CLI::ExistingFile);
    cmd->add_option("--name", o->spec.name, "experiment name (run ids, default run directory)");
    cmd->add_option("--run-dir", o->run_dir,
                    "run directory; an existing one resumes (default: runs/<name>-<UTC time>)");
    cmd->callback([o, &exit_code] {
        try {
            exit_code = run_optimize(*o);
        } catch (const std::exception& err) {
            std::cerr << "maptune optimize: " << err.what() << "\n";
            exit_code = 2;
        }
    });
}

}  // namespace maptune::cli
#endif
