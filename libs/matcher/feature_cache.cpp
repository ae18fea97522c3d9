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
    // The content, not only the id: a submap changed under the same id is another entry.
    std::uint64_t content = submap.content_hash;
    if (content == 0) {  // built in memory: the cloud and obstacle coordinates themselves
        content = 1469598103934665603ull;
        auto mix = [&](const void* data, std::size_t n) {
            const auto* b = static_cast<const unsigned char*>(data);
            for (std::size_t i = 0; i < n; ++i) content = (content ^ b[i]) * 1099511628211ull;
        };
        for (const auto& p : submap.cloud) {
            const float xyz[3] = {p.x, p.y, p.z};
            const unsigned char rgb[3] = {p.r, p.g, p.b};
            mix(xyz, sizeof xyz);
            mix(rgb, sizeof rgb);
        }
        for (const auto& o : submap.obstacles) mix(o.data(), 3 * sizeof(float));
    }
    os << submap.id << '#' << std::hex << content << std::dec << ',' << submap.cloud.size() << ','
       << submap.obstacles.size() << ',' << (submap.octree ? 1 : 0) << '|' << k(params.r_N) << ',' << k(params.v_K) << ','
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
