#include "scheduler/scheduler.hpp"

#include <gtest/gtest.h>

#include <map>
#include <random>
#include <set>

namespace maptune::scheduler {
namespace {

JobSpec job(std::size_t pairs, const std::string& space = "S1") {
    JobSpec s;
    s.dataset_id = "ds";
    s.view = "complete";
    s.matcher_id = "lru_matcher";
    s.matcher_version = "1";
    s.space_hash = space;
    s.params = {{"r_N", 0.2}};
    for (std::size_t i = 0; i < pairs; ++i) s.pair_ids.push_back("p" + std::to_string(i));
    return s;
}

WorkerInfo worker(const std::string& id, int slots = 1, const std::string& space = "S1") {
    return {id, "lru_matcher", "1", space, slots};
}

// What a deterministic worker returns: pair i matched with x-translation i.
std::vector<store::PairRecord> results_for(const Assignment& a) {
    std::vector<store::PairRecord> out;
    for (const auto& id : a.pair_ids) {
        store::PairRecord r;
        r.pair_id = id;
        r.matched = true;
        r.T_a_b_est(0, 3) = std::stod(id.substr(1));
        out.push_back(r);
    }
    return out;
}

TEST(Scheduler, SplitsIntoShardsAndSpreadsOverWorkers) {
    Scheduler s({10.0, 4, 3});
    s.heartbeat(worker("w1"), 0);
    s.heartbeat(worker("w2"), 0);
    s.heartbeat(worker("w3", 2), 0);
    EXPECT_TRUE(s.submit("k1", job(10), "opt", 0));
    const auto a = s.schedule(0);
    ASSERT_EQ(a.size(), 3u);  // 10 pairs / 4 = 3 shards
    std::map<std::string, int> per_worker;
    for (const auto& x : a) per_worker[x.worker_id]++;
    EXPECT_EQ(per_worker.size(), 3u) << "least loaded first: every worker gets one";
    EXPECT_EQ(a[0].pair_ids, (std::vector<std::string>{"p0", "p1", "p2", "p3"}));
    EXPECT_EQ(a[2].pair_ids, (std::vector<std::string>{"p8", "p9"}));
    EXPECT_EQ(s.free_slots(), 1);
    std::optional<CompletedJob> done;
    for (const auto& x : a) {
        EXPECT_FALSE(done.has_value());
        done = s.complete(x.task_id, x.worker_id, results_for(x), 1);
    }
    ASSERT_TRUE(done.has_value());
    EXPECT_EQ(done->job_key, "k1");
    ASSERT_EQ(done->pairs.size(), 10u);
    for (std::size_t i = 0; i < 10; ++i) {
        EXPECT_EQ(done->pairs[i].pair_id, "p" + std::to_string(i));
        EXPECT_EQ(done->pairs[i].T_a_b_est(0, 3), static_cast<double>(i));
    }
    EXPECT_EQ(s.jobs(), 0u);
    EXPECT_EQ(s.running_shards(), 0u);
}

TEST(Scheduler, QueuesWhenNoSlotIsFreeAndRespectsSlots) {
    Scheduler s({10.0, 1, 3});
    s.heartbeat(worker("w1", 2), 0);
    s.submit("k", job(5), "opt", 0);
    auto a = s.schedule(0);
    EXPECT_EQ(a.size(), 2u);
    EXPECT_EQ(s.queued_shards(), 3u);
    EXPECT_TRUE(s.schedule(0).empty());
    s.complete(a[0].task_id, "w1", results_for(a[0]), 1);
    a = s.schedule(1);
    ASSERT_EQ(a.size(), 1u);
    EXPECT_EQ(a[0].pair_ids[0], "p2");  // FIFO
}

TEST(Scheduler, OnlyCompatibleWorkersGetTasks) {
    Scheduler s;
    s.heartbeat(worker("other_space", 4, "S2"), 0);
    WorkerInfo other_matcher = worker("other_matcher", 4);
    other_matcher.matcher_id = "analytic";
    s.heartbeat(other_matcher, 0);
    s.submit("k", job(3), "opt", 0);
    EXPECT_TRUE(s.schedule(0).empty());
    WorkerInfo old_version = worker("old_version");
    old_version.matcher_version = "0";
    s.heartbeat(old_version, 0.5);
    s.heartbeat(worker("good"), 0.5);
    const auto a = s.schedule(0.5);
    ASSERT_EQ(a.size(), 1u);
    EXPECT_EQ(a[0].worker_id, "good");
}

// Issue 12: a job carrying its matcher settings runs on any worker that takes settings and
// shares the version's code revision; without settings, only on workers of that exact version.
TEST(Scheduler, WorkersThatTakeSettingsRunJobsOfTheirRevision) {
    auto versioned = [](const std::string& id, const std::string& version, bool takes) {
        WorkerInfo w = worker(id);
        w.matcher_version = version;
        w.takes_settings = takes;
        return w;
    };
    Scheduler s;
    s.heartbeat(versioned("fixed", "3-aaaaaaaa", false), 0);
    s.heartbeat(versioned("old_code", "2-bbbbbbbb", true), 0);
    JobSpec bare = job(1);
    bare.matcher_version = "3-bbbbbbbb";
    s.submit("bare", bare, "opt", 0);
    EXPECT_TRUE(s.schedule(0).empty()) << "no worker has 3-bbbbbbbb and the job carries no settings";
    s.heartbeat(versioned("takes", "3-aaaaaaaa", true), 0.1);
    EXPECT_TRUE(s.schedule(0.1).empty()) << "settings are needed to run another version";
    JobSpec carried = bare;
    carried.matcher_settings = {"min_ransac_inliers=0"};
    s.submit("carried", carried, "opt", 0.2);
    const auto a = s.schedule(0.2);
    ASSERT_EQ(a.size(), 1u);
    EXPECT_EQ(a[0].worker_id, "takes");
    EXPECT_EQ(a[0].job_key, "carried");
    EXPECT_EQ(a[0].job->matcher_settings, carried.matcher_settings);
    EXPECT_EQ(code_revision("3-bbbbbbbb"), "3");
    EXPECT_EQ(code_revision("1"), "1");
}

TEST(Scheduler, DuplicateConcurrentRequestsRunOnce) {
    Scheduler s({10.0, 0, 3});
    s.heartbeat(worker("w1", 4), 0);
    EXPECT_TRUE(s.submit("k", job(3), "opt-a", 0));
    EXPECT_FALSE(s.submit("k", job(3), "opt-b", 0.1));
    const auto a = s.schedule(0.1);
    ASSERT_EQ(a.size(), 1u);
    EXPECT_FALSE(s.submit("k", job(3), "opt-c", 0.2));
    EXPECT_FALSE(s.submit("k", job(3), "opt-b", 0.3));  // a re-sent request: still one answer
    EXPECT_TRUE(s.schedule(0.2).empty());
    const auto done = s.complete(a[0].task_id, "w1", results_for(a[0]), 1);
    ASSERT_TRUE(done.has_value());
    EXPECT_EQ(done->requesters, (std::vector<std::string>{"opt-a", "opt-b", "opt-c"}));
    // After completion the same key is a new job again (sample_db answers it from the store).
    EXPECT_TRUE(s.submit("k", job(3), "opt-d", 2));
}

TEST(Scheduler, SilentWorkerLosesItsShardAndTheResultEqualsAnUninterruptedRun) {
    Scheduler s({5.0, 2, 3});
    s.heartbeat(worker("w1"), 0);
    s.heartbeat(worker("w2"), 0);
    s.submit("k", job(4), "opt", 0);
    const auto a = s.schedule(0);
    ASSERT_EQ(a.size(), 2u);
    const Assignment& dead = a[0].worker_id == "w1" ? a[0] : a[1];
    const Assignment& alive = a[0].worker_id == "w1" ? a[1] : a[0];
    // w1 dies: no more heartbeats. w2 delivers and keeps heart-beating.
    EXPECT_FALSE(s.complete(alive.task_id, "w2", results_for(alive), 1).has_value());
    for (double t = 1; t <= 5; t += 1) {
        s.heartbeat(worker("w2"), t);
        EXPECT_TRUE(s.schedule(t).empty()) << "re-assigned before the lease ran out, t=" << t;
    }
    s.heartbeat(worker("w2"), 6);
    const auto re = s.schedule(6);
    ASSERT_EQ(re.size(), 1u);
    EXPECT_EQ(re[0].worker_id, "w2");
    EXPECT_EQ(re[0].pair_ids, dead.pair_ids);
    EXPECT_EQ(re[0].attempt, 2);
    // The dead worker's late result is ignored now that w2 holds the lease.
    EXPECT_FALSE(s.complete(dead.task_id, "w1", results_for(dead), 6.5).has_value());
    const auto done = s.complete(re[0].task_id, "w2", results_for(re[0]), 7);
    ASSERT_TRUE(done.has_value());
    for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(done->pairs[i].T_a_b_est(0, 3), static_cast<double>(i));
}

TEST(Scheduler, LateResultOfARequeuedShardIsAccepted) {
    Scheduler s({1.0, 0, 3});
    s.heartbeat(worker("w1"), 0);
    s.submit("k", job(2), "opt", 0);
    const auto a = s.schedule(0);
    ASSERT_EQ(a.size(), 1u);
    EXPECT_TRUE(s.schedule(2).empty());  // w1 silent: shard queued, nobody to take it
    EXPECT_EQ(s.queued_shards(), 1u);
    const auto done = s.complete(a[0].task_id, "w1", results_for(a[0]), 2.5);
    ASSERT_TRUE(done.has_value());
    EXPECT_EQ(s.queued_shards(), 0u);
}

TEST(Scheduler, FailedShardsRetryThenReportFailedPairs) {
    Scheduler s({10.0, 0, 2});
    s.heartbeat(worker("w1"), 0);
    s.submit("k", job(3), "opt", 0);
    auto a = s.schedule(0);
    ASSERT_EQ(a.size(), 1u);
    EXPECT_FALSE(s.fail(a[0].task_id, "w1", "cannot load submap p1", 1).has_value());
    a = s.schedule(1);
    ASSERT_EQ(a.size(), 1u);
    EXPECT_EQ(a[0].attempt, 2);
    const auto done = s.fail(a[0].task_id, "w1", "cannot load submap p1", 2);
    ASSERT_TRUE(done.has_value());
    for (const auto& p : done->pairs) {
        EXPECT_EQ(p.status, store::PairStatus::kFailed);
        EXPECT_FALSE(p.matched);
        EXPECT_NE(p.reason.find("cannot load submap p1"), std::string::npos);
    }
}

TEST(Scheduler, WrongCountIsAFailedAttemptUnknownTasksAndDuplicatesAreIgnored) {
    Scheduler s({10.0, 0, 3});
    s.heartbeat(worker("w1"), 0);
    s.submit("k", job(3), "opt", 0);
    auto a = s.schedule(0);
    auto short_results = results_for(a[0]);
    short_results.pop_back();
    // A live worker's wrong-sized answer must not leave the shard assigned forever.
    EXPECT_FALSE(s.complete(a[0].task_id, "w1", short_results, 1).has_value());
    EXPECT_EQ(s.running_shards(), 0u);
    a = s.schedule(1);
    ASSERT_EQ(a.size(), 1u);
    EXPECT_EQ(a[0].attempt, 2);
    EXPECT_FALSE(s.complete("t999", "w1", results_for(a[0]), 1).has_value());
    ASSERT_TRUE(s.complete(a[0].task_id, "w1", results_for(a[0]), 1).has_value());
    EXPECT_FALSE(s.complete(a[0].task_id, "w1", results_for(a[0]), 1).has_value());
}

TEST(Scheduler, EmptyJobCompletesWithoutWorkers) {
    Scheduler s;
    EXPECT_TRUE(s.submit("k", job(0), "opt", 0));
    const auto done = s.take_completed();
    ASSERT_EQ(done.size(), 1u);
    EXPECT_TRUE(done[0].pairs.empty());
}

// Random interleavings of heartbeats, deaths, results and failures: every job completes
// exactly once with every pair filled, whichever worker delivered it.
TEST(Scheduler, RandomizedChurnCompletesEveryJobOnce) {
    std::mt19937 rng(7);
    Scheduler s({3.0, 3, 100});
    std::map<std::string, bool> alive = {{"w1", true}, {"w2", true}, {"w3", true}, {"w4", true}};
    const int n_jobs = 40;
    for (int j = 0; j < n_jobs; ++j) s.submit("k" + std::to_string(j), job(1 + j % 11), "opt", 0);
    std::vector<Assignment> running;
    std::map<std::string, int> completed;
    for (double t = 0; t < 2000 && static_cast<int>(completed.size()) < n_jobs; t += 0.5) {
        for (auto& [id, up] : alive) {
            if (std::uniform_real_distribution<>(0, 1)(rng) < 0.02) up = !up;  // die or return
            if (up) s.heartbeat(worker(id, 2), t);
        }
        for (auto& a : s.schedule(t)) running.push_back(a);
        std::shuffle(running.begin(), running.end(), rng);
        std::vector<Assignment> keep;
        for (auto& a : running) {
            const double r = std::uniform_real_distribution<>(0, 1)(rng);
            if (!alive[a.worker_id] || r < 0.5) {
                if (alive[a.worker_id]) keep.push_back(a);
                continue;
            }
            std::optional<CompletedJob> done =
                r < 0.55 ? s.fail(a.task_id, a.worker_id, "flaky", t)
                         : s.complete(a.task_id, a.worker_id, results_for(a), t);
            if (done) {
                completed[done->job_key]++;
                for (std::size_t i = 0; i < done->pairs.size(); ++i) {
                    EXPECT_EQ(done->pairs[i].pair_id, "p" + std::to_string(i));
                    EXPECT_EQ(done->pairs[i].T_a_b_est(0, 3), static_cast<double>(i));
                }
            }
        }
        running = keep;
    }
    EXPECT_EQ(static_cast<int>(completed.size()), n_jobs);
    for (const auto& [k, n] : completed) EXPECT_EQ(n, 1) << k;
    EXPECT_EQ(s.jobs(), 0u);
}

}  // namespace
}  // namespace maptune::scheduler

