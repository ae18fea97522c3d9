#include "report/report_data.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numeric>
#include <optional>
#include <sstream>

#include "dataset/dataset.hpp"
#include "experiment/experiment.hpp"
#include "experiment/run_files.hpp"
#include "params/yaml_util.hpp"
#include "scoring/scoring.hpp"
#include "store/observation_store.hpp"

namespace maptune::report {
namespace fs = std::filesystem;
using nlohmann::json;
using params::ConfigError;

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

// A YAML scalar as a JSON number when it reads as one, else as text.
json scalar_json(const std::string& text) {
    if (text == "true" || text == "false") return text == "true";
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (!text.empty() && end == text.c_str() + text.size() && std::isfinite(v)) return v;
    return text;
}

json yaml_json(const YAML::Node& n) {
    if (n.IsMap()) {
        json out = json::object();
        for (const auto& kv : n) out[kv.first.IsScalar() ? kv.first.Scalar() : std::string("?")] = yaml_json(kv.second);
        return out;
    }
    if (n.IsSequence()) {
        json out = json::array();
        for (const auto& item : n) out.push_back(yaml_json(item));
        return out;
    }
    if (n.IsScalar()) return scalar_json(n.Scalar());
    return nullptr;
}

// validation.csv as a list of objects (numbers where a cell reads as one).
json read_validation(const fs::path& file) {
    json rows = json::array();
    std::ifstream in(file);
    if (!in) return rows;
    std::string line;
    std::getline(in, line);
    const auto header = experiment::split_csv_line(line);
    while (std::getline(in, line)) {
        const auto cells = experiment::split_csv_line(line);
        json row = json::object();
        for (std::size_t i = 0; i < header.size() && i < cells.size(); ++i) {
            row[header[i]] = cells[i].empty() ? json(nullptr) : scalar_json(cells[i]);
        }
        rows.push_back(row);
    }
    return rows;
}

// Values of parameter `spec` along a slice: evenly spaced (geometric on log scales); every
// integer when there are at most `n` of them.
std::vector<double> axis_values(const bo::ParameterSpec& spec, int n) {
    std::vector<double> out;
    if (spec.is_integer && spec.high - spec.low + 1 <= n) {
        for (double v = spec.low; v <= spec.high; v += 1) out.push_back(v);
        return out;
    }
    for (int i = 0; i < n; ++i) {
        const double t = n > 1 ? static_cast<double>(i) / (n - 1) : 0.5;
        double v = spec.log_scale ? std::exp(std::log(spec.low) + t * (std::log(spec.high) - std::log(spec.low)))
                                  : spec.low + t * (spec.high - spec.low);
        if (spec.is_integer) v = std::round(v);
        if (out.empty() || v != out.back()) out.push_back(v);
    }
    return out;
}

}  // namespace

