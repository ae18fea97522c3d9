#pragma once
// sample_db: the only writer of the observation store. A request is answered from the store
// when its rounded key exists; otherwise its pairs are split into shards, leased to
// compatible workers, re-assigned when a worker stops heart-beating, stored once all are in,
// and answered. Duplicate concurrent requests run once. Bad requests get an error reply.

#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "dataset_mirror.hpp"
#include "refusals.hpp"
#include "dds/participant.hpp"
#include "maptunePubSubTypes.h"
#include "params/parameter_space.hpp"
#include "scheduler/scheduler.hpp"
#include "store/observation_store.hpp"

namespace maptune::services {

struct SampleDbOptions {
    std::string store_path;                    // SQLite file; created when absent
    std::vector<params::ParameterSpace> spaces;  // design spaces it accepts (by hash)
    scheduler::SchedulerOptions scheduler;
    double dataset_timeout_s = 30;             // wait for an unknown dataset's announcement
    // One line per fault it handles (a failed or invalid task result, an answer not stored);
    // empty: silent. Called on sample_db's thread.
    std::function<void(const std::string&)> log;
};

struct SampleDbStats {
    std::size_t requests = 0, from_store = 0, evaluated = 0, refused = 0, tasks_sent = 0;
    std::size_t stored = 0, not_stored = 0;  // completed jobs kept / answered only (transient failures)
};

class SampleDb {
public:
    // Opens the store (throws store::StoreError on a foreign or corrupt file).
    SampleDb(dds::Participant& participant, DatasetMirror& mirror, SampleDbOptions options);
    ~SampleDb();
    SampleDb(const SampleDb&) = delete;
    SampleDb& operator=(const SampleDb&) = delete;

    SampleDbStats stats() const;

private:
    struct Event {
        enum Kind { kRequest, kResult, kStatus } kind;
        msg::v1::ObservationRequest request;
        msg::v1::TaskResult result;
        msg::v1::WorkerStatus status;
    };
    void loop();
    // `parked_since` >= 0: a re-try of a request parked for its dataset since then.
    void handle_request(const msg::v1::ObservationRequest& r, double parked_since = -1);
    void handle_result(const msg::v1::TaskResult& r);
    void finish(scheduler::CompletedJob job);
    void reply_error(const msg::v1::ObservationRequest& r, const std::string& error);
    void reply(const std::string& request_id, const store::Observation& o, bool from_store);
    // An error answer to one requester of a job (the job could not be evaluated).
    void reply_failure(const std::string& request_id, const std::string& error);
    // The opened dataset; nullptr with `error`, or with *pending while its metadata is still
    // being fetched in the background (the loop never waits for a transfer).
    std::shared_ptr<const dataset::Dataset> dataset(const std::string& id, std::string* error, bool* pending);

    DatasetMirror& mirror_;
    SampleDbOptions options_;
    store::ObservationStore store_;
    scheduler::Scheduler scheduler_;
    dds::Writer<msg::v1::ObservationReply> replies_;
    dds::Writer<msg::v1::EvaluationTask> tasks_;
    std::map<std::string, std::shared_ptr<const dataset::Dataset>> datasets_;
    using Opened = std::pair<std::shared_ptr<const dataset::Dataset>, std::string>;  // dataset or error
    std::map<std::string, std::future<Opened>> opening_;  // metadata fetches in flight, by dataset id
    std::map<std::string, store::ObservationKey> job_keys_;  // scheduler key -> store key
    // Pairs of a job's view already known from observations of the set under other views
    // (multi-fidelity: the whole view after its subset); the job runs only the others.
    struct Known {
        std::vector<std::string> order;                     // the view's pair ids
        std::map<std::string, store::PairRecord> pairs;
    };
    std::map<std::string, Known> known_;                    // scheduler key -> known pairs
    // Requests waiting for their dataset to be announced, with the time they arrived.
    std::vector<std::pair<double, msg::v1::ObservationRequest>> parked_;
    mutable std::mutex mutex_;
    std::condition_variable cv_;
    std::deque<Event> events_;
    bool stop_ = false;
    SampleDbStats stats_;
    RefusalLog refusals_{"sample_db", options_.log};  // after options_: uses its log
    std::thread thread_;
    // Last, so destroyed first: no callback runs once the rest starts to go away.
    std::vector<dds::Subscription> subscriptions_;
};

}  // namespace maptune::services
