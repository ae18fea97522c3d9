#pragma once
// The files of a run directory that more than one tool reads: trials.csv (one line per
// evaluation, written by the optimizer) and run.yaml (the run record: what ran, on what,
// when). `maptune validate`, `maptune report` and a resuming optimizer read them.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "experiment/experiment.hpp"
#include "params/parameter_set.hpp"
#include "params/parameter_space.hpp"
#include "store/observation_store.hpp"

namespace maptune::experiment {

struct EvaluationRecord {
    int number = 0;                  // 1-based, in order of completion
    params::ParameterSet params;     // full rounded set that was evaluated
    bool failed = false;
    std::string error;
    bool from_store = false;
    double p = 0, v = 0, eps = 0;
    std::size_t m = 0;
    double wall_s = 0;
    // Mean seconds per pair from the raw submaps (PairRecord::duration_s); 0 = not known
    // (black-box objectives, trials.csv written before this column).
    double pair_s = 0;
    // 1: scored on the whole view; k: stopped after the stratified subset "<view>/<k>" could not
    // beat the best (multi-fidelity) — p is then the subset's estimate of the whole view's p.
    int fidelity = 1;
    // [s] since the run started when the answer came (a resumed run goes on from its last
    // record); 0 in trials.csv written before this column.
    double elapsed_s = 0;
    std::string origin;              // "start", "initial", "model", "quadratic" (kept when a run resumes)
};

// What the optimizer was told for a record: experiment::objective of its p and pair_s.
double record_objective(const Experiment& e, const EvaluationRecord& r);

// The best of a run: the index in `records` of the successful whole-view evaluation with the
// best record_objective (the first of equals), or -1 when there is none. Subset-only records
// never count: their p is an estimate.
int best_index(const Experiment& e, const std::vector<EvaluationRecord>& records);

// The baseline of a run: the index in `records` of the successful evaluation of the
// experiment's first start point, or -1 when there is none.
int baseline_index(const Experiment& e, const std::vector<EvaluationRecord>& records);

// One line of a CSV file of maptune's (no quoting: cells never hold commas), a trailing
// comma giving an empty last cell.
std::vector<std::string> split_csv_line(const std::string& line);

// trials.csv of a run directory: header and one line per evaluation.
std::string trials_csv(const std::vector<EvaluationRecord>& records, const params::ParameterSpace& space);
// Empty when the file does not exist; throws params::ConfigError naming file and line when
// it does not match the space or a cell is not a number.
std::vector<EvaluationRecord> read_trials_csv(const std::filesystem::path& file,
                                              const params::ParameterSpace& space);

// What <run_dir>/run.yaml records (services/lib/optimizer_service.cpp writes it).
struct RunRecord {
    std::string experiment_file;
    std::string dataset_dir, dataset_id, view, reference;
    std::string matcher_id, matcher_version;
    std::string space_hash;  // of the design space it ran in; empty in records older than the key
    double m_star = 0;
    std::string state;              // running | finished
    std::optional<double> best_p;   // finished runs with a successful evaluation
};
// Throws params::ConfigError naming run.yaml (and the key) when it is missing or malformed.
RunRecord read_run_record(const std::filesystem::path& run_dir);

// The experiment file recorded in <run_dir>/run.yaml. Throws params::ConfigError naming
// run.yaml and the key when there is none or it no longer exists.
std::string recorded_experiment_file(const std::filesystem::path& run_dir);

// The store key of a set the run evaluated (dataset, view, matcher and version of the run).
store::ObservationKey observation_key(const RunRecord& run, const params::ParameterSpace& space,
                                      const params::ParameterSet& set);

// The seed-<n> subdirectories (each with a run.yaml) of a repeated run, in seed order; empty
// when there are none.
std::vector<std::pair<std::uint64_t, std::filesystem::path>> seed_run_dirs(const std::filesystem::path& root);

// Run directories: each of `dirs` that has a run.yaml, and for one that has not, its seed-*
// runs (a repeated run). Throws params::ConfigError naming a directory that is neither.
std::vector<std::filesystem::path> expand_run_dirs(const std::vector<std::filesystem::path>& dirs);

// The observation store of a run: <run_dir>/observations.db, else its parent's (a seed of a
// repeated run); empty when neither exists.
std::string run_store_path(const std::filesystem::path& run_dir);

}  // namespace maptune::experiment
