// maptune_matcher_worker: runs evaluation tasks with the reference matcher (or the analytic
// test objective) and returns per-pair results over DDS.
#include <CLI/CLI.hpp>
#include <iostream>
#include <thread>

#include "dds_options.hpp"
#include "evaluation/validation.hpp"
#include "experiment/experiment.hpp"
#include "params/yaml_util.hpp"
#include "matcher_worker.hpp"
#include "runtime.hpp"
#include "params/cli_range.hpp"

int main(int argc, char** argv) {
    using namespace maptune::services;
    bound_malloc_arenas();
    CLI::App app{"maptune matcher_worker: evaluates parameter sets on submap pairs"};
    maptune::dds::ParticipantOptions dds{0, "", "maptune_loopback", "matcher_worker"};
    WorkerOptions options;
    std::string space_file = "configs/spaces/lru_matcher.yaml";
    std::string cache = "/tmp/maptune-cache";
    std::string local_dataset;
    bool analytic = false;
    AnalyticOptions analytic_options;
    maptune::matcher::MatcherSettings settings;
    app.add_option("--space", space_file, "design space YAML (default: configs/spaces/lru_matcher.yaml)");
    app.add_option("--id", options.worker_id, "worker id (default: generated from host and pid)");
    app.add_option("--slots", options.slots, "tasks run at once, 1..64 (default: 1)")->check(CLI::Range(1, 64));
    app.add_option("--threads", settings.threads, "matcher threads, 0 = all cores (default: 0)");
    app.add_option("--cache", cache, "directory for fetched dataset files (default: /tmp/maptune-cache)");
    double submap_cache_mb = static_cast<double>(LruBackend::kDefaultSubmapCacheBytes >> 20);
    app.add_option("--submap-cache-mb", submap_cache_mb, "loaded submaps kept in memory, MB (default: 1024)")
        ->check(maptune::params::finite_range(1.0, 1e7));
    double feature_cache_mb = static_cast<double>(maptune::matcher::FeatureCacheOptions{}.max_bytes >> 20);
    app.add_option("--feature-cache-mb", feature_cache_mb,
                   "computed features kept in memory, MB (default: 4096; a view whose features do not fit "
                   "recomputes them for every evaluation)")
        ->check(maptune::params::finite_range(64.0, 1e7));
    double neighbour_cache_mb =
        static_cast<double>(maptune::matcher::FeatureCacheOptions{}.max_neighbour_bytes >> 20);
    app.add_option("--neighbour-cache-mb", neighbour_cache_mb,
                   "descriptor neighbour lists of pairs kept in memory, MB (default: 1024; 0 = none; a view "
                   "whose lists do not fit repeats the descriptor matching for every evaluation)")
        ->check(maptune::params::finite_range(0.0, 1e7));
    std::string experiment_file;
    std::vector<std::string> overrides;
    app.add_option("--experiment", experiment_file,
                   "take the matcher settings (matcher: section) from this experiment, so that the worker "
                   "evaluates the version its optimizer asks for")
        ->check(CLI::ExistingFile);
    app.add_option("--matcher", overrides, "non-optimized matcher setting KEY=VALUE (repeatable, after --experiment; docs/matcher.md)");
    app.add_option("--dataset-dir", local_dataset, "read this dataset directory directly instead of fetching it");
    app.add_flag("--analytic", analytic, "run the analytic test objective instead of the PCL matcher");
    app.add_option("--delay", analytic_options.delay_per_pair_s, "analytic: seconds per pair (default: 0)");
    app.add_option("--failure-rate", analytic_options.failure_rate, "analytic: task failure probability, 0..1 (default: 0)")
        ->check(maptune::params::finite_range(0.0, 1.0));
    add_dds_options(app, dds, "worker");
    CLI11_PARSE(app, argc, argv);
    install_stop_signals();
    try {
        const auto space = maptune::params::ParameterSpace::load(space_file);
        if (!experiment_file.empty()) {
            const int threads = settings.threads;
            settings = maptune::evaluation::experiment_matcher_settings(
                maptune::experiment::load_experiment(experiment_file));
            settings.threads = threads;  // this machine's cores, not the experiment's
        }
        if (auto err = maptune::matcher::set_matcher_settings(settings, overrides); !err.empty()) {
            throw maptune::params::ConfigError(err);
        }
        maptune::dds::Participant participant(dds);
        DatasetMirror mirror(participant, cache, options.worker_id.empty() ? make_id("w") : options.worker_id);
        if (!local_dataset.empty()) mirror.add_local(local_dataset);
        std::unique_ptr<WorkerBackend> backend;
        if (analytic) {
            backend = std::make_unique<AnalyticBackend>(mirror, space, analytic_options);
        } else {
            maptune::matcher::FeatureCacheOptions feature_cache;
            feature_cache.max_bytes = static_cast<std::size_t>(feature_cache_mb * 1024 * 1024);
            feature_cache.max_neighbour_bytes = static_cast<std::size_t>(neighbour_cache_mb * 1024 * 1024);
            backend = std::make_unique<LruBackend>(mirror, space, settings, feature_cache,
                                                   static_cast<std::size_t>(submap_cache_mb * 1024 * 1024));
        }
        MatcherWorker worker(participant, *backend, options);
        std::cout << "worker " << worker.id() << " (" << backend->matcher_id() << " "
                  << backend->matcher_version() << ", space " << space.hash() << ") ready on domain "
                  << dds.domain_id << std::endl;
        while (!stop_requested()) std::this_thread::sleep_for(std::chrono::milliseconds(50));
        std::cout << "stopping after " << worker.tasks_done() << " tasks, " << backend->feature_computations()
                  << " submap feature computations" << std::endl;
    } catch (const std::exception& e) {
        std::cerr << "matcher_worker: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
