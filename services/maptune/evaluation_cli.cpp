#ifdef MAPTUNE_HAVE_EVALUATION
#include "evaluation_cli.hpp"

#include "params/cli_range.hpp"
#include "params/yaml_util.hpp"

namespace maptune::cli {


void add_evaluation_options(CLI::App& cmd, EvaluationCliOptions& o) {
    cmd.add_option("--dataset", o.dataset, "dataset directory")->required()->check(CLI::ExistingDirectory);
    cmd.add_option("--view", o.view, "complete | subsequent (default: complete)")
        ->check(CLI::IsMember({"complete", "subsequent"}));
    cmd.add_option("--reference", o.reference, "gt | odometry (default: gt)")
        ->check(CLI::IsMember({"gt", "odometry"}));
    cmd.add_option("--space", o.space, "design space YAML (default: configs/spaces/lru_matcher.yaml)");
    cmd.add_option("--e-star", o.e_star, "e* [m], > 0.05 (default: 0.4)");
    cmd.add_option("--m-star", o.m_star, "m*, > 0 (default: pairs of the view with gt overlap >= 0.3)");
    cmd.add_option("--w-v", o.w_v, "weight of v in p, 0..1 (default: 0.5)")->check(maptune::params::finite_range(0.0, 1.0));
    cmd.add_option("--db", o.db, "observation store: reuse stored results and store new ones (default: none)");
    add_matcher_options(cmd, o);
}

void add_matcher_options(CLI::App& cmd, EvaluationCliOptions& o) {
    cmd.add_option("--threads", o.threads, "matcher threads, 0 = all cores")->capture_default_str();
    // Bounded like the settings table's time limits: 0, negative or NaN made every pair TIMEOUT.
    cmd.add_option("--pair-time-limit", o.pair_time_limit_s, "seconds per pair before TIMEOUT, 0.001..1e7")
        ->capture_default_str()
        ->check(params::finite_range(0.001, 1e7));
    cmd.add_option("--time-limit", o.total_time_limit_s, "seconds per evaluation before TIMEOUT, 0.001..1e7")
        ->capture_default_str()
        ->check(params::finite_range(0.001, 1e7));
    cmd.add_option("--matcher", o.matcher_overrides,
                   "non-optimized matcher setting KEY=VALUE (repeatable; e.g. min_ransac_inliers=8, "
                   "docs/matcher.md); part of the observation key");
}

measure::MeasureSettings measure_settings(const EvaluationCliOptions& o, const dataset::Dataset& ds,
                                          const std::vector<dataset::SubmapPair>& pairs) {
    measure::MeasureSettings s;
    s.e_star = o.e_star.value_or(0.4);
    s.m_star = o.m_star ? *o.m_star
                        : scoring::derive_m_star(ds.reference_overlaps(pairs, dataset::parse_reference(o.reference)));
    s.w_v = o.w_v;
    return s;
}

matcher::MatcherSettings matcher_settings(const EvaluationCliOptions& o) {
    matcher::MatcherSettings s;
    s.threads = o.threads;
    s.pair_time_limit_s = o.pair_time_limit_s;
    s.total_time_limit_s = o.total_time_limit_s;
    if (auto err = matcher::set_matcher_settings(s, o.matcher_overrides); !err.empty()) {
        throw params::ConfigError(err);
    }
    return s;
}

nlohmann::json report_json(const scoring::ScoreReport& r, double wall_seconds, bool per_pair) {
    auto stats = [](const scoring::ErrorStats& e) {
        return nlohmann::json{{"mean", e.mean}, {"median", e.median}, {"p90", e.p90}, {"max", e.max}};
    };
    nlohmann::json j = {{"p", r.score.p},
                        {"v", r.score.v},
                        {"eps", r.score.eps},
                        {"m", r.score.m},
                        {"pairs", r.pairs},
                        {"failed", r.failed},
                        {"timeouts", r.timeouts},
                        {"e_star", r.settings.e_star},
                        {"m_star", r.settings.m_star},
                        {"w_v", r.settings.w_v},
                        {"e_t", stats(r.e_t)},
                        {"e_r", stats(r.e_r)},
                        {"mean_pair_s", r.mean_pair_s},
                        {"wall_seconds", wall_seconds}};
    if (per_pair) {
        nlohmann::json arr = nlohmann::json::array();
        for (const auto& p : r.per_pair) {
            arr.push_back({{"pair", p.pair_id},
                           {"matched", p.matched},
                           {"status", store::to_string(p.status)},
                           {"reason", p.reason},
                           {"overlap", p.overlap},
                           {"e_t", p.e_t},
                           {"e_r", p.e_r},
                           {"d", p.d},
                           {"rating", p.rating},
                           {"seconds", p.duration_s}});
        }
        j["per_pair"] = arr;
    }
    return j;
}

}  // namespace maptune::cli
#endif
