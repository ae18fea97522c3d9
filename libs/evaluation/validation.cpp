#include "evaluation/validation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <sstream>

#include "dataset/simulator.hpp"
#include "params/yaml_util.hpp"

namespace maptune::evaluation {
namespace fs = std::filesystem;
using params::ConfigError;

namespace {

dataset::SimConfig generate_config(const std::string& dir, const experiment::GenerateSpec& generate) {
    dataset::SimConfig config = dataset::sim_preset(generate.preset);
    if (generate.runs > 0) config.runs = generate.runs;
    if (generate.submaps > 0) config.submaps = generate.submaps;
    config.seed = generate.seed;
    for (const auto& s : generate.sim) {
        if (const std::string error = dataset::set_sim_option(config, s.key, s.value); !error.empty()) {
            throw ConfigError((s.where.empty() ? dir + ": sim." + s.key : s.where) + ": " + error);
        }
    }
    return config;
}

}  // namespace

void ensure_dataset(const std::string& dir, const std::optional<experiment::GenerateSpec>& generate,
                    const std::function<void(const std::string&)>& log) {
    if (fs::exists(fs::path(dir) / "manifest.yaml")) {
        // A dataset made by another preset (an older maptune, an edited config) would be
        // tuned and validated on silently: refuse it, naming the setting.
        if (!generate) return;
        const dataset::Dataset existing = dataset::Dataset::open(dir);
        if (existing.manifest().source != "simulator") return;
        const std::string why = dataset::sim_settings_mismatch(generate_config(dir, *generate), existing.manifest().meta);
        if (!why.empty()) {
            throw ConfigError(dir + ": not what dataset.generate (preset " + generate->preset + ") makes — " + why +
                              "; remove the directory to regenerate it, or drop the generate section to use it as it is");
        }
        return;
    }
    if (!generate) {
        throw ConfigError(dir + ": no dataset there, and no dataset.generate section to make one");
    }
    const dataset::SimConfig config = generate_config(dir, *generate);
    if (log) {
        log("generating dataset " + dir + " (" + generate->preset + ", " + std::to_string(config.runs) +
            " runs x " + std::to_string(config.submaps) + " submaps, seed " + std::to_string(config.seed) + ")");
    }
    const auto t0 = std::chrono::steady_clock::now();
    dataset::generate_dataset(config, dir);
    if (log) {
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        log("generated " + dir + " in " + params::format_fixed(s, 1) + " s");
    }
}

matcher::MatcherSettings experiment_matcher_settings(const experiment::Experiment& e, int threads) {
    matcher::MatcherSettings s;
    s.threads = threads > 0 ? threads : e.matcher_threads;
    s.pair_time_limit_s = e.pair_time_limit_s;
    s.total_time_limit_s = e.total_time_limit_s;
    for (const auto& m : e.matcher_settings) {
        const std::string error = matcher::set_matcher_setting(s, m.key, m.value);
        if (!error.empty()) throw params::ConfigError(m.where + ": " + error);
    }
    return s;
}

std::vector<CompareTarget> validation_targets(const experiment::Experiment& e) {
    std::vector<CompareTarget> out;
    for (const auto& v : e.validate) {
        CompareTarget t;
        t.label = v.label;
        t.dataset = v.dataset_dir;
        t.view = dataset::parse_view(v.view);
        t.reference = dataset::parse_reference(v.reference);
        t.m_star = v.m_star;
        t.m_star_per_pair = v.m_star_per_pair;
        out.push_back(std::move(t));
    }
    return out;
}

std::vector<NamedParameterSet> validation_sets(const experiment::Experiment& e, const fs::path& run_dir) {
    std::vector<NamedParameterSet> out;
    for (std::size_t i = 0; i < e.start_points.size(); ++i) {
        const std::string name =
            i == 0 ? kBaselineSet : "start:" + fs::path(e.start_point_files[i]).stem().string();
        out.push_back({name, e.start_points[i]});
    }
    const fs::path best = run_dir / "best_params.yaml";
    if (!fs::exists(best)) {
        throw ConfigError((run_dir / "best_params.yaml").string() +
                          ": missing (is this a run directory, with a successful evaluation?)");
    }
    out.push_back({kBestSet, params::load_parameter_set(best.string(), e.space)});
    const fs::path predicted = run_dir / "predicted_best.yaml";
    if (fs::exists(predicted)) out.push_back({kPredictedSet, params::load_parameter_set(predicted.string(), e.space)});
    return out;
}

CompareResult validate(const experiment::Experiment& e, const std::vector<NamedParameterSet>& sets,
                       CompareOptions options) {
    if (e.validate.empty()) {
        throw ConfigError(e.file + ": no 'validate' section (held-out dataset views to score the tuned sets on)");
    }
    for (const auto& v : e.validate) {
        ensure_dataset(v.dataset_dir, v.generate, options.progress);
    }
    options.e_star = e.e_star;
    options.w_v = e.w_v;
    CompareResult r = compare(e.space, sets, validation_targets(e), options);
    add_pooled_column(r);
    return r;
}

void add_pooled_column(CompareResult& r) {
    if (r.columns.size() < 2) return;
    const CompareColumn& first = r.columns.front();
    CompareColumn pooled;
    pooled.target.label = kPooledTarget;
    pooled.target.view = first.target.view;
    pooled.target.reference = first.target.reference;
    pooled.settings = first.settings;
    pooled.settings.m_star = 0;
    for (const auto& col : r.columns) {
        if (col.target.view != first.target.view || col.target.reference != first.target.reference) return;
        pooled.pairs += col.pairs;
        pooled.settings.m_star += col.settings.m_star;
    }
    pooled.dataset_name = kPooledTarget;
    pooled.dataset_id = kPooledTarget;
    pooled.m_star_rule = "the sum of the " + std::to_string(r.columns.size()) + " targets' m*";
    for (std::size_t s = 0; s < r.set_names.size(); ++s) {
        std::vector<const scoring::ScoreReport*> parts;
        CompareCell cell;
        cell.from_store = true;
        for (const auto& col : r.columns) {
            parts.push_back(&col.cells[s].report);
            cell.from_store = cell.from_store && col.cells[s].from_store;
            cell.wall_seconds += col.cells[s].wall_seconds;
        }
        cell.report = scoring::pool_reports(parts, pooled.settings);
        pooled.cells.push_back(std::move(cell));
    }
    r.columns.push_back(std::move(pooled));
}

namespace {

std::string num(double v) { return params::format_double(v); }

// Index of the baseline row, or -1.
int baseline_row(const CompareResult& r) {
    const auto it = std::find(r.set_names.begin(), r.set_names.end(), kBaselineSet);
    return it == r.set_names.end() ? -1 : static_cast<int>(it - r.set_names.begin());
}

}  // namespace

std::string validation_csv(const CompareResult& r) {
    std::ostringstream out;
    out << "set,target,dataset_id,view,reference,pairs,m_star,p,m,eps,e_t_median_m,e_r_median_deg,pair_s,"
           "delta_p_vs_baseline,from_store\n";
    const int base = baseline_row(r);
    for (std::size_t s = 0; s < r.set_names.size(); ++s) {
        for (const auto& col : r.columns) {
            const auto& rep = col.cells[s].report;
            const bool matched = rep.score.m > 0;
            out << r.set_names[s] << "," << col.target.label << "," << col.dataset_id << ","
                << dataset::to_string(col.target.view) << "," << dataset::to_string(col.target.reference) << ","
                << col.pairs << "," << num(col.settings.m_star) << "," << num(rep.score.p) << "," << rep.score.m
                << "," << num(rep.score.eps) << "," << (matched ? num(rep.e_t.median) : "") << ","
                << (matched ? num(rep.e_r.median * 180.0 / M_PI) : "") << "," << num(rep.mean_pair_s) << ",";
            if (base >= 0) out << num(rep.score.p - col.cells[static_cast<std::size_t>(base)].report.score.p);
            out << "," << (col.cells[s].from_store ? 1 : 0) << "\n";
        }
    }
    return out.str();
}

Spread spread(std::vector<double> values) {
    Spread s;
    s.n = static_cast<int>(values.size());
    if (values.empty()) return s;
    std::sort(values.begin(), values.end());
    const std::size_t n = values.size();
    s.median = n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
    s.min = values.front();
    s.max = values.back();
    return s;
}

SeedsSummary summarize_seeds(const std::vector<SeedOutcome>& seeds) {
    SeedsSummary out;
    out.columns = {"best_p"};
    for (const auto& s : seeds) {
        std::map<std::string, double> row;
        if (s.best_p) row["best_p"] = *s.best_p;
        if (s.validation) {
            for (std::size_t i = 0; i < s.validation->set_names.size(); ++i) {
                for (const auto& col : s.validation->columns) {
                    const std::string key = s.validation->set_names[i] + "@" + col.target.label;
                    if (std::find(out.columns.begin(), out.columns.end(), key) == out.columns.end()) {
                        out.columns.push_back(key);
                    }
                    row[key] = col.cells[i].report.score.p;
                }
            }
        }
        out.rows.push_back(std::move(row));
    }
    for (const auto& c : out.columns) {
        std::vector<double> v;
        for (const auto& row : out.rows) {
            if (auto it = row.find(c); it != row.end()) v.push_back(it->second);
        }
        out.spreads.push_back(spread(v));
    }
    return out;
}

std::string seeds_summary_csv(const std::vector<SeedOutcome>& seeds) {
    const SeedsSummary summary = summarize_seeds(seeds);
    std::ostringstream out;
    out << "seed";
    for (const auto& c : summary.columns) out << "," << c;
    out << ",run_dir\n";
    for (std::size_t i = 0; i < seeds.size(); ++i) {
        out << seeds[i].seed;
        for (const auto& c : summary.columns) {
            out << ",";
            if (auto it = summary.rows[i].find(c); it != summary.rows[i].end()) out << num(it->second);
        }
        out << "," << seeds[i].run_dir.filename().string() << "\n";
    }
    const std::pair<const char*, double Spread::*> stats[] = {
        {"median", &Spread::median}, {"min", &Spread::min}, {"max", &Spread::max}};
    for (const auto& [label, member] : stats) {
        out << label;
        for (const auto& sp : summary.spreads) out << "," << (sp.n ? num(sp.*member) : "");
        out << ",\n";
    }
    out << "spread";
    for (const auto& sp : summary.spreads) out << "," << (sp.n ? num(sp.max - sp.min) : "");
    out << ",\n";
    return out.str();
}

}  // namespace maptune::evaluation
