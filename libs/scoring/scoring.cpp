#include "scoring/scoring.hpp"

#include <algorithm>
#include <map>

namespace maptune::scoring {
namespace {

ErrorStats error_stats(std::vector<double> v) {
    ErrorStats s;
    if (v.empty()) return s;
    std::sort(v.begin(), v.end());
    double sum = 0;
    for (double x : v) sum += x;
    s.mean = sum / static_cast<double>(v.size());
    s.median = v[v.size() / 2];
    s.p90 = v[std::min(v.size() - 1, static_cast<std::size_t>(0.9 * static_cast<double>(v.size())))];
    s.max = v.back();
    return s;
}

Eigen::Isometry3d to_isometry(const Eigen::Matrix4d& m) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.matrix() = m;
    return T;
}

// The matched pairs' part of a report: m, p and the error statistics.
void summarize_matches(ScoreReport& report, const std::vector<measure::MatchError>& errors) {
    std::vector<double> e_t, e_r;
    for (const auto& e : errors) {
        e_t.push_back(e.e_t);
        e_r.push_back(e.e_r);
    }
    report.matched = errors.size();
    report.score = measure::score(errors, report.settings);
    report.e_t = error_stats(std::move(e_t));
    report.e_r = error_stats(std::move(e_r));
}

}  // namespace

std::string pair_id(const dataset::SubmapPair& pair) { return pair.id_a + "|" + pair.id_b; }

std::optional<std::pair<std::string, std::string>> split_pair_id(const std::string& pair_id) {
    const auto bar = pair_id.find('|');
    if (bar == std::string::npos || bar == 0 || bar + 1 >= pair_id.size()) return std::nullopt;
    return std::make_pair(pair_id.substr(0, bar), pair_id.substr(bar + 1));
}

double derive_m_star(const std::vector<double>& overlaps, double min_overlap) {
    std::size_t n = 0;
    for (double o : overlaps) n += o >= min_overlap ? 1 : 0;
    return static_cast<double>(std::max<std::size_t>(n, 1));
}

double derive_m_star(const std::vector<dataset::SubmapPair>& pairs, double min_overlap) {
    std::vector<double> overlaps;
    overlaps.reserve(pairs.size());
    for (const auto& p : pairs) overlaps.push_back(p.overlap);
    return derive_m_star(overlaps, min_overlap);
}

ScoreReport score_observation(const dataset::Dataset& dataset,
                              const std::vector<dataset::SubmapPair>& pairs,
                              const std::vector<store::PairRecord>& results,
                              const measure::MeasureSettings& settings) {
    std::map<std::string, const store::PairRecord*> by_id;
    for (const auto& r : results) by_id[r.pair_id] = &r;
    ScoreReport report;
    report.settings = settings;
    report.pairs = pairs.size();
    std::vector<measure::MatchError> errors;
    for (const auto& p : pairs) {
        PairScore ps;
        ps.pair_id = pair_id(p);
        ps.overlap = p.overlap;
        ps.d = dataset.manifest().runs[static_cast<std::size_t>(p.run)]
                   .submaps[static_cast<std::size_t>(p.b)]
                   .size;
        const auto it = by_id.find(ps.pair_id);
        if (it == by_id.end()) {
            ++report.missing;
            ps.status = store::PairStatus::kFailed;
            ps.reason = "no result stored for this pair";
            report.per_pair.push_back(ps);
            continue;
        }
        const store::PairRecord& r = *it->second;
        ps.matched = r.matched;
        ps.status = r.status;
        ps.reason = r.reason;
        ps.duration_s = r.duration_s;
        report.mean_pair_s += r.duration_s;  // a sum until the end
        report.failed += r.status == store::PairStatus::kFailed ? 1 : 0;
        report.timeouts += r.status == store::PairStatus::kTimeout ? 1 : 0;
        if (r.matched) {
            const measure::MatchError e = measure::pair_error(p.T_a_b, to_isometry(r.T_a_b_est), ps.d);
            ps.e_t = e.e_t;
            ps.e_r = e.e_r;
            ps.rating = measure::rate_match(e, settings.e_star);
            errors.push_back(e);
        }
        report.per_pair.push_back(ps);
    }
    const std::size_t timed = report.per_pair.size() - report.missing;
    if (timed > 0) report.mean_pair_s /= static_cast<double>(timed);
    summarize_matches(report, errors);
    return report;
}

ScoreReport pool_reports(const std::vector<const ScoreReport*>& reports, const measure::MeasureSettings& settings) {
    ScoreReport pooled;
    pooled.settings = settings;
    std::vector<measure::MatchError> errors;
    double time_sum = 0;
    std::size_t timed = 0;
    for (const ScoreReport* r : reports) {
        pooled.pairs += r->pairs;
        pooled.failed += r->failed;
        pooled.timeouts += r->timeouts;
        pooled.missing += r->missing;
        const std::size_t r_timed = r->per_pair.size() - r->missing;
        time_sum += r->mean_pair_s * static_cast<double>(r_timed);
        timed += r_timed;
        for (const PairScore& ps : r->per_pair) {
            pooled.per_pair.push_back(ps);
            if (!ps.matched) continue;
            errors.push_back({ps.e_t, ps.e_r, ps.d});
        }
    }
    if (timed > 0) pooled.mean_pair_s = time_sum / static_cast<double>(timed);
    summarize_matches(pooled, errors);
    return pooled;
}

}  // namespace maptune::scoring
