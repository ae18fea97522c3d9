#pragma once
// The reference matcher (SPEC §3): per-submap features through the cache, then the pair
// stage, thread-parallel over submaps and over pairs, with time limits.

#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "dataset/submap.hpp"
#include "matcher/descriptor_matching.hpp"
#include "matcher/feature_cache.hpp"
#include "matcher/features.hpp"
#include "matcher/match_result.hpp"
#include "matcher/matcher_params.hpp"

namespace maptune::matcher {

// The pair stage (SPEC §3 steps 7-10) on precomputed features; a is the target (scene), b the
// source (model). `seed` drives every random choice of this pair. With `neighbours` (the
// pair's nearest_descriptors lists, k >= n_C) step 7 selects from them instead of running the
// descriptor GEMM; the result is the same.
PairResult match_features(const SubmapFeatures& a, const SubmapFeatures& b,
                          const MatcherParams& params, const MatcherSettings& settings,
                          const Deadline& deadline, std::uint64_t seed,
                          const NeighbourLists* neighbours = nullptr);

// Seed of one pair, independent of thread scheduling: mixes the settings seed and both ids.
std::uint64_t pair_seed(std::uint64_t seed, const std::string& id_a, const std::string& id_b);

struct EvaluationStats {
    int submaps = 0;  // distinct submaps whose features were requested
    int pairs = 0;
    double feature_wall_s = 0.0;     // per-submap stage (including cache hits)
    double pair_wall_s = 0.0;        // pair stage
    std::uint64_t cache_hits = 0;    // during this call
    std::uint64_t cache_misses = 0;  // during this call
    std::uint64_t neighbour_hits = 0;  // pairs whose descriptor neighbour lists were cached
    int failed = 0, timeouts = 0, matched = 0;
};

class Matcher {
  public:
    explicit Matcher(MatcherSettings settings = {}, FeatureCacheOptions cache_options = {});

    const MatcherSettings& settings() const { return settings_; }
    FeatureCache& cache() { return cache_; }

    // Features of one submap (cached; per-submap parameters quantized by the cache quantum).
    std::shared_ptr<const SubmapFeatures> features(const dataset::Submap& submap,
                                                   const MatcherParams& params,
                                                   const Deadline& deadline = {});

    // One pair: T_a_b estimates the pose of b in a's frame.
    PairResult match(const dataset::Submap& a, const dataset::Submap& b,
                     const MatcherParams& params);

    // Many pairs (indices into submaps); results in the order of `pairs`. Features of all
    // involved submaps are computed first in parallel, then the pairs in parallel. Pairs not
    // started before the total time limit are reported kTimeout.
    std::vector<PairResult> match_pairs(const std::vector<const dataset::Submap*>& submaps,
                                        const std::vector<std::pair<int, int>>& pairs,
                                        const MatcherParams& params,
                                        EvaluationStats* stats = nullptr);
    std::vector<PairResult> match_pairs(const std::vector<dataset::Submap>& submaps,
                                        const std::vector<std::pair<int, int>>& pairs,
                                        const MatcherParams& params,
                                        EvaluationStats* stats = nullptr);

  private:
    int thread_count() const;
    // Features by an already quantized parameter set and its cache key (match_pairs computes
    // the keys once and also keys the neighbour lists by them).
    std::shared_ptr<const SubmapFeatures> features(const dataset::Submap& submap,
                                                   const MatcherParams& quantized,
                                                   const std::string& key,
                                                   const Deadline& deadline);

    // Neighbour lists of a pair, cached by both feature keys; null when the cache is off.
    std::shared_ptr<const NeighbourLists> neighbours(const SubmapFeatures& a,
                                                     const SubmapFeatures& b,
                                                     const std::string& key_a,
                                                     const std::string& key_b);

    MatcherSettings settings_;
    FeatureCache cache_;
    // Lists of length kNeighbourListLength serve every n_C of the design space (<= 10).
    static constexpr int kNeighbourListLength = 10;
    LruCache<NeighbourLists> neighbour_cache_;
};

}  // namespace maptune::matcher
