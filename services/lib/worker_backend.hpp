#pragma once
// What a matcher worker runs. A robot's own matcher plugs in by implementing this (in C++),
// or by speaking the DDS contract of docs/plugin-matcher.md in any language.

#include <map>

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "dataset_mirror.hpp"
#include "matcher/lru_cache.hpp"
#include "evaluation/evaluation.hpp"
#include "params/parameter_space.hpp"
#include "store/observation_store.hpp"

namespace maptune::services {

struct TaskSpec {
    std::string task_id;
    std::string dataset_id;
    std::string view;
    params::ParameterSet params;        // full rounded set
    std::vector<std::string> pair_ids;  // "idA|idB"
    // The version the results must be of ("" = the backend's own), and the "KEY=VALUE"
    // settings that make it (empty = the backend's own settings).
    std::string matcher_version;
    std::vector<std::string> matcher_settings;
};

struct TaskOutcome {
    bool ok = false;
    std::string error;                     // why the whole task failed (ok = false)
    std::vector<store::PairRecord> pairs;  // one per pair id, same order (ok = true)
};

class WorkerBackend {
public:
    virtual ~WorkerBackend() = default;
    virtual std::string matcher_id() const = 0;
    virtual std::string matcher_version() const = 0;
    virtual const params::ParameterSpace& space() const = 0;
    // true: run() honours a task's matcher_settings for any version of the backend's code
    // revision (the part of matcher_version before '-'); false: only its own version.
    virtual bool takes_settings() const { return false; }
    // Thread-safe; never throws: failures are outcomes.
    virtual TaskOutcome run(const TaskSpec& task) = 0;
    // Per-submap feature computations so far (cache misses), for the feature duplication
    // factor of a distributed evaluation; 0 for a backend without per-submap features.
    virtual std::size_t feature_computations() const { return 0; }
};


// Opened datasets by id, shared by a backend's tasks.
class DatasetCache {
public:
    explicit DatasetCache(DatasetMirror& mirror) : mirror_(mirror) {}
    std::shared_ptr<const dataset::Dataset> get(const std::string& id, std::string* error);
    DatasetMirror& mirror() { return mirror_; }

private:
    DatasetMirror& mirror_;
    std::mutex mutex_;
    std::map<std::string, std::shared_ptr<const dataset::Dataset>> open_;
};

// The reference PCL pipeline (libs/matcher) on submaps fetched through the mirror.
class LruBackend : public WorkerBackend {
public:
    // Loaded submaps are kept in an LRU cache of at most `submap_cache_bytes` (a worker on a
    // large dataset must not hold every submap it ever ran).
    static constexpr std::size_t kDefaultSubmapCacheBytes = std::size_t{1} << 30;
    LruBackend(DatasetMirror& mirror, params::ParameterSpace space,
               matcher::MatcherSettings settings = {}, matcher::FeatureCacheOptions cache = {},
               std::size_t submap_cache_bytes = kDefaultSubmapCacheBytes);
    std::string matcher_id() const override { return evaluation::kMatcherId; }
    std::string matcher_version() const override { return version_; }
    const params::ParameterSpace& space() const override { return space_; }
    bool takes_settings() const override { return true; }
    TaskOutcome run(const TaskSpec& task) override;
    std::size_t feature_computations() const override;

    matcher::CacheStats submap_cache_stats() const { return submaps_.stats(); }
    // Matchers held (one per settings version recently run; at most kMaxMatchers).
    static constexpr std::size_t kMaxMatchers = 2;
    std::size_t matchers_held() const;

private:
    struct LoadedSubmap {
        dataset::Submap submap;
        std::size_t bytes() const;
    };
    std::shared_ptr<const LoadedSubmap> submap(const dataset::Dataset& ds, const std::string& id, std::string* error);

    // The matcher of a task's version, built from its settings on first use; null with
    // `error` set when the settings are bad or make another version. Called under mutex_.
    matcher::Matcher* matcher_for(const TaskSpec& task, std::string* error);

    DatasetCache datasets_;
    params::ParameterSpace space_;
    matcher::MatcherSettings settings_;
    matcher::FeatureCacheOptions cache_options_;
    std::string version_;
    mutable std::mutex mutex_;  // one task at a time: the matcher parallelizes inside
    // By version, most recently used first; each holds its own feature cache.
    std::vector<std::pair<std::string, std::unique_ptr<matcher::Matcher>>> matchers_;
    matcher::LruCache<LoadedSubmap> submaps_;
    std::size_t feature_computations_ = 0;  // under mutex_
};

// A test objective with the matcher's contract and no PCL: estimates are the ground truth
// moved by an error that depends smoothly on the parameters (best near `optimum`, in the
// unit cube of the space), matches are drawn with a parameter-dependent probability.
// Deterministic per (parameters, pair) except the simulated failures.
struct AnalyticOptions {
    double delay_per_pair_s = 0;   // simulated work
    double failure_rate = 0;       // probability that a task fails as a whole
    std::vector<double> optimum;   // unit-cube location of the best parameters; empty: 0.3…
    std::uint64_t seed = 1;
};

class AnalyticBackend : public WorkerBackend {
public:
    AnalyticBackend(DatasetMirror& mirror, params::ParameterSpace space, AnalyticOptions options = {});
    std::string matcher_id() const override { return "analytic"; }
    std::string matcher_version() const override { return "1"; }
    const params::ParameterSpace& space() const override { return space_; }
    TaskOutcome run(const TaskSpec& task) override;

    // Quality in [0, 1] of a full parameter set: 1 at the optimum.
    double quality(const params::ParameterSet& params) const;

private:
    DatasetCache datasets_;
    params::ParameterSpace space_;
    AnalyticOptions options_;
    std::mutex rng_mutex_;
    std::uint64_t rng_state_;
};

}  // namespace maptune::services
