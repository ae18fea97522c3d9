// The optimizer in-process against a scripted sample_db on a private DDS domain: it must tell
// the model only answers to its own requests for the sets it asked about — never a late reply
// of an earlier life (same experiment name, request numbers from 1 again) nor a reply whose
// parameter set differs from the request's.
#include <gtest/gtest.h>

#include <atomic>
#include <deque>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <random>
#include <set>
#include <thread>

#include "dataset/dataset.hpp"
#include "dataset_mirror.hpp"
#include "dds/convert.hpp"
#include "dds/participant.hpp"
#include "fastdds_shm.hpp"
#include "maptunePubSubTypes.h"
#include "optimizer_service.hpp"
#include "temp_dataset.hpp"
#include "test_domain.hpp"

namespace maptune {
namespace {

namespace fs = std::filesystem;
namespace v1 = msg::v1;
const std::string kSource = MAPTUNE_SOURCE_DIR;

TEST(OptimizerReplies, StaleAndForeignRepliesAreNeverToldToTheModel) {
    const fs::path dir = test::make_temp_dir("maptune_optimizer_replies_");
    const auto shm_before = testing::fastdds_shm_files();
    const fs::path lab = test::generate_tiny_dataset(dir, "lab", 1, 4, 3);
    std::ofstream(dir / "exp.yaml") << "name: replies\nspace: " << kSource << "/configs/spaces/lru_matcher.yaml\n"
                                    << "dataset: " << lab.string() << "\nview: complete\nreference: gt\n"
                                    << "measure: {m_star: 3}\nbudget: {evaluations: 4}\n"
                                    << "optimizer: {seed: 5, initial_points: 2}\n";
    const auto e = experiment::load_experiment((dir / "exp.yaml").string());
    const dataset::Dataset ds = dataset::Dataset::open(lab);
    const auto pairs = ds.pairs(dataset::View::complete, dataset::Reference::gt);
    const int domain = test::reserve_domain();

    // Every pair matched exactly (p > 0) or not at all (p = 0).
    auto results = [&](bool matched) {
        std::vector<store::PairRecord> out;
        for (const auto& p : pairs) {
            store::PairRecord r;
            r.pair_id = p.id_a + "|" + p.id_b;
            r.matched = matched;
            r.T_a_b_est = p.T_a_b.matrix();
            out.push_back(r);
        }
        return dds::to_msg(out);
    };

    std::vector<v1::ObservationRequest> asked;
    {
        // The scripted sample_db and worker announcement.
        dds::Participant fake({domain, "", "maptune_loopback", "fake_sample_db"});
        std::mutex m;
        std::deque<v1::ObservationRequest> queue;
        std::set<std::string> seen;
        const auto requests_sub = fake.reader<v1::ObservationRequestPubSubType>(dds::topics::kObservationRequest, dds::TopicQos::kReliable,
                                                      [&](const v1::ObservationRequest& r) {
                                                          std::lock_guard<std::mutex> lock(m);
                                                          if (seen.insert(r.request_id()).second) queue.push_back(r);
                                                      });
        auto replies = fake.writer<v1::ObservationReplyPubSubType>(dds::topics::kObservationReply, dds::TopicQos::kReliable);
        auto status = fake.writer<v1::WorkerStatusPubSubType>(dds::topics::kWorkerStatus, dds::TopicQos::kLatched);
        v1::WorkerStatus ws;
        ws.worker_id("fake-worker");
        ws.matcher_id("lru_matcher");
        ws.matcher_version("test");
        ws.space_hash(e.space.hash());
        ws.slots(1);
        status.write(ws);

        std::atomic<bool> stop{false};
        std::thread responder([&] {
            while (!stop) {
                std::optional<v1::ObservationRequest> r;
                {
                    std::lock_guard<std::mutex> lock(m);
                    if (!queue.empty()) {
                        r = queue.front();
                        queue.pop_front();
                    }
                }
                if (!r) {
                    std::this_thread::sleep_for(std::chrono::milliseconds(5));
                    continue;
                }
                asked.push_back(*r);
                // 1. A late reply of an earlier life of this optimizer: same experiment and
                //    request number, another incarnation, every pair matched.
                v1::ObservationReply stale;
                std::string id = r->request_id();
                const auto first = id.find('/');
                const auto second = id.find('/', first + 1);
                stale.request_id(id.substr(0, first + 1) + "0ld1ncarnat1/" + id.substr(second + 1));
                stale.ok(true);
                stale.params(r->params());
                stale.pairs(results(true));
                replies.write(stale);
                // 2. Our request id, but another parameter set (r_N moved), every pair matched.
                v1::ObservationReply foreign = stale;
                foreign.request_id(id);
                auto other = dds::from_msg(r->params());
                other.set("r_N", other.get("r_N") < 1.0 ? 1.5 : 0.3);
                foreign.params(dds::to_msg(other));
                replies.write(foreign);
                // 3. The genuine answer: nothing matched.
                v1::ObservationReply genuine;
                genuine.request_id(id);
                genuine.ok(true);
                genuine.params(r->params());
                genuine.pairs(results(false));
                replies.write(genuine);
            }
        });

        services::OptimizerServiceOptions options;
        options.experiment = e;
        options.run_dir = dir / "run";
        options.wait_s = 30;
        options.progress_bar = false;
        std::vector<std::string> log;
        options.log = [&](const std::string& line) { log.push_back(line); };
        services::RunSummary summary;
        {
            // Each life has its own participant, as a process would: a participant outliving
            // its service would call that service's callbacks after it is gone.
            dds::Participant opt_p({domain, "", "maptune_loopback", "optimizer"});
            services::DatasetMirror mirror(opt_p, dir / "cache", "optimizer");
            services::OptimizerService optimizer(opt_p, mirror, options);
            summary = optimizer.run();
        }
        // A second life on the same run directory (resumes the 4, asks 2 more): its request
        // ids must differ from the first life's, though both count from the resumed trials.
        const std::size_t first_life = asked.size();
        options.experiment.max_evaluations = 6;
        services::RunSummary resumed;
        {
            dds::Participant again_p({domain, "", "maptune_loopback", "optimizer2"});
            services::DatasetMirror again_mirror(again_p, dir / "cache", "optimizer2");
            services::OptimizerService optimizer(again_p, again_mirror, options);
            resumed = optimizer.run();
        }
        stop = true;
        responder.join();
        ASSERT_EQ(resumed.evaluations.size(), 6u);
        ASSERT_EQ(asked.size(), 6u);
        auto incarnation = [](const std::string& id) {  // "<experiment>/<incarnation>/<n>"
            const auto a = id.find('/'), b = id.rfind('/');
            return id.substr(a + 1, b - a - 1);
        };
        for (std::size_t i = 0; i < asked.size(); ++i) {
            EXPECT_EQ(incarnation(asked[i].request_id()).size(), 12u) << asked[i].request_id();
            EXPECT_EQ(incarnation(asked[i].request_id()) == incarnation(asked[0].request_id()), i < first_life)
                << asked[i].request_id();
        }
        asked.resize(first_life);

        ASSERT_EQ(summary.evaluations.size(), 4u);
        ASSERT_EQ(asked.size(), 4u);
        for (std::size_t i = 0; i < summary.evaluations.size(); ++i) {
            const auto& rec = summary.evaluations[i];
            EXPECT_FALSE(rec.failed) << rec.error;
            EXPECT_EQ(rec.p, 0.0) << "evaluation " << rec.number << " was told a reply that was not its own";
            EXPECT_EQ(rec.m, 0u);
        }
        // Every told set is one that was asked for, each once.
        std::set<std::string> asked_keys, told_keys;
        for (const auto& r : asked) asked_keys.insert(e.space.canonical_key(e.space.round(e.space.complete(dds::from_msg(r.params())))));
        for (const auto& rec : summary.evaluations) told_keys.insert(e.space.canonical_key(rec.params));
        EXPECT_EQ(asked_keys, told_keys);
        int ignored = 0;
        for (const auto& line : log) ignored += line.find("for another parameter set") != std::string::npos;
        EXPECT_EQ(ignored, 6);  // one foreign reply per request of both lives
    }
    testing::remove_orphaned_fastdds_shm(shm_before);
    fs::remove_all(dir);
}

// Workers started with other matcher settings announce another matcher version: the optimizer
// must not use them (the run's observations would belong to another matcher), and says so.
// Neither a worker of another version that cannot take settings nor one of another code
// revision runs the experiment's matcher; the error names both.
TEST(OptimizerReplies, WorkersThatCannotRunTheExperimentsMatcherAreNotUsed) {
    const fs::path dir = test::make_temp_dir("maptune_optimizer_version_");
    const auto shm_before = testing::fastdds_shm_files();
    const fs::path lab = test::generate_tiny_dataset(dir, "lab", 1, 3, 3);
    std::ofstream(dir / "exp.yaml") << "name: version\nspace: " << kSource << "/configs/spaces/lru_matcher.yaml\n"
                                    << "dataset: " << lab.string() << "\nmeasure: {m_star: 3}\nbudget: {evaluations: 2}\n";
    const auto e = experiment::load_experiment((dir / "exp.yaml").string());
    const int domain = test::reserve_domain();
    {
        dds::Participant fake({domain, "", "maptune_loopback", "fake_worker"});
        auto status = fake.writer<v1::WorkerStatusPubSubType>(dds::topics::kWorkerStatus, dds::TopicQos::kLatched);
        v1::WorkerStatus ws;
        ws.worker_id("w-defaults");
        ws.matcher_id("lru_matcher");
        ws.matcher_version("3-aaaaaaaa");
        ws.space_hash(e.space.hash());
        ws.slots(1);
        status.write(ws);
        ws.worker_id("w-old-code");
        ws.matcher_version("2-cccccccc");
        ws.takes_settings(true);
        status.write(ws);

        services::OptimizerServiceOptions options;
        options.experiment = e;
        options.run_dir = dir / "run";
        options.wait_s = 2;
        options.progress_bar = false;
        options.matcher_version = "3-bbbbbbbb";
        options.matcher_settings = {"min_ransac_inliers=0"};
        options.log = [](const std::string&) {};
        dds::Participant opt_p({domain, "", "maptune_loopback", "optimizer"});
        services::DatasetMirror mirror(opt_p, dir / "cache", "optimizer");
        services::OptimizerService optimizer(opt_p, mirror, options);
        try {
            optimizer.run();
            FAIL() << "ran with a worker of another matcher version";
        } catch (const std::runtime_error& err) {
            const std::string what = err.what();
            EXPECT_NE(what.find("no matcher worker for matcher 'lru_matcher' version 3-bbbbbbbb"), std::string::npos) << what;
            EXPECT_NE(what.find("w-defaults (version 3-aaaaaaaa)"), std::string::npos) << what;
            EXPECT_NE(what.find("w-old-code (version 2-cccccccc)"), std::string::npos) << what;
            EXPECT_NE(what.find("--experiment"), std::string::npos) << what;
        }
    }
    testing::remove_orphaned_fastdds_shm(shm_before);
    fs::remove_all(dir);
}

}  // namespace
}  // namespace maptune
