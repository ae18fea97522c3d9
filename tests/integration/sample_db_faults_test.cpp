// sample_db in-process against a scripted worker on a private DDS domain: a broken result
// (NaN transform) is a failed attempt that runs again, and answers with timeouts reach the
// requester but are not kept — a later request runs the matcher again, and only then is
// the observation stored; a shard that fails on every attempt and a request no worker can
// serve are answered with an error (never FAILED pairs scored as the matcher's answer).
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <deque>
#include <filesystem>
#include <fstream>
#include <limits>
#include <mutex>
#include <random>
#include <thread>

#include "dataset/dataset.hpp"
#include "dataset_mirror.hpp"
#include "dds/convert.hpp"
#include "dds/participant.hpp"
#include "fastdds_shm.hpp"
#include "maptunePubSubTypes.h"
#include "runtime.hpp"
#include "dataset_server.hpp"
#include "sample_db.hpp"
#include "temp_dataset.hpp"
#include "test_domain.hpp"

namespace maptune {
namespace {

namespace fs = std::filesystem;
namespace v1 = msg::v1;
const std::string kSource = MAPTUNE_SOURCE_DIR;
using namespace std::chrono_literals;

// The fake worker's heartbeat: one lru_matcher slot of version "test" for `space_hash`, listing
// the tasks it holds as the real worker does, so that a task sent before its reader matched
// is sent again after a few seconds instead of waiting out the lease (a flaky test under load).
template <class Writer>
void heartbeat(Writer& status, const std::string& space_hash, std::uint64_t sequence,
               const std::deque<v1::EvaluationTask>& queue, std::mutex& m) {
    v1::WorkerStatus ws;
    ws.worker_id("w1");
    ws.matcher_id("lru_matcher");
    ws.matcher_version("test");
    ws.space_hash(space_hash);
    ws.slots(1);
    ws.sequence_number(sequence);
    ws.lists_tasks(true);
    std::vector<std::string> held;
    {
        std::lock_guard<std::mutex> lock(m);
        for (const auto& t : queue) held.push_back(t.task_id());
    }
    ws.tasks(held);
    status.write(ws);
}

// Stops and joins a test's worker thread however the test body ends (a failed ASSERT returns
// early; a joinable std::thread would then abort the whole test binary).
struct JoinOnExit {
    std::atomic<bool>& stop;
    std::thread& thread;
    ~JoinOnExit() {
        stop = true;
        if (thread.joinable()) thread.join();
    }
};

template <class Pred>
bool poll(Pred pred, double timeout_s) {
    const double end = services::now_s() + timeout_s;
    while (!pred()) {
        if (services::now_s() > end) return false;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return true;
}

TEST(SampleDbFaults, BrokenResultsRunAgainAndTimeoutsAreNotStored) {
    const fs::path dir = test::make_temp_dir("maptune_sample_db_faults_");
    const auto shm_before = testing::fastdds_shm_files();
    const fs::path lab = test::generate_tiny_dataset(dir, "lab", 1, 3, 4);
    const auto space = params::ParameterSpace::load(kSource + "/configs/spaces/lru_matcher.yaml");
    const dataset::Dataset ds = dataset::Dataset::open(lab);
    const int domain = test::reserve_domain();

    // What the worker answers, task by task: NaN, then good; timeouts, then good.
    enum class Answer { kNan, kGood, kTimeout, kFail };
    const std::vector<Answer> script{Answer::kNan,  Answer::kGood, Answer::kTimeout, Answer::kGood,
                                     Answer::kFail, Answer::kFail, Answer::kFail};
    std::vector<v1::EvaluationTask> tasks_seen;
    std::vector<v1::ObservationReply> replies;
    std::mutex m;
    {
        dds::Participant db_p({domain, "", "maptune_loopback", "sample_db"});
        services::DatasetMirror mirror(db_p, dir / "cache", "sample_db");
        mirror.add_local(lab);
        services::SampleDbOptions options;
        options.store_path = (dir / "obs.db").string();
        options.spaces = {space};
        options.scheduler.shard_size = 0;
        options.scheduler.lease_s = 30;
        options.scheduler.unserved_timeout_s = 1;
        std::vector<std::string> log;  // written on sample_db's thread while the test reads it
        std::mutex log_m;
        options.log = [&](const std::string& line) {
            std::lock_guard<std::mutex> lock(log_m);
            log.push_back(line);
        };
        services::SampleDb db(db_p, mirror, options);

        dds::Participant worker_p({domain, "", "maptune_loopback", "worker"});
        std::deque<v1::EvaluationTask> queue;
        const auto tasks_sub = worker_p.reader<v1::EvaluationTaskPubSubType>(dds::topics::kEvaluationTask, dds::TopicQos::kReliable,
                                                      [&](const v1::EvaluationTask& t) {
                                                          std::lock_guard<std::mutex> lock(m);
                                                          queue.push_back(t);
                                                      });
        auto results = worker_p.writer<v1::TaskResultPubSubType>(dds::topics::kTaskResult, dds::TopicQos::kReliable);
        auto status = worker_p.writer<v1::WorkerStatusPubSubType>(dds::topics::kWorkerStatus, dds::TopicQos::kLatched);
        dds::Participant client_p({domain, "", "maptune_loopback", "client"});
        const auto replies_sub = client_p.reader<v1::ObservationReplyPubSubType>(dds::topics::kObservationReply, dds::TopicQos::kReliable,
                                                        [&](const v1::ObservationReply& r) {
                                                            std::lock_guard<std::mutex> lock(m);
                                                            replies.push_back(r);
                                                        });
        auto requests = client_p.writer<v1::ObservationRequestPubSubType>(dds::topics::kObservationRequest,
                                                                          dds::TopicQos::kReliable);
        ASSERT_TRUE(requests.wait_for_readers(1, 15s));

        std::atomic<bool> stop{false};
        std::thread worker([&] {
            std::size_t answered = 0;
            std::uint64_t beat = 0;
            double last_beat = -1;
            while (!stop) {
                if (services::now_s() - last_beat > 0.2) {
                    heartbeat(status, space.hash(), ++beat, queue, m);
                    last_beat = services::now_s();
                }
                std::optional<v1::EvaluationTask> t;
                {
                    std::lock_guard<std::mutex> lock(m);
                    if (!queue.empty()) {
                        t = queue.front();
                        queue.pop_front();
                        tasks_seen.push_back(*t);
                    }
                }
                if (!t) {
                    std::this_thread::sleep_for(std::chrono::milliseconds(5));
                    continue;
                }
                const Answer a = answered < script.size() ? script[answered] : Answer::kGood;
                ++answered;
                std::vector<store::PairRecord> pairs;
                for (const auto& id : t->pair_ids()) {
                    store::PairRecord r;
                    r.pair_id = id;
                    r.matched = a != Answer::kTimeout;
                    r.status = a == Answer::kTimeout ? store::PairStatus::kTimeout : store::PairStatus::kOk;
                    if (a == Answer::kNan) r.T_a_b_est(0, 3) = std::numeric_limits<double>::quiet_NaN();
                    pairs.push_back(r);
                }
                v1::TaskResult res;
                res.task_id(t->task_id());
                res.worker_id("w1");
                res.ok(a != Answer::kFail);
                if (a == Answer::kFail) {
                    res.error("cannot load submap run00/submap001");
                } else {
                    res.pairs(dds::to_msg(pairs));
                }
                results.write(res);
            }
        });
        const JoinOnExit join_worker{stop, worker};

        auto ask = [&](const std::string& id, double r_n, const std::string& matcher = "lru_matcher",
                       const std::string& view = "complete") {
            v1::ObservationRequest req;
            req.request_id(id);
            req.requester("test");
            req.dataset_id(ds.manifest().id);
            req.view(view);
            req.matcher_id(matcher);
            req.matcher_version("test");
            req.space_hash(space.hash());
            req.params(dds::to_msg(params::ParameterSet{{"r_N", r_n}}));
            requests.write(req);
        };
        auto reply_to = [&](const std::string& id) -> std::optional<v1::ObservationReply> {
            std::optional<v1::ObservationReply> out;
            poll([&] {
                std::lock_guard<std::mutex> lock(m);
                for (const auto& r : replies) {
                    if (r.request_id() == id) out = r;
                }
                return out.has_value();
            }, 30);
            return out;
        };

        // A NaN result is a failed attempt: the shard runs again, and the stored answer is finite.
        ask("r1", 0.3);
        const auto r1 = reply_to("r1");
        ASSERT_TRUE(r1.has_value());
        EXPECT_TRUE(r1->ok()) << r1->error();
        for (const auto& p : dds::from_msg(r1->pairs())) {
            EXPECT_TRUE(p.matched);
            EXPECT_TRUE(p.T_a_b_est.allFinite());
        }
        EXPECT_EQ(tasks_seen.size(), 2u);
        // Timeouts: answered, not kept; asked again, the matcher runs again and now it is kept.
        ask("r2", 0.5);
        const auto r2 = reply_to("r2");
        ASSERT_TRUE(r2.has_value());
        ASSERT_TRUE(r2->ok());
        EXPECT_FALSE(r2->from_store());
        for (const auto& p : dds::from_msg(r2->pairs())) EXPECT_EQ(p.status, store::PairStatus::kTimeout);
        ask("r3", 0.5);
        const auto r3 = reply_to("r3");
        ASSERT_TRUE(r3.has_value());
        EXPECT_FALSE(r3->from_store());
        EXPECT_EQ(tasks_seen.size(), 4u);
        for (const auto& p : dds::from_msg(r3->pairs())) EXPECT_TRUE(p.matched);
        ask("r4", 0.5);
        const auto r4 = reply_to("r4");
        ASSERT_TRUE(r4.has_value());
        EXPECT_TRUE(r4->from_store());
        EXPECT_EQ(tasks_seen.size(), 4u);
        // A shard that fails on every attempt: the requester hears the failure (its FAILED pairs
        // are not the matcher's answer about these parameters) and nothing is stored.
        ask("r5", 0.7);
        const auto r5 = reply_to("r5");
        ASSERT_TRUE(r5.has_value());
        EXPECT_FALSE(r5->ok());
        EXPECT_NE(r5->error().find("a shard failed 3 times: cannot load submap run00/submap001"), std::string::npos)
            << r5->error();
        EXPECT_EQ(tasks_seen.size(), 7u);
        // A matcher no worker serves: an error after the unserved timeout, not a wait forever.
        ask("r6", 0.9, "nobodys_matcher");
        const auto r6 = reply_to("r6");
        ASSERT_TRUE(r6.has_value());
        EXPECT_FALSE(r6->ok());
        EXPECT_NE(r6->error().find("no worker serves matcher 'nobodys_matcher'"), std::string::npos) << r6->error();
        EXPECT_EQ(tasks_seen.size(), 7u);
        // sample_db counts a job after answering it: wait for the count of the last one.
        EXPECT_TRUE(poll([&] { return db.stats().not_stored == 3u; }, 10)) << db.stats().not_stored;
        const auto stats = db.stats();
        EXPECT_EQ(stats.stored, 2u);
        EXPECT_EQ(stats.not_stored, 3u);
        // Both faults were said (every reply is out, so the loop has written its lines).
        int invalid = 0, not_stored = 0;
        std::vector<std::string> lines;
        {
            std::lock_guard<std::mutex> lock(log_m);
            lines = log;
        }
        for (const auto& line : lines) {
            // The NaN is refused at the boundary (dds::check), then the task counts as failed.
            invalid += line.find("refused a task_result message from 'w1': pairs.t_a_b: not a finite number") !=
                       std::string::npos;
            not_stored += line.find("not stored: pairs timed out") != std::string::npos;
        }
        EXPECT_EQ(invalid, 1);
        EXPECT_EQ(not_stored, 1);

        // Multi-fidelity (issue 16 item 2): the whole view after its subset runs only the other
        // pairs; a subset of a stored view runs none; a subset view that is not one is refused.
        auto pairs_sent = [&] {
            std::lock_guard<std::mutex> lock(m);
            std::size_t n = 0;
            for (const auto& t : tasks_seen) n += t.pair_ids().size();
            return n;
        };
        const std::size_t view_pairs = ds.pairs(dataset::View::complete, dataset::Reference::gt).size();
        const std::size_t subset_pairs = ds.pairs(dataset::parse_view_spec("complete/3"), dataset::Reference::gt).size();
        ASSERT_LT(subset_pairs, view_pairs);
        const std::size_t before = pairs_sent();
        ask("s1", 0.25, "lru_matcher", "complete/3");
        const auto s1 = reply_to("s1");
        ASSERT_TRUE(s1.has_value() && s1->ok());
        EXPECT_EQ(s1->pairs().size(), subset_pairs);
        EXPECT_EQ(pairs_sent() - before, subset_pairs);
        ask("s2", 0.25);
        const auto s2 = reply_to("s2");
        ASSERT_TRUE(s2.has_value() && s2->ok());
        EXPECT_EQ(s2->pairs().size(), view_pairs);
        EXPECT_EQ(pairs_sent() - before, view_pairs) << "the subset's pairs were not computed again";
        ask("s3", 0.25, "lru_matcher", "complete/2");
        const auto s3 = reply_to("s3");
        ASSERT_TRUE(s3.has_value() && s3->ok());
        EXPECT_TRUE(s3->from_store());
        EXPECT_EQ(pairs_sent() - before, view_pairs);
        ask("s4", 0.25, "lru_matcher", "complete/1");
        const auto s4 = reply_to("s4");
        ASSERT_TRUE(s4.has_value());
        EXPECT_FALSE(s4->ok());
        EXPECT_NE(s4->error().find("complete/1"), std::string::npos) << s4->error();
        stop = true;
        worker.join();
    }
    const store::ObservationStore check((dir / "obs.db").string());
    EXPECT_EQ(check.count(), 5u);
    testing::remove_orphaned_fastdds_shm(shm_before);
    fs::remove_all(dir);
}

}  // namespace
}  // namespace maptune

namespace maptune {
namespace {

// Observations are stored under the dataset's content id: a dataset_server must not serve a
// dataset whose files no longer match it.
TEST(DatasetServerFaults, RefusesADatasetWhoseFilesChanged) {
    const fs::path dir = test::make_temp_dir("maptune_dataset_server_faults_");
    const fs::path lab = test::generate_tiny_dataset(dir, "lab", 1, 2, 4);
    const int domain = test::reserve_domain();
    dds::Participant p({domain, "", "maptune_loopback", "dataset_server"});
    { services::DatasetServer intact(p, {{lab.string()}, 0, ""}); }
    const dataset::Dataset ds = dataset::Dataset::open(lab);
    std::ofstream(lab / ds.manifest().runs[0].submaps[1].cloud, std::ios::app) << "x";
    try {
        services::DatasetServer changed(p, {{lab.string()}, 0, ""});
        ADD_FAILURE() << "served a changed dataset";
    } catch (const dataset::DatasetError& e) {
        EXPECT_NE(std::string(e.what()).find("files changed since the manifest"), std::string::npos) << e.what();
    }
    fs::remove_all(dir);
}

// One dataset_server per dataset on one domain: a server stays silent about datasets it does
// not serve. It used to answer "unknown dataset", and a client whose request reached that
// server first failed although the other server had the files.
TEST(DatasetServerFaults, TwoServersOnOneDomainEachServeTheirOwn) {
    const fs::path dir = test::make_temp_dir("maptune_dataset_servers_");
    const auto shm_before = testing::fastdds_shm_files();
    const fs::path a = test::generate_tiny_dataset(dir, "a", 1, 2, 4);
    const fs::path b = test::generate_tiny_dataset(dir, "b", 1, 2, 5);
    const int domain = test::reserve_domain();
    {
        dds::Participant pa({domain, "", "maptune_loopback", "server_a"});
        dds::Participant pb({domain, "", "maptune_loopback", "server_b"});
        services::DatasetServer sa(pa, {{a.string()}, 64 * 1024, "a"});
        services::DatasetServer sb(pb, {{b.string()}, 64 * 1024, "b"});
        dds::Participant pc({domain, "", "maptune_loopback", "client"});
        services::DatasetMirror mirror(pc, dir / "cache", "client");
        for (const fs::path& d : {a, b}) {
            const std::string id = dataset::Dataset::open(d).manifest().id;
            std::string error;
            const auto ds = mirror.open(id, 60, &error);
            ASSERT_TRUE(ds.has_value()) << d << ": " << error;
            EXPECT_EQ(ds->manifest().id, id);
        }
        EXPECT_EQ(sa.requests_refused(), 0u);
        EXPECT_EQ(sb.requests_refused(), 0u);
    }
    testing::remove_orphaned_fastdds_shm(shm_before);
    fs::remove_all(dir);
}

}  // namespace
}  // namespace maptune

namespace maptune {
namespace {

// sample_db's loop used to fetch a dataset's metadata itself, blocking up to its dataset
// timeout (30 s) while heartbeats, results and every other request waited. A dataset_server
// that announces a dataset and then never answers must not stop the service.
TEST(SampleDbFaults, AHungDatasetTransferDoesNotStopOtherRequests) {
    const fs::path dir = test::make_temp_dir("maptune_sample_db_hung_");
    const auto shm_before = testing::fastdds_shm_files();
    const fs::path served = test::generate_tiny_dataset(dir, "served", 1, 2, 5);
    const fs::path hung = test::generate_tiny_dataset(dir, "hung", 1, 2, 6);
    const auto space = params::ParameterSpace::load(kSource + "/configs/spaces/lru_matcher.yaml");
    const std::string served_id = dataset::Dataset::open(served).manifest().id;
    const std::string hung_id = dataset::Dataset::open(hung).manifest().id;
    const int domain = test::reserve_domain();
    std::mutex m;
    std::vector<v1::ObservationReply> replies;
    {
        // A "dataset_server" that announces `hung` and never sends a chunk.
        dds::Participant fake_server({domain, "", "maptune_loopback", "mute_server"});
        auto announce = fake_server.writer<v1::DatasetAnnouncementPubSubType>(dds::topics::kDatasetAnnouncement,
                                                                              dds::TopicQos::kLatched);
        v1::DatasetAnnouncement a;
        a.dataset_id(hung_id);
        a.name("hung");
        a.server_id("mute");
        a.files(services::list_dataset_files(hung));
        announce.write(a);

        dds::Participant db_p({domain, "", "maptune_loopback", "sample_db"});
        services::DatasetMirror mirror(db_p, dir / "cache", "sample_db");
        mirror.add_local(served);
        services::SampleDbOptions options;
        options.store_path = (dir / "obs.db").string();
        options.spaces = {space};
        options.scheduler.shard_size = 0;
        services::SampleDb db(db_p, mirror, options);
        ASSERT_TRUE(poll([&] {
            const auto known = mirror.known();
            return std::find(known.begin(), known.end(), hung_id) != known.end();
        }, 15));

        // A worker that answers every task at once.
        dds::Participant worker_p({domain, "", "maptune_loopback", "worker"});
        std::deque<v1::EvaluationTask> queue;
        const auto tasks_sub = worker_p.reader<v1::EvaluationTaskPubSubType>(
            dds::topics::kEvaluationTask, dds::TopicQos::kReliable, [&](const v1::EvaluationTask& t) {
                std::lock_guard<std::mutex> lock(m);
                queue.push_back(t);
            });
        auto results = worker_p.writer<v1::TaskResultPubSubType>(dds::topics::kTaskResult, dds::TopicQos::kReliable);
        auto status = worker_p.writer<v1::WorkerStatusPubSubType>(dds::topics::kWorkerStatus, dds::TopicQos::kLatched);
        dds::Participant client_p({domain, "", "maptune_loopback", "client"});
        const auto replies_sub = client_p.reader<v1::ObservationReplyPubSubType>(
            dds::topics::kObservationReply, dds::TopicQos::kReliable, [&](const v1::ObservationReply& r) {
                std::lock_guard<std::mutex> lock(m);
                replies.push_back(r);
            });
        auto requests = client_p.writer<v1::ObservationRequestPubSubType>(dds::topics::kObservationRequest,
                                                                          dds::TopicQos::kReliable);
        ASSERT_TRUE(requests.wait_for_readers(1, 15s));
        std::atomic<bool> stop{false};
        std::thread worker([&] {
            double last_beat = -1;
            std::uint64_t beat = 0;
            while (!stop) {
                if (services::now_s() - last_beat > 0.2) {
                    heartbeat(status, space.hash(), ++beat, queue, m);
                    last_beat = services::now_s();
                }
                std::optional<v1::EvaluationTask> t;
                {
                    std::lock_guard<std::mutex> lock(m);
                    if (!queue.empty()) {
                        t = queue.front();
                        queue.pop_front();
                    }
                }
                if (!t) {
                    std::this_thread::sleep_for(std::chrono::milliseconds(5));
                    continue;
                }
                std::vector<store::PairRecord> pairs(t->pair_ids().size());
                for (std::size_t i = 0; i < pairs.size(); ++i) pairs[i].pair_id = t->pair_ids()[i];
                v1::TaskResult res;
                res.task_id(t->task_id());
                res.worker_id("w1");
                res.ok(true);
                res.pairs(dds::to_msg(pairs));
                results.write(res);
            }
        });
        const JoinOnExit join_worker{stop, worker};
        auto ask = [&](const std::string& id, const std::string& dataset_id) {
            v1::ObservationRequest req;
            req.request_id(id);
            req.requester("test");
            req.dataset_id(dataset_id);
            req.view("complete");
            req.matcher_id("lru_matcher");
            req.matcher_version("test");
            req.space_hash(space.hash());
            req.params(dds::to_msg(params::ParameterSet{{"r_N", 0.3}}));
            requests.write(req);
        };
        ask("stuck", hung_id);  // its metadata never comes
        const double asked = services::now_s();
        ask("fine", served_id);
        const bool answered = poll([&] {
            std::lock_guard<std::mutex> lock(m);
            for (const auto& r : replies) {
                if (r.request_id() == "fine") return true;
            }
            return false;
        }, 25);
        const double took = services::now_s() - asked;
        stop = true;
        worker.join();
        ASSERT_TRUE(answered) << "the other request was never answered";
        // Blocking in the loop would take the whole dataset timeout (30 s); a few seconds is
        // generous for a loaded CI machine.
        EXPECT_LT(took, 10.0) << "the loop waited for the hung transfer";
        std::lock_guard<std::mutex> lock(m);
        for (const auto& r : replies) EXPECT_NE(r.request_id(), "stuck") << r.error();
    }
    testing::remove_orphaned_fastdds_shm(shm_before);
    fs::remove_all(dir);
}

}  // namespace
}  // namespace maptune
