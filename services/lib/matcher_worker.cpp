#include "matcher_worker.hpp"

#include "dds/convert.hpp"
#include "dds/validate.hpp"
#include "runtime.hpp"

namespace maptune::services {

namespace v1 = msg::v1;

MatcherWorker::MatcherWorker(dds::Participant& participant, WorkerBackend& backend, WorkerOptions options)
    : backend_(backend), options_(std::move(options)) {
    if (options_.worker_id.empty()) options_.worker_id = make_id("worker");
    options_.slots = std::max(1, options_.slots);
    results_ = participant.writer<v1::TaskResultPubSubType>(dds::topics::kTaskResult, dds::TopicQos::kReliable);
    // Heartbeats are reliable too: a lost one must not look like a dead worker.
    status_ = participant.writer<v1::WorkerStatusPubSubType>(dds::topics::kWorkerStatus, dds::TopicQos::kLatched);
    auto on_task = [this](const v1::EvaluationTask& t) {
        if (t.worker_id() != options_.worker_id) return;
        if (auto bad = dds::check(t); !bad.empty()) {
            // Answered at once, so sample_db counts a failed attempt instead of waiting.
            refusals_.refused("evaluation_task", "", bad);
            v1::TaskResult r;
            if (t.task_id().size() <= dds::MessageLimits::kId) r.task_id(t.task_id());
            r.worker_id(options_.worker_id);
            r.ok(false);
            r.error("invalid task: " + bad);
            results_.write(r);
            return;
        }
        std::lock_guard<std::mutex> lock(mutex_);
        if (!held_.insert(t.task_id()).second) return;  // a re-sent task it already holds
        queue_.push_back(t);
        cv_.notify_one();
    };
    // Filtered by assignee: sample_db sends a task only to its worker, not to all of them.
    subscriptions_.push_back(options_.filter_tasks
                                 ? participant.reader_where<v1::EvaluationTaskPubSubType>(
                                       dds::topics::kEvaluationTask, dds::TopicQos::kReliable,
                                       dds::topics::kTaskAssigneeMember, options_.worker_id, on_task)
                                 : participant.reader<v1::EvaluationTaskPubSubType>(
                                       dds::topics::kEvaluationTask, dds::TopicQos::kReliable, on_task));
    for (int i = 0; i < options_.slots; ++i) threads_.emplace_back([this] { task_loop(); });
    threads_.emplace_back([this] { heartbeat_loop(); });
}

MatcherWorker::~MatcherWorker() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
        cv_.notify_all();
        stop_cv_.notify_all();
    }
    for (auto& t : threads_) t.join();
}

std::size_t MatcherWorker::tasks_done() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return done_;
}

void MatcherWorker::publish_status() {
    v1::WorkerStatus s;
    s.worker_id(options_.worker_id);
    s.matcher_id(backend_.matcher_id());
    s.matcher_version(backend_.matcher_version());
    s.space_hash(backend_.space().hash());
    s.slots(static_cast<uint32_t>(options_.slots));
    s.takes_settings(backend_.takes_settings());
    {
        std::lock_guard<std::mutex> lock(mutex_);
        s.busy(static_cast<uint32_t>(busy_));
        s.sequence_number(++sequence_);
        s.lists_tasks(true);
        s.tasks(std::vector<std::string>(held_.begin(), held_.end()));
    }
    status_.write(s);
}

void MatcherWorker::heartbeat_loop() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!stop_) {
        lock.unlock();
        publish_status();
        lock.lock();
        stop_cv_.wait_for(lock, std::chrono::duration<double>(options_.heartbeat_s), [this] { return stop_; });
    }
}

void MatcherWorker::task_loop() {
    for (;;) {
        v1::EvaluationTask t;
        {
            std::unique_lock<std::mutex> lock(mutex_);
            cv_.wait(lock, [this] { return stop_ || !queue_.empty(); });
            if (stop_) return;
            t = queue_.front();
            queue_.pop_front();
            ++busy_;
        }
        v1::TaskResult r;
        r.task_id(t.task_id());
        r.worker_id(options_.worker_id);
        const bool other_version = !t.matcher_version().empty() && t.matcher_version() != backend_.matcher_version();
        if (t.space_hash() != backend_.space().hash()) {
            r.ok(false);
            r.error("design space differs: task " + t.space_hash() + ", worker " + backend_.space().hash());
        } else if (other_version && !backend_.takes_settings()) {
            r.ok(false);
            r.error("matcher version differs: task " + t.matcher_version() + ", worker " + backend_.matcher_version());
        } else {
            TaskSpec spec{t.task_id(),  t.dataset_id(),      t.view(), dds::from_msg(t.params()), t.pair_ids(),
                          t.matcher_version(), t.matcher_settings()};
            TaskOutcome outcome;
            try {
                outcome = backend_.run(spec);
            } catch (const std::exception& e) {  // a backend bug must not kill the worker
                outcome.ok = false;
                outcome.error = std::string("backend threw: ") + e.what();
            }
            r.ok(outcome.ok);
            r.error(outcome.error);
            r.pairs(dds::to_msg(outcome.pairs));
        }
        results_.write(r);
        std::lock_guard<std::mutex> lock(mutex_);
        held_.erase(t.task_id());
        --busy_;
        ++done_;
    }
}

}  // namespace maptune::services
