#include "scheduler/scheduler.hpp"

#include <algorithm>

namespace maptune::scheduler {

Scheduler::Scheduler(SchedulerOptions options) : options_(options) {
    if (options_.max_attempts < 1) options_.max_attempts = 1;
}

void Scheduler::heartbeat(const WorkerInfo& worker, double now, const std::vector<std::string>* held) {
    Worker& w = workers_[worker.id];
    w.info = worker;
    w.info.slots = std::max(1, worker.slots);
    w.last_seen = now;
    if (held == nullptr) return;
    const std::set<std::string> listed(held->begin(), held->end());
    std::vector<std::string> lost;
    for (const auto& task : w.tasks) {
        const Shard& shard = shards_.at(task);
        if (!listed.count(task) && now - shard.assigned_at > options_.delivery_grace_s) lost.push_back(task);
    }
    for (const auto& task : lost) {
        Shard& shard = shards_.at(task);
        --shard.attempts;  // never delivered: not an attempt
        requeue(shard);
    }
}

void Scheduler::remove_worker(const std::string& worker_id) {
    const auto it = workers_.find(worker_id);
    if (it == workers_.end()) return;
    for (const auto& task : it->second.tasks) requeue(shards_.at(task));
    workers_.erase(it);
}

void Scheduler::requeue(Shard& shard) {
    if (auto w = workers_.find(shard.worker); w != workers_.end()) w->second.tasks.erase(shard.task_id);
    shard.worker.clear();
    // Re-assigned shards go first: their job has waited longest.
    queue_.push_front(shard.task_id);
}

bool Scheduler::submit(const std::string& job_key, JobSpec spec, const std::string& requester,
                       double now) {
    if (auto it = jobs_.find(job_key); it != jobs_.end()) {
        // A re-sent request joins once: one answer per request id.
        auto& r = it->second.requesters;
        if (std::find(r.begin(), r.end(), requester) == r.end()) r.push_back(requester);
        return false;
    }
    Job job;
    job.requesters = {requester};
    job.started_at = now;
    job.pairs.resize(spec.pair_ids.size());
    for (std::size_t i = 0; i < spec.pair_ids.size(); ++i) job.pairs[i].pair_id = spec.pair_ids[i];
    const std::size_t n = spec.pair_ids.size();
    const std::size_t size = options_.shard_size == 0 ? std::max<std::size_t>(n, 1) : options_.shard_size;
    for (std::size_t begin = 0; begin < n; begin += size) {
        Shard shard;
        shard.task_id = options_.task_prefix + "t" + std::to_string(next_task_++);
        shard.job_key = job_key;
        shard.begin = begin;
        shard.end = std::min(n, begin + size);
        job.shard_ids.push_back(shard.task_id);
        queue_.push_back(shard.task_id);
        shards_[shard.task_id] = shard;
    }
    job.remaining = job.shard_ids.size();
    job.spec = std::move(spec);
    const bool empty = job.remaining == 0;
    jobs_[job_key] = std::move(job);
    if (empty) {
        Job& j = jobs_[job_key];
        completed_.push_back({job_key, j.spec, j.requesters, j.pairs, j.started_at, now});
        jobs_.erase(job_key);
    }
    return true;
}

std::vector<Assignment> Scheduler::schedule(double now) {
    for (auto& [id, w] : workers_) {
        if (now - w.last_seen <= options_.lease_s) continue;
        for (const auto& task : std::set<std::string>(w.tasks)) requeue(shards_.at(task));
    }
    for (auto it = workers_.begin(); it != workers_.end();) {
        // Forget long-silent workers; they re-register with their next heartbeat.
        it = now - it->second.last_seen > 3 * options_.lease_s ? workers_.erase(it) : std::next(it);
    }
    expire_unserved(now);
    std::vector<Assignment> out;
    // With every slot taken nothing can be assigned: skip the scan of the queue.
    if (queue_.empty() || free_slots() == 0) return out;
    std::deque<std::string> waiting;
    while (!queue_.empty()) {
        const std::string task = queue_.front();
        queue_.pop_front();
        Shard& shard = shards_.at(task);
        const Job& job = jobs_.at(shard.job_key);
        // The least loaded compatible live worker (ties: the one idle longest by id order).
        Worker* best = nullptr;
        for (auto& [id, w] : workers_) {
            if (!compatible(w, job.spec, now)) continue;
            const int free = w.info.slots - static_cast<int>(w.tasks.size());
            if (free <= 0) continue;
            if (best == nullptr || w.tasks.size() < best->tasks.size()) best = &w;
        }
        if (best == nullptr) {
            waiting.push_back(task);
            continue;
        }
        shard.worker = best->info.id;
        ++shard.attempts;
        shard.assigned_at = now;
        best->tasks.insert(task);
        Assignment a;
        a.task_id = task;
        a.worker_id = best->info.id;
        a.job_key = shard.job_key;
        a.job = &job.spec;
        a.pair_ids.assign(job.spec.pair_ids.begin() + static_cast<std::ptrdiff_t>(shard.begin),
                          job.spec.pair_ids.begin() + static_cast<std::ptrdiff_t>(shard.end));
        a.attempt = shard.attempts;
        out.push_back(std::move(a));
    }
    queue_ = std::move(waiting);
    return out;
}

std::string code_revision(const std::string& matcher_version) {
    return matcher_version.substr(0, matcher_version.find('-'));
}

bool Scheduler::compatible(const Worker& w, const JobSpec& spec, double now) const {
    if (now - w.last_seen > options_.lease_s) return false;
    if (w.info.matcher_id != spec.matcher_id || w.info.space_hash != spec.space_hash) return false;
    if (spec.matcher_version.empty() || w.info.matcher_version == spec.matcher_version) return true;
    return w.info.takes_settings && !spec.matcher_settings.empty() &&
           code_revision(w.info.matcher_version) == code_revision(spec.matcher_version);
}

void Scheduler::expire_unserved(double now) {
    if (options_.unserved_timeout_s <= 0) return;
    std::vector<std::string> expired;
    for (auto& [key, job] : jobs_) {
        bool served = false;
        for (const auto& [id, w] : workers_) served = served || compatible(w, job.spec, now);
        if (served) {
            job.unserved_since.reset();
        } else if (!job.unserved_since) {
            job.unserved_since = now;
        } else if (now - *job.unserved_since > options_.unserved_timeout_s) {
            expired.push_back(key);
        }
    }
    for (const auto& key : expired) {
        Job& job = jobs_.at(key);
        job.worker_failures = true;
        job.failure = "no worker serves matcher '" + job.spec.matcher_id + "'" +
                      (job.spec.matcher_version.empty() ? "" : " version " + job.spec.matcher_version) +
                      " with design space " + job.spec.space_hash + " (waited " +
                      std::to_string(static_cast<long>(now - *job.unserved_since)) + " s)";
        std::vector<std::string> open;
        for (const auto& id : job.shard_ids) {
            if (!shards_.at(id).done) open.push_back(id);
        }
        for (const auto& id : open) {
            Shard& shard = shards_.at(id);
            for (std::size_t i = shard.begin; i < shard.end; ++i) {
                job.pairs[i].matched = false;
                job.pairs[i].status = store::PairStatus::kFailed;
                job.pairs[i].reason = job.failure;
            }
            // The last one completes the job and erases it (and `job` with it).
            if (auto done = finish_shard(shard, now)) completed_.push_back(std::move(*done));
        }
    }
}

std::optional<CompletedJob> Scheduler::finish_shard(Shard& shard, double now) {
    shard.done = true;
    if (auto w = workers_.find(shard.worker); w != workers_.end()) w->second.tasks.erase(shard.task_id);
    queue_.erase(std::remove(queue_.begin(), queue_.end(), shard.task_id), queue_.end());
    Job& job = jobs_.at(shard.job_key);
    if (--job.remaining > 0) return std::nullopt;
    CompletedJob done{shard.job_key, std::move(job.spec), std::move(job.requesters),
                      std::move(job.pairs), job.started_at, now, job.worker_failures, job.failure};
    for (const auto& id : job.shard_ids) shards_.erase(id);
    jobs_.erase(done.job_key);
    return done;
}

std::optional<CompletedJob> Scheduler::complete(const std::string& task_id,
                                                const std::string& worker_id,
                                                std::vector<store::PairRecord> results,
                                                double now) {
    const auto it = shards_.find(task_id);
    if (it == shards_.end() || it->second.done) return std::nullopt;
    Shard& shard = it->second;
    // A worker that lost its lease may still deliver, unless another worker holds it now.
    if (shard.worker != worker_id && !shard.worker.empty()) return std::nullopt;
    if (results.size() != shard.end - shard.begin) {
        // A wrong-sized answer is a failed attempt, not a lost one: otherwise the shard would
        // stay assigned to a live worker forever.
        return fail(task_id, worker_id,
                    "returned " + std::to_string(results.size()) + " pair results for " +
                        std::to_string(shard.end - shard.begin) + " pairs",
                    now);
    }
    if (auto w = workers_.find(worker_id); w != workers_.end()) w->second.last_seen = now;
    Job& job = jobs_.at(shard.job_key);
    for (std::size_t i = 0; i < results.size(); ++i) {
        store::PairRecord& slot = job.pairs[shard.begin + i];
        const std::string id = slot.pair_id;
        slot = std::move(results[i]);
        slot.pair_id = id;  // the order is the contract; ids from the worker are not trusted
    }
    if (shard.worker.empty()) {  // late delivery of a re-queued shard: drop it from the queue
        queue_.erase(std::remove(queue_.begin(), queue_.end(), task_id), queue_.end());
    }
    return finish_shard(shard, now);
}

std::optional<CompletedJob> Scheduler::fail(const std::string& task_id,
                                            const std::string& worker_id,
                                            const std::string& reason, double now) {
    const auto it = shards_.find(task_id);
    if (it == shards_.end() || it->second.done || it->second.worker != worker_id) return std::nullopt;
    Shard& shard = it->second;
    shard.last_error = reason;
    if (shard.attempts < options_.max_attempts) {
        requeue(shard);
        return std::nullopt;
    }
    Job& job = jobs_.at(shard.job_key);
    job.worker_failures = true;
    job.failure = "a shard failed " + std::to_string(shard.attempts) + " times: " + reason;
    for (std::size_t i = shard.begin; i < shard.end; ++i) {
        job.pairs[i].matched = false;
        job.pairs[i].status = store::PairStatus::kFailed;
        job.pairs[i].reason = "worker failed " + std::to_string(shard.attempts) + " times: " + reason;
    }
    return finish_shard(shard, now);
}

std::size_t Scheduler::running_shards() const {
    std::size_t n = 0;
    for (const auto& [id, w] : workers_) n += w.tasks.size();
    return n;
}

int Scheduler::free_slots() const {
    int n = 0;
    for (const auto& [id, w] : workers_) n += std::max(0, w.info.slots - static_cast<int>(w.tasks.size()));
    return n;
}

std::vector<CompletedJob> Scheduler::take_completed() {
    std::vector<CompletedJob> out;
    out.swap(completed_);
    return out;
}

}  // namespace maptune::scheduler
