#include "evaluation/evaluation.hpp"

#include <algorithm>
#include <chrono>
#include <map>
#include <sstream>

#include "dataset/io.hpp"

namespace maptune::evaluation {
store::PairStatus to_store_status(matcher::MatchStatus status) {
    switch (status) {
        case matcher::MatchStatus::kOk: return store::PairStatus::kOk;
        case matcher::MatchStatus::kNoMatch: return store::PairStatus::kNoMatch;
        case matcher::MatchStatus::kFailed: return store::PairStatus::kFailed;
        case matcher::MatchStatus::kTimeout: return store::PairStatus::kTimeout;
    }
    return store::PairStatus::kFailed;
}

std::string matcher_version(const matcher::MatcherSettings& s) {
    // Every setting but the thread count changes what the matcher returns.
    std::ostringstream text;
    text.precision(17);
    text << matcher::feature_settings_fingerprint(s) << '|' << s.collinear_inlier_fraction << ','
         << s.line_threshold_m << ',' << s.line_ransac_iterations << ',' << s.ransac_iterations
         << ',' << s.ransac_inlier_threshold_m << ',' << s.icp_max_iterations << ','
         << s.icp_max_correspondence_m << ',' << s.icp_voxel_m << ',' << s.icp_enabled << ','
         << s.max_roll_pitch_rad << ',' << s.min_points << ',' << s.min_keypoints << ','
         << s.pair_time_limit_s << ',' << s.submap_time_limit_s << ',' << s.total_time_limit_s
         << ',' << s.seed << ',' << s.min_icp_inlier_fraction << ',' << s.min_ransac_inliers;
    // Appended only when not the default, so keys of older observations stay valid.
    if (s.consensus_from_n_TF) text << ",nTF";
    if (s.ransac_threshold_from != matcher::MatcherSettings::ThresholdFrom::kVK) text << ",ransac_vTF";
    // The prefix counts code changes that alter results (2: ICP convergence epsilons).
    return "2-" + dataset::hex64(dataset::fnv1a(text.str())).substr(0, 8);
}

Evaluator::Evaluator(const dataset::Dataset& dataset, const params::ParameterSpace& space,
                     matcher::MatcherSettings settings, matcher::FeatureCacheOptions cache)
    : dataset_(dataset),
      space_(space),
      matcher_(settings, cache),
      version_(evaluation::matcher_version(settings)) {}

store::ObservationKey Evaluator::key(dataset::View view, const params::ParameterSet& params) const {
    const params::ParameterSet full = space_.round(space_.complete(params));
    return {dataset_.manifest().id, dataset::to_string(view), kMatcherId, version_,
            space_.canonical_key(full)};
}

const dataset::Submap& Evaluator::submap(int run, int index) {
    auto& slot = submaps_[{run, index}];
    if (!slot) slot = std::make_unique<dataset::Submap>(dataset_.load_submap(run, index));
    return *slot;
}

store::Observation Evaluator::evaluate(dataset::View view, const params::ParameterSet& params,
                                       matcher::EvaluationStats* stats) {
    const auto start = std::chrono::steady_clock::now();
    store::Observation obs;
    obs.params = space_.round(space_.complete(params));
    obs.key = key(view, params);
    // Any reference gives the same pairs; the matcher never sees the reference transforms.
    const auto pairs = dataset_.pairs(view, dataset::Reference::gt);
    std::vector<const dataset::Submap*> submaps;
    std::map<std::pair<int, int>, int> index_of;
    auto index = [&](int run, int i) {
        const auto [it, inserted] = index_of.emplace(std::make_pair(run, i), 0);
        if (inserted) {
            it->second = static_cast<int>(submaps.size());
            submaps.push_back(&submap(run, i));
        }
        return it->second;
    };
    std::vector<std::pair<int, int>> index_pairs;
    for (const auto& p : pairs) index_pairs.emplace_back(index(p.run, p.a), index(p.run, p.b));
    const matcher::MatcherParams mp = matcher::from_named_values(obs.params.values());
    const auto results = matcher_.match_pairs(submaps, index_pairs, mp, stats);
    for (std::size_t i = 0; i < pairs.size(); ++i) {
        store::PairRecord r;
        r.pair_id = scoring::pair_id(pairs[i]);
        r.matched = results[i].matched;
        r.T_a_b_est = results[i].T_a_b;
        r.duration_s = results[i].duration_s;
        r.status = to_store_status(results[i].status);
        r.reason = results[i].reason;
        obs.pairs.push_back(std::move(r));
    }
    obs.wall_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return obs;
}

store::Observation Evaluator::evaluate_cached(store::ObservationStore* db, dataset::View view,
                                              const params::ParameterSet& params,
                                              bool* from_store, matcher::EvaluationStats* stats) {
    if (db != nullptr) {
        if (auto found = db->get(key(view, params))) {
            if (from_store != nullptr) *from_store = true;
            return *found;
        }
    }
    if (from_store != nullptr) *from_store = false;
    store::Observation obs = evaluate(view, params, stats);
    if (db != nullptr && !store::has_timeouts(obs.pairs)) db->put(obs);
    return obs;
}

}  // namespace maptune::evaluation
