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
#include "table.hpp"

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

std::string fixed_or_dash(double v, int decimals, bool present) {
    return present ? params::format_fixed(v, decimals) : "-";
}

std::string tau_text(const std::optional<double>& tau) {
    if (!tau) return "";
    return std::isnan(*tau) ? "undefined" : params::format_fixed(*tau, 2);
}

Table build_table(const evaluation::CompareResult& r) {
    Table t;
    t.columns.push_back("set");
    t.numeric.push_back(false);
    for (const auto& col : r.columns) {
        const std::string& l = col.target.label;
        for (const char* c : {" p", " m", " eps", " e_t med [m]", " e_r med [deg]"}) {
            t.columns.push_back(l + c);
            t.numeric.push_back(true);
        }
        if (!col.reference_column.empty()) {
            t.columns.push_back(l + " ref p");
            t.numeric.push_back(true);
        }
    }
    for (std::size_t s = 0; s < r.set_names.size(); ++s) {
        std::vector<std::string> row{r.set_names[s]};
        for (const auto& col : r.columns) {
            const auto& rep = col.cells[s].report;
            const bool matched = rep.score.m > 0;
            row.push_back(params::format_fixed(rep.score.p, 3));
            row.push_back(std::to_string(rep.score.m));
            row.push_back(params::format_fixed(rep.score.eps, 3));
            row.push_back(fixed_or_dash(rep.e_t.median, 3, matched));
            row.push_back(fixed_or_dash(rep.e_r.median * 180.0 / M_PI, 2, matched));
            if (!col.reference_column.empty()) {
                const auto& ref = col.cells[s].reference_p;
                row.push_back(ref ? params::format_fixed(*ref, 2) : "");
            }
        }
        t.rows.push_back(std::move(row));
    }
    bool any_tau = false;
    for (const auto& col : r.columns) any_tau |= col.tau.has_value();
    if (any_tau) {
        std::vector<std::string> row{"kendall_tau"};
        for (const auto& col : r.columns) {
            row.push_back(tau_text(col.tau));
            for (int i = 0; i < 4; ++i) row.push_back("");
            if (!col.reference_column.empty()) row.push_back("");
        }
        t.rows.push_back(std::move(row));
    }
    return t;
}

nlohmann::json result_json(const evaluation::CompareResult& r) {
    nlohmann::json views = nlohmann::json::array();
    for (const auto& col : r.columns) {
        nlohmann::json cells = nlohmann::json::array();
        for (std::size_t s = 0; s < r.set_names.size(); ++s) {
            const auto& c = col.cells[s];
            auto j = report_json(c.report, c.wall_seconds, false);
            j["set"] = r.set_names[s];
            j["from_store"] = c.from_store;
            j["reference_p"] = c.reference_p ? nlohmann::json(*c.reference_p) : nlohmann::json();
            cells.push_back(j);
        }
        views.push_back({{"label", col.target.label},
                         {"dataset", col.target.dataset.string()},
                         {"dataset_name", col.dataset_name},
                         {"dataset_id", col.dataset_id},
                         {"world", col.world},
                         {"view", dataset::to_string(col.target.view)},
                         {"reference", dataset::to_string(col.target.reference)},
                         {"pairs", col.pairs},
                         {"m_star", col.settings.m_star},
                         {"m_star_rule", col.m_star_rule},
                         {"e_star", col.settings.e_star},
                         {"reference_column", col.reference_column},
                         {"kendall_tau", col.tau && !std::isnan(*col.tau) ? nlohmann::json(*col.tau) : nlohmann::json()},
                         {"sets", cells}});
    }
    return {{"sets", r.set_names}, {"views", views}};
}

void write_notes(std::ostream& out, const evaluation::CompareResult& r, bool markdown) {
    out << "\n";
    for (const auto& col : r.columns) {
        int evaluated = 0;
        double wall = 0;
        for (const auto& c : col.cells) {
            evaluated += c.from_store ? 0 : 1;
            wall += c.wall_seconds;
        }
        out << (markdown ? "- " : "") << col.target.label << ": " << col.target.dataset.string() << " ("
            << col.dataset_name << ", " << col.dataset_id << "), " << dataset::to_string(col.target.view) << "/"
            << dataset::to_string(col.target.reference) << ", " << col.pairs << " pairs, m* "
            << params::format_fixed(col.settings.m_star, 1) << " (" << col.m_star_rule << "), e* "
            << params::format_double(col.settings.e_star) << "; " << evaluated << " evaluated ("
            << params::format_fixed(wall, 1) << " s), " << col.cells.size() - evaluated << " from the store";
        if (col.tau) {
            out << "; Kendall's tau-b vs reference '" << col.reference_column << "': " << tau_text(col.tau);
        }
        out << "\n";
    }
}

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
        ->check(CLI::Range(1e-9, 1e9));
    cmd->add_option("--m-star-per-pair", opt->m_star_per_pair,
                    "m* = F x pairs of the view (thesis lab: 200/1365 = 0.1465), 1e-9..1e9")
        ->check(CLI::Range(1e-9, 1e9));
    cmd->add_option("--e-star", opt->e_star, "e* [m], > 0.05")->capture_default_str();
    cmd->add_option("--w-v", opt->w_v, "weight of v in p, 0..1")->check(CLI::Range(0.0, 1.0));
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
            if (opt->format == "json") {
                out << result_json(result).dump(2) << "\n";
            } else {
                const auto format = opt->format == "csv"   ? TableFormat::kCsv
                                    : opt->format == "table" ? TableFormat::kTable
                                                             : TableFormat::kMarkdown;
                write_table(out, build_table(result), format);
                if (format != TableFormat::kCsv) write_notes(out, result, format == TableFormat::kMarkdown);
            }
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
