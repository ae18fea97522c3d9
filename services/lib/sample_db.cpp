#include "sample_db.hpp"

#include <algorithm>
#include <cstdio>
#include <cmath>

#include "dds/convert.hpp"
#include "dds/validate.hpp"
#include "runtime.hpp"
#include "scoring/scoring.hpp"

namespace maptune::services {

namespace v1 = msg::v1;

SampleDb::SampleDb(dds::Participant& participant, DatasetMirror& mirror, SampleDbOptions options)
    : mirror_(mirror),
      options_(std::move(options)),
      store_(options_.store_path),
      scheduler_([this] {
          // Task ids of this life of sample_db only (see incarnation_id).
          auto o = options_.scheduler;
          if (o.task_prefix.empty()) o.task_prefix = incarnation_id() + "-";
          return o;
      }()) {
    replies_ = participant.writer<v1::ObservationReplyPubSubType>(dds::topics::kObservationReply,
                                                                 dds::TopicQos::kReliable);
    tasks_ = participant.writer<v1::EvaluationTaskPubSubType>(dds::topics::kEvaluationTask,
                                                             dds::TopicQos::kReliable);
    auto push = [this](Event e) {
        std::lock_guard<std::mutex> lock(mutex_);
        events_.push_back(std::move(e));
        cv_.notify_one();
    };
    subscriptions_.push_back(participant.reader<v1::ObservationRequestPubSubType>(
        dds::topics::kObservationRequest, dds::TopicQos::kReliable,
        [push](const v1::ObservationRequest& r) { push({Event::kRequest, r, {}, {}}); }));
    subscriptions_.push_back(participant.reader<v1::TaskResultPubSubType>(
        dds::topics::kTaskResult, dds::TopicQos::kReliable,
        [push](const v1::TaskResult& r) { push({Event::kResult, {}, r, {}}); }));
    subscriptions_.push_back(participant.reader<v1::WorkerStatusPubSubType>(
        dds::topics::kWorkerStatus, dds::TopicQos::kLatched,
        [push](const v1::WorkerStatus& s) { push({Event::kStatus, {}, {}, s}); }));
    thread_ = std::thread([this] { loop(); });
}

SampleDb::~SampleDb() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
        cv_.notify_all();
    }
    thread_.join();
    // A metadata fetch may still hang in the background (a mute dataset_server): end it, so
    // that shutting down never waits for the dataset timeout.
    if (!opening_.empty()) mirror_.interrupt();
}

SampleDbStats SampleDb::stats() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return stats_;
}

void SampleDb::loop() {
    for (;;) {
        std::deque<Event> batch;
        {
            std::unique_lock<std::mutex> lock(mutex_);
            // Wake at least every 50 ms to notice silent workers.
            cv_.wait_for(lock, std::chrono::milliseconds(50), [this] { return stop_ || !events_.empty(); });
            if (stop_) return;
            batch.swap(events_);
        }
        const double now = now_s();
        for (auto& e : batch) {
            try {
                switch (e.kind) {
                    case Event::kRequest: handle_request(e.request); break;
                    case Event::kResult: handle_result(e.result); break;
                    case Event::kStatus: {
                        const auto& st = e.status;
                        if (auto bad = dds::check(st); !bad.empty()) {
                            refusals_.refused("worker_status", st.worker_id(), bad);
                            break;
                        }
                        const std::vector<std::string> held(st.tasks().begin(), st.tasks().end());
                        scheduler_.heartbeat({st.worker_id(), st.matcher_id(), st.matcher_version(), st.space_hash(),
                                              static_cast<int>(st.slots()), st.takes_settings()},
                                             now, st.lists_tasks() ? &held : nullptr);
                        break;
                    }
                }
            } catch (const std::exception& ex) {
                // Bad input or a store I/O error never stops the service.
                if (e.kind == Event::kRequest) reply_error(e.request, std::string("internal error: ") + ex.what());
            }
        }
        auto parked = std::move(parked_);
        parked_.clear();
        for (auto& [since, request] : parked) {
            try {
                handle_request(request, since);
            } catch (const std::exception& ex) {
                reply_error(request, std::string("internal error: ") + ex.what());
            }
        }
        for (auto& job : scheduler_.take_completed()) {
            try {
                finish(std::move(job));
            } catch (const std::exception&) {
                // A store I/O error: the job's requesters re-send and the job runs again.
            }
        }
        for (const auto& a : scheduler_.schedule(now_s())) {
            v1::EvaluationTask t;
            t.task_id(a.task_id);
            t.worker_id(a.worker_id);
            t.dataset_id(a.job->dataset_id);
            t.view(a.job->view);
            t.matcher_id(a.job->matcher_id);
            t.space_hash(a.job->space_hash);
            t.params(dds::to_msg(a.job->params));
            t.pair_ids(a.pair_ids);
            t.lease_ms(static_cast<uint32_t>(options_.scheduler.lease_s * 1000));
            t.matcher_version(a.job->matcher_version);
            t.matcher_settings(a.job->matcher_settings);
            tasks_.write(t);
            std::lock_guard<std::mutex> lock(mutex_);
            ++stats_.tasks_sent;
        }
    }
}

