// maptune compare: parameter sets x dataset views in the layout of the thesis's Table 5.2.
#ifdef MAPTUNE_HAVE_EVALUATION
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "commands.hpp"
#include "evaluation/compare.hpp"
#include "evaluation_cli.hpp"
#include "params/parameter_set.hpp"
#include "params/yaml_util.hpp"
#include "compare_output.hpp"
#include "table.hpp"
#include "params/cli_range.hpp"

namespace maptune::cli {
namespace {

namespace fs = std::filesystem;

struct CompareCliOptions {
    std::vector<std::string> params, on;
    std::vector<double> m_star;
    std::string config, reference_scores;
    std::optional<double> m_star_per_pair, e_star, w_v;
    std::string space = "configs/spaces/lru_matcher.yaml";
    std::string db = "runs/compare/observations.db";
    bool no_db = false;
    std::string format = "markdown", output = "-";
    EvaluationCliOptions matcher;  // threads, time limits, --matcher overrides only
};

}  // namespace

void add_compare_command(CLI::App& app, int& exit_code) {
    auto opt = std::make_shared<CompareCliOptions>();
    auto* cmd = app.add_subcommand(
        "compare",
        "Score several parameter sets on several dataset views (the thesis's Table 5.2): per view p, m, "
        "eps, median errors, optional reference scores and Kendall's tau against them.");
    cmd->add_option("--params", opt->params, "parameter set YAML files; the row name is the file's stem");
    cmd->add_option("--on", opt->on,
                    "dataset view [LABEL=]DATASET[:complete|subsequent[:gt|odometry]] (repeatable; "
                    "default view complete/gt, label = the directory name)");
    cmd->add_option("--config", opt->config,
                    "comparison YAML (params, on, e_star, w_v, reference); command-line sets and views are added");
    cmd->add_option("--reference-scores", opt->reference_scores,
                    "YAML with a 'reference' section (e.g. configs/compare/thesis_table_5_2.yaml): scores to "
                    "rank against, and the reference's m* per pair");
    cmd->add_option("--m-star", opt->m_star,
                    "m* per view, in the order of --on (one value: for every view), 1e-9..1e9")
        ->check(maptune::params::finite_range(1e-9, 1e9));
    cmd->add_option("--m-star-per-pair", opt->m_star_per_pair,
                    "m* = F x pairs of the view (thesis lab: 200/1365 = 0.1465), 1e-9..1e9")
        ->check(maptune::params::finite_range(1e-9, 1e9));
    cmd->add_option("--e-star", opt->e_star, "e* [m], > 0.05")->capture_default_str();
    cmd->add_option("--w-v", opt->w_v, "weight of v in p, 0..1")->check(maptune::params::finite_range(0.0, 1.0));
    cmd->add_option("--space", opt->space, "design space YAML")->capture_default_str();
    cmd->add_option("--db", opt->db, "observation store; repeated comparisons are answered from it")
        ->capture_default_str();
    cmd->add_flag("--no-db", opt->no_db, "evaluate everything, store nothing");
    cmd->add_option("-f,--format", opt->format, "markdown | table | csv | json")
        ->check(CLI::IsMember({"markdown", "table", "csv", "json"}))
        ->capture_default_str();
    cmd->add_option("-o,--output", opt->output, "output file, - for standard output")->capture_default_str();
    add_matcher_options(*cmd, opt->matcher);
    cmd->callback([opt, &exit_code] {
        try {
            evaluation::CompareConfig config;
            if (!opt->config.empty()) config = evaluation::load_compare_config(opt->config);
            std::vector<std::string> param_files = config.params;
            param_files.insert(param_files.end(), opt->params.begin(), opt->params.end());
            std::vector<evaluation::CompareTarget> targets = config.targets;
            for (const auto& spec : opt->on) targets.push_back(evaluation::parse_compare_target(spec));
            if (param_files.empty()) throw params::ConfigError("no parameter sets: give --params or --config");
            if (targets.empty()) throw params::ConfigError("no dataset views: give --on or --config");
            if (!opt->m_star.empty() && opt->m_star.size() != 1 && opt->m_star.size() != targets.size()) {
                throw params::ConfigError("--m-star: " + std::to_string(opt->m_star.size()) + " values for " +
                                          std::to_string(targets.size()) + " views (give 1 or one per view)");
            }
            for (std::size_t i = 0; i < targets.size(); ++i) {
                if (!opt->m_star.empty()) targets[i].m_star = opt->m_star[opt->m_star.size() == 1 ? 0 : i];
                if (opt->m_star_per_pair) targets[i].m_star_per_pair = opt->m_star_per_pair;
            }

            const auto space = params::ParameterSpace::load(opt->space);
            std::vector<evaluation::NamedParameterSet> sets;
            for (const auto& f : param_files) {
                sets.push_back({fs::path(f).stem().string(), params::load_parameter_set(f, space)});
            }
            evaluation::CompareOptions options;
            options.matcher = matcher_settings(opt->matcher);
            options.e_star = opt->e_star.value_or(config.e_star.value_or(0.4));
            options.w_v = opt->w_v.value_or(config.w_v.value_or(0.5));
            options.reference = config.reference;
            if (!opt->reference_scores.empty()) {
                auto ref = evaluation::load_compare_config(opt->reference_scores).reference;
                if (ref.empty()) {
                    throw params::ConfigError(opt->reference_scores + ": no 'reference' section");
                }
                options.reference.insert(options.reference.begin(), ref.begin(), ref.end());
            }
            std::unique_ptr<store::ObservationStore> db;
            if (!opt->no_db) {
                if (const auto parent = fs::path(opt->db).parent_path(); !parent.empty()) fs::create_directories(parent);
                db = std::make_unique<store::ObservationStore>(opt->db);
            }
            options.db = db.get();
            options.progress = [](const std::string& what) { std::cerr << "compare: " << what << "\n"; };
            const auto result = evaluation::compare(space, sets, targets, options);

            std::ofstream file;
            if (opt->output != "-") {
                file.open(opt->output);
                if (!file) throw params::ConfigError("--output " + opt->output + ": cannot write");
            }
            std::ostream& out = opt->output == "-" ? std::cout : file;
            write_compare(out, result, opt->format);
            out.flush();
            if (!out) throw params::ConfigError("--output " + opt->output + ": write failed");
        } catch (const std::exception& e) {
            std::cerr << "maptune compare: " << e.what() << "\n";
            exit_code = 2;
        }
    });
}

}  // namespace maptune::cli
#endif