json run_data(const fs::path& run_dir, const ReportOptions& options) {
    const fs::path record_file = run_dir / "run.yaml";
    if (!fs::exists(record_file)) throw ConfigError(record_file.string() + ": missing (not a run directory)");
    const YAML::Node record = params::load_yaml_file(record_file.string());
    const experiment::Experiment e = experiment::load_experiment(
        options.experiment.empty() ? experiment::recorded_experiment_file(run_dir) : options.experiment);
    const auto trials = experiment::read_trials_csv(run_dir / "trials.csv", e.space);

    json out;
    out["dir"] = run_dir.string();
    out["name"] = run_dir.filename().string() == "" ? run_dir.parent_path().filename().string()
                                                   : run_dir.filename().string();
    if (run_dir.filename().string().rfind("seed-", 0) == 0) {
        out["name"] = run_dir.parent_path().filename().string() + "/" + run_dir.filename().string();
    }
    out["record"] = yaml_json(record);
    json notes = json::array();

    const experiment::RunRecord run = experiment::read_run_record(run_dir);
    const double m_star = run.m_star > 0 ? run.m_star : (e.m_star ? *e.m_star : 0.0);
    const measure::MeasureSettings settings{e.e_star, m_star, e.w_v};
    out["measure"] = {{"e_star", e.e_star}, {"m_star", m_star}, {"w_v", e.w_v}, {"max_pair_seconds", e.max_pair_seconds}};

    const auto box = experiment::search_space(e);
    json space = json::array();
    for (const auto& s : box) {
        space.push_back({{"name", s.name}, {"low", s.low}, {"high", s.high}, {"integer", s.is_integer},
                         {"log", s.log_scale}});
    }
    out["space"] = space;

    const int baseline = experiment::baseline_index(e, trials);

    json evaluations = json::array();
    int best = -1;
    std::vector<int> steps;  // every new best-so-far, and the baseline first
    for (std::size_t i = 0; i < trials.size(); ++i) {
        const auto& r = trials[i];
        if (!r.failed && r.fidelity == 1 && (best < 0 || experiment::better(e, experiment::record_objective(e, r),
                                                         experiment::record_objective(e, trials[static_cast<std::size_t>(best)])))) {
            best = static_cast<int>(i);
            steps.push_back(best);
        }
        json params = json::object();
        for (const auto& name : e.optimize) params[name] = r.params.get(name);
        evaluations.push_back({{"evaluation", r.number},
                               {"p", r.p},
                               {"m", r.m},
                               {"v", r.v},
                               {"eps", r.eps},
                               {"failed", r.failed},
                               {"from_store", r.from_store},
                               {"wall_s", r.wall_s},
                               {"pair_s", r.pair_s},
                               {"fidelity", r.fidelity},
                               {"elapsed_s", r.elapsed_s},
                               {"objective", experiment::record_objective(e, r)},
                               {"origin", r.origin},
                               {"best_so_far", best >= 0 ? json(trials[static_cast<std::size_t>(best)].p) : json(nullptr)},
                               {"params", params},
                               {"error", r.error}});
    }
    if (baseline >= 0 && std::find(steps.begin(), steps.end(), baseline) == steps.end()) {
        steps.insert(steps.begin(), baseline);
    }
    out["evaluations"] = evaluations;
    out["baseline"] = baseline >= 0 ? json(trials[static_cast<std::size_t>(baseline)].number) : json(nullptr);
    out["best"] = best >= 0 ? json(trials[static_cast<std::size_t>(best)].number) : json(nullptr);

    // Best-so-far steps with their per-pair errors, from the store and the dataset.
    std::optional<dataset::Dataset> ds;
    std::vector<dataset::SubmapPair> pairs;
    std::unique_ptr<store::ObservationStore> db;
    const std::string dataset_dir = run.dataset_dir.empty() ? e.dataset_dir : run.dataset_dir;
    const std::string db_path = options.db.empty() ? experiment::run_store_path(run_dir) : options.db;
    if (e.objective) {
        out["objective"] = {{"command", e.objective->command}, {"minimize", e.minimize}};
    } else try {
        if (db_path.empty()) throw std::runtime_error("no observation store next to the run (give --db)");
        db = std::make_unique<store::ObservationStore>(db_path, store::ObservationStore::Mode::kReadOnly);
        ds = dataset::Dataset::open(dataset_dir);
        // The run's observations are stored under the dataset id it ran on.
        if (!run.dataset_id.empty() && ds->manifest().id != run.dataset_id) {
            throw std::runtime_error(dataset_dir + " is now dataset " + ds->manifest().id + ", the run used " +
                                     run.dataset_id);
        }
        pairs = ds->pairs(dataset::parse_view(e.view), dataset::parse_reference(e.reference));
    } catch (const std::exception& err) {
        notes.push_back(std::string("per-pair errors left out: ") + err.what());
        db.reset();
    }
    json step_list = json::array();
    for (const int i : steps) {
        const auto& r = trials[static_cast<std::size_t>(i)];
        json step = {{"evaluation", r.number},
                     {"label", i == baseline ? std::string("baseline") : "#" + std::to_string(r.number)},
                     {"p", r.p},
                     {"v_share", e.w_v * r.v},
                     {"eps_share", (1 - e.w_v) * r.eps},
                     {"m", r.m},
                     {"pair_s", r.pair_s}};
        json errors = json::array();
        if (db && ds) {
            experiment::RunRecord on = run;
            on.dataset_id = ds->manifest().id;  // equal to the recorded one (checked above), or not recorded
            const store::ObservationKey key = experiment::observation_key(on, e.space, r.params);
            if (const auto obs = db->get(key)) {
                const auto rep = scoring::score_observation(*ds, pairs, obs->pairs, settings);
                for (const auto& ps : rep.per_pair) {
                    if (ps.matched) errors.push_back({{"e_t", ps.e_t}, {"e_r_deg", ps.e_r * kRadToDeg}});
                }
            } else {
                notes.push_back("evaluation " + std::to_string(r.number) + " is not in the store " + db_path);
            }
        }
        step["errors"] = errors;
        step_list.push_back(step);
    }
    out["steps"] = step_list;

    // The model, refitted from the run's observations with the run's optimizer settings.
    std::vector<bo::Observation> history;
    std::size_t ok = 0;
    for (const auto& r : trials) {
        history.push_back({experiment::optimizer_values(e, r.params), experiment::record_objective(e, r), r.failed, r.error});
        ok += r.failed ? 0 : 1;
    }
    out["model"] = nullptr;
    if (ok >= 2 && best >= 0) {
        bo::Optimizer opt(box, experiment::optimizer_options(e), history);
        opt.fit();
        const auto& hp = opt.hyperparameters();
        const std::vector<double> at = experiment::optimizer_values(e, trials[static_cast<std::size_t>(best)].params);
        json model;
        model["signal_variance"] = hp.signal_variance;
        model["noise_variance"] = hp.noise_variance;
        model["acquisition"] = e.acquisition;
        json importance = json::array();
        double total = 0;
        for (Eigen::Index j = 0; j < hp.length_scales.size(); ++j) total += 1.0 / hp.length_scales(j);
        for (std::size_t j = 0; j < box.size(); ++j) {
            const double ls = hp.length_scales(static_cast<Eigen::Index>(j));
            importance.push_back({{"parameter", box[j].name}, {"length_scale", ls}, {"importance", (1.0 / ls) / total}});
        }
        model["importance"] = importance;

        // Every slice's points in one posterior call (one factorization of the model).
        std::vector<std::vector<double>> points;
        std::vector<std::size_t> first{0};  // slice j: points[first[j], first[j + 1])
        for (std::size_t j = 0; j < box.size(); ++j) {
            for (double v : axis_values(box[j], options.slice_points)) {
                points.push_back(at);
                points.back()[j] = v;
            }
            first.push_back(points.size());
        }
        const auto post = opt.posterior(points);
        json slices = json::array();
        for (std::size_t j = 0; j < box.size() && !post.empty(); ++j) {
            json line = json::array();
            for (std::size_t k = first[j]; k < first[j + 1]; ++k) {
                line.push_back({{"x", points[k][j]}, {"mean", post[k].mean}, {"std", post[k].std}});
            }
            slices.push_back({{"parameter", box[j].name}, {"at", at[j]}, {"points", line}});
        }
        model["slices"] = slices;

        // The 2-D grid: the given pair, else the two most sensitive parameters.
        if (box.size() >= 2) {
            std::vector<std::size_t> order(box.size());
            std::iota(order.begin(), order.end(), 0);
            std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
                return hp.length_scales(static_cast<Eigen::Index>(a)) < hp.length_scales(static_cast<Eigen::Index>(b));
            });
            auto index_of = [&](const std::string& name) -> std::size_t {
                for (std::size_t j = 0; j < box.size(); ++j) {
                    if (box[j].name == name) return j;
                }
                throw ConfigError("--grid " + name + ": not an optimized parameter of experiment '" + e.name + "'");
            };
            const std::size_t gx = options.grid_x.empty() ? order[0] : index_of(options.grid_x);
            std::size_t gy = options.grid_y.empty() ? order[0] : index_of(options.grid_y);
            if (options.grid_y.empty()) gy = gx == order[0] ? order[1] : order[0];
            if (gx == gy) throw ConfigError("--grid: give two different parameters");
            std::vector<std::vector<double>> cell_points;
            const auto xs = axis_values(box[gx], options.grid_points);
            const auto ys = axis_values(box[gy], options.grid_points);
            for (double y : ys) {
                for (double x : xs) {
                    cell_points.push_back(at);
                    cell_points.back()[gx] = x;
                    cell_points.back()[gy] = y;
                }
            }
            const auto cell_post = opt.posterior(cell_points);
            json cells = json::array();
            for (std::size_t k = 0; k < cell_post.size(); ++k) {
                const auto& c = cell_post[k];
                cells.push_back({{"x", cell_points[k][gx]},
                                 {"y", cell_points[k][gy]},
                                 {"mean", c.mean},
                                 {"std", c.std},
                                 {"acquisition", std::isfinite(c.acquisition) ? json(c.acquisition) : json(nullptr)}});
            }
            model["grid"] = {{"x", box[gx].name}, {"y", box[gy].name}, {"at", {at[gx], at[gy]}}, {"cells", cells}};
        }
        out["model"] = model;
    } else {
        notes.push_back("no model: fewer than two successful evaluations");
    }

    out["validation"] = read_validation(run_dir / "validation.csv");
    out["notes"] = notes;
    return out;
}

json report_data(const std::vector<fs::path>& dirs, const ReportOptions& options) {
    json runs = json::array();
    for (const auto& d : experiment::expand_run_dirs(dirs)) runs.push_back(run_data(d, options));
    return {{"runs", runs}};
}

}  // namespace maptune::report
