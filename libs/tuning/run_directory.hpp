#pragma once
// The files of a run directory, written as a run goes (what `maptune validate`, `report`,
// `trials` and a resumed run read): run.yaml (what ran, on what, when), trials.csv,
// best_params.yaml, best_params.ros2.yaml, predicted_best.yaml and gp_hyperparameters.csv.
// Every file but the hyperparameter log is replaced atomically.

#include <filesystem>
#include <optional>
#include <string>

#include "experiment/experiment.hpp"
#include "gp/kernel.hpp"
#include "tuning_run.hpp"

namespace maptune::tuning {

struct RunInfo {
    std::string experiment_id;
    std::string dataset_id, dataset_name;
    std::string matcher_id, matcher_version;
    std::string started_utc;
};

struct RunEnd {
    std::string finished_utc;
    double wall_s = 0;
};

// Seconds on the monotonic clock: what run time limits, timeouts and wall_s are measured by.
double now_s();

// Wall-clock time in UTC, by strftime format (default ISO 8601: "2026-12-02T10:31:30Z").
std::string utc_now(const char* format = "%Y-%m-%dT%H:%M:%SZ");

// A random id for one life of a process (hex, 12 digits): part of every id it hands out
// (request and task ids), so that answers addressed to an earlier life — before a restart,
// or to another process of the same name — are recognized as stale, never as current.
std::string new_incarnation_id();

class RunDirectory {
public:
    // Creates the directory.
    RunDirectory(std::filesystem::path dir, const experiment::Experiment& experiment, RunInfo info);

    const std::filesystem::path& dir() const { return dir_; }
    std::filesystem::path trials_file() const { return dir_ / "trials.csv"; }
    // run.yaml; `end` marks the run finished (end time, wall time, stop reason, best).
    void write_record(const RunSummary& summary, const std::optional<RunEnd>& end = std::nullopt) const;
    // trials.csv, best_params*.yaml, predicted_best.yaml.
    void write_results(const RunSummary& summary) const;
    // One line of gp_hyperparameters.csv (header first when the file is new or empty).
    void append_hyperparameters(int evaluation, const gp::Hyperparameters& hp) const;
    // When the directory held a run recorded in another design space (its space file changed
    // since: bounds, scales or parameters), what to tell the user who resumes it; empty for a
    // new run, the same space, or a record older than the space key.
    const std::optional<std::string>& space_change() const { return space_change_; }

private:
    std::filesystem::path dir_;
    const experiment::Experiment& experiment_;
    RunInfo info_;
    std::optional<std::string> space_change_;  // read before this run's record replaces the old
};

}  // namespace maptune::tuning
