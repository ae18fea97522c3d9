#include "embedded.hpp"

#include <algorithm>
#include <iostream>

#include "dds/domain_lease.hpp"
#include "evaluation/validation.hpp"
#include "matcher_worker.hpp"
#include "params/export.hpp"
#include "params/yaml_util.hpp"
#include "runtime.hpp"
#include "sample_db.hpp"
#include "dataset_server.hpp"

namespace maptune::services {

namespace fs = std::filesystem;

namespace {

void print_summary(const experiment::Experiment& e, const RunSummary& s, const fs::path& run_dir) {
    std::cout << "\n" << s.evaluations.size() << " evaluations (" << s.stop_reason << "), m* = "
              << params::format_fixed(s.m_star, 1) << "\n";
    if (e.multi_fidelity()) {
        const auto stopped = std::count_if(s.evaluations.begin(), s.evaluations.end(),
                                           [](const EvaluationRecord& r) { return r.fidelity != 1; });
        std::cout << "multi-fidelity: " << stopped << " of them stopped on the subset (1/" << e.fidelity_subset
                  << " of the pairs), " << s.evaluations.size() - static_cast<std::size_t>(stopped)
                  << " on the whole view\n";
    }
    if (s.best < 0) {
        std::cout << "no successful evaluation\n";
        return;
    }
    const EvaluationRecord& best = s.evaluations[static_cast<std::size_t>(s.best)];
    const int base = experiment::baseline_index(e, s.evaluations);
    const EvaluationRecord* baseline = base >= 0 ? &s.evaluations[static_cast<std::size_t>(base)] : nullptr;
    std::cout << "\nparameter      " << (baseline ? "   baseline" : "") << "       best\n";
    for (const auto& spec : e.space.specs()) {
        const int dec = spec.type == params::ParamType::kInt ? 0 : 2;
        std::cout << spec.name << std::string(15 - std::min<std::size_t>(14, spec.name.size()), ' ');
        if (baseline) {
            const std::string b = params::format_fixed(baseline->params.get(spec.name), dec);
            std::cout << std::string(11 - std::min<std::size_t>(10, b.size()), ' ') << b;
        }
        const std::string v = params::format_fixed(best.params.get(spec.name), dec);
        std::cout << std::string(11 - std::min<std::size_t>(10, v.size()), ' ') << v << "\n";
    }
    auto score_line = [&](const char* label, double baseline_v, double best_v, int dec) {
        std::cout << label << std::string(15 - std::string(label).size(), ' ');
        if (baseline) {
            const std::string b = params::format_fixed(baseline_v, dec);
            std::cout << std::string(11 - std::min<std::size_t>(10, b.size()), ' ') << b;
        }
        const std::string v = params::format_fixed(best_v, dec);
        std::cout << std::string(11 - std::min<std::size_t>(10, v.size()), ' ') << v << "\n";
    };
    score_line("p", baseline ? baseline->p : 0, best.p, 4);
    score_line("m", baseline ? static_cast<double>(baseline->m) : 0, static_cast<double>(best.m), 0);
    score_line("eps", baseline ? baseline->eps : 0, best.eps, 4);
    // Seconds per pair from the raw submaps (measure.max_pair_seconds budgets them).
    if (best.pair_s > 0) score_line("s/pair", baseline ? baseline->pair_s : 0, best.pair_s, 3);
    if (e.max_pair_seconds > 0) {
        std::cout << "run-time budget " << params::format_double(e.max_pair_seconds)
                  << " s per pair: best by p·min(1, budget/t)² = "
                  << params::format_fixed(experiment::record_objective(e, best), 4) << "\n";
    }
    std::cout << "\nbest found at evaluation " << best.number << "; written to "
              << (run_dir / "best_params.yaml").string() << " and best_params.ros2.yaml\n";
}

}  // namespace

int run_embedded(const EmbeddedOptions& options, EmbeddedResult* result) {
    install_stop_signals();
    experiment::Experiment e;
    try {
        e = experiment::load_experiment(options.experiment_file);
        evaluation::ensure_dataset(e.dataset_dir, e.generate, [](const std::string& line) {
            std::cout << line << std::endl;
        });
    } catch (const params::ConfigError& err) {
        std::cerr << "maptune run: " << err.what() << "\n";
        return 2;
    }
    if (options.budget > 0) e.max_evaluations = options.budget;
    std::vector<std::uint64_t> seeds = !options.seeds.empty() ? options.seeds : e.seeds;
    const bool repeated = !seeds.empty();
    if (seeds.empty()) seeds.push_back(e.seed);
    const fs::path root = options.run_dir.empty() ? fs::path("runs") / (e.name + "-" + utc_now("%Y%m%d-%H%M%S"))
                                                  : options.run_dir;
    fs::create_directories(root);
    const std::string db = options.db_path.empty() ? (root / "observations.db").string() : options.db_path;
    int domain = options.domain_id;
    if (domain < 0) {
        domain = dds::lease_random_domain();
    } else if (!dds::lease_domain(domain)) {
        std::cerr << "maptune run: warning: another maptune process on this host holds DDS domain " << domain
                  << "; its services would answer this run's requests\n";
    }
    const std::string matcher_id = options.analytic ? "analytic" : e.matcher_id;
    const bool reference = matcher_id == evaluation::kMatcherId;
    if (!options.external_workers && !reference && matcher_id != "analytic") {
        std::cerr << "maptune run: matcher '" << matcher_id << "' (" << options.experiment_file
                  << ": matcher.id) runs in its own workers: start them on a DDS domain and run with "
                     "--external-workers --domain N\n";
        return 2;
    }
    const int n_workers = options.external_workers ? 0 : options.workers > 0 ? options.workers : e.workers;
    std::cout << "run directory " << root.string() << ", store " << db << ", DDS domain " << domain << " (loopback" << (options.dds_security.empty() ? "" : ", DDS-Security") << "), ";
    if (options.external_workers) {
        std::cout << "external workers of matcher '" << matcher_id << "' (design space " << e.space.hash()
                  << "): start them with --domain " << domain << "; waiting up to " << options.wait_s << " s";
    } else {
        std::cout << n_workers << (matcher_id == "analytic" ? " analytic" : "") << " worker(s)";
    }
    std::cout << (repeated ? ", " + std::to_string(seeds.size()) + " seeds" : "") << std::endl;
    if (result) {
        result->experiment = e;
        result->root = root;
        result->db_path = db;
    }

    // Each service authenticates as its role (with --dds-security), as separate processes do.
    auto participant = [&](const std::string& name, const std::string& role) {
        dds::ParticipantOptions o{domain, "", "maptune_loopback", name};
        o.security_dir = options.dds_security;
        o.identity = role;
        return std::make_unique<dds::Participant>(o);
    };
    int exit_code = 0;
    try {
        auto server_p = participant("dataset_server", "dataset_server");
        DatasetServer server(*server_p, {{e.dataset_dir}, 512 * 1024, ""});

        auto db_p = participant("sample_db", "sample_db");
        DatasetMirror db_mirror(*db_p, root / "cache", "sample_db");
        SampleDbOptions db_options;
        db_options.store_path = db;
        db_options.spaces = {e.space};
        db_options.scheduler.locality = options.locality;
        db_options.log = [](const std::string& line) { std::cerr << "sample_db: " << line << std::endl; };
        SampleDb sample_db(*db_p, db_mirror, db_options);

        // The experiment's `matcher.threads` per worker when set; else the cores shared out.
        const matcher::MatcherSettings settings = evaluation::experiment_matcher_settings(
            e, e.matcher_threads > 0
                   ? e.matcher_threads
                   : std::max(1, static_cast<int>(std::thread::hardware_concurrency()) / std::max(1, n_workers)));
        std::vector<std::unique_ptr<dds::Participant>> worker_ps;
        std::vector<std::unique_ptr<DatasetMirror>> mirrors;
        std::vector<std::unique_ptr<WorkerBackend>> backends;
        std::vector<std::unique_ptr<MatcherWorker>> workers;
        for (int i = 0; i < n_workers; ++i) {
            worker_ps.push_back(participant("worker" + std::to_string(i), "worker"));
            mirrors.push_back(std::make_unique<DatasetMirror>(*worker_ps.back(), root / "cache",
                                                              "worker" + std::to_string(i)));
            // Embedded workers read the dataset directory directly: no copy.
            mirrors.back()->add_local(e.dataset_dir);
            if (!reference) {
                backends.push_back(std::make_unique<AnalyticBackend>(*mirrors.back(), e.space));
            } else {
                matcher::FeatureCacheOptions cache;
                cache.max_bytes = static_cast<std::size_t>(e.feature_cache_mb) << 20;
                cache.max_neighbour_bytes = static_cast<std::size_t>(e.neighbour_cache_mb) << 20;
                backends.push_back(std::make_unique<LruBackend>(*mirrors.back(), e.space, settings, cache));
            }
            workers.push_back(std::make_unique<MatcherWorker>(*worker_ps.back(), *backends.back(),
                                                              WorkerOptions{"", 1, 0.5}));
        }

        // One optimizer per seed, one after the other; the store answers what an earlier seed
        // already evaluated (the start points, at least).
        for (const std::uint64_t seed : seeds) {
            if (stop_requested()) break;
            const fs::path run_dir = repeated ? root / ("seed-" + std::to_string(seed)) : root;
            experiment::Experiment seeded = e;
            seeded.seed = seed;
            if (repeated) std::cout << "\n== seed " << seed << ": " << run_dir.string() << std::endl;
            auto opt_p = participant("optimizer", "optimizer");
            DatasetMirror opt_mirror(*opt_p, root / "cache", "optimizer");
            OptimizerServiceOptions opt_options;
            opt_options.experiment = seeded;
            opt_options.run_dir = run_dir;
            if (repeated) opt_options.experiment_id = e.name + "-seed" + std::to_string(seed);
            opt_options.matcher_id = matcher_id;
            // The reference matcher's settings travel in every request, so standalone workers of
            // this build evaluate exactly them; another matcher's version is whatever its workers say.
            if (reference) {
                opt_options.matcher_version = evaluation::matcher_version(settings);
                opt_options.matcher_settings = matcher::setting_texts(settings);
            }
            opt_options.wait_s = options.wait_s;
            opt_options.progress_bar = options.progress_bar;
            OptimizerService optimizer(*opt_p, opt_mirror, opt_options);
            RunSummary summary = optimizer.run();
            print_summary(e, summary, run_dir);
            if (summary.best < 0) exit_code = 1;
            if (result) result->runs.push_back({seed, run_dir, std::move(summary)});
        }
        if (reference && !backends.empty()) {
            // Feature work of the workers together (a submap computed by two workers counts
            // twice): the scheduler's locality shows here (docs/distributed.md, "Locality").
            std::size_t total = 0;
            std::string each;
            for (std::size_t i = 0; i < backends.size(); ++i) {
                total += backends[i]->feature_computations();
                each += (i ? " + " : "") + std::to_string(backends[i]->feature_computations());
            }
            std::cout << "submap feature computations by " << backends.size() << " worker(s): "
                      << (backends.size() > 1 ? each + " = " : "") << total << std::endl;
        }
    } catch (const std::exception& err) {
        std::cerr << "maptune run: " << err.what() << "\n";
        return 1;
    }
    return exit_code;
}

}  // namespace maptune::services
