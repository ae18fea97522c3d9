#include "maptune_sdk/worker.hpp"

#include <CLI/CLI.hpp>

#include <chrono>
#include <iostream>
#include <thread>

#include "dataset_mirror.hpp"
#include "dds_options.hpp"
#include "matcher_worker.hpp"
#include "runtime.hpp"
#include "worker_backend.hpp"

namespace maptune::sdk {

Outcome run_pairs(const Task& task, Datasets& datasets, const PairMatch& match) {
    Outcome out;
    const auto ds = datasets.open(task.dataset_id, &out.error);
    if (!ds) return out;
    for (const auto& pair_id : task.pair_ids) {
        const auto bar = pair_id.find('|');
        if (bar == std::string::npos) {
            out.error = "pair id '" + pair_id + "' is not '<submap>|<submap>'";
            out.pairs.clear();
            return out;
        }
        const std::string a_id = pair_id.substr(0, bar), b_id = pair_id.substr(bar + 1);
        if (!datasets.ensure_submaps(*ds, {a_id, b_id}, &out.error)) {
            out.pairs.clear();
            return out;
        }
        const auto start = std::chrono::steady_clock::now();
        PairResult r;
        r.pair_id = pair_id;
        try {
            match(*ds, a_id, b_id, r);
        } catch (const std::exception& e) {
            r.matched = false;
            r.status = PairStatus::kFailed;
            r.reason = e.what();
        }
        r.duration_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        out.pairs.push_back(std::move(r));
    }
    out.ok = true;
    return out;
}

namespace {


store::PairRecord to_record(const PairResult& p) {
    store::PairRecord r;
    r.pair_id = p.pair_id;
    r.matched = p.matched;
    for (int i = 0; i < 16; ++i) r.T_a_b_est(i / 4, i % 4) = p.T_a_b[static_cast<std::size_t>(i)];
    r.duration_s = p.duration_s;
    switch (p.status) {
        case PairStatus::kOk: r.status = store::PairStatus::kOk; break;
        case PairStatus::kNoMatch: r.status = store::PairStatus::kNoMatch; break;
        case PairStatus::kFailed: r.status = store::PairStatus::kFailed; break;
        case PairStatus::kTimeout: r.status = store::PairStatus::kTimeout; break;
    }
    r.reason = p.reason;
    return r;
}

class MirrorDatasets : public Datasets {
public:
    explicit MirrorDatasets(services::DatasetMirror& mirror) : cache_(mirror) {}
    std::shared_ptr<const dataset::Dataset> open(const std::string& id, std::string* error) override {
        return cache_.get(id, error);
    }
    bool ensure_submaps(const dataset::Dataset& ds, const std::vector<std::string>& ids, std::string* error) override {
        return cache_.mirror().ensure_submaps(ds, ids, 120.0, error);
    }

private:
    services::DatasetCache cache_;
};

// The plug-in's matcher behind maptune's worker service.
class Backend : public services::WorkerBackend {
public:
    Backend(Matcher& matcher, services::DatasetMirror& mirror, params::ParameterSpace space)
        : matcher_(matcher), datasets_(mirror), space_(std::move(space)), id_(matcher.id()),
          version_(matcher.version()) {}
    std::string matcher_id() const override { return id_; }
    std::string matcher_version() const override { return version_; }
    const params::ParameterSpace& space() const override { return space_; }
    services::TaskOutcome run(const services::TaskSpec& spec) override {
        Task task{spec.task_id, spec.dataset_id, spec.view, {}, spec.pair_ids};
        for (const auto& [name, value] : spec.params) task.params[name] = value;
        services::TaskOutcome out;
        Outcome o;
        try {
            o = matcher_.run(task, datasets_);
        } catch (const std::exception& e) {  // a plug-in bug must not end the worker
            out.error = std::string("the matcher threw: ") + e.what();
            return out;
        }
        out.ok = o.ok;
        out.error = o.error;
        if (o.ok && o.pairs.size() != spec.pair_ids.size()) {
            out.ok = false;
            out.error = "the matcher returned " + std::to_string(o.pairs.size()) + " results for " +
                        std::to_string(spec.pair_ids.size()) + " pairs";
            return out;
        }
        for (const auto& p : o.pairs) out.pairs.push_back(to_record(p));
        return out;
    }

private:
    Matcher& matcher_;
    MirrorDatasets datasets_;
    params::ParameterSpace space_;
    std::string id_, version_;
};

}  // namespace

int run_worker(const WorkerConfig& config, Matcher& matcher, bool (*stop)()) {
    services::install_stop_signals();
    try {
        if (config.space_file.empty()) throw std::runtime_error("no design space (--space FILE)");
        const auto space = params::ParameterSpace::load(config.space_file);
        dds::ParticipantOptions o{config.domain, config.dds_profiles, config.dds_profile, "worker"};
        o.security_dir = config.dds_security;
        o.identity = config.dds_identity;
        dds::Participant participant(o);
        const std::string id = config.worker_id.empty() ? services::make_id(matcher.id()) : config.worker_id;
        services::DatasetMirror mirror(participant, config.cache, id);
        if (!config.local_dataset.empty()) mirror.add_local(config.local_dataset);
        Backend backend(matcher, mirror, space);
        services::MatcherWorker worker(participant, backend, services::WorkerOptions{id, config.slots, 0.5});
        std::cout << "worker " << worker.id() << " (" << backend.matcher_id() << " " << backend.matcher_version()
                  << ", space " << space.hash() << ") ready on domain " << config.domain << std::endl;
        while (!services::stop_requested() && !(stop && stop())) {
            std::this_thread::sleep_for(std::chrono::milliseconds(100));
        }
        mirror.interrupt();  // a transfer in progress must not hold up the stop
        std::cout << "stopping after " << worker.tasks_done() << " tasks" << std::endl;
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "worker: " << e.what() << std::endl;
        return 1;
    }
}

int parse_worker_args(int argc, char** argv, const std::string& description, WorkerConfig& config) {
    CLI::App app{description};
    app.add_option("--space", config.space_file, "the matcher's design space YAML")->required();
    app.add_option("--id", config.worker_id, "worker id (default: generated from host and pid)");
    app.add_option("--slots", config.slots, "tasks run at once, 1..64 (default: 1)")->check(CLI::Range(1, 64));
    app.add_option("--cache", config.cache, "directory for fetched dataset files (default: /tmp/maptune-cache)");
    app.add_option("--dataset-dir", config.local_dataset, "read this dataset directory instead of fetching it");
    dds::ParticipantOptions dds{config.domain, config.dds_profiles, config.dds_profile, "worker"};
    services::add_dds_options(app, dds, config.dds_identity);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    config.domain = dds.domain_id;
    config.dds_profiles = dds.profiles_file;
    config.dds_profile = dds.profile;
    config.dds_security = dds.security_dir;
    config.dds_identity = dds.identity;
    return -1;
}

}  // namespace maptune::sdk
