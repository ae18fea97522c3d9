// The second real matcher as its own service (issue 13): FPFH + RANSAC + GICP
// (fpfh_matcher.hpp), served through the worker SDK alone — no DDS header, no maptune matcher.
//
//   maptune_fpfh_worker --space configs/spaces/fpfh_gicp.yaml --domain 42
#include <functional>
#include <list>
#include <mutex>
#include <sstream>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "fpfh_matcher.hpp"
#include "maptune_sdk/worker.hpp"

namespace {

using maptune::sdk::Outcome;
using maptune::sdk::PairResult;
using maptune::sdk::PairStatus;
using maptune::sdk::Task;

std::uint64_t fnv1a(const std::string& s) {
    std::uint64_t h = 1469598103934665603ULL;
    for (unsigned char c : s) h = (h ^ c) * 1099511628211ULL;
    return h;
}

// Prepared clouds of recent submaps: a complete view touches each submap in many pairs.
class FeatureCache {
public:
    using Entry = maptune::fpfh::PrepareResult;
    explicit FeatureCache(std::size_t capacity) : capacity_(capacity) {}

    Entry get(const std::string& key, const std::function<Entry()>& make) {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            const auto it = index_.find(key);
            if (it != index_.end()) {
                order_.splice(order_.begin(), order_, it->second);
                return it->second->second;
            }
        }
        Entry e = make();  // outside the lock: other slots keep working
        std::lock_guard<std::mutex> lock(mutex_);
        if (index_.count(key)) return e;
        order_.emplace_front(key, e);
        index_[key] = order_.begin();
        if (order_.size() > capacity_) {
            index_.erase(order_.back().first);
            order_.pop_back();
        }
        return e;
    }

private:
    std::size_t capacity_;
    std::mutex mutex_;
    std::list<std::pair<std::string, Entry>> order_;
    std::unordered_map<std::string, std::list<std::pair<std::string, Entry>>::iterator> index_;
};

class FpfhMatcher : public maptune::sdk::Matcher {
public:
    std::string id() const override { return "fpfh_gicp"; }
    std::string version() const override {
        return "2-d" + std::to_string(settings_.ransac_max_draws) + "-g" + std::to_string(settings_.gicp_iterations) +
               "-t" + std::to_string(static_cast<int>(settings_.pair_time_limit_s));
    }

    Outcome run(const Task& task, maptune::sdk::Datasets& datasets) override {
        maptune::fpfh::Params params;
        try {
            params = maptune::fpfh::params_from(task.params);
        } catch (const std::exception& e) {
            Outcome out;
            out.error = e.what();
            return out;
        }
        std::ostringstream key;
        key << task.dataset_id << '|' << params.voxel_m << '|' << params.normal_scale << '|' << params.feature_scale << '|';
        return maptune::sdk::run_pairs(task, datasets, [&](const maptune::dataset::Dataset& ds, const std::string& a_id,
                                                           const std::string& b_id, PairResult& r) {
            const auto features = [&](const std::string& submap_id) {
                return cache_.get(key.str() + submap_id, [&] {
                    const auto submap = ds.load_submap(submap_id);
                    std::vector<Eigen::Vector3f> points;
                    points.reserve(submap.cloud.size());
                    for (const auto& p : submap.cloud) points.emplace_back(p.x, p.y, p.z);
                    return maptune::fpfh::prepare(points, params);
                });
            };
            const auto a = features(a_id), b = features(b_id);
            if (!a.cloud || !b.cloud) {
                r.reason = "submap " + (a.cloud ? b_id + ": " + b.reason : a_id + ": " + a.reason);
                return;
            }
            const auto pair = maptune::fpfh::register_pair(*a.cloud, *b.cloud, params, settings_, fnv1a(r.pair_id));
            r.matched = pair.matched;
            r.status = pair.matched ? PairStatus::kOk : pair.timed_out ? PairStatus::kTimeout : PairStatus::kNoMatch;
            r.reason = pair.reason;
            for (int i = 0; i < 16; ++i) r.T_a_b[static_cast<std::size_t>(i)] = pair.T_a_b(i / 4, i % 4);
        });
    }

private:
    maptune::fpfh::Settings settings_;
    FeatureCache cache_{64};
};

}  // namespace

int main(int argc, char** argv) {
    maptune::sdk::WorkerConfig config;
    if (const int code = maptune::sdk::parse_worker_args(
            argc, argv, "maptune fpfh_worker: FPFH + RANSAC + GICP matcher on the worker SDK", config);
        code >= 0) {
        return code;
    }
    FpfhMatcher matcher;
    return maptune::sdk::run_worker(config, matcher);
}