std::shared_ptr<const dataset::Dataset> SampleDb::dataset(const std::string& id, std::string* error, bool* pending) {
    *pending = false;
    if (auto it = datasets_.find(id); it != datasets_.end()) return it->second;
    auto it = opening_.find(id);
    if (it == opening_.end()) {
        // Fetching the metadata can take seconds (or the timeout, when the dataset_server dies):
        // in the background, so heartbeats, results and other requests go on meanwhile.
        it = opening_
                 .emplace(id, std::async(std::launch::async,
                                         [this, id]() -> Opened {
                                             std::string why;
                                             auto ds = mirror_.open(id, options_.dataset_timeout_s, &why);
                                             if (!ds) return {nullptr, why};
                                             return {std::make_shared<const dataset::Dataset>(std::move(*ds)), ""};
                                         }))
                 .first;
    }
    if (it->second.wait_for(std::chrono::seconds(0)) != std::future_status::ready) {
        *pending = true;
        return nullptr;
    }
    Opened opened = it->second.get();
    opening_.erase(it);  // a failure is not remembered: a later request fetches again
    if (!opened.first) {
        *error = opened.second;
        return nullptr;
    }
    return datasets_[id] = opened.first;
}

void SampleDb::reply_error(const v1::ObservationRequest& r, const std::string& error) {
    reply_failure(r.request_id(), error);
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.refused;
}

void SampleDb::reply_failure(const std::string& request_id, const std::string& error) {
    v1::ObservationReply rep;
    rep.request_id(request_id);
    rep.ok(false);
    rep.error(error);
    replies_.write(rep);
}

void SampleDb::reply(const std::string& request_id, const store::Observation& o, bool from_store) {
    v1::ObservationReply rep;
    rep.request_id(request_id);
    rep.ok(true);
    rep.from_store(from_store);
    rep.params_key(o.key.params_key);
    rep.params(dds::to_msg(o.params));
    rep.pairs(dds::to_msg(o.pairs));
    rep.wall_seconds(o.wall_seconds);
    replies_.write(rep);
}

