// maptune run: the embedded default — every service in one process on a private DDS domain.
#ifdef MAPTUNE_HAVE_SERVICES
#include "commands.hpp"
#include "embedded.hpp"
#include "runtime.hpp"
#include "validate_cli.hpp"

#include <iostream>

namespace maptune::cli {

void add_run_command(CLI::App& app, int& exit_code) {
    auto opt = std::make_shared<services::EmbeddedOptions>();
    auto no_validate = std::make_shared<bool>(false);
    auto* cmd = app.add_subcommand(
        "run", "Tune: run an experiment with all services in this process (dataset_server, "
               "sample_db, workers, optimizer) on a private loopback DDS domain.");
    cmd->add_option("--experiment", opt->experiment_file, "experiment YAML (configs/experiments/)")
        ->required()->check(CLI::ExistingFile);
    cmd->add_option("--run-dir", opt->run_dir,
                    "run directory; an existing one resumes (default: runs/<name>-<UTC time>)");
    cmd->add_option("--db", opt->db_path,
                    "observation store shared across runs (default: <run-dir>/observations.db)");
    cmd->add_option("--workers", opt->workers, "matcher workers, 1..64 (default: the experiment's)")
        ->check(CLI::Range(1, 64));
    cmd->add_option("--domain", opt->domain_id, "DDS domain id, 0..232 (default: random in 1..200)")
        ->check(CLI::Range(0, 232));
    cmd->add_flag("--analytic", opt->analytic,
                  "use the analytic test matcher instead of the PCL pipeline (for trying things fast)");
    cmd->add_flag("!--no-progress", opt->progress_bar, "no progress bar");
    cmd->add_option("--seeds", opt->seeds,
                    "optimizer seeds, e.g. 1,2,3: one run directory per seed (seed-<n>) sharing one store "
                    "(default: the experiment's seeds, else its one seed)")
        ->delimiter(',');
    cmd->add_flag("--no-validate", *no_validate, "skip the validation on the experiment's validate: views");
    cmd->callback([opt, no_validate, &exit_code] {
        services::EmbeddedResult result;
        exit_code = services::run_embedded(*opt, &result);
        // Validation runs the PCL matcher locally, after the services stopped.
        const auto& e = result.experiment;
        if (exit_code != 0 || *no_validate || e.validate.empty() || result.runs.empty() ||
            services::stop_requested()) {
            return;
        }
        if (opt->analytic) {
            std::cout << "\nvalidation skipped: the analytic test matcher has no held-out views\n";
            return;
        }
        try {
            ValidateSettings settings;
            settings.db = result.db_path;
            std::vector<evaluation::SeedOutcome> outcomes;
            for (const auto& run : result.runs) {
                std::optional<double> best;
                if (run.summary.best >= 0) best = run.summary.evaluations[static_cast<std::size_t>(run.summary.best)].p;
                outcomes.push_back({run.seed, run.run_dir, best, validate_run_dir(run.run_dir, e, settings, std::cout)});
            }
            if (result.runs.size() > 1 || result.runs.front().run_dir != result.root) {
                write_seeds_summary(result.root, outcomes, std::cout);
            }
        } catch (const std::exception& err) {
            std::cerr << "maptune run: validation: " << err.what() << "\n";
            exit_code = 1;
        }
    });
}

}  // namespace maptune::cli
#endif
