// maptune evaluate: the reference matcher on one dataset view with one parameter set.
#ifdef MAPTUNE_HAVE_EVALUATION
#include <iostream>
#include <memory>

#include "commands.hpp"
#include "evaluation_cli.hpp"
#include "params/parameter_set.hpp"
#include "params/yaml_util.hpp"

namespace maptune::cli {

void add_evaluate_command(CLI::App& app, int& exit_code) {
    auto opt = std::make_shared<EvaluationCliOptions>();
    auto json = std::make_shared<bool>(false);
    auto* cmd = app.add_subcommand("evaluate", "Run the matcher on every pair of a dataset view and score it.");
    add_evaluation_options(*cmd, *opt);
    cmd->add_option("--params", opt->params, "parameter set YAML (default: the space's defaults)");
    cmd->add_flag("--json", *json, "print one JSON object with p, m, pairs, wall_seconds and per-pair entries");
    cmd->callback([opt, json, &exit_code] {
        try {
            const auto space = params::ParameterSpace::load(opt->space);
            const auto set = opt->params.empty() ? space.defaults() : params::load_parameter_set(opt->params, space);
            const auto ds = dataset::Dataset::open(opt->dataset);
            const auto view = dataset::parse_view(opt->view);
            const auto pairs = ds.pairs(view, dataset::parse_reference(opt->reference));
            const auto settings = measure_settings(*opt, ds, pairs);
            if (auto bad = measure::check_settings(settings); !bad.empty()) throw params::ConfigError(bad);
            std::unique_ptr<store::ObservationStore> db;
            if (!opt->db.empty()) db = std::make_unique<store::ObservationStore>(opt->db);
            evaluation::Evaluator evaluator(ds, space, matcher_settings(*opt));
            bool from_store = false;
            matcher::EvaluationStats stats;
            const auto obs = evaluator.evaluate_cached(db.get(), view, set, &from_store, &stats);
            const auto report = scoring::score_observation(ds, pairs, obs.pairs, settings);
            if (*json) {
                auto j = report_json(report, obs.wall_seconds, true);
                j["from_store"] = from_store;
                j["params_key"] = obs.key.params_key;
                std::cout << j.dump(2) << "\n";
                return;
            }
            std::cout << "dataset " << ds.manifest().name << " (" << ds.manifest().id << "), view "
                      << opt->view << "/" << opt->reference << ", " << report.pairs << " pairs\n"
                      << "params  " << obs.key.params_key << (from_store ? "  (from the store)" : "") << "\n"
                      << "m       " << report.score.m << " matched, " << report.failed << " failed, "
                      << report.timeouts << " timed out\n"
                      << "e_t [m] median " << params::format_fixed(report.e_t.median, 3) << ", p90 "
                      << params::format_fixed(report.e_t.p90, 3) << ", max "
                      << params::format_fixed(report.e_t.max, 3) << "\n"
                      << "e_r [deg] median " << params::format_fixed(report.e_r.median * 180 / M_PI, 2)
                      << ", p90 " << params::format_fixed(report.e_r.p90 * 180 / M_PI, 2) << ", max "
                      << params::format_fixed(report.e_r.max * 180 / M_PI, 2) << "\n"
                      << "p       " << params::format_fixed(report.score.p, 4) << "  (v "
                      << params::format_fixed(report.score.v, 4) << ", eps "
                      << params::format_fixed(report.score.eps, 4) << ", e* "
                      << params::format_double(settings.e_star) << ", m* "
                      << params::format_double(settings.m_star) << ")\n"
                      << "wall    " << params::format_fixed(obs.wall_seconds, 2) << " s (features "
                      << params::format_fixed(stats.feature_wall_s, 2) << " s, pairs "
                      << params::format_fixed(stats.pair_wall_s, 2) << " s)\n";
        } catch (const params::ConfigError& e) {
            std::cerr << "maptune evaluate: " << e.what() << "\n";
            exit_code = 2;
        } catch (const std::exception& e) {
            std::cerr << "maptune evaluate: " << e.what() << "\n";
            exit_code = 2;
        }
    });
}

}  // namespace maptune::cli
#endif
