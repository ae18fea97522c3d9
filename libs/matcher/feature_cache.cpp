#include "matcher/feature_cache.hpp"

#include <cmath>
#include <sstream>

namespace maptune::matcher {

MatcherParams quantize_feature_params(const MatcherParams& params, double quantum) {
    MatcherParams q = params;
    if (!(quantum > 0)) return q;
    auto round = [&](double v) { return std::round(v / quantum) * quantum; };
    q.r_N = round(params.r_N);
    q.v_K = round(params.v_K);
    q.t_K = round(params.t_K);
    q.r_D = round(params.r_D);
    q.r_LRF = round(params.r_LRF);
    return q;
}

std::string feature_key(const dataset::Submap& submap, const MatcherParams& params,
                        const MatcherSettings& settings, double quantum) {
    const double q = quantum > 0 ? quantum : 1e-9;
    auto k = [&](double v) { return std::llround(v / q); };
    std::ostringstream os;
    os << submap.id << '#' << submap.cloud.size() << ',' << submap.obstacles.size() << ','
       << (submap.octree ? 1 : 0) << '|' << k(params.r_N) << ',' << k(params.v_K) << ','
       << k(params.t_K) << ',' << k(params.r_D) << ',' << k(params.r_LRF) << '@' << q << '|'
       << feature_settings_fingerprint(settings);
    return os.str();
}

FeatureCache::FeatureCache(FeatureCacheOptions options)
    : options_(options), cache_(options.max_bytes, options.max_entries) {}

FeatureCache::FeaturesPtr FeatureCache::get_or_compute(
    const std::string& key, const std::function<FeaturesPtr()>& compute) {
    return cache_.get_or_compute(
        key,
        [&]() -> FeaturesPtr {
            try {
                return compute();
            } catch (...) {
                // compute_features does not throw for bad input; this is bad_alloc and the like.
                auto f = std::make_shared<SubmapFeatures>();
                f->status = FeatureStatus::kFailed;
                f->reason = "exception while computing features";
                return f;
            }
        },
        [](const SubmapFeatures& f) { return f.status != FeatureStatus::kTimeout; });
}

}  // namespace maptune::matcher
