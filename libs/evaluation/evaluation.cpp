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
    // Every setting of the one table (all but the thread count) changes what the matcher returns.
    std::string text;
    for (const auto& f : matcher::setting_fields())
        if (matcher::in_version(f, s)) text += f.name + "=" + f.get(s) + ";";
    // The prefix counts code changes that alter results (2: ICP convergence epsilons; 3: the
    // version derived from the settings table instead of a hand-kept list; 4: pair durations
    // include both submaps' feature time, which run-time budgets compare).
    return std::string(kMatcherCodeRevision) + "-" + dataset::hex64(dataset::fnv1a(text)).substr(0, 8);
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

std::optional<std::vector<store::PairRecord>> match_pair_ids(matcher::Matcher& matcher,
                                                             const params::ParameterSet& params,
                                                             const std::vector<std::string>& pair_ids,
                                                             const SubmapSource& source, std::string* error,
                                                             matcher::EvaluationStats* stats) {
    std::vector<const dataset::Submap*> submaps;
    std::map<std::string, int> index;
    std::vector<std::pair<int, int>> pairs;
    auto index_of = [&](const std::string& id) -> int {
        if (auto it = index.find(id); it != index.end()) return it->second;
        const dataset::Submap* s = source(id, error);
        if (s == nullptr) return -1;
        submaps.push_back(s);
        return index[id] = static_cast<int>(submaps.size()) - 1;
    };
    for (const auto& pid : pair_ids) {
        const auto ids = scoring::split_pair_id(pid);
        if (!ids) {
            *error = "malformed pair id '" + pid + "'";
            return std::nullopt;
        }
        const int a = index_of(ids->first), b = index_of(ids->second);
        if (a < 0 || b < 0) return std::nullopt;
        pairs.emplace_back(a, b);
    }
    const auto results = matcher.match_pairs(submaps, pairs, matcher::from_named_values(params.values()), stats);
    std::vector<store::PairRecord> out;
    for (std::size_t i = 0; i < results.size(); ++i) {
        store::PairRecord r;
        r.pair_id = pair_ids[i];
        r.matched = results[i].matched;
        r.T_a_b_est = results[i].T_a_b;
        // The pair's cost from the raw submaps (features of both + pair stage): what a robot
        // pays to match them, the same whatever this worker had cached (docs/experiments.md,
        // "Run time").
        r.duration_s = results[i].duration_s + results[i].features_s;
        r.status = to_store_status(results[i].status);
        r.reason = results[i].reason;
        out.push_back(std::move(r));
    }
    return out;
}

store::Observation Evaluator::evaluate(dataset::View view, const params::ParameterSet& params,
                                       matcher::EvaluationStats* stats) {
    const auto start = std::chrono::steady_clock::now();
    store::Observation obs;
    obs.params = space_.round(space_.complete(params));
    obs.key = key(view, params);
    // Any reference gives the same pairs; the matcher never sees the reference transforms.
    const auto pairs = dataset_.pairs(view, dataset::Reference::gt);
    std::map<std::string, std::pair<int, int>> where;  // submap id -> (run, index)
    std::vector<std::string> pair_ids;
    for (const auto& p : pairs) {
        where[p.id_a] = {p.run, p.a};
        where[p.id_b] = {p.run, p.b};
        pair_ids.push_back(scoring::pair_id(p));
    }
    std::string error;
    // Dataset submaps load or throw (DatasetError names the file): no nullopt here.
    auto results = match_pair_ids(
        matcher_, obs.params, pair_ids,
        [&](const std::string& id, std::string*) { return &submap(where.at(id).first, where.at(id).second); },
        &error, stats);
    if (!results) throw std::runtime_error("evaluate: " + error);
    obs.pairs = std::move(*results);
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
    if (db != nullptr && !verified_) {
        // Observations are stored under the manifest's content id: files changed since it was
        // written would file another dataset's results under it for good. Checked once.
        std::string recomputed;
        if (!dataset_.verify(&recomputed)) {
            throw std::runtime_error(dataset_.dir().string() + ": its files changed since the manifest was written (id " +
                                     dataset_.manifest().id + ", the files give " + recomputed +
                                     "): nothing is stored for it; regenerate or re-import the dataset");
        }
        verified_ = true;
    }
    store::Observation obs = evaluate(view, params, stats);
    if (db != nullptr && !store::has_timeouts(obs.pairs)) db->put(obs);
    return obs;
}

}  // namespace maptune::evaluation
