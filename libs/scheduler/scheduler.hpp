#pragma once
// Coordinates evaluations across matcher workers (ARCHITECTURE: sample_db).
//
// A job is one observation to compute: a parameter set on a list of pairs. It is split into
// shards of at most `shard_size` pairs that touch few submaps (plan_shards); each shard is
// leased to a worker with a free slot and the same design space and matcher, preferring the
// worker that already holds the shard's submaps (its feature cache), so that the feature work
// of all workers together stays close to one pass over the submaps (docs/distributed.md,
// "Locality"). A worker that sends no heartbeat for `lease_s`
// loses its shards, which go back to the queue; a shard that failed `max_attempts` times
// is reported as FAILED pairs with the reason. Identical concurrent jobs (same key) run
// once and answer every requester. Results from a worker that lost its lease are ignored
// once another worker delivered the shard.

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "params/parameter_set.hpp"
#include "store/observation_store.hpp"

namespace maptune::scheduler {

struct SchedulerOptions {
    double lease_s = 10.0;       // silence after which a worker's shards are re-assigned
    std::size_t shard_size = 8;  // pairs per shard; 0 = one shard per job
    int max_attempts = 3;        // assignments of one shard before its pairs are FAILED
    // Prefix of every task id: a per-process incarnation, so results for tasks of an earlier
    // life of sample_db (same counter, other parameters) are unknown tasks, never current ones.
    std::string task_prefix;
    // A task that a worker's heartbeats still do not list this long after it was assigned never
    // arrived: it goes back to the queue (not counted as a failed attempt).
    double delivery_grace_s = 3.0;
    // A job that no live worker can run (none with its matcher, version and design space) for
    // this long completes as a failure naming what is missing, instead of waiting forever.
    // <= 0: wait forever.
    double unserved_timeout_s = 300.0;
    // false: shards of consecutive pairs handed out oldest first to the least loaded worker
    // (no regard to submaps; for measuring what locality gains).
    bool locality = true;
    // A worker joins others' component also when at most this fraction of the submaps its
    // share needs are computed by them too (docs/distributed.md, "Locality").
    double join_duplication = 0.1;
};

struct WorkerInfo {
    std::string id;
    std::string matcher_id;
    std::string matcher_version;
    std::string space_hash;
    int slots = 1;  // shards it runs at once
    // Runs jobs that carry settings for any version of its code revision (see code_revision).
    bool takes_settings = false;
};

// The part of a matcher version before its first '-' ("3-1a2b3c4d" -> "3"): versions of one
// revision differ only in settings, which a task can carry.
std::string code_revision(const std::string& matcher_version);

// The two submap ids of a pair id "idA|idB" (an id without '|' is one submap: both).
std::pair<std::string, std::string> pair_submaps(const std::string& pair_id);

// Groups pairs into shards of at most `shard_size` pairs (0: one shard per component) that
// touch few submaps. The pairs' submaps form connected components (with the complete view:
// the runs); a shard never spans two. Within a component submaps are numbered in order of
// first appearance and cut into blocks of ceil(sqrt(shard_size)); pairs are ordered by the
// tile (block of A, block of B) of the submap x submap matrix they fall in, keeping their
// order within a tile, then cut. A row of 8 pairs of one submap touches 9 submaps, a 3 x 3
// tile 6. tiles = false: consecutive pairs in their given order, `shard_size` at a time.
struct PlannedShard {
    std::vector<std::size_t> pairs;  // indices into pair_ids
    int component = 0;
};
std::vector<PlannedShard> plan_shards(const std::vector<std::string>& pair_ids, std::size_t shard_size,
                                      bool tiles = true);

struct JobSpec {
    std::string dataset_id;
    std::string view;
    std::string matcher_id;
    std::string matcher_version;  // empty: any version of matcher_id
    std::string space_hash;
    params::ParameterSet params;  // full rounded set
    std::vector<std::string> pair_ids;                   // results come back in this order
    // "KEY=VALUE" settings that make matcher_version; with them, workers that take settings
    // and share the version's code revision can run the job too.
    std::vector<std::string> matcher_settings;
};

struct Assignment {
    std::string task_id;
    std::string worker_id;
    std::string job_key;
    const JobSpec* job = nullptr;          // valid until the job completes
    std::vector<std::string> pair_ids;
    int attempt = 1;
};

struct CompletedJob {
    std::string job_key;
    JobSpec spec;
    std::vector<std::string> requesters;        // everyone who asked while it ran
    std::vector<store::PairRecord> pairs;       // in spec.pair_ids order
    double started_at = 0, finished_at = 0;
    // Some shard gave up after max_attempts worker failures (unloadable submap, fetch
    // timeout, ...): its FAILED pairs say nothing about the parameters, so the job is an
    // answer for the requesters now but not an observation to keep.
    bool worker_failures = false;
    std::string failure;  // why, when worker_failures: the last worker error or "no worker serves ..."
};

class Scheduler {
public:
    explicit Scheduler(SchedulerOptions options = {});

    // A worker's announcement or heartbeat; (re)registers it. `held` (when the worker lists
    // them): the task ids it holds; tasks assigned to it more than delivery_grace_s ago and
    // not among them were lost on the way and are queued again.
    void heartbeat(const WorkerInfo& worker, double now, const std::vector<std::string>* held = nullptr);
    // Removes a worker at once (it said goodbye); its shards go back to the queue.
    void remove_worker(const std::string& worker_id);

