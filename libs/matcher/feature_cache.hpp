#pragma once
// In-memory LRU cache of per-submap features, bounded by bytes and entries. Thread-safe;
// concurrent requests for the same key compute once and share the result.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <future>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "matcher/features.hpp"
#include "matcher/matcher_params.hpp"

namespace maptune::matcher {

struct FeatureCacheOptions {
    std::size_t max_bytes = std::size_t{4} << 30;  // 4 GiB
    std::size_t max_entries = 100000;
    // Per-submap parameters are rounded to multiples of this before computing and keying
    // (0.01 = "2 decimals" as the sample database rounds). Object-scale data (the bunny)
    // needs a finer quantum.
    double key_quantum = 0.01;
};

struct FeatureCacheStats {
    std::uint64_t hits = 0;
    std::uint64_t misses = 0;  // computations started
    std::uint64_t evictions = 0;
    std::size_t bytes = 0;
    std::size_t entries = 0;
};

// The per-submap parameters rounded to the cache quantum (what is actually computed).
MatcherParams quantize_feature_params(const MatcherParams& params, double quantum);

// Key: submap id, a cheap content fingerprint (sizes), the quantized (r_N, v_K, t_K, r_D,
// r_LRF) and the feature-relevant settings.
std::string feature_key(const dataset::Submap& submap, const MatcherParams& params,
                        const MatcherSettings& settings, double quantum);

class FeatureCache {
  public:
    using FeaturesPtr = std::shared_ptr<const SubmapFeatures>;
    explicit FeatureCache(FeatureCacheOptions options = {});

    // Returns the cached entry or runs compute() (outside the lock). Timed-out results are
    // returned but not stored, since they depend on load rather than on the key.
    FeaturesPtr get_or_compute(const std::string& key, const std::function<FeaturesPtr()>& compute);
    FeaturesPtr find(const std::string& key);  // no compute; counts a hit if present

    FeatureCacheStats stats() const;
    const FeatureCacheOptions& options() const { return options_; }
    void clear();

  private:
    struct Entry {
        std::string key;
        FeaturesPtr value;
        std::size_t bytes = 0;
    };
    void insert_locked(const std::string& key, FeaturesPtr value);
    void evict_locked();

    FeatureCacheOptions options_;
    mutable std::mutex mutex_;
    std::list<Entry> lru_;  // front = most recently used
    std::unordered_map<std::string, std::list<Entry>::iterator> index_;
    std::unordered_map<std::string, std::shared_future<FeaturesPtr>> in_flight_;
    FeatureCacheStats stats_;
};

}  // namespace maptune::matcher