namespace maptune::scheduler {
namespace {

// After a restart the task counter starts again: with another incarnation prefix, the old
// life's result for "its" task 1 is an unknown task, never the new life's task 1 (which
// carries other parameters).
TEST(Scheduler, TaskIdsOfAnEarlierIncarnationAreUnknown) {
    SchedulerOptions before_o, after_o;
    before_o.task_prefix = "aaaa-";
    after_o.task_prefix = "bbbb-";
    Scheduler before(before_o), after(after_o);
    before.heartbeat(worker("w1"), 0);
    after.heartbeat(worker("w1"), 0);
    ASSERT_TRUE(before.submit("k1", job(2), "r1", 0));
    JobSpec other = job(2);
    other.params = {{"r_N", 0.9}};
    ASSERT_TRUE(after.submit("k2", other, "r2", 0));
    const auto old_tasks = before.schedule(0);
    const auto new_tasks = after.schedule(0);
    ASSERT_EQ(old_tasks.size(), 1u);
    ASSERT_EQ(new_tasks.size(), 1u);
    EXPECT_EQ(old_tasks[0].task_id.rfind("aaaa-", 0), 0u);
    EXPECT_EQ(new_tasks[0].task_id.rfind("bbbb-", 0), 0u);
    EXPECT_NE(old_tasks[0].task_id, new_tasks[0].task_id);
    // The late result of the old life reaches the new one: ignored.
    EXPECT_FALSE(after.complete(old_tasks[0].task_id, "w1", results_for(old_tasks[0]), 1).has_value());
    const auto done = after.complete(new_tasks[0].task_id, "w1", results_for(new_tasks[0]), 1);
    ASSERT_TRUE(done.has_value());
    EXPECT_EQ(done->job_key, "k2");
}

}  // namespace
}  // namespace maptune::scheduler

