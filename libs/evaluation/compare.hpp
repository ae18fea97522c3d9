#pragma once
// Comparing parameter sets on dataset views — the thesis's Table 5.2 as a command (issue 10):
// every set scored on every view through the observation store, with optional reference
// scores (the thesis's) and Kendall's tau between both orderings.

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "evaluation/evaluation.hpp"

namespace maptune::evaluation {

// One dataset view of a comparison: a column group of the table.
struct CompareTarget {
    std::string label;  // column name; default: the dataset directory's name
    std::filesystem::path dataset;
    dataset::View view = dataset::View::complete;
    dataset::Reference reference = dataset::Reference::gt;
    std::optional<double> m_star;           // absolute m*
    std::optional<double> m_star_per_pair;  // m* = this x pairs of the view (thesis: 200/1365)
};

// "[LABEL=]DATASET[:VIEW[:REFERENCE]]", e.g. "lab=datasets/lab:complete:gt". Throws
// params::ConfigError naming the spec and the bad part.
CompareTarget parse_compare_target(const std::string& spec);

struct NamedParameterSet {
    std::string name;  // row name; from a file: its stem ("x_baseline")
    params::ParameterSet set;
};

// Reference scores of one column (e.g. the thesis's lab), by parameter-set name.
struct ReferenceColumn {
    std::string name;                       // "lab"
    std::vector<std::string> aliases;       // other labels or dataset worlds it stands for
    std::optional<double> m_star_per_pair;  // how the reference chose m*, per pair of the view
    std::map<std::string, double> scores;   // set name -> p
};

// A comparison file (configs/compare/*.yaml). Every key is optional:
//   params: [file, ...]            parameter sets (paths relative to this file)
//   on: [LABEL=DATASET:VIEW:REF]   targets (dataset paths relative to this file)
//   e_star: 0.4   w_v: 0.5
//   reference: {NAME: {aliases: [..], m_star_per_pair: F, scores: {SET: p, ...}}, ...}
struct CompareConfig {
    std::vector<std::string> params;
    std::vector<CompareTarget> targets;
    std::optional<double> e_star, w_v;
    std::vector<ReferenceColumn> reference;
};
// Throws params::ConfigError naming the file, line and key.
CompareConfig load_compare_config(const std::string& file);

// The reference column for a target: by its label, else by an alias equal to the label or
// to the dataset's simulated world ("moon"). Null when none fits.
const ReferenceColumn* find_reference_column(const std::vector<ReferenceColumn>& columns,
                                             const std::string& label, const std::string& world);

// Kendall's tau-b of two score lists of equal length (ties in either list are handled as in
// tau-b); NaN when it is undefined (fewer than 2 items, or one list entirely tied).
double kendall_tau_b(const std::vector<double>& x, const std::vector<double>& y);

struct CompareCell {
    scoring::ScoreReport report;  // p, m, eps, error statistics of the set on the view
    bool from_store = false;
    double wall_seconds = 0;  // of the matcher run (0 when answered by the store)
    std::optional<double> reference_p;
};

struct CompareColumn {
    CompareTarget target;
    std::string dataset_name, dataset_id, world;
    std::size_t pairs = 0;
    measure::MeasureSettings settings;
    std::string m_star_rule;        // how m* was chosen, for the table's notes
    std::string reference_column;   // empty without reference scores
    std::vector<CompareCell> cells;  // one per set, in the order of the sets
    // Over the sets that have a reference score; NaN when fewer than 2 or all tied.
    std::optional<double> tau;
};

struct CompareResult {
    std::vector<std::string> set_names;
    std::vector<CompareColumn> columns;
};

struct CompareOptions {
    matcher::MatcherSettings matcher;
    double e_star = 0.4;
    double w_v = 0.5;
    store::ObservationStore* db = nullptr;  // reuse and store observations when given
    std::vector<ReferenceColumn> reference;
    // Called before each evaluation ("lab: x_2D (3/6)"), for progress output.
    std::function<void(const std::string&)> progress;
};

// Scores every set on every target. m* per target: its own m_star, else its m_star_per_pair,
// else the reference column's m_star_per_pair, else scoring::derive_m_star of the view's
// overlaps under its own reference (Dataset::reference_overlaps).
// Throws params::ConfigError for bad settings (m* <= 0, unknown dataset) before evaluating.
CompareResult compare(const params::ParameterSpace& space,
                      const std::vector<NamedParameterSet>& sets,
                      const std::vector<CompareTarget>& targets, const CompareOptions& options);

}  // namespace maptune::evaluation
