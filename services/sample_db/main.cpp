// maptune_sample_db: the observation store's only writer; coordinates workers.
#include <CLI/CLI.hpp>
#include <iostream>
#include <thread>

#include "dds_options.hpp"
#include "runtime.hpp"
#include "sample_db.hpp"

int main(int argc, char** argv) {
    using namespace maptune::services;
    CLI::App app{"maptune sample_db: answers observation requests from the store or the workers"};
    maptune::dds::ParticipantOptions dds{0, "", "maptune_loopback", "sample_db"};
    SampleDbOptions options;
    options.log = [](const std::string& line) { std::cerr << "sample_db: " << line << std::endl; };
    std::vector<std::string> spaces = {"configs/spaces/lru_matcher.yaml"};
    std::string cache = "/tmp/maptune-cache";
    app.add_option("--db", options.store_path, "observation store (SQLite), created when absent")->required();
    app.add_option("--space", spaces, "accepted design space YAML, repeatable (default: configs/spaces/lru_matcher.yaml)");
    app.add_option("--lease", options.scheduler.lease_s, "seconds of worker silence before its shards move (default: 10)");
    app.add_option("--shard-size", options.scheduler.shard_size, "pairs per task, 0 = one task per request (default: 8)");
    bool no_locality = false;
    app.add_flag("--no-locality", no_locality,
                 "hand out shards of consecutive pairs oldest first, without regard to the submaps workers hold (for measuring what locality gains)");
    app.add_option("--unserved-timeout", options.scheduler.unserved_timeout_s,
                   "seconds a request may wait with no worker for its matcher and space before it is answered with an error, <= 0 = forever (default: 300)");
    app.add_option("--cache", cache, "directory for fetched dataset metadata (default: /tmp/maptune-cache)");
    add_dds_options(app, dds, "sample_db");
    CLI11_PARSE(app, argc, argv);
    options.scheduler.locality = !no_locality;
    install_stop_signals();
    try {
        for (const auto& s : spaces) options.spaces.push_back(maptune::params::ParameterSpace::load(s));
        maptune::dds::Participant participant(dds);
        DatasetMirror mirror(participant, cache, make_id("sample_db"));
        SampleDb db(participant, mirror, options);
        std::cout << "sample_db ready on domain " << dds.domain_id << ", store " << options.store_path << std::endl;
        while (!stop_requested()) std::this_thread::sleep_for(std::chrono::milliseconds(50));
        const auto s = db.stats();
        std::cout << "stopping: " << s.requests << " requests, " << s.from_store << " from the store, "
                  << s.evaluated << " evaluated, " << s.refused << " refused" << std::endl;
    } catch (const std::exception& e) {
        std::cerr << "sample_db: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
