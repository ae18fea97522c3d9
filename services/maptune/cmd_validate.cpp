// maptune validate: the baseline, the best observed and the model's predicted best of a run,
// scored on the experiment's held-out views (issue 11).
#ifdef MAPTUNE_HAVE_EVALUATION
#include <algorithm>
#include <iostream>
#include <memory>

#include "commands.hpp"
#include "compare_output.hpp"
#include "dataset/io.hpp"
#include "experiment/run_files.hpp"
#include "params/yaml_util.hpp"
#include "validate_cli.hpp"

namespace maptune::cli {
namespace {

namespace fs = std::filesystem;
using params::ConfigError;

std::string default_db(const fs::path& run_dir) {
    const std::string found = experiment::run_store_path(run_dir);
    return found.empty() ? (run_dir / "observations.db").string() : found;
}

}  // namespace

experiment::Experiment experiment_of_run(const fs::path& run_dir, const std::string& override_file) {
    return experiment::load_experiment(override_file.empty() ? experiment::recorded_experiment_file(run_dir)
                                                             : override_file);
}

evaluation::CompareResult validate_run_dir(const fs::path& run_dir, const experiment::Experiment& e,
                                           const ValidateSettings& settings, std::ostream& out) {
    const auto sets = evaluation::validation_sets(e, run_dir);
    const std::string db_path = settings.db.empty() ? default_db(run_dir) : settings.db;
    store::ObservationStore db(db_path);
    evaluation::CompareOptions options;
    options.matcher = evaluation::experiment_matcher_settings(e, settings.threads);
    options.db = &db;
    options.progress = [](const std::string& what) { std::cerr << "validate: " << what << "\n"; };
    const auto result = evaluation::validate(e, sets, options);
    dataset::write_file(run_dir / "validation.csv", evaluation::validation_csv(result));
    int baseline = -1;
    for (std::size_t i = 0; i < result.set_names.size(); ++i) {
        if (result.set_names[i] == evaluation::kBaselineSet) baseline = static_cast<int>(i);
    }
    out << "\nvalidation of " << run_dir.string() << " (store " << db_path << "):\n\n";
    write_compare(out, result, settings.format, baseline);
    out << "written to " << (run_dir / "validation.csv").string() << "\n";
    return result;
}

void write_seeds_summary(const fs::path& root, const std::vector<evaluation::SeedOutcome>& seeds,
                         std::ostream& out) {
    dataset::write_file(root / "summary.csv", evaluation::seeds_summary_csv(seeds));
    // One line per score.
    const auto summary = evaluation::summarize_seeds(seeds);
    Table t;
    t.columns = {"score", "median", "min", "max", "spread"};
    t.numeric = {false, true, true, true, true};
    for (std::size_t c = 0; c < summary.columns.size(); ++c) {
        const auto& sp = summary.spreads[c];
        auto cell = [&](double v) { return sp.n ? params::format_fixed(v, 4) : std::string(); };
        t.rows.push_back({summary.columns[c], cell(sp.median), cell(sp.min), cell(sp.max), cell(sp.max - sp.min)});
    }
    const std::size_t n_seeds = seeds.size();
    out << "\nover " << n_seeds << " seeds (" << (root / "summary.csv").string() << "):\n\n";
    write_table(out, t, TableFormat::kMarkdown);
}

void add_validate_command(CLI::App& app, int& exit_code) {
    struct Options {
        std::string run_dir, experiment;
        ValidateSettings settings;
    };
    auto opt = std::make_shared<Options>();
    auto* cmd = app.add_subcommand(
        "validate",
        "Score a run's baseline, best observed and predicted best on the experiment's held-out views "
        "(validate: section); writes validation.csv. A run directory with seed-* directories (several "
        "seeds) validates each and writes summary.csv.");
    cmd->add_option("--run-dir", opt->run_dir, "run directory of `maptune run` or the optimizer")
        ->required()->check(CLI::ExistingDirectory);
    cmd->add_option("--experiment", opt->experiment,
                    "experiment YAML (default: the one recorded in the run's run.yaml)")
        ->check(CLI::ExistingFile);
    cmd->add_option("--db", opt->settings.db,
                    "observation store (default: the run's observations.db, or its parent's)");
    cmd->add_option("--threads", opt->settings.threads, "matcher threads, 0 = all cores")->capture_default_str();
    cmd->add_option("-f,--format", opt->settings.format, "markdown | table | csv | json")
        ->check(CLI::IsMember({"markdown", "table", "csv", "json"}))
        ->capture_default_str();
    cmd->callback([opt, &exit_code] {
        try {
            const fs::path root = opt->run_dir;
            const auto seeds = fs::exists(root / "run.yaml") ? decltype(experiment::seed_run_dirs(root)){} : experiment::seed_run_dirs(root);
            if (seeds.empty()) {
                const auto e = experiment_of_run(root, opt->experiment);
                validate_run_dir(root, e, opt->settings, std::cout);
                return;
            }
            std::vector<evaluation::SeedOutcome> outcomes;
            for (const auto& [seed, dir] : seeds) {
                const auto e = experiment_of_run(dir, opt->experiment);
                outcomes.push_back({seed, dir, experiment::read_run_record(dir).best_p, validate_run_dir(dir, e, opt->settings, std::cout)});
            }
            write_seeds_summary(root, outcomes, std::cout);
        } catch (const std::exception& e) {
            std::cerr << "maptune validate: " << e.what() << "\n";
            exit_code = 2;
        }
    });
}

}  // namespace maptune::cli
#endif