namespace maptune::scheduler {
namespace {

// A shard that failed max_attempts times completes the job with FAILED pairs and says so:
// such a job is an answer, not an observation to keep.
TEST(Scheduler, JobsThatGaveUpOnAShardAreFlaggedAsWorkerFailures) {
    SchedulerOptions o;
    o.max_attempts = 2;
    Scheduler s(o);
    s.heartbeat(worker("w1"), 0);
    ASSERT_TRUE(s.submit("k", job(2), "r", 0));
    std::optional<CompletedJob> done;
    for (int attempt = 0; attempt < 2 && !done; ++attempt) {
        const auto tasks = s.schedule(attempt);
        ASSERT_EQ(tasks.size(), 1u);
        done = s.fail(tasks[0].task_id, "w1", "cannot fetch submap", attempt);
    }
    ASSERT_TRUE(done.has_value());
    EXPECT_TRUE(done->worker_failures);
    for (const auto& p : done->pairs) EXPECT_EQ(p.status, store::PairStatus::kFailed);

    ASSERT_TRUE(s.submit("k2", job(2), "r", 10));
    const auto tasks = s.schedule(10);
    ASSERT_EQ(tasks.size(), 1u);
    const auto ok = s.complete(tasks[0].task_id, "w1", results_for(tasks[0]), 10);
    ASSERT_TRUE(ok.has_value());
    EXPECT_FALSE(ok->worker_failures);
}

}  // namespace
}  // namespace maptune::scheduler

