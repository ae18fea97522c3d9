#include "worker_backend.hpp"

#include <octomap/OcTree.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include "analytic/analytic.hpp"
#include "dataset/io.hpp"

namespace maptune::services {

std::shared_ptr<const dataset::Dataset> DatasetCache::get(const std::string& id, std::string* error) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = open_.find(id); it != open_.end()) return it->second;
    auto ds = mirror_.open(id, 30.0, error);
    if (!ds) return nullptr;
    auto shared = std::make_shared<const dataset::Dataset>(std::move(*ds));
    open_[id] = shared;
    return shared;
}

// ---- LruBackend ----

LruBackend::LruBackend(DatasetMirror& mirror, params::ParameterSpace space,
                       matcher::MatcherSettings settings, matcher::FeatureCacheOptions cache,
                       std::size_t submap_cache_bytes)
    : datasets_(mirror),
      space_(std::move(space)),
      settings_(settings),
      cache_options_(cache),
      version_(evaluation::matcher_version(settings)),
      submaps_(submap_cache_bytes, 1u << 20) {
    matchers_.emplace_back(version_, std::make_unique<matcher::Matcher>(settings_, cache_options_));
}

std::size_t LruBackend::matchers_held() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return matchers_.size();
}

matcher::Matcher* LruBackend::matcher_for(const TaskSpec& task, std::string* error) {
    std::string version = task.matcher_version.empty() ? version_ : task.matcher_version;
    auto found = std::find_if(matchers_.begin(), matchers_.end(), [&](const auto& m) { return m.first == version; });
    if (found == matchers_.end()) {
        if (task.matcher_settings.empty()) {
            *error = "matcher version " + version + " differs from this worker's " + version_ +
                     " and the task carries no settings";
            return nullptr;
        }
        // A task's settings replace all of the worker's but the local ones (threads).
        matcher::MatcherSettings settings;
        settings.threads = settings_.threads;
        if (auto err = matcher::set_matcher_settings(settings, task.matcher_settings); !err.empty()) {
            *error = "task settings: " + err;
            return nullptr;
        }
        if (const auto made = evaluation::matcher_version(settings); made != version) {
            *error = "task settings make matcher version " + made + ", not the " + version + " it asks for";
            return nullptr;
        }
        if (matchers_.size() >= kMaxMatchers) matchers_.pop_back();
        matchers_.emplace_back(version, std::make_unique<matcher::Matcher>(settings, cache_options_));
        found = std::prev(matchers_.end());
    }
    std::rotate(matchers_.begin(), found, std::next(found));  // most recently used first
    return matchers_.front().second.get();
}

std::size_t LruBackend::LoadedSubmap::bytes() const {
    return sizeof(*this) + submap.cloud.capacity() * sizeof(dataset::ColoredPoint) +
           submap.obstacles.capacity() * sizeof(Eigen::Vector3f) +
           (submap.octree ? submap.octree->memoryUsage() : 0);
}

std::shared_ptr<const LruBackend::LoadedSubmap> LruBackend::submap(const dataset::Dataset& ds, const std::string& id,
                                                                   std::string* error) {
    const std::string key = ds.manifest().id + "/" + id;
    try {
        return submaps_.get_or_compute(key, [&]() -> std::shared_ptr<const LoadedSubmap> {
            std::string fetch_error;
            if (!datasets_.mirror().ensure_submaps(ds, {id}, 120.0, &fetch_error)) {
                throw std::runtime_error(fetch_error);
            }
            return std::make_shared<const LoadedSubmap>(LoadedSubmap{ds.load_submap(id)});
        });
    } catch (const std::exception& e) {
        *error = e.what();
        return nullptr;
    }
}

TaskOutcome LruBackend::run(const TaskSpec& task) {
    TaskOutcome out;
    std::string error;
    const auto ds = datasets_.get(task.dataset_id, &error);
    if (!ds) {
        out.error = error;
        return out;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    matcher::Matcher* matcher = matcher_for(task, &error);
    if (matcher == nullptr) {
        out.error = error;
        return out;
    }
    std::vector<std::shared_ptr<const LoadedSubmap>> held;  // alive for the task, evicted or not
    const std::size_t misses_before = matcher->cache().stats().misses;
    auto results = evaluation::match_pair_ids(
        *matcher, task.params, task.pair_ids,
        [&](const std::string& id, std::string* why) -> const dataset::Submap* {
            auto s = submap(*ds, id, why);
            if (!s) return nullptr;
            held.push_back(s);
            return &s->submap;
        },
        &error);
    feature_computations_ += matcher->cache().stats().misses - misses_before;
    if (!results) {
        out.error = error;
        return out;
    }
    out.pairs = std::move(*results);
    out.ok = true;
    return out;
}

std::size_t LruBackend::feature_computations() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return feature_computations_;
}

// ---- AnalyticBackend ----

AnalyticBackend::AnalyticBackend(DatasetMirror& mirror, params::ParameterSpace space,
                                 AnalyticOptions options)
    : datasets_(mirror), space_(std::move(space)), options_(std::move(options)), rng_state_(options_.seed) {
    if (options_.optimum.empty()) options_.optimum = analytic::default_optimum(space_.size());
}

double AnalyticBackend::quality(const params::ParameterSet& params) const {
    return analytic::quality(space_, options_.optimum, params);
}

TaskOutcome AnalyticBackend::run(const TaskSpec& task) {
    TaskOutcome out;
    std::string error;
    const auto ds = datasets_.get(task.dataset_id, &error);
    if (!ds) {
        out.error = error;
        return out;
    }
    if (options_.failure_rate > 0) {
        std::lock_guard<std::mutex> lock(rng_mutex_);
        rng_state_ = rng_state_ * 6364136223846793005ULL + 1442695040888963407ULL;
        if (static_cast<double>(rng_state_ >> 11) * (1.0 / 9007199254740992.0) < options_.failure_rate) {
            out.error = "simulated failure";
            return out;
        }
    }
    if (options_.delay_per_pair_s > 0) {
        std::this_thread::sleep_for(
            std::chrono::duration<double>(options_.delay_per_pair_s * static_cast<double>(task.pair_ids.size())));
    }
    auto pairs = analytic::evaluate(*ds, space_, options_.optimum, task.params, task.pair_ids,
                                    options_.delay_per_pair_s, &error);
    if (!pairs) {
        out.error = error;
        return out;
    }
    out.pairs = std::move(*pairs);
    out.ok = true;
    return out;
}

}  // namespace maptune::services
