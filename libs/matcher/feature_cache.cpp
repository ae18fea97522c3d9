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

FeatureCache::FeatureCache(FeatureCacheOptions options) : options_(options) {}

FeatureCache::FeaturesPtr FeatureCache::find(const std::string& key) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = index_.find(key);
    if (it == index_.end()) return nullptr;
    lru_.splice(lru_.begin(), lru_, it->second);
    ++stats_.hits;
    return it->second->value;
}

FeatureCache::FeaturesPtr FeatureCache::get_or_compute(
    const std::string& key, const std::function<FeaturesPtr()>& compute) {
    std::promise<FeaturesPtr> promise;
    {
        std::unique_lock<std::mutex> lock(mutex_);
        auto it = index_.find(key);
        if (it != index_.end()) {
            lru_.splice(lru_.begin(), lru_, it->second);
            ++stats_.hits;
            return it->second->value;
        }
        auto fl = in_flight_.find(key);
        if (fl != in_flight_.end()) {
            auto future = fl->second;
            ++stats_.hits;
            lock.unlock();
            return future.get();
        }
        ++stats_.misses;
        in_flight_.emplace(key, promise.get_future().share());
    }
    FeaturesPtr value;
    try {
        value = compute();
    } catch (...) {
        // compute_features does not throw for bad input; this is bad_alloc and the like.
        auto f = std::make_shared<SubmapFeatures>();
        f->status = FeatureStatus::kFailed;
        f->reason = "exception while computing features";
        value = f;
    }
    {
        std::lock_guard<std::mutex> lock(mutex_);
        in_flight_.erase(key);
        if (value && value->status != FeatureStatus::kTimeout) insert_locked(key, value);
    }
    promise.set_value(value);
    return value;
}

void FeatureCache::insert_locked(const std::string& key, FeaturesPtr value) {
    const std::size_t bytes = value->bytes() + key.size();
    lru_.push_front(Entry{key, std::move(value), bytes});
    index_[key] = lru_.begin();
    stats_.bytes += bytes;
    stats_.entries = lru_.size();
    evict_locked();
}

void FeatureCache::evict_locked() {
    // Never evict the entry just inserted (front), or a single big submap could not be cached.
    while (lru_.size() > 1 &&
           (stats_.bytes > options_.max_bytes || lru_.size() > options_.max_entries)) {
        const Entry& victim = lru_.back();
        stats_.bytes -= victim.bytes;
        index_.erase(victim.key);
        lru_.pop_back();
        ++stats_.evictions;
    }
    stats_.entries = lru_.size();
}

FeatureCacheStats FeatureCache::stats() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return stats_;
}

void FeatureCache::clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    lru_.clear();
    index_.clear();
    stats_.bytes = 0;
    stats_.entries = 0;
}

}  // namespace maptune::matcher