namespace maptune::scheduler {
namespace {

// A task sent to a live worker but never received (a DDS sample dropped before the reader
// matched) would wait forever behind the worker's heartbeats: once the worker's list of held
// tasks still lacks it after the grace period, it is queued again — not as a failed attempt.
TEST(Scheduler, TaskMissingFromAWorkersListAfterTheGraceIsQueuedAgain) {
    SchedulerOptions o;
    o.delivery_grace_s = 3;
    o.max_attempts = 1;
    Scheduler s(o);
    s.heartbeat(worker("w1"), 0);
    ASSERT_TRUE(s.submit("k", job(2), "r", 0));
    const auto first = s.schedule(0);
    ASSERT_EQ(first.size(), 1u);
    const std::vector<std::string> none, has{first[0].task_id};
    s.heartbeat(worker("w1"), 1, &none);  // within the grace: may still be on its way
    EXPECT_TRUE(s.schedule(1).empty());
    s.heartbeat(worker("w1"), 5, &has);  // listed: it is running
    EXPECT_TRUE(s.schedule(5).empty());
    s.heartbeat(worker("w1"), 6);  // a worker that does not list its tasks: nothing assumed
    EXPECT_TRUE(s.schedule(6).empty());
    s.heartbeat(worker("w1"), 7, &none);  // past the grace and not listed: lost
    const auto again = s.schedule(7);
    ASSERT_EQ(again.size(), 1u);
    EXPECT_EQ(again[0].task_id, first[0].task_id);
    EXPECT_EQ(again[0].attempt, 1) << "a lost delivery is not a failed attempt";
    const auto done = s.complete(again[0].task_id, "w1", results_for(again[0]), 8);
    ASSERT_TRUE(done.has_value());
    EXPECT_FALSE(done->worker_failures);
}

}  // namespace
}  // namespace maptune::scheduler

