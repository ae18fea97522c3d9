#pragma once
// The per-submap feature cache: an LruCache keyed by submap and per-submap parameters.

#include <cstddef>
#include <functional>
#include <memory>
#include <string>

#include "matcher/features.hpp"
#include "matcher/lru_cache.hpp"
#include "matcher/matcher_params.hpp"

namespace maptune::matcher {

struct FeatureCacheOptions {
    std::size_t max_bytes = std::size_t{4} << 30;  // 4 GiB
    std::size_t max_entries = 100000;
    // Per-submap parameters are rounded to multiples of this before computing and keying
    // (0.01 = "2 decimals" as the sample database rounds). Object-scale data (the bunny)
    // needs a finer quantum.
    double key_quantum = 0.01;
    // Per-pair descriptor neighbour lists (what makes re-evaluating pair-stage parameters
    // skip the descriptor GEMM): bound of their own cache; 0 disables it.
    std::size_t max_neighbour_bytes = std::size_t{1} << 30;  // 1 GiB
};

using FeatureCacheStats = CacheStats;

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
    // returned but not stored, since they depend on load rather than on the key; an
    // exception (bad_alloc and the like) becomes a FAILED result.
    FeaturesPtr get_or_compute(const std::string& key, const std::function<FeaturesPtr()>& compute);
    FeaturesPtr find(const std::string& key) { return cache_.find(key); }

    FeatureCacheStats stats() const { return cache_.stats(); }
    const FeatureCacheOptions& options() const { return options_; }
    void clear() { cache_.clear(); }

  private:
    FeatureCacheOptions options_;
    LruCache<SubmapFeatures> cache_;
};

}  // namespace maptune::matcher