void SampleDb::handle_request(const v1::ObservationRequest& r, double parked_since) {
    if (parked_since < 0) {
        std::lock_guard<std::mutex> lock(mutex_);
        ++stats_.requests;
    }
    if (auto bad = dds::check(r); !bad.empty()) {
        refusals_.refused("observation_request", r.requester(), bad);
        // An id too long to echo gets no answer: the requester cannot be told apart.
        if (r.request_id().size() <= dds::MessageLimits::kId) reply_error(r, "invalid request: " + bad);
        return;
    }
    if (r.request_id().empty()) return reply_error(r, "request_id is empty");
    const params::ParameterSpace* space = nullptr;
    for (const auto& s : options_.spaces) {
        if (s.hash() == r.space_hash()) space = &s;
    }
    if (space == nullptr) {
        std::string known;
        for (const auto& s : options_.spaces) known += (known.empty() ? "" : ", ") + s.name() + " " + s.hash();
        return reply_error(r, "design space " + r.space_hash() + " differs from the sample_db's (" + known + ")");
    }
    params::ParameterSet partial;
    for (const auto& nv : r.params()) {
        if (partial.has(nv.name())) return reply_error(r, nv.name() + ": given twice");
        partial.set(nv.name(), nv.value());
    }
    params::ParameterSet full;
    try {
        full = space->round(space->complete(partial));
    } catch (const std::exception& e) {
        return reply_error(r, e.what());
    }
    dataset::ViewSpec view;
    try {
        view = dataset::parse_view_spec(r.view());
    } catch (const std::exception& e) {
        return reply_error(r, e.what());
    }
    if (r.matcher_id().empty()) return reply_error(r, "matcher_id is empty");
    // An unannounced dataset may still come (services start in any order): park the request
    // instead of blocking the loop, and refuse it once the wait is over.
    const auto known = mirror_.known();
    if (std::find(known.begin(), known.end(), r.dataset_id()) == known.end()) {
        const double since = parked_since < 0 ? now_s() : parked_since;
        if (now_s() - since < options_.dataset_timeout_s) {
            parked_.emplace_back(since, r);
            return;
        }
        return reply_error(r, "unknown dataset '" + r.dataset_id() + "': no dataset_server announced it");
    }
    std::string error;
    bool pending = false;
    const auto ds = dataset(r.dataset_id(), &error, &pending);
    const double since = parked_since < 0 ? now_s() : parked_since;
    // Its metadata is on the way; or the transfer timed out (a dataset_server restarting):
    // an infrastructure fault, not an answer — fetch again for a while before refusing.
    const bool transient = !ds && !pending && error.find("timed out") != std::string::npos &&
                           now_s() - since < 10 * options_.dataset_timeout_s;
    if (pending || transient) {
        if (transient && options_.log) options_.log("fetching dataset " + r.dataset_id() + " again: " + error);
        parked_.emplace_back(since, r);
        return;
    }
    if (!ds) return reply_error(r, "unknown dataset: " + error);
    const store::ObservationKey key{r.dataset_id(), r.view(), r.matcher_id(), r.matcher_version(),
                                    space->canonical_key(full)};
    if (auto found = store_.get(key)) {
        reply(r.request_id(), *found, true);
        std::lock_guard<std::mutex> lock(mutex_);
        ++stats_.from_store;
        return;
    }
    scheduler::JobSpec spec;
    spec.dataset_id = r.dataset_id();
    spec.view = r.view();
    spec.matcher_id = r.matcher_id();
    spec.matcher_version = r.matcher_version();
    spec.space_hash = r.space_hash();
    spec.matcher_settings = r.matcher_settings();
    spec.params = full;
    Known view_pairs;
    for (const auto& p : ds->pairs(view, dataset::Reference::gt)) view_pairs.order.push_back(scoring::pair_id(p));
    // What other views of this set already computed is not computed again.
    std::map<std::string, store::PairRecord> elsewhere;
    for (auto& o : store_.other_views(key)) {
        for (auto& p : o.pairs) elsewhere.emplace(p.pair_id, std::move(p));
    }
    for (const auto& id : view_pairs.order) {
        if (auto it = elsewhere.find(id); it != elsewhere.end()) {
            view_pairs.pairs.emplace(id, it->second);
        } else {
            spec.pair_ids.push_back(id);
        }
    }
    if (spec.pair_ids.empty()) {
        store::Observation o;
        o.key = key;
        o.params = full;
        for (const auto& id : view_pairs.order) o.pairs.push_back(view_pairs.pairs.at(id));
        store_.put(o);
        reply(r.request_id(), store_.get(key).value_or(o), true);
        std::lock_guard<std::mutex> lock(mutex_);
        ++stats_.from_store;
        return;
    }
    const std::string job_key = key.dataset_id + "\n" + key.view + "\n" + key.matcher_id + "\n" +
                                key.matcher_version + "\n" + key.params_key;
    job_keys_[job_key] = key;
    if (!view_pairs.pairs.empty()) known_[job_key] = std::move(view_pairs);
    scheduler_.submit(job_key, std::move(spec), r.request_id(), now_s());
}