namespace maptune::scheduler {
namespace {

// A request for a matcher or space no worker serves used to wait forever (issue 12): after
// unserved_timeout_s without a compatible live worker the job completes as a failure that says
// what is missing; a compatible worker in time restarts the clock.
TEST(Scheduler, AJobNoWorkerCanServeFailsAfterTheTimeoutNamingWhatIsMissing) {
    SchedulerOptions o;
    o.unserved_timeout_s = 60;
    o.shard_size = 2;
    Scheduler s(o);
    s.heartbeat(worker("w-other-space", 1, "S2"), 0);
    ASSERT_TRUE(s.submit("k", job(5), "opt", 0));
    EXPECT_TRUE(s.schedule(0).empty());
    EXPECT_TRUE(s.schedule(59).empty());
    EXPECT_TRUE(s.take_completed().empty()) << "still within the timeout";
    s.heartbeat(worker("w-other-space", 1, "S2"), 61);
    EXPECT_TRUE(s.schedule(61).empty());
    const auto done = s.take_completed();
    ASSERT_EQ(done.size(), 1u);
    EXPECT_EQ(done[0].job_key, "k");
    EXPECT_TRUE(done[0].worker_failures);
    EXPECT_NE(done[0].failure.find("no worker serves matcher 'lru_matcher' version 1 with design space S1"),
              std::string::npos)
        << done[0].failure;
    ASSERT_EQ(done[0].pairs.size(), 5u);
    for (const auto& p : done[0].pairs) EXPECT_EQ(p.status, store::PairStatus::kFailed);
    EXPECT_EQ(s.jobs(), 0u);
    EXPECT_EQ(s.queued_shards(), 0u);
}

TEST(Scheduler, ACompatibleWorkerRestartsTheUnservedClock) {
    SchedulerOptions o;
    o.unserved_timeout_s = 60;
    o.lease_s = 10;
    Scheduler s(o);
    ASSERT_TRUE(s.submit("k", job(2), "opt", 0));
    s.schedule(0);
    s.heartbeat(worker("w1"), 50);  // appears in time, runs the shard, then goes silent
    auto a = s.schedule(50);
    ASSERT_EQ(a.size(), 1u);
    // Silent past its lease at 61: the shard is queued again and the clock starts at 61 ...
    EXPECT_TRUE(s.schedule(61).empty());
    EXPECT_TRUE(s.schedule(120).empty());
    EXPECT_TRUE(s.take_completed().empty()) << "59 s without a worker is within the timeout";
    s.schedule(122);
    ASSERT_EQ(s.take_completed().size(), 1u);
}

TEST(Scheduler, ZeroUnservedTimeoutWaitsForever) {
    SchedulerOptions o;
    o.unserved_timeout_s = 0;
    Scheduler s(o);
    ASSERT_TRUE(s.submit("k", job(2), "opt", 0));
    s.schedule(0);
    s.schedule(1e6);
    EXPECT_TRUE(s.take_completed().empty());
    EXPECT_EQ(s.jobs(), 1u);
}

}  // namespace
}  // namespace maptune::scheduler

