// maptune run: the embedded default — every service in one process on a private DDS domain.
#ifdef MAPTUNE_HAVE_SERVICES
#include "commands.hpp"
#include "params/cli_range.hpp"
#include "dds_options.hpp"
#include "embedded.hpp"
#include "runtime.hpp"
#include "validate_cli.hpp"
#ifdef MAPTUNE_HAVE_REPORT
#include "report_cli.hpp"
#endif

#include <iostream>

namespace maptune::cli {
namespace {

// Scores every seed's baseline, best and predicted best on the experiment's validate: views
// (the PCL matcher, locally, after the services stopped); summary.csv for several seeds.
void validate(const services::EmbeddedOptions& opt, const services::EmbeddedResult& result, bool skip,
              int& exit_code) {
    const auto& e = result.experiment;
    if (skip || e.validate.empty()) return;
    if (opt.analytic || e.matcher_id != "lru_matcher") {
        std::cout << "\nvalidation skipped: it runs the reference matcher locally, and this run's matcher is '"
                  << (opt.analytic ? std::string("analytic") : e.matcher_id) << "'\n";
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
}

}  // namespace

void add_run_command(CLI::App& app, int& exit_code) {
    auto opt = std::make_shared<services::EmbeddedOptions>();
    auto no_validate = std::make_shared<bool>(false);
    auto no_report = std::make_shared<bool>(false);
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
    cmd->add_option("--domain", opt->domain_id, "DDS domain id, 0..232 (default: a random one in 1..200 that no other maptune process on this host holds)")
        ->check(CLI::Range(0, 232));
    services::add_dds_security_options(*cmd, opt->dds_security, nullptr);
    cmd->add_flag("--analytic", opt->analytic,
                  "use the analytic test matcher instead of the PCL pipeline (for trying things fast)");
    cmd->add_flag("--external-workers", opt->external_workers,
                  "start no matcher workers: wait for workers of the experiment's matcher.id started apart "
                  "(plug-ins, other machines) on --domain");
    cmd->add_option("--wait", opt->wait_s, "seconds to wait for the first compatible worker (default: 120)")
        ->check(maptune::params::finite_range(1.0, 86400.0));
    cmd->add_flag("!--no-progress", opt->progress_bar, "no progress bar");
    cmd->add_flag("!--no-locality", opt->locality,
                  "shards of consecutive pairs oldest first, without regard to the submaps each worker holds "
                  "(for measuring what locality-aware scheduling gains)");
    cmd->add_option("--seeds", opt->seeds,
                    "optimizer seeds, e.g. 1,2,3: one run directory per seed (seed-<n>) sharing one store "
                    "(default: the experiment's seeds, else its one seed)")
        ->delimiter(',');
    cmd->add_option("--budget", opt->budget,
                    "evaluations per seed, 1..100000 (default: the experiment's budget.evaluations); "
                    "a larger one on an existing --run-dir goes on from where that run stopped")
        ->check(CLI::Range(1, 100000));
    cmd->add_flag("--no-validate", *no_validate, "skip the validation on the experiment's validate: views");
    cmd->add_flag("--no-report", *no_report, "skip the HTML report (<run-dir>/report/index.html)");
    cmd->callback([opt, no_validate, no_report, &exit_code] {
        services::EmbeddedResult result;
        exit_code = services::run_embedded(*opt, &result);
        if (exit_code != 0 || result.runs.empty() || services::stop_requested()) return;
        validate(*opt, result, *no_validate, exit_code);
#ifdef MAPTUNE_HAVE_REPORT
        if (*no_report) return;
        // The report is a view of the results: a machine without Node.js still has them all.
        try {
            const auto out = result.root / "report";
            write_report({result.root.string()}, out, {}, 0);
            std::cout << "\nreport: " << (out / "index.html").string() << "\n";
        } catch (const std::exception& err) {
            std::cerr << "maptune run: no report: " << err.what() << "\n";
        }
#else
        (void)no_report;
#endif
    });
}

}  // namespace maptune::cli
#endif