    // Adds a job, or attaches `requester` to the running job with the same key. Returns
    // true when the job is new. A job without pairs completes at the next schedule().
    bool submit(const std::string& job_key, JobSpec spec, const std::string& requester, double now);

    // Re-queues shards of silent workers, then leases queued shards to workers with free
    // slots, matching matcher id and design-space hash. Returns the new assignments.
    std::vector<Assignment> schedule(double now);

    // A worker's results for a task. Returns the job when this completed it. Results for an
    // unknown or already-delivered task, from a worker that does not hold the lease while
    // another one does, or with the wrong pair count, are ignored (returns nullopt).
    std::optional<CompletedJob> complete(const std::string& task_id, const std::string& worker_id,
                                         std::vector<store::PairRecord> results, double now);
    // A worker reports it could not run a task (e.g. cannot load a submap).
    std::optional<CompletedJob> fail(const std::string& task_id, const std::string& worker_id,
                                     const std::string& reason, double now);

    // Jobs whose shards no live worker can run (no worker with that matcher/space yet).
    std::size_t queued_shards() const;
    std::size_t running_shards() const;
    std::size_t jobs() const { return jobs_.size(); }
    std::size_t workers() const { return workers_.size(); }
    int free_slots() const;
    // Completed jobs from schedule() (empty jobs) since the last call.
    std::vector<CompletedJob> take_completed();
    // The time of one submap's features in units of one pair's stage, learnt from the
    // delivered shards' durations (least squares on submaps new to the worker and pairs);
    // kDefaultFeaturePairs until shards with different shares of new submaps were timed.
    double feature_cost_in_pairs() const;
    static constexpr double kDefaultFeaturePairs = 8.0;  // reference matcher, lab (BENCHMARKS)
    // Seconds per new submap and per pair (the fit behind feature_cost_in_pairs); before shards
    // tell them apart, only their scale is fitted with kDefaultFeaturePairs. None before any.
    std::optional<std::pair<double, double>> cost_fit() const;

private:
    struct Shard {
        std::string task_id;
        std::string job_key;
        std::vector<std::size_t> pairs;  // indices into the job's pair list
        std::vector<int> submaps;        // distinct submaps it touches (SubmapIndex numbers)
        int component = 0;               // of the job's pair graph (PlannedShard)
        std::string worker;              // empty while queued
        std::size_t fresh = 0;           // submaps new to its worker when assigned (held proxy)
        int attempts = 0;
        double assigned_at = 0;
        bool done = false;
        std::string last_error;
    };
    struct Job {
        JobSpec spec;
        std::vector<std::string> requesters;
        std::vector<std::string> shard_ids;
        std::vector<store::PairRecord> pairs;
        std::size_t remaining = 0;
        bool worker_failures = false;
        std::string failure;
        double started_at = 0;
        std::optional<double> unserved_since;  // no compatible live worker since then
        std::deque<std::string> queued;        // its shards waiting for a worker, oldest first
        std::map<int, std::set<std::string>> component_workers;  // who was given shards of it
    };
    struct Worker {
        WorkerInfo info;
        double last_seen = 0;
        std::set<std::string> tasks;
        // By dataset: submaps of shards it was given (a proxy for its feature cache, which
        // keeps them across jobs that share per-submap parameters).
        std::map<std::string, std::vector<char>> held;
    };
    // Submaps of one dataset, numbered; how many live workers hold each.
    struct SubmapIndex {
        std::map<std::string, int> ids;
        std::vector<int> holders;
    };

    std::optional<CompletedJob> finish_shard(Shard& shard, double now);
    bool compatible(const Worker& w, const JobSpec& spec, double now) const;
    // Ends jobs that waited unserved_timeout_s without a compatible worker (into completed_).
    void expire_unserved(double now);
    void requeue(Shard& shard);
    // The queued shard `w` should run next, of the oldest job with a shard `w` can run: one
    // that needs no submap `w` lacks, else one in a component no other worker was given
    // shards of (runs are shared out whole); then the fewest submaps `w` lacks per pair, the
    // fewest of those held by others, the oldest. A shard that makes `w` join others' component
    // only when worth_joining says so. Empty when none.
    std::string pick_for(const Worker& w, double now) const;
    // Whether `w`, in none of them yet, should join the workers of `component` (computing
    // submaps they hold) rather than wait: when the free workers, each joining the component
    // that would finish last, end the job sooner by more than a newcomer's duplicated features
    // take, or when its share needs few submaps others compute too (docs/distributed.md,
    // "Locality").
    bool worth_joining(const Worker& w, const Job& job, int component, double now) const;
    void hold(Worker& w, const Shard& shard, Job& job);
    void forget(Worker& w);

    SchedulerOptions options_;
    std::uint64_t next_task_ = 1;
    std::map<std::string, Job> jobs_;
    std::map<std::string, Shard> shards_;
    std::vector<std::string> job_order_;  // job keys, oldest first
    std::map<std::string, Worker> workers_;
    std::map<std::string, SubmapIndex> submaps_;  // by dataset id
    std::vector<CompletedJob> completed_;
    // Sums for the least-squares fit duration = a * fresh submaps + b * pairs.
    struct CostSums {
        double ff = 0, fp = 0, pp = 0, fd = 0, pd = 0;
        std::size_t n = 0;
    } cost_;
};

}  // namespace maptune::scheduler
