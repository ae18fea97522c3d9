#pragma once
// matcher_worker: announces itself with heartbeats (id, matcher id and version, design-space
// hash, slots), runs the tasks assigned to it with its backend on `slots` threads, and
// returns per-pair results. Any number of workers on any number of machines.

#include <condition_variable>
#include <deque>
#include <mutex>
#include <string>
#include <thread>
#include <set>
#include <vector>

#include "dds/participant.hpp"
#include "maptunePubSubTypes.h"
#include "refusals.hpp"
#include "worker_backend.hpp"

namespace maptune::services {

struct WorkerOptions {
    std::string worker_id;      // empty: generated
    int slots = 1;              // tasks run at once
    double heartbeat_s = 0.5;   // sample_db re-assigns after its lease (default 10 s) of silence
    bool filter_tasks = true;   // subscribe to its own tasks only (false: every task, what dispatch_bench compares)
};

class MatcherWorker {
public:
    MatcherWorker(dds::Participant& participant, WorkerBackend& backend, WorkerOptions options = {});
    ~MatcherWorker();  // finishes running tasks, then stops
    MatcherWorker(const MatcherWorker&) = delete;
    MatcherWorker& operator=(const MatcherWorker&) = delete;

    const std::string& id() const { return options_.worker_id; }
    std::size_t tasks_done() const;

private:
    void heartbeat_loop();
    void task_loop();
    void publish_status();

    WorkerBackend& backend_;
    WorkerOptions options_;
    dds::Writer<msg::v1::TaskResult> results_;
    dds::Writer<msg::v1::WorkerStatus> status_;
    mutable std::mutex mutex_;
    std::condition_variable cv_;         // task threads: a task arrived, or stop
    std::condition_variable stop_cv_;    // heartbeat thread: stop (own variable, so notify_one
                                         // on cv_ can never wake it instead of a task thread)
    std::deque<msg::v1::EvaluationTask> queue_;
    std::set<std::string> held_;         // task ids received and not answered yet (heartbeats list them)
    int busy_ = 0;
    bool stop_ = false;
    std::size_t done_ = 0;
    std::uint64_t sequence_ = 0;
    std::vector<std::thread> threads_;
    RefusalLog refusals_{"matcher_worker"};
    // Last, so destroyed first: no callback runs once the rest starts to go away.
    std::vector<dds::Subscription> subscriptions_;
};

}  // namespace maptune::services