void SampleDb::handle_result(const v1::TaskResult& r) {
    if (auto bad = dds::check(r); !bad.empty()) {
        refusals_.refused("task_result", r.worker_id(), bad);
        // A failed attempt of the task when it comes from its worker (else ignored).
        if (auto done = scheduler_.fail(r.task_id(), r.worker_id(), "invalid message: " + bad, now_s())) {
            finish(std::move(*done));
        }
        return;
    }
    std::string invalid = r.ok() ? "" : r.error();
    std::vector<store::PairRecord> pairs;
    if (r.ok()) {
        pairs = dds::from_msg(r.pairs());
        // A broken result (NaN transform, ...) is a failed attempt: re-run elsewhere, never stored.
        for (const auto& p : pairs) {
            if (invalid.empty()) invalid = store::check_pair_record(p);
        }
        if (!invalid.empty()) invalid = "invalid result: " + invalid;
    }
    if (!invalid.empty() && options_.log) {
        options_.log("task " + r.task_id() + " of worker " + r.worker_id() + " failed: " + invalid);
    }
    std::optional<scheduler::CompletedJob> done =
        invalid.empty() ? scheduler_.complete(r.task_id(), r.worker_id(), std::move(pairs), now_s())
                        : scheduler_.fail(r.task_id(), r.worker_id(), invalid, now_s());
    if (done) finish(std::move(*done));
}

void SampleDb::finish(scheduler::CompletedJob job) {
    store::Observation o;
    o.key = job_keys_.at(job.job_key);
    job_keys_.erase(job.job_key);
    o.params = job.spec.params;
    o.pairs = std::move(job.pairs);
    if (auto it = known_.find(job.job_key); it != known_.end()) {
        // The view's order, its known pairs with the ones just computed.
        for (auto& p : o.pairs) it->second.pairs[p.pair_id] = std::move(p);
        o.pairs.clear();
        for (const auto& id : it->second.order) {
            if (auto p = it->second.pairs.find(id); p != it->second.pairs.end()) o.pairs.push_back(std::move(p->second));
        }
        known_.erase(it);
    }
    o.wall_seconds = job.finished_at - job.started_at;
    if (options_.log && job.spec.pair_ids.size() >= 2 * options_.scheduler.shard_size) {
        // What the locality rule assumed (docs/distributed.md, "Locality"), for whoever tunes a cluster.
        char line[160];
        std::snprintf(line, sizeof line, "%zu pairs in %.1f s; a submap's features cost %.1f pairs (learnt)",
                      job.spec.pair_ids.size(), o.wall_seconds, scheduler_.feature_cost_in_pairs());
        options_.log(line);
    }
    // Timeouts depend on the machine's load and worker failures on the worker: the requesters
    // get the answer, the store does not keep it, and a later request runs the matcher again.
    const bool transient = job.worker_failures || store::has_timeouts(o.pairs);
    if (transient && options_.log) {
        options_.log("answer for " + o.key.params_key + " not stored: " +
                     (job.worker_failures ? job.failure : "pairs timed out"));
    }
    std::optional<store::Observation> stored;
    if (!transient) {
        store_.put(o);  // durable before anyone hears of it
        stored = store_.get(o.key);
    }
    for (const auto& requester : job.requesters) {
        // FAILED pairs of a broken worker say nothing about the parameters: scored, they would
        // tell the optimizer a p that is not the matcher's. The requester hears the failure.
        if (job.worker_failures) {
            reply_failure(requester, "evaluation failed: " + job.failure);
        } else {
            reply(requester, stored ? *stored : o, false);
        }
    }
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.evaluated;
    ++(transient ? stats_.not_stored : stats_.stored);
}

}  // namespace maptune::services
