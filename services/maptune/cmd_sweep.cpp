// maptune sweep: one parameter over its bounds, the others fixed (thesis Appendix A).
#ifdef MAPTUNE_HAVE_EVALUATION
#include <chrono>
#include <fstream>
#include <iostream>
#include <memory>

#include "commands.hpp"
#include "evaluation_cli.hpp"
#include "params/parameter_set.hpp"
#include "params/yaml_util.hpp"

namespace maptune::cli {

void add_sweep_command(CLI::App& app, int& exit_code) {
    auto opt = std::make_shared<EvaluationCliOptions>();
    auto name = std::make_shared<std::string>();
    auto steps = std::make_shared<int>(10);
    auto out = std::make_shared<std::string>("-");
    auto* cmd = app.add_subcommand(
        "sweep", "Single-parameter experiment: NAME over its bounds in K steps, the others at --params "
                 "(default: the space's defaults). Prints CSV: value, m, errors, p, seconds.");
    add_evaluation_options(*cmd, *opt);
    cmd->add_option("--params", opt->params, "base parameter set YAML (default: the space's defaults)");
    cmd->add_option("--param", *name, "parameter to sweep")->required();
    cmd->add_option("--steps", *steps, "values from low to high, 2..1000 (default: 10)")->check(CLI::Range(2, 1000));
    cmd->add_option("-o,--output", *out, "CSV file, - for standard output (default: -)");
    cmd->callback([opt, name, steps, out, &exit_code] {
        try {
            const auto space = params::ParameterSpace::load(opt->space);
            const params::ParameterSpec* spec = space.find(*name);
            if (spec == nullptr) throw params::ConfigError("--param " + *name + ": not a parameter of " + opt->space);
            const auto base = opt->params.empty() ? space.defaults() : params::load_parameter_set(opt->params, space);
            const auto ds = dataset::Dataset::open(opt->dataset);
            const auto view = dataset::parse_view(opt->view);
            const auto pairs = ds.pairs(view, dataset::parse_reference(opt->reference));
            const auto settings = measure_settings(*opt, ds, pairs);
            std::unique_ptr<store::ObservationStore> db;
            if (!opt->db.empty()) db = std::make_unique<store::ObservationStore>(opt->db);
            evaluation::Evaluator evaluator(ds, space, matcher_settings(*opt));
            std::ofstream file;
            if (*out != "-") {
                // Before any evaluation: a sweep costs minutes, its output must have somewhere to go.
                file.open(*out);
                if (!file) throw std::runtime_error(*out + ": cannot write");
            }
            std::ostream& csv = *out == "-" ? std::cout : file;
            csv << "param,value,m,failed,timeouts,e_t_median,e_t_p90,e_r_median_deg,v,eps,p,seconds,from_store\n";
            std::vector<double> values;
            for (int i = 0; i < *steps; ++i) {
                double v = spec->low + (spec->high - spec->low) * i / (*steps - 1);
                if (spec->type == params::ParamType::kInt) v = std::round(v);
                if (!values.empty() && values.back() == v) continue;
                values.push_back(v);
            }
            for (double v : values) {
                auto set = base;
                set.set(*name, v);
                bool from_store = false;
                const auto obs = evaluator.evaluate_cached(db.get(), view, set, &from_store);
                const auto r = scoring::score_observation(ds, pairs, obs.pairs, settings);
                csv << *name << "," << params::format_double(space.round(set).get(*name)) << "," << r.score.m
                    << "," << r.failed << "," << r.timeouts << "," << params::format_fixed(r.e_t.median, 4)
                    << "," << params::format_fixed(r.e_t.p90, 4) << ","
                    << params::format_fixed(r.e_r.median * 180 / M_PI, 3) << ","
                    << params::format_fixed(r.score.v, 4) << "," << params::format_fixed(r.score.eps, 4) << ","
                    << params::format_fixed(r.score.p, 4) << "," << params::format_fixed(obs.wall_seconds, 2)
                    << "," << (from_store ? 1 : 0) << std::endl;
            }
            if (!csv) throw std::runtime_error(*out + ": write failed");
        } catch (const std::exception& e) {
            std::cerr << "maptune sweep: " << e.what() << "\n";
            exit_code = 2;
        }
    });
}

}  // namespace maptune::cli
#endif
