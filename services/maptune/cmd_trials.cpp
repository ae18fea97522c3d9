// maptune trials: list the observations in a store.
#include <ctime>
#include <filesystem>
#include <iostream>
#include <algorithm>
#include <map>
#include <optional>
#include <set>

#include "commands.hpp"
#include "params/cli_range.hpp"
#include "experiment/experiment.hpp"
#include "experiment/run_files.hpp"
#include "params/parameter_space.hpp"
#include "params/yaml_util.hpp"
#include "store/observation_store.hpp"
#include "table.hpp"
#ifdef MAPTUNE_HAVE_SCORING
#include "scoring/scoring.hpp"
#endif

namespace maptune::cli {
namespace {

std::string iso_time(std::int64_t unix_ms) {
    const std::time_t t = static_cast<std::time_t>(unix_ms / 1000);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[32];
    std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

}  // namespace

// Score of one observation under a measure, when it was made on the scored dataset.
struct TrialScore {
    double p = 0, v = 0, eps = 0;
    std::size_t m = 0;
};

Table observations_table(const std::vector<store::Observation>& observations,
                         const std::vector<std::optional<TrialScore>>& scores) {
    std::set<std::string> names;
    for (const auto& o : observations) {
        for (const auto& [name, value] : o.params) names.insert(name);
    }
    const bool scored = !scores.empty();
    Table t;
    t.columns = {"id", "created", "dataset", "view", "matcher", "pairs", "matched", "failed",
                 "timeout", "wall_s"};
    t.numeric = {true, false, false, false, false, true, true, true, true, true};
    if (scored) {
        for (const char* c : {"p", "m", "eps", "v"}) {
            t.columns.push_back(c);
            t.numeric.push_back(true);
        }
    }
    for (const auto& n : names) {
        t.columns.push_back(n);
        t.numeric.push_back(true);
    }
    for (std::size_t i = 0; i < observations.size(); ++i) {
        const auto& o = observations[i];
        std::size_t matched = 0, failed = 0, timeout = 0;
        for (const auto& p : o.pairs) {
            matched += p.matched ? 1 : 0;
            failed += p.status == store::PairStatus::kFailed ? 1 : 0;
            timeout += p.status == store::PairStatus::kTimeout ? 1 : 0;
        }
        std::vector<std::string> row = {std::to_string(o.row_id),
                                         iso_time(o.created_unix_ms),
                                         o.key.dataset_id,
                                         o.key.view,
                                         o.key.matcher_id + "/" + o.key.matcher_version,
                                         std::to_string(o.pairs.size()),
                                         std::to_string(matched),
                                         std::to_string(failed),
                                         std::to_string(timeout),
                                         params::format_fixed(o.wall_seconds, 3)};
        if (scored) {
            const auto& sc = scores[i];
            row.push_back(sc ? params::format_fixed(sc->p, 4) : "");
            row.push_back(sc ? std::to_string(sc->m) : "");
            row.push_back(sc ? params::format_fixed(sc->eps, 4) : "");
            row.push_back(sc ? params::format_fixed(sc->v, 4) : "");
        }
        for (const auto& n : names) {
            const auto v = o.params.find(n);
            row.push_back(v ? params::format_double(*v) : "");
        }
        t.rows.push_back(std::move(row));
    }
    return t;
}

void add_trials_command(CLI::App& app, int& exit_code) {
    struct Options {
        std::string db;
        std::string format = "table";
        std::string dataset, view;
        std::size_t limit = 0;
        std::string score_on, reference = "gt";
        std::optional<double> e_star, m_star;
        double w_v = 0.5;
        std::string sort = "id";
        bool descending = false;
        std::size_t best = 0;
        std::vector<std::int64_t> remove;
        std::string import_from;
        std::vector<std::string> run_dirs;
    };
    auto opt = std::make_shared<Options>();
    auto* cmd = app.add_subcommand(
        "trials", "List the observations stored in an observation database, scored under a measure, "
                  "sorted; remove some or import another store.");
    cmd->add_option("--db", opt->db, "observation store (SQLite file); must exist (except with --import)")->required();
    cmd->add_option("-f,--format", opt->format, "output format: table | csv | json")
        ->check(CLI::IsMember({"table", "csv", "json"}))
        ->capture_default_str();
    cmd->add_option("--run-dir", opt->run_dirs,
                    "only the observations these runs evaluated (an experiment's runs; a repeated run's "
                    "directory stands for its seed-* runs), scored as the run scored them unless --score-on");
    cmd->add_option("--dataset", opt->dataset, "only this dataset id (default: all)");
    cmd->add_option("--view", opt->view, "only this view, e.g. complete | subsequent (default: all)");
    cmd->add_option("--limit", opt->limit, "at most this many rows, 0 = all")->capture_default_str();
#ifdef MAPTUNE_HAVE_SCORING
    cmd->add_option("--score-on", opt->score_on,
                    "dataset directory: add p, m, eps, v of its observations (other datasets' rows stay "
                    "empty; only observations of this dataset with --best)")
        ->check(CLI::ExistingDirectory);
    cmd->add_option("--reference", opt->reference, "reference transforms for the score: gt | odometry")
        ->check(CLI::IsMember({"gt", "odometry"}))
        ->capture_default_str();
    cmd->add_option("--e-star", opt->e_star, "e* [m] of the score, > 0.05 (default: 0.4)");
    cmd->add_option("--m-star", opt->m_star,
                    "m* of the score, > 0 (default: the view's pairs with overlap >= 0.3 under --reference)");
    cmd->add_option("--w-v", opt->w_v, "weight of v in p, 0..1")->check(maptune::params::finite_range(0.0, 1.0))->capture_default_str();
    cmd->add_option("--best", opt->best, "only the N best by p (needs --score-on; sorted by p, best first)");
#endif
    cmd->add_option("--sort", opt->sort, "sort by id | created | wall_s | matched | p (p needs --score-on)")
        ->check(CLI::IsMember({"id", "created", "wall_s", "matched", "p"}))
        ->capture_default_str();
    cmd->add_flag("--desc", opt->descending, "sort descending");
    cmd->add_option("--remove", opt->remove,
                    "delete the observation with this id (repeatable); the matcher runs again when it is "
                    "requested later");
    cmd->add_option("--import", opt->import_from,
                    "copy every observation of this other store that --db lacks (creates --db if needed)")
        ->check(CLI::ExistingFile);
    cmd->callback([opt, &exit_code] {
        if (opt->import_from.empty() && !std::filesystem::exists(opt->db)) {
            std::cerr << "maptune trials: " << opt->db << ": no such file\n";
            exit_code = 2;
            return;
        }
        try {
            if (!opt->import_from.empty()) {
                store::ObservationStore db(opt->db);
                const store::ObservationStore other(opt->import_from, store::ObservationStore::Mode::kReadOnly);
                const auto st = db.import_from(other);
                std::cout << "imported " << st.imported << " of " << st.read << " observations from "
                          << opt->import_from << " (" << st.already_present << " already present)\n";
                return;
            }
            if (!opt->remove.empty()) {
                store::ObservationStore db(opt->db);
                int missing = 0;
                for (const auto id : opt->remove) {
                    if (db.remove(id)) {
                        std::cout << "removed observation " << id << "\n";
                    } else {
                        std::cerr << "maptune trials: " << opt->db << ": no observation with id " << id << "\n";
                        ++missing;
                    }
                }
                exit_code = missing ? 2 : 0;
                return;
            }
            const store::ObservationStore db(opt->db, store::ObservationStore::Mode::kReadOnly);
            store::ObservationFilter filter;
            if (!opt->dataset.empty()) filter.dataset_id = opt->dataset;
            if (!opt->view.empty()) filter.view = opt->view;
            auto observations = db.list(filter);
            // --run-dir: the keys of every set the runs evaluated, and the first run's measure.
            std::optional<experiment::RunRecord> run_measure;
            double run_e_star = 0.4, run_w_v = 0.5;
            if (!opt->run_dirs.empty()) {
                std::set<std::string> keys;
                auto text = [](const store::ObservationKey& k) {
                    return k.dataset_id + "|" + k.view + "|" + k.matcher_id + "|" + k.matcher_version + "|" + k.params_key;
                };
                const std::vector<std::filesystem::path> dirs(opt->run_dirs.begin(), opt->run_dirs.end());
                for (const auto& dir : experiment::expand_run_dirs(dirs)) {
                    const auto record = experiment::read_run_record(dir);
                    const auto e = experiment::load_experiment(experiment::recorded_experiment_file(dir));
                    for (const auto& r : experiment::read_trials_csv(dir / "trials.csv", e.space)) {
                        keys.insert(text(experiment::observation_key(record, e.space, r.params)));
                    }
                    if (!run_measure) {
                        run_measure = record;
                        run_e_star = e.e_star;
                        run_w_v = e.w_v;
                    }
                }
                observations.erase(std::remove_if(observations.begin(), observations.end(),
                                                  [&](const store::Observation& o) { return !keys.count(text(o.key)); }),
                                   observations.end());
            }
            std::vector<std::optional<TrialScore>> scores;
#ifdef MAPTUNE_HAVE_SCORING
            if (opt->score_on.empty() && run_measure && std::filesystem::exists(run_measure->dataset_dir)) {
                // Scored as the run scored them (its dataset, reference and measure).
                opt->score_on = run_measure->dataset_dir;
                opt->reference = run_measure->reference.empty() ? opt->reference : run_measure->reference;
                if (!opt->e_star) opt->e_star = run_e_star;
                if (!opt->m_star && run_measure->m_star > 0) opt->m_star = run_measure->m_star;
                opt->w_v = run_w_v;
            }
            if (!opt->score_on.empty()) {
                const auto ds = dataset::Dataset::open(opt->score_on);
                const auto reference = dataset::parse_reference(opt->reference);
                std::map<std::string, std::pair<std::vector<dataset::SubmapPair>, measure::MeasureSettings>> views;
                for (const auto& o : observations) {
                    if (o.key.dataset_id != ds.manifest().id || views.count(o.key.view)) continue;
                    auto pairs = ds.pairs(dataset::parse_view(o.key.view), reference);
                    measure::MeasureSettings s;
                    s.e_star = opt->e_star.value_or(0.4);
                    s.m_star = opt->m_star ? *opt->m_star : scoring::derive_m_star(ds.reference_overlaps(pairs, reference));
                    s.w_v = opt->w_v;
                    if (auto bad = measure::check_settings(s); !bad.empty()) throw params::ConfigError(bad);
                    views.emplace(o.key.view, std::make_pair(std::move(pairs), s));
                }
                for (const auto& o : observations) {
                    const auto it = views.find(o.key.view);
                    if (o.key.dataset_id != ds.manifest().id || it == views.end()) {
                        scores.emplace_back();
                        continue;
                    }
                    const auto r = scoring::score_observation(ds, it->second.first, o.pairs, it->second.second);
                    scores.push_back(TrialScore{r.score.p, r.score.v, r.score.eps, r.score.m});
                }
            }
#endif
            if ((opt->sort == "p" || opt->best > 0) && scores.empty()) {
                throw params::ConfigError(std::string(opt->best ? "--best" : "--sort p") + " needs --score-on DATASET");
            }
            // Sort (stable, ids as tie-break), then --best and --limit.
            std::vector<std::size_t> order(observations.size());
            for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
            const bool by_p = opt->sort == "p" || opt->best > 0;
            const bool desc = opt->best > 0 ? true : opt->descending;
            auto key = [&](std::size_t i) -> double {
                const auto& o = observations[i];
                if (by_p) return scores[i] ? scores[i]->p : -1.0;  // unscored rows last when descending
                if (opt->sort == "created") return static_cast<double>(o.created_unix_ms);
                if (opt->sort == "wall_s") return o.wall_seconds;
                if (opt->sort == "matched") {
                    double m = 0;
                    for (const auto& p : o.pairs) m += p.matched ? 1 : 0;
                    return m;
                }
                return static_cast<double>(o.row_id);
            };
            std::vector<double> keys(observations.size());  // once per row, not per comparison
            for (std::size_t i = 0; i < keys.size(); ++i) keys[i] = key(i);
            std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
                return desc ? keys[a] > keys[b] : keys[a] < keys[b];
            });
            if (opt->best > 0) {
                order.erase(std::remove_if(order.begin(), order.end(), [&](std::size_t i) { return !scores[i]; }),
                            order.end());
                if (order.size() > opt->best) order.resize(opt->best);
            }
            if (opt->limit > 0 && order.size() > opt->limit) order.resize(opt->limit);
            std::vector<store::Observation> rows;
            std::vector<std::optional<TrialScore>> row_scores;
            for (auto i : order) {
                rows.push_back(std::move(observations[i]));
                if (!scores.empty()) row_scores.push_back(scores[i]);
            }
            const TableFormat format = opt->format == "csv"    ? TableFormat::kCsv
                                       : opt->format == "json" ? TableFormat::kJson
                                                               : TableFormat::kTable;
            write_table(std::cout, observations_table(rows, row_scores), format);
        } catch (const std::exception& e) {
            std::cerr << "maptune trials: " << e.what() << "\n";
            exit_code = 2;
        }
    });
}

}  // namespace maptune::cli
