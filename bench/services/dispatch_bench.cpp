// Coordinator throughput: sample_db dispatching one-pair tasks to N analytic workers with zero
// delay, over DDS on loopback, all in this process (one participant per service/worker).
//   dispatch_bench --workers 16 --requests 4
// Reports tasks completed per second and the assignment latency: the time from a worker
// publishing a result to it receiving its next task while work is queued (the round trip
// through sample_db that a worker waits for).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <mutex>

#include "dataset/simulator.hpp"
#include "dataset_server.hpp"
#include "dds/convert.hpp"
#include "dds/domain_lease.hpp"
#include "matcher_worker.hpp"
#include "runtime.hpp"
#include "sample_db.hpp"

namespace fs = std::filesystem;
using namespace maptune;

namespace {

// Records when each of its tasks starts and ends, per worker thread.
class TimedBackend : public services::WorkerBackend {
public:
    TimedBackend(services::DatasetMirror& mirror, const params::ParameterSpace& space)
        : inner_(mirror, space) {}
    std::string matcher_id() const override { return inner_.matcher_id(); }
    std::string matcher_version() const override { return inner_.matcher_version(); }
    const params::ParameterSpace& space() const override { return inner_.space(); }
    services::TaskOutcome run(const services::TaskSpec& t) override {
        const double start = services::now_s();
        {
            std::lock_guard<std::mutex> lock(mutex_);
            if (last_end_ > 0) gaps_.push_back(start - last_end_);
        }
        auto out = inner_.run(t);
        std::lock_guard<std::mutex> lock(mutex_);
        last_end_ = services::now_s();
        ++tasks_;
        return out;
    }
    std::vector<double> gaps() {
        std::lock_guard<std::mutex> lock(mutex_);
        return gaps_;
    }
    std::size_t tasks() {
        std::lock_guard<std::mutex> lock(mutex_);
        return tasks_;
    }

private:
    services::AnalyticBackend inner_;
    std::mutex mutex_;
    double last_end_ = 0;
    std::vector<double> gaps_;
    std::size_t tasks_ = 0;
};

double percentile(std::vector<double> v, double q) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"sample_db dispatch throughput with analytic workers (zero delay)"};
    int n_workers = 16, requests = 4, submaps = 40;
    std::string data = "/tmp/maptune_dispatch_bench_data";
    app.add_option("--workers", n_workers, "analytic workers, 1..128 (default: 16)")->check(CLI::Range(1, 128));
    app.add_option("--requests", requests, "concurrent observation requests (default: 4)");
    app.add_option("--submaps", submaps, "submaps of the one-run dataset: tasks per request = C(n,2) (default: 40)");
    app.add_option("--data", data, "where to generate the dataset (kept between runs)");
    std::string security;
    app.add_option("--dds-security", security, "DDS-Security PKI (scripts/make-pki.sh): measure its cost");
    bool unfiltered = false;
    app.add_flag("--unfiltered-tasks", unfiltered, "workers read every task, not only their own (what the content filter buys)");
    bool no_locality = false;
    app.add_flag("--no-locality", no_locality, "sample_db hands out shards without regard to submaps (what locality costs)");
    std::string profile = "maptune_loopback";
    app.add_option("--dds-profile", profile,
                   "participant profile of the built-in XML, e.g. maptune_loopback_shm (default: maptune_loopback, UDP on 127.0.0.1)");
    CLI11_PARSE(app, argc, argv);

    const fs::path ds_dir = fs::path(data) / ("lab-" + std::to_string(submaps));
    if (!fs::exists(ds_dir / "manifest.yaml")) {
        auto c = dataset::sim_preset("lab-tiny");
        c.runs = 1;
        c.submaps = submaps;
        dataset::generate_dataset(c, ds_dir);
    }
    const auto space = params::ParameterSpace::load(std::string(MAPTUNE_SOURCE_DIR_BENCH) + "/configs/spaces/lru_matcher.yaml");
    const int domain = maptune::dds::lease_random_domain();
    auto participant = [&](const std::string& name, const std::string& role) {
        maptune::dds::ParticipantOptions po{domain, "", profile, name};
        po.security_dir = security;
        po.identity = role;
        return std::make_unique<maptune::dds::Participant>(po);
    };
    const fs::path tmp = fs::temp_directory_path() / ("maptune_dispatch_" + std::to_string(domain));
    fs::remove_all(tmp);
    fs::create_directories(tmp);

    auto server_p = participant("server", "dataset_server");
    services::DatasetServer server(*server_p, {{ds_dir}, 512 * 1024, ""});
    auto db_p = participant("sample_db", "sample_db");
    services::DatasetMirror db_mirror(*db_p, tmp / "cache", "db");
    db_mirror.add_local(ds_dir);
    services::SampleDbOptions o;
    o.store_path = (tmp / "obs.db").string();
    o.spaces = {space};
    o.scheduler.shard_size = 1;  // one pair per task: tasks/s = dispatch rate
    o.scheduler.locality = !no_locality;
    services::SampleDb db(*db_p, db_mirror, o);

    std::vector<std::unique_ptr<maptune::dds::Participant>> ps;
    std::vector<std::unique_ptr<services::DatasetMirror>> mirrors;
    std::vector<std::unique_ptr<TimedBackend>> backends;
    std::vector<std::unique_ptr<services::MatcherWorker>> workers;
    for (int i = 0; i < n_workers; ++i) {
        ps.push_back(participant("w" + std::to_string(i), "worker"));
        mirrors.push_back(std::make_unique<services::DatasetMirror>(*ps.back(), tmp / "cache", "w" + std::to_string(i)));
        mirrors.back()->add_local(ds_dir);
        backends.push_back(std::make_unique<TimedBackend>(*mirrors.back(), space));
        workers.push_back(std::make_unique<services::MatcherWorker>(*ps.back(), *backends.back(),
                                                                    services::WorkerOptions{"w" + std::to_string(i), 1, 0.5, !unfiltered}));
    }
    auto client_p = participant("client", "optimizer");
    std::mutex m;
    int replies = 0;
    const auto replies_sub = client_p->reader<msg::v1::ObservationReplyPubSubType>(maptune::dds::topics::kObservationReply, maptune::dds::TopicQos::kReliable,
                                                         [&](const msg::v1::ObservationReply&) {
                                                             std::lock_guard<std::mutex> lock(m);
                                                             ++replies;
                                                         });
    auto w = client_p->writer<msg::v1::ObservationRequestPubSubType>(maptune::dds::topics::kObservationRequest,
                                                                    maptune::dds::TopicQos::kReliable);
    w.wait_for_readers(1, std::chrono::seconds(30));
    // Let every worker's heartbeat reach sample_db.
    std::this_thread::sleep_for(std::chrono::seconds(2));
    const std::string id = dataset::Dataset::open(ds_dir).manifest().id;
    const double start = services::now_s();
    for (int r = 0; r < requests; ++r) {
        msg::v1::ObservationRequest req;
        req.request_id("bench/" + std::to_string(r));
        req.dataset_id(id);
        req.view("complete");
        req.matcher_id("analytic");
        req.matcher_version("1");
        req.space_hash(space.hash());
        auto p = space.defaults();
        p.set("r_N", 0.1 + 0.01 * (r + domain % 50) + 0.001);  // a fresh key every run
        req.params(maptune::dds::to_msg(p));
        w.write(req);
    }
    services::wait_for([&] { std::lock_guard<std::mutex> lock(m); return replies == requests; }, 600);
    const double elapsed = services::now_s() - start;
    std::size_t tasks = 0;
    std::vector<double> gaps;
    for (auto& b : backends) {
        tasks += b->tasks();
        auto g = b->gaps();
        gaps.insert(gaps.end(), g.begin(), g.end());
    }
    std::cout << "workers " << n_workers << "  tasks " << tasks << "  seconds " << elapsed << "  tasks/s "
              << static_cast<double>(tasks) / elapsed << "  assignment latency p50 " << percentile(gaps, 0.5) * 1e3
              << " ms  p99 " << percentile(gaps, 0.99) * 1e3 << " ms  (replies " << replies << "/" << requests
              << ")" << std::endl;
    workers.clear();
    fs::remove_all(tmp);
    return replies == requests ? 0 : 1;
}
