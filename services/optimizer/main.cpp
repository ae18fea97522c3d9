// maptune_optimizer: runs an experiment against the sample_db and workers on a DDS domain.
#include <CLI/CLI.hpp>
#include <iostream>

#include "dds_options.hpp"
#include "params/yaml_util.hpp"
#include "evaluation/validation.hpp"
#include "optimizer_service.hpp"
#include "runtime.hpp"
#include "params/cli_range.hpp"

int main(int argc, char** argv) {
    using namespace maptune::services;
    CLI::App app{"maptune optimizer: Bayesian optimization of matcher parameters over DDS"};
    maptune::dds::ParticipantOptions dds{0, "", "maptune_loopback", "optimizer"};
    std::string experiment_file, run_dir, cache = "/tmp/maptune-cache";
    OptimizerServiceOptions options;
    app.add_option("--experiment", experiment_file, "experiment YAML")->required()->check(CLI::ExistingFile);
    app.add_option("--run-dir", run_dir, "run directory: trials.csv, best_params*.yaml; an existing one resumes")->required();
    app.add_option("--dataset-id", options.dataset_id, "dataset id as announced (default: read the experiment's dataset dir)");
    std::string matcher_id;
    app.add_option("--matcher", matcher_id, "matcher id of the workers (default: the experiment's matcher.id)");
    app.add_option("--wait", options.wait_s, "seconds to wait for dataset and workers (default: 120)");
    app.add_option("--resend", options.resend_s, "seconds before an unanswered request is sent again (default: 15)")
        ->check(maptune::params::finite_range(0.1, 3600.0));
    app.add_option("--cache", cache, "directory for fetched dataset metadata (default: /tmp/maptune-cache)");
    add_dds_options(app, dds, "optimizer");
    CLI11_PARSE(app, argc, argv);
    install_stop_signals();
    try {
        options.experiment = maptune::experiment::load_experiment(experiment_file);
        options.matcher_id = matcher_id.empty() ? options.experiment.matcher_id : matcher_id;
        options.run_dir = run_dir;
        // The reference matcher's version follows from the experiment's matcher settings, which
        // every request carries: any worker of this code revision evaluates them.
        if (options.matcher_id == maptune::evaluation::kMatcherId) {
            const auto settings = maptune::evaluation::experiment_matcher_settings(options.experiment);
            options.matcher_version = maptune::evaluation::matcher_version(settings);
            options.matcher_settings = maptune::matcher::setting_texts(settings);
        }
        maptune::dds::Participant participant(dds);
        DatasetMirror mirror(participant, cache, make_id("optimizer"));
        OptimizerService service(participant, mirror, options);
        const RunSummary s = service.run();
        std::cout << s.evaluations.size() << " evaluations (" << s.stop_reason << ")";
        if (s.best >= 0) std::cout << ", best p = " << s.evaluations[static_cast<std::size_t>(s.best)].p;
        std::cout << std::endl;
        return s.best >= 0 ? 0 : 1;
    } catch (const maptune::params::ConfigError& e) {
        std::cerr << "optimizer: " << e.what() << "\n";
        return 2;
    } catch (const std::exception& e) {
        std::cerr << "optimizer: " << e.what() << "\n";
        return 1;
    }
}
