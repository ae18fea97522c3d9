#pragma once
// Validation of run directories on the experiment's held-out views, shared by
// `maptune validate` and the end of `maptune run`.
#ifdef MAPTUNE_HAVE_EVALUATION
#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "evaluation/validation.hpp"

namespace maptune::cli {

struct ValidateSettings {
    std::string db;          // empty: the run's store (<run>/observations.db, or its parent's)
    int threads = 0;         // matcher threads; 0 = all cores
    std::string format = "markdown";
};

// The experiment a run directory ran: `experiment_file` of its run.yaml, unless `override_file`.
// Throws params::ConfigError naming run.yaml and the key when it cannot tell.
experiment::Experiment experiment_of_run(const std::filesystem::path& run_dir, const std::string& override_file);

// Scores the run's baseline, best and predicted best on the experiment's `validate:` targets,
// writes <run_dir>/validation.csv and prints the table to `out` (progress to stderr).
evaluation::CompareResult validate_run_dir(const std::filesystem::path& run_dir, const experiment::Experiment& e,
                                           const ValidateSettings& settings, std::ostream& out);

// Writes <root>/summary.csv for repeated seeds and prints median, min, max and spread of the
// best training p and of every validation score over the seeds.
void write_seeds_summary(const std::filesystem::path& root, const std::vector<evaluation::SeedOutcome>& seeds,
                         std::ostream& out);

}  // namespace maptune::cli
#endif
