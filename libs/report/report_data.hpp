#pragma once
// The data of a tuning report (issue 11): one JSON document with, per run directory, the run
// record, every evaluation, the best-so-far steps with their per-pair errors, the GP refitted
// from the run's observations (1-D slices through the best, a 2-D grid, importance from the
// ARD length scales) and the validation table. tools/report turns it into figures.

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace maptune::report {

struct ReportOptions {
    std::string db;                 // observation store; empty: the run's own (or its parent's)
    std::string experiment;         // experiment file; empty: the one in each run.yaml
    int slice_points = 60;          // per 1-D slice
    int grid_points = 30;           // per axis of the 2-D grid
    std::string grid_x, grid_y;     // grid parameters; empty: the two shortest length scales
};

// The data of one run directory. Throws params::ConfigError naming the file and what is wrong
// (no run.yaml, trials.csv not matching the experiment's space, ...). A missing store or
// dataset only leaves the per-pair errors out (noted in "notes").
nlohmann::json run_data(const std::filesystem::path& run_dir, const ReportOptions& options);

// {"runs": [run_data...]} for every run of `dirs` (experiment::expand_run_dirs).
nlohmann::json report_data(const std::vector<std::filesystem::path>& dirs, const ReportOptions& options);

}  // namespace maptune::report
