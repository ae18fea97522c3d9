#pragma once
// Black-box tuning (`maptune optimize`, issue 15; thesis §6.2: reuse the tuner for other parts
// of the robot): the same ask/tell core and run directory as a matcher run, with each set
// evaluated by an objective command (command_objective.hpp) instead of the matcher.

#include <filesystem>
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

#include "experiment/experiment.hpp"
#include "tuning_run.hpp"

namespace maptune::tuning {

// A black-box experiment given on the command line; written as <run_dir>/experiment.yaml
// (with the space copied beside it) so that a resumed run and `maptune report` read it back.
struct BlackBoxSpec {
    std::string name = "optimize";
    std::string space_file;
    std::vector<std::string> optimize;  // empty: every parameter of the space
    std::string command;
    bool minimize = false;
    double timeout_s = 0;
    int parallel = 1;
    int budget = 100;
    double seconds = 0;
    std::uint64_t seed = 1;
    std::string acquisition = "log_ei";
    int initial_points = 0;
    std::string warping = "automatic", search = "alternate", cholesky = "eigen";
    bool quadratic_steps = true;
    int hyper_samples = 4;
    std::vector<std::string> start_points;  // parameter set YAML files
};

// Writes <run_dir>/experiment.yaml and <run_dir>/space.yaml; returns the experiment file.
// Throws params::ConfigError naming the file and key when the spec is not valid.
std::string write_black_box_experiment(const std::filesystem::path& run_dir, const BlackBoxSpec& spec);

// The parameter set as the objective reads it: a JSON object, integers as integers.
std::string parameters_json(const experiment::Experiment& e, const params::ParameterSet& set);

// Runs a black-box experiment (one with `objective`) into `run_dir`, resuming the trials
// already there. Progress lines go to `log`; `stop` is polled (SIGINT: running commands are
// stopped, results written).
RunSummary run_black_box(const experiment::Experiment& e, const std::filesystem::path& run_dir, std::ostream& log,
                         const std::function<bool()>& stop);

}  // namespace maptune::tuning
