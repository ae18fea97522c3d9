// maptune run: the embedded default — every service in one process on a private DDS domain.
#ifdef MAPTUNE_HAVE_SERVICES
#include "commands.hpp"
#include "embedded.hpp"

namespace maptune::cli {

void add_run_command(CLI::App& app, int& exit_code) {
    auto opt = std::make_shared<services::EmbeddedOptions>();
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
    cmd->callback([opt, &exit_code] { exit_code = services::run_embedded(*opt); });
}

}  // namespace maptune::cli
#endif