namespace maptune::scheduler {
namespace {

// The complete view of `runs` runs of `submaps` submaps: every pair within a run.
std::vector<std::string> complete_view(int runs, int submaps) {
    std::vector<std::string> ids;
    for (int r = 0; r < runs; ++r) {
        for (int a = 0; a < submaps; ++a) {
            for (int b = a + 1; b < submaps; ++b) {
                ids.push_back("r" + std::to_string(r) + "s" + std::to_string(a) + "|r" + std::to_string(r) + "s" +
                              std::to_string(b));
            }
        }
    }
    return ids;
}

std::set<std::string> submaps_of(const std::vector<std::string>& pair_ids) {
    std::set<std::string> out;
    for (const auto& p : pair_ids) {
        const auto [a, b] = pair_submaps(p);
        out.insert(a);
        out.insert(b);
    }
    return out;
}

TEST(ShardPlanner, ShardsStayInsideARunAndTouchFewSubmaps) {
    const auto ids = complete_view(3, 15);  // 105 pairs per run
    const auto plan = plan_shards(ids, 8);
    std::vector<int> seen(ids.size(), 0);
    std::size_t touched = 0;
    for (const auto& shard : plan) {
        ASSERT_LE(shard.pairs.size(), 8u);
        std::vector<std::string> pairs;
        std::set<char> runs;
        for (const auto i : shard.pairs) {
            ++seen[i];
            pairs.push_back(ids[i]);
            runs.insert(ids[i][1]);
        }
        EXPECT_EQ(runs.size(), 1u) << "a shard never spans two runs (components)";
        touched += submaps_of(pairs).size();
    }
    for (const int n : seen) EXPECT_EQ(n, 1) << "every pair in exactly one shard";
    // Consecutive row order touches ~9 submaps per shard of 8; tiles ~6.
    const auto rows = plan_shards(ids, 8, false);
    std::size_t touched_rows = 0;
    for (const auto& shard : rows) {
        std::vector<std::string> pairs;
        for (const auto i : shard.pairs) pairs.push_back(ids[i]);
        touched_rows += submaps_of(pairs).size();
    }
    EXPECT_LT(static_cast<double>(touched) / plan.size(), 6.5);
    EXPECT_GT(static_cast<double>(touched_rows) / rows.size(), 7.5);
}

TEST(ShardPlanner, SmallComponentsArePackedAndOneShardPerComponentWithoutASize) {
    std::vector<std::string> ids = {"a|b", "c|d", "e|f", "g|h", "i|j"};  // five one-pair components
    const auto plan = plan_shards(ids, 2);
    ASSERT_EQ(plan.size(), 3u);
    EXPECT_EQ(plan[0].pairs, (std::vector<std::size_t>{0, 1}));
    EXPECT_EQ(plan[2].pairs, (std::vector<std::size_t>{4}));
    EXPECT_EQ(plan_shards(complete_view(2, 4), 0).size(), 1u) << "0: everything in one shard";
}

// The subsequent view of `runs` runs of `submaps` submaps: each submap with the next.
std::vector<std::string> subsequent_view(int runs, int submaps) {
    std::vector<std::string> ids;
    for (int r = 0; r < runs; ++r) {
        for (int a = 0; a + 1 < submaps; ++a) {
            ids.push_back("r" + std::to_string(r) + "s" + std::to_string(a) + "|r" + std::to_string(r) + "s" +
                          std::to_string(a + 1));
        }
    }
    return ids;
}

struct Simulated {
    double duplication = 0;  // feature computations / distinct submaps
    double makespan = 0;     // simulated seconds
    double learnt = 0;       // the scheduler's feature_cost_in_pairs() at the end
};

// Workers run shards in simulated time (one slot each, a shard takes `pair_s` per pair and
// `feature_s` per submap the worker has not computed).
Simulated simulate(const std::vector<std::string>& ids, int n_workers, bool locality, double feature_s = 0.25,
                   double pair_s = 0.03) {
    SchedulerOptions options;
    options.shard_size = 8;
    options.locality = locality;
    options.unserved_timeout_s = 0;
    Scheduler s(options);
    std::vector<std::set<std::string>> caches(static_cast<std::size_t>(n_workers));
    auto name = [](std::size_t i) { return "w" + std::to_string(10 + i); };
    auto beat = [&](double now) {
        for (std::size_t i = 0; i < caches.size(); ++i) s.heartbeat(worker(name(i)), now);
    };
    JobSpec spec = job(0);
    spec.pair_ids = ids;
    s.submit("k", spec, "opt", 0);
    std::map<double, std::pair<std::size_t, Assignment>> running;  // finish time -> (worker, task)
    std::size_t computed = 0;
    double now = 0;
    for (int step = 0; step < 100000; ++step) {
        beat(now);
        for (auto& a : s.schedule(now)) {
            const std::size_t w = std::stoul(a.worker_id.substr(1)) - 10;
            double t = pair_s * static_cast<double>(a.pair_ids.size());
            for (const auto& sub : submaps_of(a.pair_ids)) {
                if (caches[w].insert(sub).second) {
                    ++computed;
                    t += feature_s;
                }
            }
            // Distinct finish times: ties broken by worker.
            running.emplace(now + t + 1e-9 * static_cast<double>(w), std::make_pair(w, a));
        }
        if (running.empty()) break;
        const auto [t, next] = *running.begin();
        running.erase(running.begin());
        now = t;
        std::vector<store::PairRecord> results(next.second.pair_ids.size());
        for (std::size_t k = 0; k < results.size(); ++k) results[k].pair_id = next.second.pair_ids[k];
        if (s.complete(next.second.task_id, name(next.first), results, now)) break;
    }
    return {static_cast<double>(computed) / static_cast<double>(submaps_of(ids).size()), now,
            s.feature_cost_in_pairs()};
}

double duplication(const std::vector<std::string>& ids, int n_workers, bool locality) {
    return simulate(ids, n_workers, locality).duplication;
}

TEST(Scheduler, WorkersKeepToTheirSubmaps) {
    // 12 runs of 15 submaps (the lab's shape): with runs shared out whole, 4 workers compute
    // almost every submap once; without locality each submap about four times.
    const auto ids = complete_view(12, 15);
    const double with = duplication(ids, 4, true);
    const double without = duplication(ids, 4, false);
    EXPECT_LE(with, 1.1);
    EXPECT_GT(without, 2.5);
    EXPECT_DOUBLE_EQ(duplication(ids, 1, true), 1.0);
}

TEST(Scheduler, AWorkerJoinsOthersOnlyWhereThatEndsTheJobSooner) {
    // The lab's 13 runs on 8 workers: 5 runs are left for the second round and 3 workers are
    // free. Splitting 3 of the 5 runs cannot end the evaluation sooner (the other two still take
    // a whole run), and each split costs ~11 of a run's 15 submaps twice.
    const auto ids = complete_view(13, 15);
    const Simulated eight = simulate(ids, 8, true);
    EXPECT_LE(eight.duplication, 1.1);
    EXPECT_LE(eight.makespan, 2 * simulate(complete_view(1, 15), 1, true).makespan + 1e-6)
        << "two rounds of runs, nothing longer";
    // 2 long runs on 8 workers: splitting them ends the evaluation much sooner than a worker
    // per run would (~0.65 of a run's time), more than the features computed twice take.
    const Simulated split = simulate(complete_view(2, 40), 8, true);
    EXPECT_GT(split.duplication, 1.5);
    EXPECT_LT(split.makespan, 0.8 * simulate(complete_view(1, 40), 1, true).makespan);
}

TEST(Scheduler, WorkersShareStretchesOfSubsequentPairsAtLittleCost) {
    // 5 chains of 40 submaps on 8 workers: a newcomer's stretch needs one submap another worker
    // computes too, so free workers join even where the water level would not move.
    const auto ids = subsequent_view(5, 40);
    const Simulated eight = simulate(ids, 8, true);
    const double one_run = simulate(subsequent_view(1, 40), 1, true).makespan;
    EXPECT_LE(eight.duplication, 1.1);
    EXPECT_LT(eight.makespan, 0.9 * one_run) << "more than one worker per chain";
}

TEST(Scheduler, LearnsWhatASubmapsFeaturesCostFromShardDurations) {
    // Features 0.5 s, pairs 0.05 s: a submap costs 10 pairs, not the default 8.
    const Simulated run = simulate(complete_view(4, 15), 2, true, 0.5, 0.05);
    EXPECT_NEAR(run.learnt, 10.0, 0.5);
    Scheduler fresh;
    EXPECT_DOUBLE_EQ(fresh.feature_cost_in_pairs(), Scheduler::kDefaultFeaturePairs);
}

}  // namespace
}  // namespace maptune::scheduler
