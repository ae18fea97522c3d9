// maptune params: inspect a design space, and check, key and export parameter sets.
#include <fstream>
#include <iostream>

#include "commands.hpp"
#include "params/export.hpp"
#include "params/parameter_set.hpp"
#include "params/parameter_space.hpp"
#include "params/yaml_util.hpp"
#include "table.hpp"

namespace maptune::cli {

void add_params_command(CLI::App& app, int& exit_code) {
    struct Options {
        std::string space = "configs/spaces/lru_matcher.yaml";
        std::string params;
        std::string format = "ros2";
        std::string node = "map_matcher";
        std::string output = "-";
    };
    auto opt = std::make_shared<Options>();
    auto* cmd = app.add_subcommand("params", "Design spaces and parameter sets.");
    cmd->require_subcommand(1);
    auto add_space = [opt](CLI::App* sub) {
        sub->add_option("--space", opt->space,
                        "design space YAML (default: configs/spaces/lru_matcher.yaml)");
    };
    auto* show = cmd->add_subcommand("show", "Print the design space: names, types, bounds, defaults.");
    add_space(show);
    auto* key = cmd->add_subcommand("key", "Print the canonical rounded key of a parameter set.");
    add_space(key);
    key->add_option("--params", opt->params, "parameter set YAML (flat or ROS 2)")->required();
    auto* exp = cmd->add_subcommand("export", "Write a parameter set for a robot.");
    add_space(exp);
    exp->add_option("--params", opt->params, "parameter set YAML (flat or ROS 2)")->required();
    exp->add_option("--format", opt->format, "ros2 | yaml (default: ros2)")
        ->check(CLI::IsMember({"ros2", "yaml"}));
    exp->add_option("--node", opt->node, "ROS 2 node name (default: map_matcher)");
    exp->add_option("-o,--output", opt->output, "output file, - for standard output (default: -)");

    auto run = [opt, &exit_code, show, key, exp] {
        try {
            const auto space = params::ParameterSpace::load(opt->space);
            if (show->parsed()) {
                Table t;
                t.columns = {"name", "type", "low", "high", "default", "unit", "description"};
                t.numeric = {false, false, true, true, true, false, false};
                for (const auto& s : space.specs()) {
                    const bool is_int = s.type == params::ParamType::kInt;
                    auto fmt = [&](double v) {
                        return is_int ? params::format_fixed(v, 0) : params::format_double(v);
                    };
                    t.rows.push_back({s.name, is_int ? "int" : "float", fmt(s.low), fmt(s.high),
                                      fmt(s.default_value), s.unit,
                                      s.description + (s.log_scale ? " (log scale)" : "")});
                }
                std::cout << "space " << space.name() << " (hash " << space.hash() << ")\n";
                write_table(std::cout, t, TableFormat::kTable);
                return;
            }
            const auto set = params::load_parameter_set(opt->params, space);
            if (key->parsed()) {
                std::cout << space.canonical_key(set) << "\n";
                return;
            }
            if (exp->parsed()) {
                const std::string text = opt->format == "ros2"
                                             ? params::to_ros2_yaml(set, space, opt->node)
                                             : params::to_plain_yaml(set, space);
                if (opt->output == "-") {
                    std::cout << text;
                } else {
                    std::ofstream out(opt->output);
                    out << text;
                    if (!out) throw params::ConfigError(opt->output + ": cannot write file");
                }
            }
        } catch (const params::ConfigError& e) {
            std::cerr << "maptune params: " << e.what() << "\n";
            exit_code = 2;
        }
    };
    show->callback(run);
    key->callback(run);
    exp->callback(run);
}

}  // namespace maptune::cli
